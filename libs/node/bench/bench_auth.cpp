// The cost of authenticating what the processes exchange: a JOINT_COMMAND of 27 joints (the
// TORO-like robot) encoded as the wbc's Output does it, without and with its code, and the check the
// hal and the simulator make on every one before decoding it; then the code of a message of each
// size the control chain sends (ROBOT_SENSORS, ROBOT_STATE, ... are 0.5 to 3 kB at 27 joints), from
// which one tick's cost is the sum over the chain's messages of one signature and one check per
// reader (docs/PERFORMANCE.md). At 1 kHz the per-message figure times 1000 is the share of a core.
//
//   bench_auth --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <humanoid/joint_command_t.hpp>
#include <cstdint>
#include <string>
#include <vector>

#include "hpr/common/auth.hpp"
#include "hpr/node/runtime.hpp"

namespace {

humanoid::joint_command_t make_command(int joints) {
  humanoid::joint_command_t m{};
  m.tick = 12345;
  m.utime = 1'700'000'000'000'000;
  m.mode = humanoid::joint_command_t::MODE_RUN;
  m.num_joints = joints;
  for (int i = 0; i < joints; ++i) m.joint_name.push_back("joint_" + std::to_string(i) + "_pitch");
  const auto n = static_cast<std::size_t>(joints);
  m.tau_ff.assign(n, 1.5);
  m.q_des.assign(n, 0.2);
  m.qd_des.assign(n, 0.0);
  m.kp.assign(n, 300.0);
  m.kd.assign(n, 5.0);
  return m;
}

hpr::auth::Key key() {
  hpr::auth::Key k;
  for (std::size_t i = 0; i < k.bytes.size(); ++i) k.bytes[i] = static_cast<std::uint8_t>(i * 11 + 3);
  return k;
}

void BM_EncodeJointCommand(benchmark::State& state) {
  const auto m = make_command(static_cast<int>(state.range(0)));
  std::vector<std::uint8_t> buffer;
  for (auto _ : state) benchmark::DoNotOptimize(hpr::node::encode_message(m, buffer, "JOINT_COMMAND", nullptr));
  state.counters["bytes"] = static_cast<double>(m.getEncodedSize());
}

void BM_EncodeAndSignJointCommand(benchmark::State& state) {
  const auto m = make_command(static_cast<int>(state.range(0)));
  const auto k = key();
  std::vector<std::uint8_t> buffer;
  for (auto _ : state) benchmark::DoNotOptimize(hpr::node::encode_message(m, buffer, "JOINT_COMMAND", &k));
}

void BM_VerifyJointCommand(benchmark::State& state) {
  const auto m = make_command(static_cast<int>(state.range(0)));
  const auto k = key();
  std::vector<std::uint8_t> buffer;
  const int n = hpr::node::encode_message(m, buffer, "JOINT_COMMAND", &k);
  for (auto _ : state) benchmark::DoNotOptimize(hpr::auth::verify(buffer.data(), static_cast<std::size_t>(n), "JOINT_COMMAND", k));
}

/// Signing `state.range(0)` bytes (the code over all but the last 32).
void BM_SignBytes(benchmark::State& state) {
  std::vector<std::uint8_t> buffer(static_cast<std::size_t>(state.range(0)), 0x5a);
  const auto k = key();
  for (auto _ : state) {
    hpr::auth::sign(buffer.data(), buffer.size(), "JOINT_COMMAND", k);
    benchmark::DoNotOptimize(buffer.data());
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations()) * state.range(0));
}

void BM_VerifyBytes(benchmark::State& state) {
  std::vector<std::uint8_t> buffer(static_cast<std::size_t>(state.range(0)), 0x5a);
  const auto k = key();
  hpr::auth::sign(buffer.data(), buffer.size(), "JOINT_COMMAND", k);
  for (auto _ : state) benchmark::DoNotOptimize(hpr::auth::verify(buffer.data(), buffer.size(), "JOINT_COMMAND", k));
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations()) * state.range(0));
}

BENCHMARK(BM_EncodeJointCommand)->Arg(27)->Arg(12);
BENCHMARK(BM_SignBytes)->Arg(256)->Arg(512)->Arg(1024)->Arg(2048)->Arg(4096);
BENCHMARK(BM_VerifyBytes)->Arg(256)->Arg(512)->Arg(1024)->Arg(2048)->Arg(4096);
BENCHMARK(BM_EncodeAndSignJointCommand)->Arg(27)->Arg(12);
BENCHMARK(BM_VerifyJointCommand)->Arg(27)->Arg(12);

}  // namespace

BENCHMARK_MAIN();
