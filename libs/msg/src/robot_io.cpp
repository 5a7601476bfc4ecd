#include "hpr/msg/robot_io.hpp"

#include <fmt/format.h>

#include <cmath>

namespace hpr::msg {

namespace {
template <class V>
std::string check_names(const std::vector<std::string>& got, const V& expected, const char* what) {
  if (got.empty()) return "";  // names are optional on the wire
  if (got.size() != expected.size()) return fmt::format("{} names: {} given, {} expected", what, got.size(), expected.size());
  for (std::size_t i = 0; i < got.size(); ++i) {
    if (got[i] != expected[i]) return fmt::format("{} {} is '{}', expected '{}'", what, i, got[i], expected[i]);
  }
  return "";
}

bool all_finite(const std::vector<double>& v) {
  for (double x : v) {
    if (!std::isfinite(x)) return false;
  }
  return true;
}
}  // namespace

void to_message(const SensorSample& s, const RobotNames& names, humanoid::robot_sensors_t& m) {
  const int n = static_cast<int>(s.q.size());
  m.tick = s.tick;
  m.utime = static_cast<int64_t>(std::llround(s.time * 1e6));
  m.num_joints = n;
  m.joint_name = names.joints;
  m.q.assign(s.q.data(), s.q.data() + n);
  m.qd.assign(s.qd.data(), s.qd.data() + n);
  m.tau.assign(s.tau.data(), s.tau.data() + n);
  m.drive_status = s.drive_status;
  for (int k = 0; k < 4; ++k) m.imu_quat_WB[k] = s.imu_quat_WB(k);
  for (int k = 0; k < 3; ++k) {
    m.imu_gyro_B[k] = s.imu_gyro_B(k);
    m.imu_accel_B[k] = s.imu_accel_B(k);
  }
  m.num_ft = 2;
  m.ft_name.assign(names.feet.begin(), names.feet.end());
  m.ft_wrench_S.resize(2);
  for (int f = 0; f < 2; ++f) {
    const auto& w = s.ft_wrench_S[static_cast<size_t>(f)];
    m.ft_wrench_S[static_cast<size_t>(f)].assign(w.data(), w.data() + 6);
  }
}

std::string from_message(const humanoid::robot_sensors_t& m, const RobotNames& names, SensorSample& s) {
  const auto n = static_cast<int>(names.joints.size());
  if (m.num_joints != n) return fmt::format("num_joints {} != {} configured", m.num_joints, n);
  if (auto why = check_names(m.joint_name, names.joints, "joint"); !why.empty()) return why;
  if (m.num_ft != 2) return fmt::format("num_ft {} != 2", m.num_ft);
  if (auto why = check_names(m.ft_name, names.feet, "ft sensor"); !why.empty()) return why;
  if (!all_finite(m.q) || !all_finite(m.qd) || !all_finite(m.tau)) return "non-finite joint value";
  for (int k = 0; k < 4; ++k) {
    if (!std::isfinite(m.imu_quat_WB[k])) return "non-finite IMU orientation";
  }
  for (int k = 0; k < 3; ++k) {
    if (!std::isfinite(m.imu_gyro_B[k]) || !std::isfinite(m.imu_accel_B[k])) return "non-finite IMU rate or acceleration";
  }
  for (const auto& w : m.ft_wrench_S) {
    if (!all_finite(w)) return "non-finite force/torque";
  }
  const double qn = std::sqrt(m.imu_quat_WB[0] * m.imu_quat_WB[0] + m.imu_quat_WB[1] * m.imu_quat_WB[1] +
                              m.imu_quat_WB[2] * m.imu_quat_WB[2] + m.imu_quat_WB[3] * m.imu_quat_WB[3]);
  if (std::abs(qn - 1.0) > 1e-3) return fmt::format("IMU quaternion norm {} is not 1", qn);
  s.tick = m.tick;
  s.time = static_cast<double>(m.utime) * 1e-6;
  s.q = Eigen::Map<const Eigen::VectorXd>(m.q.data(), n);
  s.qd = Eigen::Map<const Eigen::VectorXd>(m.qd.data(), n);
  s.tau = Eigen::Map<const Eigen::VectorXd>(m.tau.data(), n);
  s.drive_status = m.drive_status;
  for (int k = 0; k < 4; ++k) s.imu_quat_WB(k) = m.imu_quat_WB[k] / qn;
  for (int k = 0; k < 3; ++k) {
    s.imu_gyro_B(k) = m.imu_gyro_B[k];
    s.imu_accel_B(k) = m.imu_accel_B[k];
  }
  for (int f = 0; f < 2; ++f) {
    s.ft_wrench_S[static_cast<size_t>(f)] = Eigen::Map<const Eigen::Matrix<double, 6, 1>>(m.ft_wrench_S[static_cast<size_t>(f)].data());
  }
  return "";
}

void to_message(const JointCommand& c, const RobotNames& names, humanoid::joint_command_t& m) {
  const int n = static_cast<int>(c.tau_ff.size());
  m.tick = c.tick;
  m.utime = static_cast<int64_t>(std::llround(c.time * 1e6));
  m.mode = static_cast<int8_t>(c.mode);
  m.num_joints = n;
  m.joint_name = names.joints;
  m.tau_ff.assign(c.tau_ff.data(), c.tau_ff.data() + n);
  m.q_des.assign(c.q_des.data(), c.q_des.data() + n);
  m.qd_des.assign(c.qd_des.data(), c.qd_des.data() + n);
  m.kp.assign(c.kp.data(), c.kp.data() + n);
  m.kd.assign(c.kd.data(), c.kd.data() + n);
}

std::string from_message(const humanoid::joint_command_t& m, const RobotNames& names, JointCommand& c) {
  const auto n = static_cast<int>(names.joints.size());
  if (m.num_joints != n) return fmt::format("num_joints {} != {} configured", m.num_joints, n);
  if (auto why = check_names(m.joint_name, names.joints, "joint"); !why.empty()) return why;
  if (m.mode < humanoid::joint_command_t::MODE_OFF || m.mode > humanoid::joint_command_t::MODE_RUN) {
    return fmt::format("unknown mode {}", static_cast<int>(m.mode));
  }
  JointCommand tmp;
  tmp.tick = m.tick;
  tmp.time = static_cast<double>(m.utime) * 1e-6;
  tmp.mode = static_cast<JointCommand::Mode>(m.mode);
  tmp.tau_ff = Eigen::Map<const Eigen::VectorXd>(m.tau_ff.data(), n);
  tmp.q_des = Eigen::Map<const Eigen::VectorXd>(m.q_des.data(), n);
  tmp.qd_des = Eigen::Map<const Eigen::VectorXd>(m.qd_des.data(), n);
  tmp.kp = Eigen::Map<const Eigen::VectorXd>(m.kp.data(), n);
  tmp.kd = Eigen::Map<const Eigen::VectorXd>(m.kd.data(), n);
  if (auto why = tmp.check(n); !why.empty()) return why;
  c = std::move(tmp);
  return "";
}

}  // namespace hpr::msg
