#pragma once
/// \file Every LCM type of the stack, and a filler that gives each field random content, for the
/// round-trip tests and the transport benchmark.

#include <humanoid/balance_plan_t.hpp>
#include <humanoid/balance_status_t.hpp>
#include <humanoid/cam_reference_t.hpp>
#include <humanoid/hal_status_t.hpp>
#include <humanoid/health_t.hpp>
#include <humanoid/joint_command_t.hpp>
#include <humanoid/operator_t.hpp>
#include <humanoid/params_t.hpp>
#include <humanoid/push_t.hpp>
#include <humanoid/robot_sensors_t.hpp>
#include <humanoid/robot_state_t.hpp>
#include <humanoid/sim_truth_t.hpp>
#include <humanoid/supervisor_command_t.hpp>
#include <humanoid/supervisor_status_t.hpp>
#include <humanoid/wholebody_command_t.hpp>
#include <random>
#include <string>
#include <vector>

namespace hpr::test {

/// Calls f.template operator()<Msg>(name) for every type, always in this order.
template <class F>
void for_each_type(F&& f) {
  f.template operator()<humanoid::robot_sensors_t>("ROBOT_SENSORS");
  f.template operator()<humanoid::robot_state_t>("ROBOT_STATE");
  f.template operator()<humanoid::balance_status_t>("BALANCE_STATUS");
  f.template operator()<humanoid::cam_reference_t>("CAM_REFERENCE");
  f.template operator()<humanoid::wholebody_command_t>("WHOLEBODY_COMMAND");
  f.template operator()<humanoid::joint_command_t>("JOINT_COMMAND");
  f.template operator()<humanoid::push_t>("PUSH");
  f.template operator()<humanoid::sim_truth_t>("SIM_TRUTH");
  f.template operator()<humanoid::health_t>("HEALTH");
  f.template operator()<humanoid::operator_t>("OPERATOR");
  f.template operator()<humanoid::hal_status_t>("HAL_STATUS");
  f.template operator()<humanoid::params_t>("PARAMS");
  f.template operator()<humanoid::supervisor_status_t>("SUPERVISOR_STATUS");
  f.template operator()<humanoid::supervisor_command_t>("SUPERVISOR_COMMAND");
  f.template operator()<humanoid::balance_plan_t>("BALANCE_PLAN");  // last: a fuzz input's first byte picks a type by its place
}

/// How many types for_each_type visits.
inline int type_count() {
  int n = 0;
  for_each_type([&]<class Msg>(const char*) { ++n; });
  return n;
}

class Filler {
 public:
  explicit Filler(unsigned seed, int joints = 27) : gen_(seed), joints_(joints) {}

  double r() { return std::uniform_real_distribution<double>(-100, 100)(gen_); }
  int64_t i64() { return std::uniform_int_distribution<int64_t>(0, int64_t{1} << 40)(gen_); }
  int32_t i32() { return std::uniform_int_distribution<int32_t>(-1000, 1000)(gen_); }
  int8_t i8() { return static_cast<int8_t>(std::uniform_int_distribution<int>(-100, 100)(gen_)); }
  bool b() { return (gen_() & 1U) != 0; }
  std::string s() { return "joint_" + std::to_string(gen_() % 1000); }
  template <size_t N>
  void arr(double (&a)[N]) {
    for (auto& x : a) x = r();
  }
  std::vector<double> vec(int n) {
    std::vector<double> v(static_cast<size_t>(n));
    for (auto& x : v) x = r();
    return v;
  }
  std::vector<std::vector<double>> mat(int n, int m) {
    std::vector<std::vector<double>> v(static_cast<size_t>(n));
    for (auto& row : v) row = vec(m);
    return v;
  }
  std::vector<std::string> names(int n) {
    std::vector<std::string> v(static_cast<size_t>(n));
    for (auto& x : v) x = s();
    return v;
  }
  template <class T, class G>
  std::vector<T> gen(int n, G g) {
    std::vector<T> v(static_cast<size_t>(n));
    for (auto& x : v) x = g();
    return v;
  }

