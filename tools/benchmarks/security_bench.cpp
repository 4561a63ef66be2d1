// Signing a request_t into a signed_request_t (RequestSigner::sign) and verifying it
// (RequestVerifier::verify: key lookup, Ed25519 verification, window and counter, bounded decode),
// for a move of 1 and of 8 axes, with 1 and 100 principals in authorized_keys; and the
// coordinator's SYNC_TRIGGER2 of 3 buses signed into a signed_message_t (MessageSigner) and
// verified by a gateway (MessageVerifier): what a synchronized start costs on top. And a gateway's
// AXIS_STATE signed with its gateway key and verified by the coordinator (any of the gateway keys,
// counter per key and bus), against an unsigned LCM round trip measured in the same run
// (publish -> an echo thread on its own LCM instance -> back) and a 20 Hz poll period: the
// figures are printed as ratios after the table.
#include <benchmark/benchmark.h>

#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include <lcm/lcm-cpp.hpp>
#include <motionlcm/axis_state_t.hpp>
#include <motionlcm/sync_trigger2_t.hpp>

#include "bench_process.hpp"
#include "motion/security/authorized_keys.hpp"

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

// Times `verify` (the reason of a refusal, empty when accepted) over envelopes that `sign(now)`
// made ahead, 1000 at a time, outside the timed part: counters must increase, so they are verified
// in order, `now` moving on with each signature from `start`.
template <typename Sign, typename Verify>
void verify_presigned(benchmark::State& state, std::int64_t start, Sign sign, Verify verify) {
  std::vector<decltype(sign(start))> batch;
  std::int64_t now = start;
  std::size_t next = 0;
  for (auto _ : state) {
    if (next == batch.size()) {
      state.PauseTiming();
      batch.clear();
      for (int i = 0; i < 1000; ++i) batch.push_back(sign(++now));
      next = 0;
      state.ResumeTiming();
    }
    if (const std::string why = verify(batch[next++], now); !why.empty()) state.SkipWithError(why.c_str());
  }
}

