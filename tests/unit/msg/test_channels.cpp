// One conversion per channel (hpr/msg): every value a component publishes arrives unchanged at the
// component that reads it, through the message's bytes; and a message with a non-finite value or an
// impossible enumeration is refused with the reason.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "hpr/msg/balance.hpp"
#include "hpr/msg/plan.hpp"
#include "hpr/msg/robot_io.hpp"
#include "hpr/msg/sim_truth.hpp"
#include "hpr/msg/state.hpp"

namespace {

using namespace hpr;

/// The message as a receiver gets it: encoded, then decoded from the bytes.
template <class Msg>
Msg through_bytes(const Msg& m) {
  std::vector<std::uint8_t> bytes(static_cast<size_t>(m.getEncodedSize()));
  EXPECT_EQ(m.encode(bytes.data(), 0, static_cast<int>(bytes.size())), static_cast<int>(bytes.size()));
  Msg out{};
  EXPECT_EQ(out.decode(bytes.data(), 0, static_cast<int>(bytes.size())), static_cast<int>(bytes.size()));
  return out;
}

class Channels : public ::testing::Test {
 protected:
  Channels() {
    names.joints = {"hip_pitch", "knee", "ankle_pitch", "shoulder"};
    free_names = {"shoulder"};
  }
  double r() { return dist(rng); }
  template <class V>
  void fill(V& v) {
    for (Eigen::Index i = 0; i < v.size(); ++i) v(i) = r();
  }
  Eigen::Quaterniond unit_quaternion() { return Eigen::Quaterniond(Eigen::Vector4d(r(), r(), r(), r()).normalized()); }
  /// Microseconds, as the messages carry times.
  double time() { return static_cast<double>(std::uniform_int_distribution<long>(0, 100'000'000)(rng)) * 1e-6; }
  /// A task reference with every field set (one free joint, `still` the foot out of contact, a step under way).
  balance::TaskReference task_reference(balance::Support support, int still, double load_limit) {
    balance::TaskReference t;
    t.time = time();
    t.support = support;
    fill(t.p_com);
    fill(t.v_com);
    fill(t.a_com);
    t.R_base = unit_quaternion().toRotationMatrix();
    fill(t.omega_base);
    fill(t.omegadot_base);
    for (auto& f : t.feet) {
      fill(f.X_WS.p);
      f.X_WS.R = unit_quaternion().toRotationMatrix();
      fill(f.twist);
      fill(f.accel);
      f.load_limit = load_limit;
    }
    t.feet[static_cast<size_t>(still)].contact = false;
    t.q_free = t.qd_free = t.qdd_free = Eigen::VectorXd::Zero(1);
    fill(t.q_free);
    fill(t.qd_free);
    fill(t.qdd_free);
    balance::StepStatus& st = t.stepping;
    st.enabled = true;
    fill(st.xi_W);
    st.excess = r();
    st.swing = still;
    fill(st.target_W);
    st.target_yaw = r();
    st.time_left = 0.21;
    st.steps_taken = 3;
    st.follow_steps = 1;
    return t;
  }
  /// `g` is `t` to the bit, but its orientations, which agree to `rotation_tolerance` (0: to the bit).
  static void expect_same_task(const balance::TaskReference& g, const balance::TaskReference& t, double rotation_tolerance) {
    const auto same_rotation = [&](const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
      return rotation_tolerance == 0.0 ? a == b : a.isApprox(b, rotation_tolerance);
    };
    EXPECT_EQ(g.time, t.time);
    EXPECT_EQ(g.support, t.support);
    EXPECT_EQ(g.p_com, t.p_com);
    EXPECT_EQ(g.v_com, t.v_com);
    EXPECT_EQ(g.a_com, t.a_com);
    EXPECT_TRUE(same_rotation(g.R_base, t.R_base));
    EXPECT_EQ(g.omega_base, t.omega_base);
    EXPECT_EQ(g.omegadot_base, t.omegadot_base);
    for (size_t f = 0; f < 2; ++f) {
      EXPECT_EQ(g.feet[f].X_WS.p, t.feet[f].X_WS.p);
      EXPECT_TRUE(same_rotation(g.feet[f].X_WS.R, t.feet[f].X_WS.R)) << "foot " << f;
      EXPECT_EQ(g.feet[f].twist, t.feet[f].twist);
      EXPECT_EQ(g.feet[f].accel, t.feet[f].accel);
      EXPECT_EQ(g.feet[f].contact, t.feet[f].contact);
      EXPECT_EQ(g.feet[f].load_limit, t.feet[f].load_limit);
    }
    EXPECT_EQ(g.q_free, t.q_free);
    EXPECT_EQ(g.qd_free, t.qd_free);
    EXPECT_EQ(g.qdd_free, t.qdd_free);
    const balance::StepStatus &gs = g.stepping, &ts = t.stepping;
    EXPECT_EQ(gs.enabled, ts.enabled);
    EXPECT_EQ(gs.xi_W, ts.xi_W);
    EXPECT_EQ(gs.excess, ts.excess);
    EXPECT_EQ(gs.swing, ts.swing);
    EXPECT_EQ(gs.target_W, ts.target_W);
    EXPECT_EQ(gs.target_yaw, ts.target_yaw);
    EXPECT_EQ(gs.time_left, ts.time_left);
    EXPECT_EQ(gs.steps_taken, ts.steps_taken);
    EXPECT_EQ(gs.follow_steps, ts.follow_steps);
  }