  void fill(humanoid::robot_sensors_t& m) {
    m.tick = i64(); m.utime = i64(); m.source = i64(); m.num_joints = joints_;
    m.joint_name = names(joints_); m.q = vec(joints_); m.qd = vec(joints_); m.tau = vec(joints_);
    m.drive_status = gen<int32_t>(joints_, [&] { return i32(); });
    arr(m.imu_quat_WB); arr(m.imu_gyro_B); arr(m.imu_accel_B);
    m.num_ft = 2; m.ft_name = names(2); m.ft_wrench_S = mat(2, 6);
    bytes(m.mac);
  }
  void fill(humanoid::robot_state_t& m) {
    m.tick = i64(); m.utime = i64(); m.source = i64();
    arr(m.p_WB); arr(m.quat_WB); arr(m.v_WB); arr(m.omega_WB); arr(m.p_WCom); arr(m.v_WCom);
    m.num_joints = joints_; m.joint_name = names(joints_); m.q = vec(joints_); m.qd = vec(joints_); m.tau = vec(joints_);
    m.num_feet = 2; m.foot_name = names(2); m.foot_contact = gen<int8_t>(2, [&] { return static_cast<int8_t>(b()); });
    m.foot_force_z = vec(2); m.foot_wrench_W = mat(2, 6);
    arr(m.l_WCom); arr(m.ldot_WCom); m.status = i32();
    bytes(m.mac);
  }
  void fill(humanoid::balance_status_t& m) {
    m.tick = i64(); m.utime = i64(); m.source = i64(); m.support = i8(); arr(m.p_WV); m.yaw_WV = r();
    arr(m.tau_ankle_V); arr(m.tau_hip_V); arr(m.tau_V); arr(m.tau_min_V); arr(m.tau_max_V);
    arr(m.cop_V); arr(m.cop_measured_V); m.f_vz = r(); arr(m.w_des_WCom); arr(m.w_achieved_WCom);
    m.num_contacts = 2; m.contact_name = names(2); m.contact_wrench_W = mat(2, 6);
    m.qp_status = i32(); m.qp_iterations = i32(); m.qp_solve_time_us = r(); m.qp_fallback = b(); m.compute_time_us = r();
    bytes(m.mac);
  }
  void fill(humanoid::cam_reference_t& m) {
    m.tick = i64(); m.utime = i64(); m.source = i64(); arr(m.l_ref_W); arr(m.ldot_ref_W); arr(m.l_ref_V); arr(m.ldot_ref_V);
    m.yaw_WV = r();
    for (auto& p : m.phase) p = i8();
    for (auto& row : m.t_phase_start) arr(row);
    arr(m.tau_thres_V); arr(m.ldot_max_V); m.status = i32(); m.balance_tick = i64();
    bytes(m.mac);
  }
  void fill(humanoid::wholebody_command_t& m) {
    m.tick = i64(); m.utime = i64(); m.source = i64(); m.support = i8();
    arr(m.p_WCom); arr(m.v_WCom); arr(m.a_WCom); arr(m.quat_WB); arr(m.omega_WB); arr(m.omegadot_WB);
    m.num_feet = 2; m.foot_name = names(2); m.p_WF = mat(2, 3); m.quat_WF = mat(2, 4); m.v_WF = mat(2, 6); m.a_WF = mat(2, 6);
    m.foot_contact = gen<int8_t>(2, [&] { return static_cast<int8_t>(b()); }); m.foot_load_limit = vec(2);
    const int nf = joints_ - 12;
    m.num_free = nf; m.free_joint = names(nf); m.q_free = vec(nf); m.qd_free = vec(nf); m.qdd_free = vec(nf);
    arr(m.l_cmd_W); arr(m.ldot_cmd_W); arr(m.l_ref_W);
    m.num_adjusted = 12; m.adjusted_name = names(12); m.xa_opt = vec(12); m.xad_opt = vec(12);
    m.xa_min = vec(12); m.xa_max = vec(12); m.xad_min = vec(12); m.xad_max = vec(12);
    m.num_segments = 5; m.segment_name = names(5); m.segment_l_W = mat(5, 3);
    m.posture_error = r(); m.qp_status = i32(); m.qp_iterations = i32(); m.qp_solve_time_us = r(); m.status = i32();
    bytes(m.mac);
  }
  void fill(humanoid::balance_plan_t& m) {
    m.tick = i64(); m.utime = i64(); m.source = i64(); m.support = i8(); m.stage = i8(); m.settled = b();
    arr(m.p_WCom); arr(m.v_WCom); arr(m.a_WCom); for (auto& row : m.R_WB) arr(row); arr(m.omega_WB); arr(m.omegadot_WB);
    m.num_feet = 2; m.foot_name = names(2); m.p_WF = mat(2, 3); m.R_WF = mat(2, 9); m.v_WF = mat(2, 6); m.a_WF = mat(2, 6);
    m.foot_contact = gen<int8_t>(2, [&] { return static_cast<int8_t>(b()); }); m.foot_load_limit = vec(2);
    const int nf = joints_ - 12;
    m.num_free = nf; m.free_joint = names(nf); m.q_free = vec(nf); m.qd_free = vec(nf); m.qdd_free = vec(nf);
    arr(m.f_ext_W);
    m.stepping = b(); arr(m.xi_W); m.xi_excess = r(); m.step_foot = i32(); arr(m.step_target_W); m.step_time_left = r();
    m.steps_taken = i32(); m.follow_steps = i32();
    bytes(m.mac);
  }
  void fill(humanoid::joint_command_t& m) {
    m.tick = i64(); m.utime = i64(); m.source = i64(); m.mode = i8(); m.num_joints = joints_; m.joint_name = names(joints_);
    m.tau_ff = vec(joints_); m.q_des = vec(joints_); m.qd_des = vec(joints_); m.kp = vec(joints_); m.kd = vec(joints_);
    bytes(m.mac);
  }
  void fill(humanoid::push_t& m) {
    m.tick = i64(); m.utime = i64(); m.id = i64(); m.link = s(); arr(m.point_L); arr(m.force_W);
    m.start_time = r(); m.duration = r(); m.profile = i8();
  }
  void fill(humanoid::sim_truth_t& m) {
    m.tick = i64(); m.utime = i64(); m.source = i64(); arr(m.p_WB); arr(m.quat_WB); arr(m.v_WB); arr(m.omega_WB);
    arr(m.p_WCom); arr(m.v_WCom); arr(m.h_lin_W); arr(m.l_WCom);
    m.num_feet = 2; m.foot_name = names(2); m.p_WF = mat(2, 3); m.quat_WF = mat(2, 4); m.contact_wrench_W = mat(2, 6);
    m.foot_contact = gen<int8_t>(2, [&] { return static_cast<int8_t>(b()); }); m.foot_tilt = vec(2);
    m.push_id = i64(); m.push_active = b(); arr(m.push_force_W); arr(m.push_impulse_W); arr(m.push_point_W); m.fallen = b(); m.sim_time = r();
    bytes(m.mac);
  }
  void fill(humanoid::health_t& m) {
    m.tick = i64(); m.utime = i64(); m.node = s(); m.host = s(); m.pid = i32(); m.state = i8(); m.lifecycle = i8(); m.steps = i64();
    m.rate_hz = r(); m.cycle_median_us = r(); m.cycle_p99_us = r(); m.cycle_max_us = r();
    m.deadline_misses = i64(); m.decode_errors = i64(); m.stale_inputs = i64(); m.log_suppressed = i64(); m.unauthenticated = i64(); m.num_faults = 2; m.faults = names(2);
  }
  void fill(humanoid::operator_t& m) {
    m.tick = i64(); m.utime = i64(); m.source = s(); m.command = i8(); m.support = i8(); m.reason = s();
    m.num_params = 3; m.param_name = names(3); m.param_value = vec(3);
    bytes(m.mac);
  }
  void fill(humanoid::params_t& m) {
    m.tick = i64(); m.utime = i64(); m.node = s(); m.version = i64(); m.request_utime = i64(); m.request_source = s();
    m.accepted = b(); m.result = s(); m.num_params = 5; m.name = names(5); m.value = vec(5); m.min_value = vec(5);
    m.max_value = vec(5); m.unit = names(5);
  }
  void fill(humanoid::hal_status_t& m) {
    m.tick = i64(); m.utime = i64(); m.source = i64(); m.state = i8(); m.state_reason = s(); m.num_drives = joints_;
    m.drive_joint = names(joints_); m.drive_id = gen<int32_t>(joints_, [&] { return i32(); });
    m.drive_state = gen<int8_t>(joints_, [&] { return i8(); }); m.drive_temperature = vec(joints_);
    m.drive_fault = gen<int32_t>(joints_, [&] { return i32(); }); m.drive_missed = gen<int64_t>(joints_, [&] { return i64(); });
    m.drive_missed_run = gen<int32_t>(joints_, [&] { return i32(); });
    m.num_buses = 9; m.bus_name = names(9); m.bus_tx_fps = vec(9); m.bus_rx_fps = vec(9);
    m.bus_errors = gen<int64_t>(9, [&] { return i64(); }); m.bus_off = gen<int8_t>(9, [&] { return static_cast<int8_t>(b()); });
    m.commands_rejected = i64(); m.commands_stale = i64(); m.frames_malformed = i64();
    bytes(m.mac);
  }

