// The hal against the drive emulator in one process over in-memory buses, stepped in lockstep:
// the safety state machine's transitions, command validation, missed replies, bus-off and the
// drives' own timeout.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "hpr/sim/drive_emulator.hpp"
#include "hpr/hal/hal.hpp"
#include "hal_rig.hpp"
#include "hpr/hal/memory_transport.hpp"
#include "hpr/model/urdf.hpp"
#include "process_group.hpp"
#include "shell.hpp"

namespace {

using namespace hpr;
using hal::SafetyState;
using test::Rig;

TEST(SafetyMachine, TransitionsOfTheTable) {
  hal::SafetyConfig c;
  c.command_max_age = 0.005;
  c.torque_off_after = 0.5;
  hal::SafetyMachine s(c);
  EXPECT_EQ(s.state(), SafetyState::kOff);
  EXPECT_EQ(s.drive_mode(), hal::DriveMode::kOff);
  s.update(0.0, 1e9);
  EXPECT_EQ(s.state(), SafetyState::kOff) << "no command while off is nothing to act on";
  EXPECT_NE(s.enable(0.0, test::issued(), true, "bus-off on can3"), "") << "enable refused while a fault is present";
  EXPECT_EQ(s.state(), SafetyState::kOff);
  EXPECT_EQ(s.enable(0.0, test::issued(), false, ""), "");
  EXPECT_TRUE(s.entering());
  s.update(0.001, 0.001);
  EXPECT_EQ(s.state(), SafetyState::kEnabled);
  EXPECT_EQ(s.drive_mode(), hal::DriveMode::kRun);
  s.update(0.006, 0.0051);
  EXPECT_EQ(s.state(), SafetyState::kDamping) << "stale command: damping in the same tick";
  EXPECT_EQ(s.drive_mode(), hal::DriveMode::kDamp);
  s.update(0.3, 0.0);
  EXPECT_EQ(s.state(), SafetyState::kDamping) << "fresh commands do not re-enable by themselves";
  s.update(0.507, 0.0);
  EXPECT_EQ(s.state(), SafetyState::kTorqueOff);
  EXPECT_EQ(s.drive_mode(), hal::DriveMode::kOff);
  EXPECT_EQ(s.enable(1.0, test::issued(), false, ""), "");
  s.stop(1.1, test::issued(), "stop from operator");
  EXPECT_EQ(s.state(), SafetyState::kDamping);
  EXPECT_EQ(s.enable(1.2, test::issued(), false, ""), "");
  s.fault(1.3, "r_knee fault code 3");
  EXPECT_EQ(s.state(), SafetyState::kFault);
  EXPECT_EQ(s.drive_mode(), hal::DriveMode::kDamp);
  s.damp(1.35, "damp");
  EXPECT_EQ(s.state(), SafetyState::kFault) << "a fault keeps its state";
  s.update(1.81, 0.0);
  EXPECT_EQ(s.drive_mode(), hal::DriveMode::kOff) << "torque off after the fault has lasted torque_off_after";
  EXPECT_EQ(s.state(), SafetyState::kFault);
}


TEST(Hal, ClosesTheLoopThroughTheCodecAndSensorsMatchTheSimulation) {
  Rig r;
  for (int k = 0; k < 5; ++k) r.tick_once();
  EXPECT_FALSE(r.emu->released()) << "on the gantry until enabled";
  EXPECT_EQ(r.h->operator_command(hal::kOperatorEnable, r.now, "test", test::issued()), "enabled by test");
  SensorSample measured;  // what the drives measured when they answered (before the physics step)
  for (int k = 0; k < 500; ++k) {
    ASSERT_EQ(r.h->set_command(r.hold(), r.now), "");
    measured = r.sim.sensors();
    r.tick_once();
    ASSERT_TRUE(r.h->replies_complete()) << k;
  }
  EXPECT_EQ(r.h->safety().state(), SafetyState::kEnabled);
  EXPECT_TRUE(r.emu->released());
  // The sample the hal assembled is what the drives and sensors measured, within half a step of
  // each field's quantisation.
  const SensorSample& s = r.h->sensors();
  for (int j = 0; j < r.robot.model.nj; ++j) {
    const auto& l = r.config.drives[static_cast<std::size_t>(j)].limits;
    const std::string name = r.robot.model.joint_name[static_cast<std::size_t>(j)];
    EXPECT_NEAR(s.q(j), measured.q(j), 0.5 * (l.p_max - l.p_min) / 65535.0 + 1e-12) << name;
    EXPECT_NEAR(s.qd(j), measured.qd(j), 0.5 * (l.v_max - l.v_min) / 4095.0 + 1e-12) << name;
    EXPECT_NEAR(s.tau(j), measured.tau(j), 0.5 * (l.t_max - l.t_min) / 4095.0 + 1e-12) << name;
  }
  for (int f = 0; f < 2; ++f) {
    for (int k = 0; k < 3; ++k) {
      EXPECT_NEAR(s.ft_wrench_S[static_cast<std::size_t>(f)](k), measured.ft_wrench_S[static_cast<std::size_t>(f)](k), 0.5 * hal::kFtForceScale + 1e-12);
      EXPECT_NEAR(s.ft_wrench_S[static_cast<std::size_t>(f)](3 + k), measured.ft_wrench_S[static_cast<std::size_t>(f)](3 + k), 0.5 * hal::kFtTorqueScale + 1e-12);
    }
  }
  EXPECT_LT((s.imu_gyro_B - measured.imu_gyro_B).cwiseAbs().maxCoeff(), 0.5 * hal::kImuGyroScale + 1e-12);
  EXPECT_LT((s.imu_accel_B - measured.imu_accel_B).cwiseAbs().maxCoeff(), 0.5 * hal::kImuAccelScale + 1e-12);
  EXPECT_LT((s.imu_quat_WB - measured.imu_quat_WB).cwiseAbs().maxCoeff(), 1e-4);
  // The emulated drives apply what was commanded (decoded from the frames).
  const auto& applied = r.emu->applied();
  const JointCommand hold = r.hold();
  for (int j = 0; j < r.robot.model.nj; ++j) {
    EXPECT_NEAR(applied.kp(j), hold.kp(j), 0.5 * 1000.0 / 4095.0 + 1e-9);
    EXPECT_NEAR(applied.kd(j), hold.kd(j), 0.5 * 50.0 / 4095.0 + 1e-9);
    EXPECT_NEAR(applied.q_des(j), r.robot.q_joints_stand(j), 1e-3);
  }
}

TEST(Hal, StaleCommandsDampWithinOneTickThenTorqueOff) {
  Rig r({"hal.safety.torque_off_after=0.2"});
  (void)r.h->operator_command(hal::kOperatorEnable, r.now, "test", test::issued());
  for (int k = 0; k < 200; ++k) {
    (void)r.h->set_command(r.hold(), r.now);
    r.tick_once();
  }
  const double last_command = r.now;
  int damped_at = -1;
  for (int k = 1; k <= 400; ++k) {
    r.tick_once();
    const bool damping = std::all_of(r.h->sent().begin(), r.h->sent().end(),
                                     [](const hal::DriveCommand& c) { return c.kp == 0 && c.t_ff == 0 && c.kd > 0; });
    if (damped_at < 0 && damping) damped_at = k;
  }
  ASSERT_GT(damped_at, 0);
  EXPECT_LE(damped_at * 1e-3, 0.005 + 1e-3 + 1e-9) << "damping within one tick of the command age limit";
  EXPECT_EQ(r.h->safety().state(), SafetyState::kTorqueOff);
  for (std::size_t i = 0; i < r.config.drives.size(); ++i) EXPECT_FALSE(r.emu->motor_mode(i)) << "torque off";
  EXPECT_GT(r.h->commands_stale(), 0);
  (void)last_command;
}

TEST(Hal, NonFiniteAndOutOfLimitCommandsAreRejectedAndNeverSent) {
  Rig r;
  (void)r.h->operator_command(hal::kOperatorEnable, r.now, "test", test::issued());
  JointCommand good = r.hold();
  for (int k = 0; k < 10; ++k) {
    good.tick = k;
    ASSERT_EQ(r.h->set_command(good, r.now), "");
    r.tick_once();
  }
  const auto before = r.h->sent();
  ++good.tick;
  JointCommand bad = good;
  bad.tau_ff(3) = std::nan("");
  EXPECT_NE(r.h->set_command(bad, r.now), "");
  bad = good;
  bad.tau_ff(3) = 1e4;
  EXPECT_NE(r.h->set_command(bad, r.now).find("tau_ff"), std::string::npos);
  bad = good;
  bad.kp(0) = 5e3;
  EXPECT_NE(r.h->set_command(bad, r.now).find("kp"), std::string::npos);
  EXPECT_EQ(r.h->commands_rejected(), 3);
  r.tick_once();
  for (std::size_t i = 0; i < before.size(); ++i) {
    EXPECT_TRUE(std::isfinite(r.h->sent()[i].t_ff));
    EXPECT_EQ(r.h->sent()[i].t_ff, before[i].t_ff) << "the last valid command is what went out";
    EXPECT_EQ(r.h->sent()[i].kp, before[i].kp);
  }
}

// A stop latches: an enable issued before it (a recording of one, played after the stop) is refused,
// whatever its freshness on the group; only an enable issued after the stop lifts it.
TEST(Hal, AStopHoldsUntilAnEnableIssuedAfterIt) {
  Rig r;
  const std::int64_t enable_before = test::issued();
  ASSERT_EQ(r.h->operator_command(hal::kOperatorEnable, r.now, "test", enable_before), "enabled by test");
  (void)r.h->set_command(r.hold(), r.now);
  r.tick_once();
  const std::int64_t stop_at = test::issued();
  (void)r.h->operator_command(hal::kOperatorStop, r.now, "operator", stop_at);
  r.tick_once();
  EXPECT_EQ(r.h->safety().state(), SafetyState::kDamping);
  const std::string replayed = r.h->operator_command(hal::kOperatorEnable, r.now, "test", enable_before);
  EXPECT_NE(replayed.find("enable refused"), std::string::npos) << replayed;
  EXPECT_NE(r.h->operator_command(hal::kOperatorEnable, r.now, "test", stop_at).find("refused"), std::string::npos)
      << "an enable as old as the stop does not lift it";
  EXPECT_EQ(r.h->safety().state(), SafetyState::kDamping);
  // A later damp from the supervisor latches too; an earlier one does not move the latch back.
  (void)r.h->operator_command(hal::kOperatorDamp, r.now, "supervisor", stop_at - 10);
  EXPECT_EQ(r.h->safety().stop_issued_us(), stop_at);
  EXPECT_EQ(r.h->operator_command(hal::kOperatorEnable, r.now, "test", test::issued()), "enabled by test");
}

// The stale-command watchdog cannot be kept alive by the last command sent again: only a newer tick
// renews a command, so the hal damps within its command age as if nothing came.
TEST(Hal, TheLastCommandSentAgainDoesNotKeepTheDrivesEnabled) {
  Rig r;
  (void)r.h->operator_command(hal::kOperatorEnable, r.now, "test", test::issued());
  const JointCommand last = r.hold();
  ASSERT_EQ(r.h->set_command(last, r.now), "");
  r.tick_once();
  ASSERT_EQ(r.h->safety().state(), SafetyState::kEnabled);
  int ticks = 0;
  while (r.h->safety().state() == SafetyState::kEnabled && ticks < 1000) {
    EXPECT_NE(r.h->set_command(last, r.now).find("not newer"), std::string::npos);
    r.tick_once();
    ++ticks;
  }
  EXPECT_EQ(r.h->safety().state(), SafetyState::kDamping);
  EXPECT_EQ(r.h->safety().reason(), "JOINT_COMMAND stale");
  EXPECT_LE(ticks * 1e-3, r.config.safety.command_max_age + 1.5e-3) << "damped within the command's age, plus a tick";
  EXPECT_EQ(r.h->commands_repeated(), ticks);
  EXPECT_EQ(r.h->commands_rejected(), 0);
}

// The attack on the bus: a forged reply frame after each drive's own. One reply per drive per tick:
// the first stands (its position, its fault flag), the others are counted, and a drive answered
// twice for missed_replies_fault ticks in a row is a fault.
TEST(Hal, ASecondReplyInATickNeverOverwritesTheFirstAndIsAFaultWhenItGoesOn) {
  Rig r;
  r.enable_and_hold(20);
  const auto j = static_cast<std::size_t>(r.robot.model.joint_index("r_knee"));
  const auto& d = r.config.drives[j];
  hal::MitCodec codec;
  r.after_replies = [&](Rig& rig) {
    hal::DriveReply forged;
    forged.drive_id = d.id;
    forged.p = d.sign * (rig.sim.sensors().q(static_cast<Eigen::Index>(j)) + 0.01 - d.offset);  // within reach: only the order refuses it
    forged.fault = 7;
    auto& bus = *rig.drive_buses[static_cast<std::size_t>(d.bus)];
    bus.send(codec.encode_reply(forged, d.limits));
    bus.flush();
  };
  const int n = r.config.safety.missed_replies_fault;
  for (int k = 0; k < n - 1; ++k) {
    (void)r.h->set_command(r.hold(), r.now);
    const double q_true = r.sim.sensors().q(static_cast<Eigen::Index>(j));
    r.tick_once();
    EXPECT_NEAR(r.h->sensors().q(static_cast<Eigen::Index>(j)), q_true, 1e-3) << "the forged position was taken";
    EXPECT_EQ(r.h->drives()[j].fault, 0) << "the forged fault flag was taken";
    EXPECT_EQ(r.h->safety().state(), SafetyState::kEnabled);
  }
  EXPECT_EQ(r.h->drives()[j].extra, n - 1);
  (void)r.h->set_command(r.hold(), r.now);
  r.tick_once();
  EXPECT_EQ(r.h->safety().state(), SafetyState::kFault);
  EXPECT_NE(r.h->fault_conditions().find("r_knee answered more than once"), std::string::npos) << r.h->fault_conditions();
}

// A reply whose position the drive cannot have reached since its last one, at its largest speed, is
// refused and counts as missed.
TEST(Hal, APositionBeyondTheDrivesReachSinceItsLastReplyIsRefused) {
  Rig r;
  for (int k = 0; k < 5; ++k) r.tick_once();
  const auto j = static_cast<std::size_t>(r.robot.model.joint_index("r_knee"));
  const auto& d = r.config.drives[j];
  const double q_before = r.h->sensors().q(static_cast<Eigen::Index>(j));
  const double reach = 20.0 * std::max(std::abs(d.limits.v_min), d.limits.v_max) * 1e-3;  // one tick: 20 × the velocity range
  hal::MitCodec codec;
  double offset = 3.0 * reach;
  r.after_replies = [&](Rig& rig) {
    hal::DriveReply forged;
    forged.drive_id = d.id;
    forged.p = d.sign * (q_before + offset - d.offset);
    auto& bus = *rig.drive_buses[static_cast<std::size_t>(d.bus)];
    bus.send(codec.encode_reply(forged, d.limits));
    bus.flush();
  };
  r.drives_answer = false;
  r.tick_once();
  EXPECT_EQ(r.h->drives()[j].implausible, 1);
  EXPECT_EQ(r.h->drives()[j].missed_run, 1) << "a refused reply is a missed one";
  EXPECT_NEAR(r.h->sensors().q(static_cast<Eigen::Index>(j)), q_before, 1e-9);
  offset = 0.5 * reach;  // within reach (two ticks since the last reply taken): taken
  r.tick_once();
  EXPECT_EQ(r.h->drives()[j].implausible, 1);
  EXPECT_NEAR(r.h->sensors().q(static_cast<Eigen::Index>(j)), q_before + offset, 1e-3);
}

TEST(Hal, MissedRepliesFaultAndEnableNeedsThemBack) {
  Rig r;
  r.enable_and_hold(20);
  r.drives_answer = false;
  r.hold_for(5);
  EXPECT_EQ(r.h->safety().state(), SafetyState::kFault);
  EXPECT_EQ(r.h->safety().drive_mode(), hal::DriveMode::kDamp);
  EXPECT_NE(r.h->fault_conditions().find("missed 5 replies"), std::string::npos) << r.h->fault_conditions();
  EXPECT_NE(r.h->operator_command(hal::kOperatorEnable, r.now, "test", test::issued()).find("refused"), std::string::npos);
  r.drives_answer = true;
  (void)r.h->set_command(r.hold(), r.now);
  r.tick_once();
  EXPECT_EQ(r.h->fault_conditions(), "");
  EXPECT_EQ(r.h->operator_command(hal::kOperatorEnable, r.now, "test", test::issued()), "enabled by test");
}

TEST(Hal, BusOffOnOneBusDampsEveryDrive) {
  Rig r({"emulator.bus_off_bus=can4", "emulator.bus_off_at=0.05"});
  (void)r.h->operator_command(hal::kOperatorEnable, r.now, "test", test::issued());
  for (int k = 0; k < 100; ++k) {
    (void)r.h->set_command(r.hold(), r.now);
    r.tick_once();
  }
  EXPECT_EQ(r.h->safety().state(), SafetyState::kFault);
  EXPECT_NE(r.h->fault_conditions().find("bus-off on can4"), std::string::npos) << r.h->fault_conditions();
  for (std::size_t i = 0; i < r.config.drives.size(); ++i) {
    EXPECT_EQ(r.h->sent()[i].kp, 0.0);
    EXPECT_EQ(r.h->sent()[i].t_ff, 0.0);
  }
}

TEST(Hal, SoftLimitDampsTowardsRestNotTowardsTheCommandedVelocity) {
  Rig r;
  (void)r.h->operator_command(hal::kOperatorEnable, r.now, "test", test::issued());
  ASSERT_EQ(r.h->set_command(r.hold(), r.now), "");
  r.h->begin_tick(0, r.now);  // enter motor mode
  const int j = r.robot.model.joint_index("r_knee");
  const auto& d = r.config.drives[static_cast<std::size_t>(j)];
  const double inside = 0.01;  // [rad] from the lower limit, within the soft-limit margin
  ASSERT_LT(inside, r.config.soft_limit_margin);
  hal::DriveReply reply;
  reply.drive_id = d.id;
  reply.p = d.sign * (d.q_lower + inside - d.offset);
  hal::MitCodec codec;
  r.drive_buses[static_cast<std::size_t>(d.bus)]->send(codec.encode_reply(reply, d.limits));
  r.drive_buses[static_cast<std::size_t>(d.bus)]->flush();
  r.h->receive();
  r.h->end_tick(r.now);
  ASSERT_NEAR(r.h->sensors().q(j), d.q_lower + inside, 1e-4);
  JointCommand c = r.hold();
  const double kd = 5.0, qd_des = -2.0;  // asked to move fast into the limit
  c.kd(j) = kd;
  c.qd_des(j) = qd_des;
  ASSERT_EQ(r.h->set_command(c, r.now), "");
  r.h->begin_tick(1, r.now);
  const hal::DriveCommand& sent = r.h->sent()[static_cast<std::size_t>(j)];
  const double measured = r.h->sensors().q(j) - d.q_lower;  // `inside`, quantised by the position field
  const double kd_s = (r.config.soft_limit_margin - measured) / r.config.soft_limit_margin * r.config.soft_limit_kd;
  EXPECT_NEAR(sent.kd, kd + kd_s, 1e-12);
  // The drive's law kd' (v_des' − v) equals the commanded damping plus damping towards rest, in
  // drive units, at every velocity.
  for (const double v : {-3.0, -1.0, 0.0, 0.5, 2.0}) {
    EXPECT_NEAR(sent.kd * (sent.v_des - v), kd * (d.sign * qd_des - v) - kd_s * v, 1e-9) << v;
  }
}

TEST(Hal, LockstepTickClosesOnTheEmulatorsClockFrameWhateverTheRepliesDid) {
  Rig r({"hal.clock=lockstep", "emulator.drop_reply_probability=0.2", "emulator.bus_off_bus=can4", "emulator.bus_off_at=0.0"});
  ASSERT_TRUE(r.config.lockstep);
  (void)r.h->operator_command(hal::kOperatorEnable, 0.0, "test", test::issued());  // drives in motor mode: losses injected
  std::vector<hal::CanFrame> rx;
  int incomplete = 0;
  for (std::int64_t k = 0; k < 50; ++k) {
    r.h->begin_tick(k, 1e-3 * static_cast<double>(k));
    EXPECT_FALSE(r.emu->any_requested());
    for (std::size_t b = 0; b < r.drive_buses.size(); ++b) {
      rx.clear();
      r.drive_buses[b]->receive(rx);
      for (const auto& f : rx) r.emu->handle(static_cast<int>(b), f, 1e-3 * static_cast<double>(k), *r.drive_buses[b]);
      r.drive_buses[b]->flush();
    }
    // Every drive on a live bus and the SYNC have been heard (can4 is bus-off: deaf).
    ASSERT_TRUE(r.emu->tick_requested()) << k;
    r.h->receive();
    EXPECT_FALSE(r.h->tick_closed()) << "replies alone never close a lockstep tick";
    incomplete += r.h->replies_complete() ? 0 : 1;
    r.emu->step(1e-3 * static_cast<double>(k));
    for (auto& bus : r.drive_buses) {
      hal::DriveEmulator::report_tick(k, *bus);
      bus->flush();
    }
    r.h->receive();
    EXPECT_TRUE(r.h->tick_closed()) << k;
    r.h->end_tick(1e-3 * static_cast<double>(k));
  }
  EXPECT_EQ(incomplete, 50) << "dropped replies and a deaf bus: no tick had every reply";
  EXPECT_EQ(r.h->frames_malformed(), 0) << "the clock frame is no unknown frame in lockstep";
  // On the robot's clock the same frame is an unknown one: counted, nothing else.
  Rig rt;
  ASSERT_FALSE(rt.config.lockstep);
  rt.h->begin_tick(0, 0.0);
  hal::DriveEmulator::report_tick(0, *rt.drive_buses[0]);
  rt.drive_buses[0]->flush();
  rt.h->receive();
  EXPECT_EQ(rt.h->frames_malformed(), 1);
  EXPECT_FALSE(rt.h->tick_closed());
}

TEST(DriveEmulator, DrivesDampByThemselvesWhenTheHalStops) {
  Rig r;
  (void)r.h->operator_command(hal::kOperatorEnable, r.now, "test", test::issued());
  for (int k = 0; k < 50; ++k) {
    (void)r.h->set_command(r.hold(), r.now);
    r.tick_once();
  }
  for (int k = 0; k < 30; ++k) r.tick_once(false);  // the hal is gone
  for (std::size_t i = 0; i < r.config.drives.size(); ++i) {
    const auto j = static_cast<Eigen::Index>(i);
    EXPECT_TRUE(r.emu->timed_out(i, r.now));
    EXPECT_EQ(r.emu->applied().kp(j), 0.0);
    EXPECT_EQ(r.emu->applied().tau_ff(j), 0.0);
    EXPECT_GT(r.emu->applied().kd(j), 0.0);
  }
}

// Held joints (robot.held_joints) keep their drives: outside JOINT_COMMAND and ROBOT_SENSORS, held
// by the hal's own joint impedance at their positions, damped and switched off with every drive.
TEST(Hal, HoldsTheHeldJointsOutsideTheCommands) {
  Rig r({"robot.held_joints={r_wrist_yaw: 0.3, neck_yaw: -0.2}", "hal.held_joints={kp: 40, kd: 1.5}"});
  ASSERT_EQ(r.robot.model.nj, 25);
  ASSERT_EQ(r.config.drives.size(), 27U);
  ASSERT_EQ(r.config.controlled, 25);
  EXPECT_EQ(r.h->sensors().q.size(), 25);
  (void)r.h->operator_command(hal::kOperatorEnable, r.now, "test", test::issued());
  for (int k = 0; k < 1500; ++k) {
    ASSERT_EQ(r.h->set_command(r.hold(), r.now), "");
    r.tick_once();
  }
  // What went out to the held drives, and where the simulated joints are: at their held positions.
  for (std::size_t k = 0; k < 2; ++k) {
    const std::size_t i = 25 + k;
    const hal::DriveConfig& d = r.config.drives[i];
    ASSERT_TRUE(d.held);
    const double held = r.robot.held.at(d.joint);
    EXPECT_NEAR(d.sign * r.h->sent()[i].p_des + d.offset, held, 1e-12) << d.joint;
    EXPECT_EQ(r.h->sent()[i].kp, 40.0);
    EXPECT_EQ(r.h->sent()[i].kd, 1.5);
    const auto h = static_cast<Eigen::Index>(k);
    ASSERT_EQ(r.robot.model.held_joint_name[k], d.joint);
    EXPECT_NEAR(r.sim.truth().q_held(h), held, 0.02) << d.joint;
    const double resolution = (d.limits.p_max - d.limits.p_min) / 65535.0;
    EXPECT_NEAR(r.h->held_positions()(h), r.sim.truth().q_held(h), 0.02 + resolution) << d.joint;
  }
  EXPECT_FALSE(r.sim.truth().fallen);
  // Damping reaches the held drives too: no stiffness, only damping.
  (void)r.h->operator_command(hal::kOperatorDamp, r.now, "test", test::issued());
  r.tick_once();
  for (std::size_t i = 25; i < 27; ++i) {
    EXPECT_EQ(r.h->sent()[i].kp, 0.0);
    EXPECT_GT(r.h->sent()[i].kd, 0.0);
  }
}

TEST(HalConfig, AHeldJointWithoutADriveIsNamed) {
  Config c = Config::load(test::source_dir() + "/config/toro.yaml", {"robot.held_joints={neck_yaw: 0.0}"});
  const auto robot = model::RobotSpec::load(c.section("robot"));
  // Remove neck_yaw's drive: the hal must refuse, naming the joint.
  std::string yaml = test::read_file(test::source_dir() + "/config/toro.yaml");
  const auto at = yaml.find("    - {joint: neck_yaw");
  ASSERT_NE(at, std::string::npos);
  yaml.erase(at, yaml.find('\n', at) - at + 1);
  const Config edited = Config::parse(yaml, "edited.yaml");
  try {
    (void)hal::HalConfig::load(edited.section("hal"), robot);
    FAIL() << "accepted";
  } catch (const ConfigError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("neck_yaw"), std::string::npos) << msg;
    EXPECT_NE(msg.find("held joint"), std::string::npos) << msg;
  }
}

