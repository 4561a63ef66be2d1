// The adaptive trigger lead (trigger_lead.hpp): the configured maximum until a bus has enough
// samples, then the envelope of its recent delays (each halved every half_life samples after it)
// x margin + floor, within [min, max].
#include "motion/coordinator/trigger_lead.hpp"

#include <gtest/gtest.h>

namespace motion::coordinator {
namespace {

TriggerLead::Settings settings() {
  TriggerLead::Settings s;
  s.max_us = 30'000;
  s.min_us = 3'000;
  s.margin = 1.5;
  s.floor_us = 2'000;
  s.window = 64;
  s.enough = 8;
  s.half_life = 8;
  return s;
}

TEST(TriggerLead, WithoutSamplesTheConfiguredLeadHolds) {
  TriggerLead lead(settings());
  EXPECT_EQ(lead.lead_us({"can0", "rs485"}), 30'000);
  // One bus with enough fast samples, the other none: the configured lead still.
  for (int i = 0; i < 20; ++i) lead.add("can0", 200);
  EXPECT_EQ(lead.lead_us({"can0", "rs485"}), 30'000);
  // Fewer than `enough` samples: not yet.
  for (int i = 0; i < 7; ++i) lead.add("rs485", 200);
  EXPECT_EQ(lead.lead_us({"can0", "rs485"}), 30'000);
  lead.add("rs485", 200);
  EXPECT_LT(lead.lead_us({"can0", "rs485"}), 30'000);
}

TEST(TriggerLead, FastSamplesShrinkTheLeadToTheFloorAndTheMinimum) {
  TriggerLead lead(settings());
  for (int i = 0; i < 64; ++i) {
    lead.add("can0", 600);
    lead.add("rs485", 800);
  }
  // The slower bus decides: 800 x 1.5 + 2000.
  EXPECT_EQ(lead.lead_us({"can0", "rs485"}), 3'200);
  for (int i = 0; i < 64; ++i) lead.add("rs485", 100);
  // 800 gone from the window: 600 x 1.5 + 2000 = 2900, below the minimum 3000.
  EXPECT_EQ(lead.lead_us({"can0", "rs485"}), 3'000);
  // A clock behind the coordinator's gives negative delays: taken as 0, the floor.
  TriggerLead floor_only([] {
    auto s = settings();
    s.min_us = 1'000;
    return s;
  }());
  for (int i = 0; i < 8; ++i) floor_only.add("can0", -5'000);
  EXPECT_EQ(floor_only.lead_us({"can0"}), 2'000);
}

TEST(TriggerLead, ALateTriggerRaisesTheLeadAtOnceAndItsWeightHalvesEveryHalfLife) {
  TriggerLead lead(settings());
  for (int i = 0; i < 64; ++i) lead.add("can0", 1'000);
  EXPECT_EQ(lead.lead_us({"can0"}), 3'500);
  // A trigger published at 1 s for a send time 3500 us later, heard 9000 us after it: late.
  lead.published(7, 1'000'000);
  EXPECT_TRUE(lead.heard("can0", 7, 1'009'000));
  EXPECT_EQ(lead.envelope_us("can0"), 9'000);
  EXPECT_EQ(lead.lead_us({"can0"}), 9'000 * 3 / 2 + 2'000);
  EXPECT_GT(lead.lead_us({"can0"}), 9'000);  // the next trigger is heard in time at that delay
  // Eight fast samples later it weighs half, sixteen later a quarter.
  for (int i = 0; i < 8; ++i) lead.add("can0", 1'000);
  EXPECT_EQ(lead.envelope_us("can0"), 4'500);
  EXPECT_EQ(lead.lead_us({"can0"}), 8'750);
  for (int i = 0; i < 8; ++i) lead.add("can0", 1'000);
  EXPECT_EQ(lead.envelope_us("can0"), 2'250);
  // Once its weight is below the ordinary delays (9000 x 2^(-26/8) = 946), they decide again:
  // 26 triggers after the late one, not 64.
  for (int i = 0; i < 9; ++i) lead.add("can0", 1'000);
  EXPECT_GT(lead.lead_us({"can0"}), 3'500);
  lead.add("can0", 1'000);
  EXPECT_EQ(lead.lead_us({"can0"}), 3'500);
}

TEST(TriggerLead, DelaysThatKeepComingBackKeepTheLeadUp) {
  TriggerLead lead(settings());
  for (int i = 0; i < 64; ++i) lead.add("can0", i % 8 == 0 ? 9'000 : 1'000);
  // The newest long delay is 7 samples old: 9000 x 2^(-7/8) = 4907.
  EXPECT_EQ(lead.envelope_us("can0"), 4'907);
  for (int round = 0; round < 4; ++round) {
    for (int i = 0; i < 8; ++i) {
      lead.add("can0", i == 0 ? 9'000 : 1'000);
      EXPECT_GE(lead.lead_us({"can0"}), 4'907 * 3 / 2 + 2'000);
    }
  }
}

TEST(TriggerLead, ClampedAtTheConfiguredMaximum) {
  TriggerLead lead(settings());
  for (int i = 0; i < 10; ++i) lead.add("can0", 500);
  lead.add("can0", 80'000);
  EXPECT_EQ(lead.lead_us({"can0"}), 30'000);
  // A minimum above the maximum (trigger_lead_ms set below the default minimum): the maximum.
  auto s = settings();
  s.min_us = 50'000;
  TriggerLead fixed(s);
  for (int i = 0; i < 10; ++i) fixed.add("can0", 100);
  EXPECT_EQ(fixed.lead_us({"can0"}), 30'000);
}

TEST(TriggerLead, OnlyTheFirstHearingOfARecentTriggerIsASample) {
  TriggerLead lead(settings());
  EXPECT_FALSE(lead.heard("can0", 1, 1'000));  // never published
  lead.published(1, 10'000);
  EXPECT_TRUE(lead.heard("can0", 1, 10'400));
  EXPECT_FALSE(lead.heard("can0", 1, 10'900));  // the same bus again (the plain and the signed copy)
  EXPECT_TRUE(lead.heard("rs485", 1, 10'700));
  EXPECT_EQ(lead.samples("can0"), 1u);
  EXPECT_EQ(lead.envelope_us("can0"), 400);
  EXPECT_EQ(lead.envelope_us("rs485"), 700);
  // Only the last kRememberedTriggers triggers are known.
  for (std::int64_t id = 2; id < 2 + static_cast<std::int64_t>(TriggerLead::kRememberedTriggers); ++id)
    lead.published(id, 20'000);
  EXPECT_FALSE(lead.heard("rs485", 2 - 1, 20'100));
  EXPECT_TRUE(lead.heard("rs485", 2, 20'100));
}

}  // namespace
}  // namespace motion::coordinator