  void fill(humanoid::supervisor_status_t& m) {
    m.tick = i64(); m.utime = i64(); m.host = s(); m.group = s(); m.pid = i32(); m.run_dir = s(); m.state = i8(); m.message = s();
    const int n = 6;
    m.num_processes = n; m.name = names(n); m.process_state = gen<int8_t>(n, [&] { return i8(); });
    m.process_pid = gen<int32_t>(n, [&] { return i32(); }); m.uptime_s = vec(n);
    m.restarts = gen<int32_t>(n, [&] { return i32(); }); m.critical = gen<int8_t>(n, [&] { return static_cast<int8_t>(b()); });
    m.health_state = gen<int8_t>(n, [&] { return i8(); }); m.lifecycle = gen<int8_t>(n, [&] { return i8(); }); m.rate_hz = vec(n);
    m.deadline_misses = gen<int64_t>(n, [&] { return i64(); }); m.detail = names(n);
  }
  void fill(humanoid::supervisor_command_t& m) {
    m.tick = i64(); m.utime = i64(); m.source = s(); m.host = s(); m.group = s(); m.command = i8(); m.process = s();
    bytes(m.mac);
  }

 private:
  template <std::size_t N>
  void bytes(std::uint8_t (&a)[N]) {
    for (auto& x : a) x = static_cast<std::uint8_t>(gen_());
  }
  std::mt19937_64 gen_;
  int joints_;
};

/// The encoded bytes of a message (for exact comparisons).
template <class Msg>
std::vector<uint8_t> encode(const Msg& m) {
  std::vector<uint8_t> buf(static_cast<size_t>(m.getEncodedSize()));
  m.encode(buf.data(), 0, static_cast<int>(buf.size()));
  return buf;
}

}  // namespace hpr::test
