// Hardware-in-the-loop over the udp transport: drive_emulator (Bullet behind MIT-mode drive frames
// in cannelloni datagrams) + hal + the control processes. The whole CAN path runs without kernel
// CAN support.
//
// Built twice. test_hil (label hil): in real time at 1 kHz, as on the robot's computer, plus the
// real-time simulation group (`supervisor up sim`) and the group split over two hosts; it needs a
// machine that keeps 1 kHz deadlines. test_hil_lockstep (HPR_HIL_LOCKSTEP, label integration): the
// same tests on the emulator's simulated clock (hal.clock=lockstep), where every deadline is a tick:
// the same frames, codec, transport and safety rules, on any machine. test_hil_canopen_lockstep
// (HPR_HIL_CANOPEN as well): every drive speaks CANopen CiA 402 (hal.protocol=cia402), the tests
// whose subject is the drives.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <fstream>
#include <csignal>

#include "all_types.hpp"
#include "hal_enable.hpp"
#include "lcm_listener.hpp"
#include "process_group.hpp"
#include "shell.hpp"

#ifndef HPR_HIL_LOCKSTEP
#define HPR_HIL_LOCKSTEP 0
#endif
#ifndef HPR_HIL_CANOPEN
#define HPR_HIL_CANOPEN 0
#endif
#if HPR_HIL_CANOPEN
#define HIL_TEST(name) TEST(HardwareInTheLoopCanopenLockstep, name)
#elif HPR_HIL_LOCKSTEP
#define HIL_TEST(name) TEST(HardwareInTheLoopLockstep, name)
#else
#define HIL_TEST(name) TEST(HardwareInTheLoop, name)
#endif

namespace {

using namespace std::chrono_literals;
using hpr::test::LcmListener;
using hpr::test::ProcessGroup;

/// The hil group on a private LCM URL and private UDP ports, recording what a test looks at.
struct Hil {
  ProcessGroup group;
  LcmListener lcm{group.lcm_url()};
  std::shared_ptr<std::vector<humanoid::sim_truth_t>> truth = lcm.collect<humanoid::sim_truth_t>("SIM_TRUTH");
  std::shared_ptr<std::vector<humanoid::hal_status_t>> status = lcm.collect<humanoid::hal_status_t>("HAL_STATUS");
  std::shared_ptr<std::vector<humanoid::robot_sensors_t>> sensors = lcm.collect<humanoid::robot_sensors_t>("ROBOT_SENSORS");
  std::shared_ptr<std::vector<humanoid::joint_command_t>> commands = lcm.collect<humanoid::joint_command_t>("JOINT_COMMAND");
  std::shared_ptr<std::vector<humanoid::health_t>> health = lcm.collect<humanoid::health_t>("HEALTH");
  std::string cfg = hpr::test::source_dir() + "/config/toro.yaml";
  // Below the kernel's ephemeral range (32768-60999), where another process's socket could hold
  // the port, and above the configured 21000 that the supervisor's hil groups use.
  std::string port = "hal.udp_base_port=" + std::to_string(22000 + 40 * (getpid() % 250));
  std::string clock = HPR_HIL_LOCKSTEP ? "hal.clock=lockstep" : "hal.clock=realtime";
  std::string protocol = HPR_HIL_CANOPEN ? "hal.protocol=cia402" : "hal.protocol=mit";
  pid_t emulator = -1, hal = -1, wbc = -1;

