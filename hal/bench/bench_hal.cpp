// The hal's per-tick work for the TORO configuration (27 joints on 9 buses plus a sensor bus) over
// cannelloni UDP on loopback: encode and send every command, the drives' side answering in the same
// thread (decode, encode a reply), receive and decode every reply and sensor frame; with MIT-mode
// drives and with CiA 402 drives (RPDO + SYNC out, two TPDOs back per drive).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <memory>

#include "hpr/common/config.hpp"
#include "hpr/hal/hal.hpp"
#include "hpr/model/robot.hpp"

namespace {

using namespace hpr;

/// The drives' side of the benchmark for one protocol: MIT mode answers every command frame with a
/// reply; CiA 402 devices (one per drive) answer each SYNC with their two TPDOs. The sensor bus's
/// SYNC is answered with the 7 sensor frames either way.
class DriveSide {
 public:
  DriveSide(const hal::HalConfig& config, std::vector<std::unique_ptr<hal::CanTransport>> buses) : config_(config), buses_(std::move(buses)) {
    for (const auto& d : config_.drives) {
      if (d.protocol != hal::DriveProtocol::kCia402) {
        devices_.push_back(nullptr);
        continue;
      }
      devices_.push_back(std::make_unique<hal::Cia402Device>(d.id, od_));
    }
  }
  void answer(double now) {
    for (std::size_t b = 0; b < buses_.size(); ++b) {
      rx_.clear();
      buses_[b]->receive(rx_);
      for (const auto& f : rx_) {
        tx_.clear();
        for (std::size_t i = 0; i < devices_.size(); ++i) {
          if (devices_[i] && config_.drives[i].bus == static_cast<int>(b)) devices_[i]->on_frame(f, now, tx_);
        }
        for (const auto& t : tx_) buses_[b]->send(t);
        if ((f.id & hal::kCanSffMask) == hal::kSyncId) {
          if (static_cast<int>(b) != config_.sensor_bus) continue;
          const double q[4] = {1, 0, 0, 0}, v[3] = {0.01, -0.02, 9.81};
          buses_[b]->send(hal::encode_int16s(hal::kImuQuatId, q, 4, 1.0 / 32767.0));
          buses_[b]->send(hal::encode_int16s(hal::kImuGyroId, v, 3, hal::kImuGyroScale));
          buses_[b]->send(hal::encode_int16s(hal::kImuAccelId, v, 3, hal::kImuAccelScale));
          for (std::uint32_t k = 0; k < 4; ++k) buses_[b]->send(hal::encode_int16s(hal::kFtForceId + k, v, 3, hal::kFtForceScale));
          continue;
        }
        const auto req = codec_.decode_request(f, config_.drives[0].limits);
        if (!req) continue;
        hal::DriveReply r;
        r.drive_id = req->drive_id;
        buses_[b]->send(codec_.encode_reply(r, config_.drives[0].limits));
      }
      tx_.clear();
      for (std::size_t i = 0; i < devices_.size(); ++i) {
        if (devices_[i] && config_.drives[i].bus == static_cast<int>(b)) {
          devices_[i]->power_on(tx_);
          devices_[i]->periodic(now, 1.0, tx_);
        }
      }
      for (const auto& t : tx_) buses_[b]->send(t);
      buses_[b]->flush();
    }
  }

 private:
  const hal::HalConfig& config_;
  std::vector<std::unique_ptr<hal::CanTransport>> buses_;
  hal::canopen::ObjectDictionary od_ = hal::canopen::ObjectDictionary::parse(hal::Cia402Device::default_eds(500), "bench.eds");
  std::vector<std::unique_ptr<hal::Cia402Device>> devices_;
  hal::MitCodec codec_;
  std::vector<hal::CanFrame> rx_, tx_;
};

/// One hal tick, `state.range(0)`: 0 MIT mode, 1 CiA 402 (cyclic synchronous torque).
void BM_HalTick(benchmark::State& state) {
  const bool cia402 = state.range(0) == 1;
  const Config cfg = Config::load(std::string(HPR_SOURCE_DIR) + "/config/toro.yaml",
                                  {"hal.udp_base_port=23400", std::string("hal.protocol=") + (cia402 ? "cia402" : "mit")});
  const auto robot = model::RobotSpec::load(cfg.section("robot"));
  const auto config = hal::HalConfig::load(cfg.section("hal"), robot);
  hal::Hal h(config, hal::open_buses(config, false), std::make_unique<hal::MitCodec>());
  DriveSide drives(config, hal::open_buses(config, true));
  JointCommand c;
  c.resize(robot.model.nj);
  c.mode = JointCommand::Mode::kRun;
  c.q_des = robot.q_joints_stand;
  c.kp.setConstant(100.0);
  c.kd.setConstant(2.0);
  std::int64_t tick = 0;
  double now = 0.0;
  auto one_tick = [&] {
    now += 1e-3;
    c.tick = tick;
    (void)h.set_command(c, now);
    h.begin_tick(tick++, now);
    drives.answer(now);
    int spins = 0;
    while (!h.replies_complete() && spins++ < 1000) h.receive();
    h.end_tick(now);
  };
  // CiA 402: the start-up (NMT, SDO configuration, NMT start) before the timed ticks.
  for (int k = 0; k < 2000 && !h.starting_drives().empty(); ++k) one_tick();
  if (!h.starting_drives().empty()) state.SkipWithError(("drives did not start: " + h.starting_drives()).c_str());
  const std::string enabled = h.operator_command(hal::kOperatorEnable, now, "bench", 1);
  if (enabled != "enabled by bench") state.SkipWithError(enabled.c_str());
  for (int k = 0; k < 10; ++k) one_tick();
  const std::int64_t missed_before = h.drives()[0].missed;
  for (auto _ : state) {
    one_tick();
    benchmark::DoNotOptimize(h.sensors().q.data());
  }
  state.counters["missed"] = static_cast<double>(h.drives()[0].missed - missed_before);
  state.SetLabel(cia402 ? "CiA 402" : "MIT mode");
}
BENCHMARK(BM_HalTick)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond)->Repetitions(5);

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