  std::mt19937 rng{42};
  std::uniform_real_distribution<double> dist{-3.0, 3.0};
  msg::RobotNames names;
  std::vector<std::string> free_names;
};

TEST_F(Channels, RobotSensorsArriveUnchanged) {
  SensorSample s;
  s.resize(4);
  s.tick = 1234;
  s.time = time();
  fill(s.q);
  fill(s.qd);
  fill(s.tau);
  s.drive_status = {1, 1, 3, 9};
  s.imu_quat_WB = unit_quaternion().coeffs();  // any unit quaternion, (w, x, y, z) by convention
  fill(s.imu_gyro_B);
  fill(s.imu_accel_B);
  for (auto& w : s.ft_wrench_S) fill(w);
  humanoid::robot_sensors_t m{};
  msg::to_message(s, names, m);
  SensorSample got;
  ASSERT_EQ(msg::from_message(through_bytes(m), names, got), "");
  EXPECT_EQ(got.tick, s.tick);
  EXPECT_EQ(got.time, s.time);
  EXPECT_EQ(got.q, s.q);
  EXPECT_EQ(got.qd, s.qd);
  EXPECT_EQ(got.tau, s.tau);
  EXPECT_EQ(got.drive_status, s.drive_status);
  EXPECT_LT((got.imu_quat_WB - s.imu_quat_WB).norm(), 1e-15);  // normalised on receipt
  EXPECT_EQ(got.imu_gyro_B, s.imu_gyro_B);
  EXPECT_EQ(got.imu_accel_B, s.imu_accel_B);
  for (size_t f = 0; f < 2; ++f) EXPECT_EQ(got.ft_wrench_S[f], s.ft_wrench_S[f]);

  m.q[2] = std::nan("");
  EXPECT_NE(msg::from_message(m, names, got), "");
}

TEST_F(Channels, JointCommandArrivesUnchanged) {
  JointCommand c;
  c.resize(4);
  c.tick = 77;
  c.time = 12.345678;  // its stream's clock: the time rule at the drives reads it
  c.mode = JointCommand::Mode::kRun;
  fill(c.tau_ff);
  fill(c.q_des);
  fill(c.qd_des);
  c.kp = c.q_des.cwiseAbs();
  c.kd = c.qd_des.cwiseAbs();
  humanoid::joint_command_t m{};
  msg::to_message(c, names, m);
  JointCommand got;
  ASSERT_EQ(msg::from_message(through_bytes(m), names, got), "");
  EXPECT_EQ(got.tick, c.tick);
  EXPECT_EQ(m.utime, 12345678);
  EXPECT_DOUBLE_EQ(got.time, c.time);
  EXPECT_EQ(got.mode, c.mode);
  EXPECT_EQ(got.tau_ff, c.tau_ff);
  EXPECT_EQ(got.q_des, c.q_des);
  EXPECT_EQ(got.qd_des, c.qd_des);
  EXPECT_EQ(got.kp, c.kp);
  EXPECT_EQ(got.kd, c.kd);

  m.tau_ff[0] = std::numeric_limits<double>::infinity();
  EXPECT_NE(msg::from_message(m, names, got), "");
}

TEST_F(Channels, RobotStateArrivesUnchanged) {
  EstimatedState s;
  s.tick = 5;
  s.time = time();
  s.q.resize(11);
  s.v.resize(10);
  fill(s.q);
  fill(s.v);
  s.q.segment<4>(3) = unit_quaternion().coeffs();  // (x, y, z, w)
  s.tau = Eigen::VectorXd::Zero(4);
  fill(s.tau);
  fill(s.p_com);
  fill(s.v_com);
  fill(s.l_com);
  fill(s.ldot_com);
  s.contact = {true, false};
  s.foot_force_z = {r(), r()};
  for (auto& w : s.foot_wrench_W) fill(w);
  s.status = EstimatedState::kNoContact | EstimatedState::kInitialising;
  humanoid::robot_state_t m{};
  msg::to_message(s, names, m);
  EstimatedState got;
  ASSERT_EQ(msg::from_message(through_bytes(m), names, got), "");
  EXPECT_EQ(got.tick, s.tick);
  EXPECT_EQ(got.time, s.time);
  EXPECT_EQ(got.q.head<3>(), s.q.head<3>());
  EXPECT_EQ(got.q.tail(4), s.q.tail(4));
  // The base orientation and twist travel in world axes: equal to rounding.
  EXPECT_TRUE(Eigen::Quaterniond(got.q.segment<4>(3)).isApprox(Eigen::Quaterniond(s.q.segment<4>(3)), 1e-15));
  EXPECT_LT((got.v - s.v).cwiseAbs().maxCoeff(), 1e-14);
  EXPECT_EQ(got.v.tail(4), s.v.tail(4));
  EXPECT_EQ(got.tau, s.tau);
  EXPECT_EQ(got.p_com, s.p_com);
  EXPECT_EQ(got.v_com, s.v_com);
  EXPECT_EQ(got.l_com, s.l_com);
  EXPECT_EQ(got.ldot_com, s.ldot_com);
  EXPECT_EQ(got.contact, s.contact);
  EXPECT_EQ(got.foot_force_z, s.foot_force_z);
  for (size_t f = 0; f < 2; ++f) EXPECT_EQ(got.foot_wrench_W[f], s.foot_wrench_W[f]);
  EXPECT_EQ(got.status, s.status);
  EXPECT_TRUE(got.usable());

  m.quat_WB[0] = 2.0;
  EXPECT_NE(msg::from_message(m, names, got), "");
}

TEST_F(Channels, WholebodyCommandArrivesUnchanged) {
  balance::WholebodyCommand c;
  c.tick = 99;
  c.command = task_reference(balance::Support::kLeft, 1, 0.3);
  fill(c.l_cmd);
  fill(c.ldot_cmd);
  fill(c.l_ref);
  c.adjusted_name = {"base_rotation_x", "shoulder"};
  for (Eigen::VectorXd* v : {&c.xa_opt, &c.xad_opt, &c.xa_min, &c.xa_max, &c.xad_min, &c.xad_max}) {
    v->resize(2);
    fill(*v);
  }
  c.segment_names = {"trunk", "right_arm"};
  c.segment_l = {Eigen::Vector3d(r(), r(), r()), Eigen::Vector3d(r(), r(), r())};
  c.posture_error = 0.25;
  c.qp_status = 3;
  c.qp_iterations = 4;
  c.qp_solve_time_us = 12.5;
  c.qp_failed = true;
  c.singular = true;
  humanoid::wholebody_command_t m{};
  msg::to_message(c, free_names, names, m);
  balance::WholebodyCommand got;
  ASSERT_EQ(msg::from_message(through_bytes(m), free_names, got), "");
  EXPECT_EQ(got.tick, c.tick);
  expect_same_task(got.command, c.command, 1e-15);  // orientations travel as quaternions
  EXPECT_EQ(got.l_cmd, c.l_cmd);
  EXPECT_EQ(got.ldot_cmd, c.ldot_cmd);
  EXPECT_EQ(got.l_ref, c.l_ref);
  EXPECT_EQ(got.adjusted_name, c.adjusted_name);
  EXPECT_EQ(got.xa_opt, c.xa_opt);
  EXPECT_EQ(got.xad_opt, c.xad_opt);
  EXPECT_EQ(got.xa_min, c.xa_min);
  EXPECT_EQ(got.xa_max, c.xa_max);
  EXPECT_EQ(got.xad_min, c.xad_min);
  EXPECT_EQ(got.xad_max, c.xad_max);
  EXPECT_EQ(got.segment_names, c.segment_names);
  ASSERT_EQ(got.segment_l.size(), 2U);
  EXPECT_EQ(got.segment_l[1], c.segment_l[1]);
  EXPECT_EQ(got.posture_error, c.posture_error);
  EXPECT_EQ(got.qp_status, c.qp_status);
  EXPECT_EQ(got.qp_iterations, c.qp_iterations);
  EXPECT_EQ(got.qp_solve_time_us, c.qp_solve_time_us);
  EXPECT_TRUE(got.qp_failed && got.singular && !got.reference_stale);

  // A reader of the diagnostics only takes any free joints; a configured reader refuses others.
  EXPECT_EQ(msg::from_message(m, {}, got), "");
  EXPECT_NE(msg::from_message(m, {"elbow"}, got), "");
  m.posture_error = std::nan("");
  EXPECT_NE(msg::from_message(m, free_names, got), "");
  m.posture_error = 0.25;
  m.xi_W[1] = std::numeric_limits<double>::infinity();
  EXPECT_EQ(msg::from_message(m, free_names, got), "non-finite capture point or step");
  m.xi_W[1] = 0.0;
  m.step_foot = 2;
  EXPECT_EQ(msg::from_message(m, free_names, got), "step_foot 2 is no foot (-1, 0 or 1)");
  m.step_foot = -1;
  EXPECT_EQ(msg::from_message(m, free_names, got), "");
}

// BALANCE_PLAN carries every number of the plan bit for bit (its rotations as matrices: a
// quaternion's round trip is not exact), so that motion_opt and the wbc of separate processes
// follow the very plan the planner made, as composed; a rotation that is not one is refused.
TEST_F(Channels, BalancePlanArrivesBitForBit) {
  balance::BalancePlan p;
  p.tick = 321;
  p.stage = balance::PlanStage::kStepSwing;
  fill(p.f_ext_W);
  p.reference = task_reference(balance::Support::kRight, 0, 0.7);
  p.reference.settled = true;
  const balance::TaskReference& t = p.reference;
  humanoid::balance_plan_t m{};
  msg::to_message(p, free_names, names, m);
  balance::BalancePlan got;
  ASSERT_EQ(msg::from_message(through_bytes(m), free_names, got), "");
  EXPECT_EQ(got.tick, p.tick);
  EXPECT_EQ(got.stage, p.stage);
  EXPECT_EQ(got.f_ext_W, p.f_ext_W);
  EXPECT_TRUE(got.reference.settled);
  expect_same_task(got.reference, t, 0.0);  // bit for bit, the orientations too
  // Through a WHOLEBODY_COMMAND's quaternion the same base orientation is only equal to rounding:
  // what the plan's own channel avoids.
  balance::WholebodyCommand wc;
  wc.command = t;
  humanoid::wholebody_command_t wm{};
  msg::to_message(wc, free_names, names, wm);
  balance::WholebodyCommand wgot;
  ASSERT_EQ(msg::from_message(wm, free_names, wgot), "");
  EXPECT_LT((wgot.command.R_base - t.R_base).norm(), 1e-14);

  // Refused whole, with the reason.
  const auto refused = [&](auto&& spoil) {
    humanoid::balance_plan_t bad = m;
    spoil(bad);
    return msg::from_message(bad, free_names, got);
  };
  EXPECT_EQ(refused([](auto& b) { b.R_WB[0][0] += 1e-6; }).rfind("base orientation is not a rotation", 0), 0U);
  EXPECT_EQ(refused([](auto& b) {
              for (int j = 0; j < 3; ++j) b.R_WB[2][j] = -b.R_WB[2][j];
            }).rfind("base orientation is a reflection", 0),
            0U);
  EXPECT_EQ(refused([](auto& b) { b.R_WF[1][4] = std::nan(""); }), "left non-finite sole orientation");
  EXPECT_EQ(refused([](auto& b) { b.stage = 10; }), "unknown stage 10");
  EXPECT_EQ(refused([](auto& b) { b.support = 3; }), "unknown support 3");
  EXPECT_EQ(refused([](auto& b) { b.f_ext_W[0] = std::numeric_limits<double>::infinity(); }), "non-finite external force");
  EXPECT_EQ(refused([](auto& b) { b.foot_load_limit[0] = 1.5; }), "right foot's load limit 1.5 is not in [0, 1]");
  EXPECT_EQ(refused([](auto& b) { b.p_WCom[2] = std::nan(""); }), "non-finite value");
  EXPECT_EQ(refused([](auto& b) { b.step_foot = 2; }), "step_foot 2 is no foot (-1, 0 or 1)");
  EXPECT_NE(msg::from_message(m, {"elbow"}, got), "") << "another robot's free joints";
  EXPECT_EQ(got.tick, p.tick) << "a refused plan leaves the last one as it was";
}

TEST_F(Channels, BalanceStatusArrivesUnchanged) {
  balance::BalanceStatus s;
  s.tick = 41;
  s.time = time();
  s.support = balance::Support::kRight;
  fill(s.p_WV);
  s.yaw_WV = r();
  fill(s.tau_ankle_V);
  fill(s.tau_hip_V);
  fill(s.tau_V);
  s.tau_min_V = -s.tau_ankle_V.cwiseAbs();
  s.tau_max_V = s.tau_hip_V.cwiseAbs();
  fill(s.cop_V);
  fill(s.cop_measured_V);
  s.f_vz = 600.0;
  fill(s.w_des);
  fill(s.w_achieved);
  for (auto& w : s.contact_wrench_W) fill(w);
  s.qp_status = 1;
  s.qp_iterations = 2;
  s.qp_solve_time_us = 3.5;
  s.qp_fallback = true;
  s.compute_time_us = 40.25;
  humanoid::balance_status_t m{};
  msg::to_message(s, names, m);
  EXPECT_EQ(m.contact_name[1], names.feet[1]);
  balance::BalanceStatus got;
  ASSERT_EQ(msg::from_message(through_bytes(m), got), "");
  EXPECT_EQ(got.tick, s.tick);
  EXPECT_EQ(got.time, s.time);
  EXPECT_EQ(got.support, s.support);
  EXPECT_EQ(got.p_WV, s.p_WV);
  EXPECT_EQ(got.yaw_WV, s.yaw_WV);
  EXPECT_EQ(got.tau_ankle_V, s.tau_ankle_V);
  EXPECT_EQ(got.tau_hip_V, s.tau_hip_V);
  EXPECT_EQ(got.tau_V, s.tau_V);
  EXPECT_EQ(got.tau_min_V, s.tau_min_V);
  EXPECT_EQ(got.tau_max_V, s.tau_max_V);
  EXPECT_EQ(got.cop_V, s.cop_V);
  EXPECT_EQ(got.cop_measured_V, s.cop_measured_V);
  EXPECT_EQ(got.f_vz, s.f_vz);
  EXPECT_EQ(got.w_des, s.w_des);
  EXPECT_EQ(got.w_achieved, s.w_achieved);
  for (size_t f = 0; f < 2; ++f) EXPECT_EQ(got.contact_wrench_W[f], s.contact_wrench_W[f]);
  EXPECT_EQ(got.qp_status, s.qp_status);
  EXPECT_EQ(got.qp_iterations, s.qp_iterations);
  EXPECT_EQ(got.qp_solve_time_us, s.qp_solve_time_us);
  EXPECT_EQ(got.qp_fallback, s.qp_fallback);
  EXPECT_EQ(got.compute_time_us, s.compute_time_us);

  auto refused = [&](auto change) {
    humanoid::balance_status_t bad = m;
    change(bad);
    return msg::from_message(bad, got);
  };
  EXPECT_NE(refused([](auto& b) { b.tau_ankle_V[1] = std::nan(""); }), "");
  EXPECT_NE(refused([](auto& b) { std::swap(b.tau_min_V[0], b.tau_max_V[0]); }), "");
  EXPECT_NE(refused([](auto& b) { b.support = 3; }), "");
}

TEST_F(Channels, CamReferenceArrivesUnchanged) {
  balance::CamReference c;
  c.tick = 8;
  c.time = time();
  fill(c.l_ref_V);
  fill(c.ldot_ref_V);
  fill(c.l_ref_W);
  fill(c.ldot_ref_W);
  c.yaw_WV = r();
  c.phase = {balance::Phase::kGenerate, balance::Phase::kIdle, balance::Phase::kRecover};
  c.t_phase_start = {{{1.0, -1.0, -1.0}, {-1.0, -1.0, -1.0}, {0.5, 0.7, 0.9}}};
  fill(c.tau_thres_V);
  fill(c.ldot_max_V);
  c.ramping = true;
  c.balance_tick = 7;
  humanoid::cam_reference_t m{};
  msg::to_message(c, m);
  balance::CamReference got;
  ASSERT_EQ(msg::from_message(through_bytes(m), got), "");
  EXPECT_EQ(got.tick, c.tick);
  EXPECT_EQ(got.time, c.time);
  EXPECT_EQ(got.l_ref_V, c.l_ref_V);
  EXPECT_EQ(got.ldot_ref_V, c.ldot_ref_V);
  EXPECT_EQ(got.l_ref_W, c.l_ref_W);
  EXPECT_EQ(got.ldot_ref_W, c.ldot_ref_W);
  EXPECT_EQ(got.yaw_WV, c.yaw_WV);
  EXPECT_EQ(got.phase, c.phase);
  EXPECT_EQ(got.t_phase_start, c.t_phase_start);
  EXPECT_EQ(got.tau_thres_V, c.tau_thres_V);
  EXPECT_EQ(got.ldot_max_V, c.ldot_max_V);
  EXPECT_EQ(got.stale, c.stale);
  EXPECT_EQ(got.ramping, c.ramping);
  EXPECT_EQ(got.balance_tick, c.balance_tick);
  EXPECT_TRUE(got.generating());

  m.phase[2] = 4;
  EXPECT_NE(msg::from_message(m, got), "");
  m.phase[2] = 0;
  m.l_ref_W[0] = -std::numeric_limits<double>::infinity();
  EXPECT_NE(msg::from_message(m, got), "");
}

TEST_F(Channels, SimTruthArrivesUnchanged) {
  SimTruth t;
  t.tick = 12;
  t.time = 0.012;
  for (Eigen::Vector3d* v : {&t.p_WB, &t.v_WB, &t.omega_WB, &t.p_WCom, &t.v_WCom, &t.h_lin_W, &t.l_WCom, &t.push_force_W,
                             &t.push_impulse_W, &t.push_point_W}) {
    fill(*v);
  }
  const Eigen::Quaterniond qb = unit_quaternion();
  t.quat_WB = Eigen::Vector4d(qb.w(), qb.x(), qb.y(), qb.z());
  for (size_t f = 0; f < 2; ++f) {
    fill(t.p_WF[f]);
    t.quat_WF[f] = unit_quaternion().coeffs();
    fill(t.contact_wrench_W[f]);
    t.foot_tilt[f] = 0.1 * static_cast<double>(f);
  }
  t.foot_contact = {true, false};
  t.push_id = 3;
  t.push_active = true;
  t.fallen = true;
  humanoid::sim_truth_t m{};
  msg::to_message(t, names.feet, m);
  SimTruth got;
  ASSERT_EQ(msg::from_message(through_bytes(m), got), "");
  EXPECT_EQ(got.tick, t.tick);
  EXPECT_EQ(got.time, t.time);
  EXPECT_EQ(got.p_WB, t.p_WB);
  EXPECT_EQ(got.quat_WB, t.quat_WB);
  EXPECT_EQ(got.v_WB, t.v_WB);
  EXPECT_EQ(got.omega_WB, t.omega_WB);
  EXPECT_EQ(got.p_WCom, t.p_WCom);
  EXPECT_EQ(got.v_WCom, t.v_WCom);
  EXPECT_EQ(got.h_lin_W, t.h_lin_W);
  EXPECT_EQ(got.l_WCom, t.l_WCom);
  EXPECT_EQ(got.push_force_W, t.push_force_W);
  EXPECT_EQ(got.push_impulse_W, t.push_impulse_W);
  EXPECT_EQ(got.push_point_W, t.push_point_W);
  for (size_t f = 0; f < 2; ++f) {
    EXPECT_EQ(got.p_WF[f], t.p_WF[f]);
    EXPECT_EQ(got.quat_WF[f], t.quat_WF[f]);
    EXPECT_EQ(got.contact_wrench_W[f], t.contact_wrench_W[f]);
    EXPECT_EQ(got.foot_tilt[f], t.foot_tilt[f]);
  }
  EXPECT_EQ(got.foot_contact, t.foot_contact);
  EXPECT_EQ(got.push_id, t.push_id);
  EXPECT_EQ(got.push_active, t.push_active);
  EXPECT_EQ(got.fallen, t.fallen);

  m.quat_WB[0] *= 1.5;
  EXPECT_NE(msg::from_message(m, got), "");
}

}  // namespace