  static hpr::launch::StartOptions rt(int priority) {
    hpr::launch::StartOptions o;
    if (!HPR_HIL_LOCKSTEP) o.rt_priority = priority;
    return o;
  }
  explicit Hil(const std::vector<std::string>& emulator_sets = {}) {
    std::vector<std::string> emu_args = {"--config", cfg, "--set", port, "--set", clock, "--set", protocol};
    for (const auto& s : emulator_sets) emu_args.insert(emu_args.end(), {"--set", s});
    // The priorities of the hil group in config/groups.yaml (where the system permits them).
    emulator = group.start("drive_emulator", emu_args, rt(85));
    hal = group.start("hal", {"--config", cfg, "--set", port, "--set", clock, "--set", protocol}, rt(80));
    group.start("estimator", {"--config", cfg}, rt(70));
    group.start("planner", {"--config", cfg}, rt(70));
    wbc = group.start("wbc", {"--config", cfg}, rt(70));
    group.start("reference_gen", {"--config", cfg}, rt(65));
    group.start("motion_opt", {"--config", cfg}, rt(65));
  }
  [[nodiscard]] int hal_state() const { return status->empty() ? -1 : status->back().state; }
  /// Waits for commands to flow, then enables the hal.
  void enable() {
    ASSERT_EQ(hpr::test::enable_drives(lcm, commands, status, 30s, 5s), "");
    missed_at_enable = status->back().drive_missed;  // the hal may have started before the drives answered
  }
  std::vector<std::int64_t> missed_at_enable;
  [[nodiscard]] bool fallen() const { return !truth->empty() && truth->back().fallen; }
  [[nodiscard]] double sim_time() const { return truth->empty() ? 0.0 : truth->back().sim_time; }
  /// Waits for `seconds` of simulated time (lockstep: the chain's pace on a loaded machine may be a
  /// few hundred ticks per second).
  void run_for(double seconds) {
    const double until = sim_time() + seconds;
    lcm.wait_for([&] { return sim_time() >= until || fallen(); }, wall_bound(seconds));
  }
  /// Waits until `done` holds, for at most `sim_seconds` of simulated time from now: a condition due at
  /// a simulated instant is waited for in simulated time, whatever the pace of the loaded machine.
  template <class Pred>
  [[nodiscard]] bool within_sim(double sim_seconds, Pred done) {
    const double until = sim_time() + sim_seconds;
    return lcm.wait_for([&] { return done() || sim_time() >= until; }, wall_bound(sim_seconds)) && done();
  }
  /// The wall time that `sim_seconds` of simulated time may take on a loaded 2-core machine.
  static std::chrono::milliseconds wall_bound(double sim_seconds) {
    const double wall_per_sim = HPR_HIL_LOCKSTEP ? 10.0 : 3.0;
    return std::chrono::milliseconds(static_cast<int>(sim_seconds * wall_per_sim * 1000 + 5000));
  }
};

#if !HPR_HIL_CANOPEN  // what the drives speak does not matter here
// Only the stack enables the drives: an OPERATOR enable without the deployment's code, or with another
// key's, leaves them disabled and is counted in the hal's HEALTH; the same enable signed then enables.
HIL_TEST(AnEnableWithoutTheDeploymentsCodeLeavesTheDrivesDisabled) {
  Hil hil;
  ASSERT_TRUE(hil.lcm.wait_for([&] { return hil.commands->size() > 200 && !hil.status->empty(); }, 30s)) << "no JOINT_COMMAND";
  humanoid::operator_t op{};
  op.source = "intruder";
  op.command = humanoid::operator_t::COMMAND_ENABLE;
  hpr::auth::Key other = hil.lcm.key();
  other.bytes[0] ^= 1;
  for (int k = 0; k < 3; ++k) {
    op.tick = k;
    hil.lcm.publish_unsigned("OPERATOR", op);
    hpr::node::publish_signed(hil.lcm.lcm(), "OPERATOR", op, other);
  }
  const auto hal_refused = [&] {
    for (auto it = hil.health->rbegin(); it != hil.health->rend(); ++it) {
      if (it->node == "hal") return it->unauthenticated >= 6;
    }
    return false;
  };
  EXPECT_TRUE(hil.lcm.wait_for(hal_refused, 5s)) << "the hal did not count the 6 forged enables";
  hil.lcm.spin_for(300ms);
  EXPECT_NE(hil.hal_state(), int{humanoid::hal_status_t::STATE_ENABLED}) << "enabled by a sender without the key";
  hil.enable();  // signed with the deployment's key
  EXPECT_EQ(hil.hal_state(), int{humanoid::hal_status_t::STATE_ENABLED});
}

#endif

HIL_TEST(StandsTenSecondsAndRecoversExperiment1OverUdp) {
  Hil hil;
  hil.enable();
  hil.run_for(10.0);
  ASSERT_FALSE(hil.fallen()) << "fell while standing";
  EXPECT_GT(hil.sim_time(), 9.9);
  // ROBOT_SENSORS carry the hal's clock, which the estimator integrates over: one period per tick
  // in lockstep however slowly the chain runs, increasing in real time.
  ASSERT_GT(hil.sensors->size(), 1000U);
  for (std::size_t k = 1; k < hil.sensors->size(); ++k) {
    const auto& s = (*hil.sensors)[k];
    if (HPR_HIL_LOCKSTEP) {
      ASSERT_EQ(s.utime, s.tick * 1000) << "sample " << k;
    } else {
      ASSERT_GT(s.utime, (*hil.sensors)[k - 1].utime) << "sample " << k;
    }
  }
  EXPECT_EQ(hil.hal_state(), int{humanoid::hal_status_t::STATE_ENABLED}) << hil.status->back().state_reason;
  // Paper experiment 1: 18 N s from behind on the pelvis, 65 N peak half-sine.
  humanoid::push_t p{};
  p.id = 1;
  p.link = "pelvis";
  p.force_W[0] = 65.0;
  p.duration = M_PI * 18.0 / (2.0 * 65.0);
  p.start_time = -1.0;
  p.profile = humanoid::push_t::PROFILE_HALF_SINE;
  hil.lcm.publish("PUSH", p);
  hil.run_for(6.0);
  ASSERT_FALSE(hil.truth->empty());
  const auto& t = hil.truth->back();
  EXPECT_FALSE(t.fallen);
  EXPECT_NEAR(t.push_impulse_W[0], 18.0, 0.5) << "the push was applied";
  double max_tilt = 0;
  for (const auto& s : *hil.truth) max_tilt = std::max({max_tilt, s.foot_tilt[0], s.foot_tilt[1]});
  EXPECT_LT(max_tilt * 180.0 / M_PI, 2.0) << "soles stay flat";
  EXPECT_EQ(hil.hal_state(), int{humanoid::hal_status_t::STATE_ENABLED}) << hil.status->back().state_reason;
  // Every drive answered nearly every frame since the enable.
  const auto& missed = hil.status->back().drive_missed;
  ASSERT_EQ(missed.size(), hil.missed_at_enable.size());
  for (std::size_t i = 0; i < missed.size(); ++i) {
    EXPECT_LT(missed[i] - hil.missed_at_enable[i], 50) << hil.status->back().drive_joint[i];
  }
}

#if !HPR_HIL_CANOPEN
HIL_TEST(EveryRefusedJointCommandIsCountedInHalStatus) {
  Hil hil;
  hil.enable();
  hil.run_for(1.0);
  ASSERT_FALSE(hil.fallen());
  ASSERT_FALSE(hil.commands->empty());
  const std::int64_t before = hil.status->back().commands_rejected;
  // Five bad commands, each refused for another reason, beside the live stream.
  const std::uint8_t garbage[16] = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16};
  hil.lcm.lcm().publish("JOINT_COMMAND", garbage, sizeof(garbage));  // does not decode
  humanoid::joint_command_t c = hil.commands->back();
  humanoid::joint_command_t few = c;                                  // other joints
  few.num_joints = 3;
  few.joint_name.resize(3);
  for (auto* v : {&few.tau_ff, &few.q_des, &few.qd_des, &few.kp, &few.kd}) v->resize(3);
  hil.lcm.publish("JOINT_COMMAND", few);
  humanoid::joint_command_t nan = c;
  nan.tau_ff[0] = std::nan("");
  hil.lcm.publish("JOINT_COMMAND", nan);
  humanoid::joint_command_t strong = c;
  strong.kp[0] = 1e9;  // beyond the drive's kp range
  hil.lcm.publish("JOINT_COMMAND", strong);
  humanoid::joint_command_t future = c;
  future.tick += 1'000'000'000;
  hil.lcm.publish("JOINT_COMMAND", future);
  ASSERT_TRUE(hil.lcm.wait_for([&] { return hil.status->back().commands_rejected >= before + 5; }, 10s))
      << "HAL_STATUS.commands_rejected " << hil.status->back().commands_rejected << " (was " << before << ")";
  hil.run_for(1.0);
  EXPECT_EQ(hil.status->back().commands_rejected, before + 5) << "exactly the five refused";
  EXPECT_EQ(hil.hal_state(), int{humanoid::hal_status_t::STATE_ENABLED}) << hil.status->back().state_reason;
  EXPECT_FALSE(hil.fallen());
}

