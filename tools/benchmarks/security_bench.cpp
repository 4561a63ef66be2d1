// Signing a request_t into a signed_request_t (RequestSigner::sign) and verifying it
// (RequestVerifier::verify: key lookup, Ed25519 verification, window and counter, bounded decode),
// for a move of 1 and of 8 axes, with 1 and 100 principals in authorized_keys; and the
// coordinator's SYNC_TRIGGER2 of 3 buses signed into a signed_message_t (MessageSigner) and
// verified by a gateway (MessageVerifier): what a synchronized start costs on top.
#include <benchmark/benchmark.h>

#include <chrono>
#include <string>
#include <vector>

#include <motionlcm/sync_trigger2_t.hpp>

#include "motion/security/request_verifier.hpp"
#include "motion/security/signed_messages.hpp"
#include "motion/security/signed_request.hpp"

namespace motion::security {
namespace {

motionlcm::request_t move(int axes) {
  motionlcm::request_t r{};
  r.client_id = "op/bench";
  r.request_id = 1;
  r.kind = motionlcm::request_t::MOVE_ABSOLUTE;
  for (int i = 0; i < axes; ++i) {
    r.axes.push_back("axis" + std::to_string(i));
    r.values.push_back(1.5 * i);
  }
  r.num_axes = axes;
  return r;
}

AuthorizedKeys keys_with(const KeyPair& signer, int principals) {
  std::string text;
  for (int i = 1; i < principals; ++i)
    text += KeyPair::generate("other" + std::to_string(i)).authorized_line("observe") + "\n";
  text += signer.authorized_line("operate") + "\n";
  return std::get<AuthorizedKeys>(AuthorizedKeys::parse(text, "bench"));
}

void BM_Sign(benchmark::State& state) {
  RequestSigner signer(KeyPair::generate("op"), "MOTION_");
  const auto request = move(static_cast<int>(state.range(0)));
  std::int64_t now = 1'700'000'000'000'000;
  for (auto _ : state) benchmark::DoNotOptimize(signer.sign(request, ++now));
}
BENCHMARK(BM_Sign)->Arg(1)->Arg(8);

void BM_Verify(benchmark::State& state) {
  const KeyPair key = KeyPair::generate("op");
  RequestSigner signer(key, "MOTION_");
  const std::int64_t start = 1'700'000'000'000'000;
  RequestVerifier verifier(keys_with(key, static_cast<int>(state.range(1))), "MOTION_", std::chrono::seconds(2), start);
  const auto request = move(static_cast<int>(state.range(0)));
  // Counters must increase: pre-sign a batch and verify them in order, re-signing between runs.
  std::vector<motionlcm::signed_request_t> batch;
  std::int64_t now = start;
  std::size_t next = 0;
  for (auto _ : state) {
    if (next == batch.size()) {
      state.PauseTiming();
      batch.clear();
      for (int i = 0; i < 1000; ++i) batch.push_back(signer.sign(request, ++now));
      next = 0;
      state.ResumeTiming();
    }
    const Verdict v = verifier.verify(batch[next++], now);
    if (!v.accepted) state.SkipWithError(v.reason.c_str());
  }
}
BENCHMARK(BM_Verify)->Args({1, 1})->Args({8, 1})->Args({1, 100});

motionlcm::sync_trigger2_t trigger_of_three_buses() {
  motionlcm::sync_trigger2_t t{};
  t.trigger_id = 1;
  t.buses = {"can0", "rs485", "rs232"};
  t.send_utime = {1, 2, 3};
  t.lead_us = {100.0, 900.0, 400.0};
  t.num_buses = 3;
  t.start_command_ids = {11, 12, 13, 14};
  t.num_starts = 4;
  return t;
}

void BM_SignTrigger(benchmark::State& state) {
  MessageSigner signer(KeyPair::generate("coordinator"), "MOTION_");
  const auto trigger = trigger_of_three_buses();
  std::int64_t now = 1'700'000'000'000'000;
  for (auto _ : state) benchmark::DoNotOptimize(signer.sign("SYNC_TRIGGER2", trigger, ++now));
}
BENCHMARK(BM_SignTrigger);

void BM_VerifyTrigger(benchmark::State& state) {
  const KeyPair key = KeyPair::generate("coordinator");
  MessageSigner signer(key, "MOTION_");
  const std::int64_t start = 1'700'000'000'000'000;
  MessageVerifier verifier(key.public_key(), "MOTION_", "SYNC_TRIGGER2", std::chrono::seconds(2), start);
  const auto trigger = trigger_of_three_buses();
  std::vector<motionlcm::signed_message_t> batch;
  std::int64_t now = start;
  std::size_t next = 0;
  for (auto _ : state) {
    if (next == batch.size()) {
      state.PauseTiming();
      batch.clear();
      for (int i = 0; i < 1000; ++i) batch.push_back(signer.sign("SYNC_TRIGGER2", trigger, ++now));
      next = 0;
      state.ResumeTiming();
    }
    const auto v = verifier.verify<motionlcm::sync_trigger2_t>(batch[next++], now);
    if (!v.message) state.SkipWithError(v.reason.c_str());
  }
}
BENCHMARK(BM_VerifyTrigger);

}  // namespace
}  // namespace motion::security

BENCHMARK_MAIN();