TEST(HalConfig, ErrorsNameTheFileKeyAndValue) {
  // A copy of the configuration with one line changed (the URDF path made absolute).
  std::ifstream in(test::source_dir() + "/config/toro.yaml");
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  auto load = [&](const std::string& from, const std::string& to) {
    std::string t = text;
    const auto at = t.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    if (at != std::string::npos) t.replace(at, from.size(), to);
    const std::string path = test::temp_dir("halcfg") + "/robot.yaml";
    std::ofstream(path) << t;
    const Config c = Config::load(path, {"robot.urdf=" + test::source_dir() + "/models/toro/toro.urdf"});
    const auto robot = model::RobotSpec::load(c.section("robot"));
    return hal::HalConfig::load(c.section("hal"), robot);
  };
  EXPECT_NO_THROW((void)load("{joint: r_knee, bus: can1, id: 1}", "{joint: r_knee, bus: can1, id: 1}"));
  try {
    (void)load("{joint: r_knee, bus: can1, id: 1}", "{joint: r_knee, bus: can42, id: 1}");
    FAIL() << "unknown bus accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("can42"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("robot.yaml"), std::string::npos) << e.what();
  }
  try {
    (void)load("{joint: r_knee, bus: can1, id: 1}", "{joint: r_knee, bus: can1, id: 2}");
    FAIL() << "duplicate drive id accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("used twice"), std::string::npos) << e.what();
  }
  try {
    (void)load("    - {joint: neck_pitch, bus: can8, id: 3}\n", "");
    FAIL() << "a joint without a drive accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("neck_pitch"), std::string::npos) << e.what();
  }
  EXPECT_THROW((void)load("{joint: r_knee, bus: can1, id: 1}", "{joint: r_knee, bus: can1, id: 1, sign: 2}"), ConfigError);
  EXPECT_THROW((void)load("command_max_age: 0.005", "command_max_age: -1"), ConfigError);
}

}  // namespace