#endif

HIL_TEST(KilledControllerDampsEveryDriveWithin10msThenTorqueOff) {
  Hil hil;
  hil.enable();
  hil.run_for(2.0);
  ASSERT_FALSE(hil.fallen());
  hil.group.signal(hil.wbc, SIGKILL);
  // Wall-time bounds below are generous (a loaded machine runs the hal's clock slowly); the damping
  // latency itself is measured in hal ticks.
  ASSERT_TRUE(hil.within_sim(1.0, [&] { return hil.hal_state() == humanoid::hal_status_t::STATE_DAMPING; }));
  hil.lcm.spin_for(300ms);
  // Measured in hal ticks (1 ms): the last command answered sensor tick k; the first sample whose
  // drives are all damping.
  const std::int64_t last_command_tick = hil.commands->back().tick;
  std::int64_t damped_tick = -1;
  for (const auto& s : *hil.sensors) {
    if (s.tick <= last_command_tick) continue;
    const bool all = std::all_of(s.drive_status.begin(), s.drive_status.end(),
                                 [](std::int32_t b) { return (b & humanoid::robot_sensors_t::DRIVE_DAMPING) != 0; });
    if (all) {
      damped_tick = s.tick;
      break;
    }
  }
  ASSERT_GE(damped_tick, 0);
  std::printf("last JOINT_COMMAND answered tick %lld, every drive damping from tick %lld\n", static_cast<long long>(last_command_tick),
              static_cast<long long>(damped_tick));
  EXPECT_LE(damped_tick - last_command_tick, 10) << "damping within 10 ms of the last command";
  // Torque off after the configured time (1 s of hal time).
  ASSERT_TRUE(hil.within_sim(2.0, [&] { return hil.hal_state() == humanoid::hal_status_t::STATE_TORQUE_OFF; }));
}

