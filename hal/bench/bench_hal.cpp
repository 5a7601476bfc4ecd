// The hal's per-tick work for the TORO configuration (27 joints on 9 buses plus a sensor bus) over
// cannelloni UDP on loopback: encode and send every command, the drives' side answering in the same
// thread (decode, encode a reply), receive and decode every reply and sensor frame.
#include <benchmark/benchmark.h>

#include <algorithm>

#include "hpr/common/config.hpp"
#include "hpr/hal/hal.hpp"
#include "hpr/model/robot.hpp"

namespace {

using namespace hpr;

void BM_HalTick(benchmark::State& state) {
  const Config cfg = Config::load(std::string(HPR_SOURCE_DIR) + "/config/toro.yaml", {"hal.udp_base_port=23400"});
  const auto robot = model::RobotSpec::load(cfg.section("robot"));
  const auto config = hal::HalConfig::load(cfg.section("hal"), robot);
  hal::Hal h(config, hal::open_buses(config, false), std::make_unique<hal::MitCodec>());
  auto drives = hal::open_buses(config, true);
  hal::MitCodec codec;
  JointCommand c;
  c.resize(robot.model.nj);
  c.mode = JointCommand::Mode::kRun;
  c.q_des = robot.q_joints_stand;
  c.kp.setConstant(100.0);
  c.kd.setConstant(2.0);
  std::vector<hal::CanFrame> rx;
  // Drives' side: answer every command with a reply, SYNC with the 7 sensor frames.
  auto answer = [&] {
    for (std::size_t b = 0; b < drives.size(); ++b) {
      rx.clear();
      drives[b]->receive(rx);
      for (const auto& f : rx) {
        if ((f.id & hal::kCanSffMask) == hal::kSyncId) {
          const double q[4] = {1, 0, 0, 0}, v[3] = {0.01, -0.02, 9.81};
          drives[b]->send(hal::encode_int16s(hal::kImuQuatId, q, 4, 1.0 / 32767.0));
          drives[b]->send(hal::encode_int16s(hal::kImuGyroId, v, 3, hal::kImuGyroScale));
          drives[b]->send(hal::encode_int16s(hal::kImuAccelId, v, 3, hal::kImuAccelScale));
          for (std::uint32_t k = 0; k < 4; ++k) drives[b]->send(hal::encode_int16s(hal::kFtForceId + k, v, 3, hal::kFtForceScale));
          continue;
        }
        const auto req = codec.decode_request(f, config.drives[0].limits);
        if (!req) continue;
        hal::DriveReply r;
        r.drive_id = req->drive_id;
        drives[b]->send(codec.encode_reply(r, config.drives[0].limits));
      }
      drives[b]->flush();
    }
  };
  std::int64_t tick = 0;
  double now = 0.0;
  (void)h.operator_command(hal::kOperatorEnable, now, "bench");
  for (auto _ : state) {
    now += 1e-3;
    (void)h.set_command(c, now);
    h.begin_tick(tick++, now);
    answer();
    int spins = 0;
    while (!h.replies_complete() && spins++ < 1000) h.receive();
    h.end_tick(now);
    benchmark::DoNotOptimize(h.sensors().q.data());
  }
  state.counters["missed"] = static_cast<double>(h.drives()[0].missed);
}
BENCHMARK(BM_HalTick)->Unit(benchmark::kMicrosecond)->Repetitions(5);

void BM_MitEncodeDecode(benchmark::State& state) {
  hal::MitCodec codec;
  hal::DriveLimits l;
  hal::DriveCommand c{0.3, -1.0, 50.0, 1.0, 2.5};
  for (auto _ : state) {
    const auto f = codec.encode_command(1, c, l);
    const auto r = codec.decode_request(f, l);
    benchmark::DoNotOptimize(r);
  }
}
BENCHMARK(BM_MitEncodeDecode);

}  // namespace

BENCHMARK_MAIN();