void BM_Verify(benchmark::State& state) {
  const KeyPair key = KeyPair::generate("op");
  RequestSigner signer(key, "MOTION_");
  const std::int64_t start = 1'700'000'000'000'000;
  RequestVerifier verifier(keys_with(key, static_cast<int>(state.range(1))), "MOTION_", std::chrono::seconds(2), start);
  const auto request = move(static_cast<int>(state.range(0)));
  verify_presigned(
      state, start, [&](std::int64_t now) { return signer.sign(request, now); },
      [&](const motionlcm::signed_request_t& e, std::int64_t now) {
        const Verdict v = verifier.verify(e, now);
        return v.accepted ? std::string() : v.reason;
      });
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

// Times signing `message` for `channel` with a key named `signer_name`.
template <typename Msg>
void time_signing(benchmark::State& state, const char* signer_name, std::string_view channel, const Msg& message) {
  MessageSigner signer(KeyPair::generate(signer_name), "MOTION_");
  std::int64_t now = 1'700'000'000'000'000;
  for (auto _ : state) benchmark::DoNotOptimize(signer.sign(channel, message, ++now));
}

void BM_SignTrigger(benchmark::State& state) {
  time_signing(state, "coordinator", "SYNC_TRIGGER2", trigger_of_three_buses());
}
BENCHMARK(BM_SignTrigger);

void BM_VerifyTrigger(benchmark::State& state) {
  const KeyPair key = KeyPair::generate("coordinator");
  MessageSigner signer(key, "MOTION_");
  const std::int64_t start = 1'700'000'000'000'000;
  MessageVerifier verifier(key.public_key(), "MOTION_", "SYNC_TRIGGER2", std::chrono::seconds(2), start);
  const auto trigger = trigger_of_three_buses();
  verify_presigned(
      state, start, [&](std::int64_t now) { return signer.sign("SYNC_TRIGGER2", trigger, now); },
      [&](const motionlcm::signed_message_t& e, std::int64_t now) {
        const auto v = verifier.verify<motionlcm::sync_trigger2_t>(e, now);
        return v.message ? std::string() : v.reason;
      });
}
BENCHMARK(BM_VerifyTrigger);

motionlcm::axis_state_t axis_state() {
  motionlcm::axis_state_t s{};
  s.utime = s.sample_utime = 1'700'000'000'000'000;
  s.axis = "x1";
  s.family = "uim342";
  s.bus = "can0";
  s.node_id = 5;
  s.position = 12.5;
  s.position_counts = 8000;
  s.online = s.enabled = s.in_position = true;
  s.inputs = 0b0010;
  return s;
}

void BM_SignAxisState(benchmark::State& state) { time_signing(state, "gateway", "AXIS_STATE", axis_state()); }
BENCHMARK(BM_SignAxisState)->Unit(benchmark::kMicrosecond);

void BM_VerifyAxisState(benchmark::State& state) {
  // The coordinator's verifier: the gateway keys of authorized_keys (here two), counters per bus.
  const KeyPair key = KeyPair::generate("gateway");
  MessageSigner signer(key, "MOTION_");
  const std::int64_t start = 1'700'000'000'000'000;
  MessageVerifier verifier({KeyPair::generate("gateway-b").public_key(), key.public_key()}, "a gateway key", "MOTION_",
                           "AXIS_STATE", std::chrono::seconds(2), start);
  const auto s = axis_state();
  verify_presigned(
      state, start, [&](std::int64_t now) { return signer.sign("AXIS_STATE", s, now); },
      [&](const motionlcm::signed_message_t& e, std::int64_t now) {
        const auto v =
            verifier.verify<motionlcm::axis_state_t>(e, now, [](const motionlcm::axis_state_t& m) { return m.bus; });
        return v.message ? std::string() : v.reason;
      });
}
BENCHMARK(BM_VerifyAxisState)->Unit(benchmark::kMicrosecond);

// An unsigned AXIS_STATE published and echoed back by another LCM instance (its own thread) on a
// URL of this process's own: the transport the signature rides on.
void BM_LcmRoundTrip(benchmark::State& state) {
  const int port = 20000 + (static_cast<int>(::getpid()) * 17 + 3) % 40000;
  const std::string url = "udpm://239.255.76.67:" + std::to_string(port) + "?ttl=0";
  bench::Echo echo(url, "BENCH_PING", "BENCH_PONG");
  ::lcm::LCM lcm(url);
  if (!echo.ok() || !lcm.good()) {
    state.SkipWithError("no LCM (multicast route?)");
    return;
  }
  bool pong = false;
  auto* sub = lcm.subscribeFunction(
      "BENCH_PONG", +[](const ::lcm::ReceiveBuffer*, const std::string&, bool* got) { *got = true; }, &pong);
  const auto s = axis_state();
  for (auto _ : state) {
    pong = false;
    lcm.publish("BENCH_PING", &s);
    while (!pong) {
      if (lcm.handleTimeout(1000) <= 0) {
        state.SkipWithError("the LCM echo did not answer within 1 s");
        break;
      }
    }
  }
  lcm.unsubscribe(sub);
}
BENCHMARK(BM_LcmRoundTrip)->Unit(benchmark::kMicrosecond)->UseRealTime()->Iterations(2000);

// The table as usual, and each run's time per iteration in µs kept for the ratios.
class Capture : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    for (const auto& r : runs) {
      if (r.error_occurred || r.run_type != Run::RT_Iteration) continue;
      const double per_unit = benchmark::GetTimeUnitMultiplier(r.time_unit);  // units per second
      us[r.benchmark_name()] = r.GetAdjustedCPUTime() / per_unit * 1e6;
      real_us[r.benchmark_name()] = r.GetAdjustedRealTime() / per_unit * 1e6;
    }
    ConsoleReporter::ReportRuns(runs);
  }
  std::map<std::string, double> us, real_us;
};

void print_ratios(const Capture& c) {
  const auto find = [](const std::map<std::string, double>& m, const std::string& name) {
    const auto it = m.find(name);
    return it == m.end() ? -1.0 : it->second;
  };
  const double sign = find(c.us, "BM_SignAxisState");
  const double verify = find(c.us, "BM_VerifyAxisState");
  const double rtt = find(c.real_us, "BM_LcmRoundTrip/iterations:2000/real_time");
  const double request = find(c.us, "BM_Sign/1") + find(c.us, "BM_Verify/1/1");
  if (sign < 0 || verify < 0 || rtt <= 0) {
    std::printf("\nratios: not all of BM_SignAxisState, BM_VerifyAxisState, BM_LcmRoundTrip ran\n");
    return;
  }
  constexpr double kPollUs = 1e6 / 20.0;  // the default poll rate, 20 Hz
  std::printf("\nOne AXIS_STATE signed by its gateway and verified by the coordinator: %.1f + %.1f us CPU\n", sign,
              verify);
  std::printf(
      "  = %.2f %% of a 20 Hz poll period (per axis and poll), %.2f x an unsigned LCM round trip (%.1f us "
      "measured in this run)\n",
      100.0 * (sign + verify) / kPollUs, (sign + verify) / rtt, rtt);
  if (request > 0) {
    std::printf("One signed request (move of 1 axis) signed and verified: %.1f us CPU = %.2f x that LCM round trip\n",
                request, request / rtt);
  }
}

}  // namespace
}  // namespace motion::security

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  motion::security::Capture capture;
  benchmark::RunSpecifiedBenchmarks(&capture);
  motion::security::print_ratios(capture);
  benchmark::Shutdown();
  return 0;
}