HIL_TEST(FivePercentDroppedRepliesKeepStandingAndAreReported) {
  Hil hil({"emulator.drop_reply_probability=0.05"});
  hil.enable();
  hil.run_for(5.0);
  EXPECT_FALSE(hil.fallen());
  ASSERT_FALSE(hil.status->empty());
  const auto& s = hil.status->back();
  EXPECT_EQ(s.state, int{humanoid::hal_status_t::STATE_ENABLED}) << s.state_reason;
  std::int64_t missed = 0;
  for (const auto m : s.drive_missed) missed += m;
  EXPECT_GT(missed, 0) << "the loss is reported";
}

HIL_TEST(BusOffOnOneBusDampsAllDrivesAndKilledHalLetsTheDrivesTimeOut) {
  Hil hil({"emulator.bus_off_bus=can5", "emulator.bus_off_at=3.0"});
  hil.enable();
  // The bus goes off 3 s of simulated time after the emulator starts.
  ASSERT_TRUE(hil.within_sim(4.0, [&] { return hil.hal_state() == humanoid::hal_status_t::STATE_FAULT; }));
  EXPECT_NE(hil.status->back().state_reason.find("bus-off on can5"), std::string::npos) << hil.status->back().state_reason;
  ASSERT_TRUE(hil.status->back().bus_off[5]);
  hil.lcm.spin_for(100ms);
  const auto& last = hil.sensors->back();
  for (const auto b : last.drive_status) EXPECT_NE(b & humanoid::robot_sensors_t::DRIVE_DAMPING, 0);
  // Now the hal dies: the emulated drives fall back to their own damping.
  hil.group.signal(hil.hal, SIGKILL);
  ASSERT_TRUE(hil.lcm.wait_for(
      [&] {
        for (const auto& h : *hil.health) {
          if (h.node != "drive_emulator") continue;
          for (const auto& f : h.faults) {
            if (f.find("timed out") != std::string::npos) return true;
          }
        }
        return false;
      },
      3s));
}

#if HPR_HIL_CANOPEN
// A drive's emergency (EMCY 0x2310, overcurrent) faults the hal, which names the joint, the code
// and its meaning; the other drives damp and the faulted one brakes by itself.
HIL_TEST(AnEmergencyFromOneDriveFaultsTheHalAndNamesIt) {
  Hil hil({"emulator.fault_joint=l_knee", "emulator.fault_code=8976", "emulator.fault_at=2.0"});
  hil.enable();
  ASSERT_TRUE(hil.within_sim(4.0, [&] { return hil.hal_state() == humanoid::hal_status_t::STATE_FAULT; }));
  const std::string reason = hil.status->back().state_reason;
  EXPECT_NE(reason.find("l_knee: node 1: EMCY 0x2310 (current"), std::string::npos) << reason;
  hil.lcm.spin_for(100ms);
  const auto& last = hil.sensors->back();
  int faulted = 0;
  for (const auto b : last.drive_status) {
    EXPECT_NE(b & humanoid::robot_sensors_t::DRIVE_DAMPING, 0);
    faulted += (b & humanoid::robot_sensors_t::DRIVE_FAULT) != 0 ? 1 : 0;
  }
  EXPECT_EQ(faulted, 1);
}
#endif

#if !HPR_HIL_LOCKSTEP
TEST(HardwareInTheLoop, RealTimeSimGroupIsUpAndStandsTenSeconds) {
  // `tools/supervisor up sim` as the README gives it: Bullet at 1 kHz wall-clock time. On a machine
  // that keeps the 1 kHz deadlines every node reports ok, the robot stands and lcm-spy decodes
  // every channel live.
  const std::string url = hpr::test::unique_lcm_url();
  const std::string dir = hpr::test::temp_dir("sim-realtime");
  const std::string sup = hpr::test::bin_dir() + "/supervisor";
  LcmListener lcm(url);
  ASSERT_TRUE(lcm.good());
  auto truth = lcm.collect<humanoid::sim_truth_t>("SIM_TRUTH");
  auto balance = lcm.collect<humanoid::balance_status_t>("BALANCE_STATUS");
  auto supervisor = lcm.collect<humanoid::supervisor_status_t>("SUPERVISOR_STATUS");
  hpr::test::GroupDown group_down(sup, url);  // whatever fails below
  const auto up = hpr::test::run_command({sup, "up", "sim", "--groups", hpr::test::source_dir() + "/config/groups.yaml", "--lcm-url", url, "--run-root", dir});
  ASSERT_EQ(up.exit_code, 0) << up.out;
  lcm.wait_for([&] { return !truth->empty() && (truth->back().sim_time >= 10.0 || truth->back().fallen); }, 30s);
  ASSERT_FALSE(truth->empty());
  EXPECT_FALSE(truth->back().fallen) << "fell at t = " << truth->back().sim_time;
  EXPECT_GE(truth->back().sim_time, 10.0);
  EXPECT_GT(balance->size(), 9000U) << "BALANCE_STATUS every tick while standing";
  ASSERT_FALSE(supervisor->empty());
  const auto& st = supervisor->back();
  std::string details;
  for (int i = 0; i < st.num_processes; ++i) details += st.name[i] + ": " + st.detail[i] + "\n";
  EXPECT_EQ(int{st.state}, int{humanoid::supervisor_status_t::STATE_UP}) << details;
  // lcm-spy decodes every live message of the running group, every channel of the stack present.
  const std::string channels = "ROBOT_SENSORS,ROBOT_STATE,BALANCE_PLAN,BALANCE_STATUS,CAM_REFERENCE,WHOLEBODY_COMMAND,JOINT_COMMAND,SIM_TRUTH,HEALTH";
  const auto spy = hpr::test::run_command({hpr::test::source_dir() + "/tools/lcm-spy", "--check", "3", "--lcm-url", url, "--expect", channels});
  EXPECT_EQ(spy.exit_code, 0) << spy.out;
  for (const char* c : {"ROBOT_SENSORS", "ROBOT_STATE", "BALANCE_PLAN", "BALANCE_STATUS", "CAM_REFERENCE", "WHOLEBODY_COMMAND", "JOINT_COMMAND", "SIM_TRUTH", "HEALTH"}) {
    EXPECT_NE(spy.out.find(std::string("\n") + c + " "), std::string::npos) << c << " not seen by lcm-spy:\n" << spy.out;
  }
  const auto down = hpr::test::run_command({sup, "down", "--lcm-url", url});
  group_down.dismiss();
  EXPECT_EQ(down.exit_code, 0) << down.out;
}

TEST(HardwareInTheLoop, SplitOverTwoHostsStandsTenSeconds) {
  // The hil group with the drives' side (drive emulator + hal) on host "robot" and the control
  // processes on host "pc": two network namespaces joined by a veth pair, one supervisor each.
  hpr::test::NetnsPair hosts;
  if (!hosts.ok) GTEST_SKIP() << hosts.why;
  const std::string url = "udpm://239.255.76.67:7667?ttl=1";
  const std::string dir = hpr::test::temp_dir("hil-hosts");
  const std::string file = dir + "/groups.yaml";
  const std::string cfg = hpr::test::source_dir() + "/config/toro.yaml";
  std::ofstream(file) << "vars: {cfg: " << cfg << "}\n"
                      << "defaults: {rt_priority: 70}\n"
                      << "groups:\n  hil-split:\n    processes:\n"
                      << "      drive_emulator: {command: drive_emulator, host: robot, args: [--config, '${cfg}'], rt_priority: 85}\n"
                      << "      hal: {command: hal, host: robot, args: [--config, '${cfg}'], depends_on: [drive_emulator], rt_priority: 80}\n"
                      << hpr::test::control_processes_yaml("pc");
  ASSERT_TRUE(hosts.enter(hosts.a));
  LcmListener lcm(url);
  ASSERT_TRUE(lcm.good());
  auto truth = lcm.collect<humanoid::sim_truth_t>("SIM_TRUTH");
  auto status = lcm.collect<humanoid::hal_status_t>("HAL_STATUS");
  auto commands = lcm.collect<humanoid::joint_command_t>("JOINT_COMMAND");
  const std::string sup = hpr::test::bin_dir() + "/supervisor";
  hpr::test::GroupDown group_down(sup, url, hosts.exec(hosts.b));  // both hosts, whatever fails below
  const auto robot = hpr::test::run_command({sup, "up", "hil-split", "--groups", file, "--host", "robot", "--lcm-url", url, "--run-root", dir + "/robot"}, hosts.exec(hosts.a));
  ASSERT_EQ(robot.exit_code, 0) << robot.out;
  const auto pc = hpr::test::run_command({sup, "up", "hil-split", "--groups", file, "--host", "pc", "--lcm-url", url, "--run-root", dir + "/pc"}, hosts.exec(hosts.b));
  ASSERT_EQ(pc.exit_code, 0) << pc.out;
  ASSERT_EQ(hpr::test::enable_drives(lcm, commands, status, 30s, 5s), "") << "with the control processes on the other host";
  const auto state = [&] { return status->empty() ? -1 : int{status->back().state}; };
  const double t0 = truth->empty() ? 0.0 : truth->back().sim_time;
  lcm.wait_for([&] { return !truth->empty() && (truth->back().sim_time >= t0 + 10.0 || truth->back().fallen); }, 60s);
  ASSERT_FALSE(truth->empty());
  EXPECT_FALSE(truth->back().fallen) << "fell at t = " << truth->back().sim_time;
  EXPECT_GE(truth->back().sim_time, t0 + 10.0);
  EXPECT_EQ(state(), int{humanoid::hal_status_t::STATE_ENABLED}) << status->back().state_reason;
  const auto down = hpr::test::run_command({sup, "down", "--lcm-url", url}, hosts.exec(hosts.b));
  group_down.dismiss();
  EXPECT_EQ(down.exit_code, 0) << down.out;
}

#endif  // !HPR_HIL_LOCKSTEP

}  // namespace
