#include "hpr/msg/state.hpp"

#include <fmt/format.h>

#include <cmath>

#include "arrays.hpp"
#include "task_fields.hpp"

namespace hpr::msg {

namespace {
using detail::finite_all;
Eigen::Quaterniond quat_wxyz(const double* a) { return Eigen::Quaterniond(a[0], a[1], a[2], a[3]); }
void put_quat(const Eigen::Quaterniond& q, double* a) {
  a[0] = q.w();
  a[1] = q.x();
  a[2] = q.y();
  a[3] = q.z();
}
}  // namespace

void to_message(const EstimatedState& s, const RobotNames& names, humanoid::robot_state_t& m) {
  const int n = static_cast<int>(s.q.size()) - 7;
  m.tick = s.tick;
  m.utime = static_cast<int64_t>(std::llround(s.time * 1e6));
  const Eigen::Quaterniond quat(s.q(6), s.q(3), s.q(4), s.q(5));
  const Eigen::Matrix3d R = quat.normalized().toRotationMatrix();
  const Eigen::Vector3d v_W = R * s.v.head<3>(), w_W = R * s.v.segment<3>(3);
  for (int k = 0; k < 3; ++k) {
    m.p_WB[k] = s.q(k);
    m.v_WB[k] = v_W(k);
    m.omega_WB[k] = w_W(k);
    m.p_WCom[k] = s.p_com(k);
    m.v_WCom[k] = s.v_com(k);
    m.l_WCom[k] = s.l_com(k);
    m.ldot_WCom[k] = s.ldot_com(k);
  }
  put_quat(quat, m.quat_WB);
  m.num_joints = n;
  m.joint_name = names.joints;
  m.q.assign(s.q.data() + 7, s.q.data() + 7 + n);
  m.qd.assign(s.v.data() + 6, s.v.data() + 6 + n);
  if (s.tau.size() == n) {
    m.tau.assign(s.tau.data(), s.tau.data() + n);
  } else {
    m.tau.assign(static_cast<size_t>(n), 0.0);
  }
  m.num_feet = 2;
  m.foot_name.assign(names.feet.begin(), names.feet.end());
  m.foot_contact = {static_cast<int8_t>(s.contact[0]), static_cast<int8_t>(s.contact[1])};
  m.foot_force_z = {s.foot_force_z[0], s.foot_force_z[1]};
  m.foot_wrench_W.resize(2);
  for (size_t f = 0; f < 2; ++f) m.foot_wrench_W[f].assign(s.foot_wrench_W[f].data(), s.foot_wrench_W[f].data() + 6);
  m.status = s.status;
}

std::string from_message(const humanoid::robot_state_t& m, const RobotNames& names, EstimatedState& s) {
  const auto n = static_cast<int>(names.joints.size());
  if (m.num_joints != n) return fmt::format("num_joints {} != {} configured", m.num_joints, n);
  if (!m.joint_name.empty() && m.joint_name != names.joints) return "joint names differ from the configured robot";
  if (m.num_feet != 2) return fmt::format("num_feet {} != 2", m.num_feet);
  if (!finite_all(m.q) || !finite_all(m.qd) || !finite_all(m.tau)) return "non-finite joint value";
  if (!detail::finite(m.p_WB, 3) || !detail::finite(m.quat_WB, 4) || !detail::finite(m.v_WB, 3) ||
      !detail::finite(m.omega_WB, 3) || !detail::finite(m.p_WCom, 3) || !detail::finite(m.v_WCom, 3) ||
      !detail::finite(m.l_WCom, 3) || !detail::finite(m.ldot_WCom, 3)) {
    return "non-finite base, CoM or momentum value";
  }
  Eigen::Quaterniond quat = quat_wxyz(m.quat_WB);
  if (std::abs(quat.norm() - 1.0) > 1e-3) return fmt::format("base quaternion norm {} is not 1", quat.norm());
  quat.normalize();
  s.tick = m.tick;
  s.time = static_cast<double>(m.utime) * 1e-6;
  s.q.resize(7 + n);
  s.v.resize(6 + n);
  s.q.head<3>() = Eigen::Vector3d(m.p_WB[0], m.p_WB[1], m.p_WB[2]);
  s.q(3) = quat.x();
  s.q(4) = quat.y();
  s.q(5) = quat.z();
  s.q(6) = quat.w();
  s.q.tail(n) = Eigen::Map<const Eigen::VectorXd>(m.q.data(), n);
  const Eigen::Matrix3d Rt = quat.toRotationMatrix().transpose();
  s.v.head<3>() = Rt * Eigen::Vector3d(m.v_WB[0], m.v_WB[1], m.v_WB[2]);
  s.v.segment<3>(3) = Rt * Eigen::Vector3d(m.omega_WB[0], m.omega_WB[1], m.omega_WB[2]);
  s.v.tail(n) = Eigen::Map<const Eigen::VectorXd>(m.qd.data(), n);
  s.tau = Eigen::Map<const Eigen::VectorXd>(m.tau.data(), n);
  s.p_com = Eigen::Vector3d(m.p_WCom[0], m.p_WCom[1], m.p_WCom[2]);
  s.v_com = Eigen::Vector3d(m.v_WCom[0], m.v_WCom[1], m.v_WCom[2]);
  s.l_com = Eigen::Vector3d(m.l_WCom[0], m.l_WCom[1], m.l_WCom[2]);
  s.ldot_com = Eigen::Vector3d(m.ldot_WCom[0], m.ldot_WCom[1], m.ldot_WCom[2]);
  for (size_t f = 0; f < 2; ++f) {
    s.contact[f] = m.foot_contact[f] != 0;
    s.foot_force_z[f] = m.foot_force_z[f];
    s.foot_wrench_W[f] = Eigen::Map<const Eigen::Matrix<double, 6, 1>>(m.foot_wrench_W[f].data());
  }
  s.status = m.status;
  return "";
}

void to_message(const balance::WholebodyCommand& c, const std::vector<std::string>& free_names, const RobotNames& names,
                humanoid::wholebody_command_t& m) {
  const balance::TaskReference& r = c.command;
  m.tick = c.tick;
  m.utime = static_cast<int64_t>(std::llround(r.time * 1e6));
  detail::put_task(r, free_names, names, m);
  put_quat(Eigen::Quaterniond(r.R_base), m.quat_WB);
  m.quat_WF.resize(2);
  for (size_t f = 0; f < 2; ++f) {
    m.quat_WF[f].resize(4);
    put_quat(Eigen::Quaterniond(r.feet[f].X_WS.R), m.quat_WF[f].data());
  }
  for (int k = 0; k < 3; ++k) {
    m.l_cmd_W[k] = c.l_cmd(k);
    m.ldot_cmd_W[k] = c.ldot_cmd(k);
    m.l_ref_W[k] = c.l_ref(k);
  }
  const auto na = static_cast<int>(c.adjusted_name.size());
  m.num_adjusted = na;
  m.adjusted_name = c.adjusted_name;
  auto put = [na](const Eigen::VectorXd& v, std::vector<double>& dst) {
    if (v.size() >= na) {
      dst.assign(v.data(), v.data() + na);
    } else {
      dst.assign(static_cast<size_t>(na), 0.0);
    }
  };
  put(c.xa_opt, m.xa_opt);
  put(c.xad_opt, m.xad_opt);
  put(c.xa_min, m.xa_min);
  put(c.xa_max, m.xa_max);
  put(c.xad_min, m.xad_min);
  put(c.xad_max, m.xad_max);
  m.num_segments = static_cast<int32_t>(c.segment_names.size());
  m.segment_name = c.segment_names;
  m.segment_l_W.resize(c.segment_names.size());
  for (size_t s = 0; s < c.segment_names.size(); ++s) {
    m.segment_l_W[s].assign(c.segment_l[s].data(), c.segment_l[s].data() + 3);
  }
  m.posture_error = c.posture_error;
  m.qp_status = c.qp_status;
  m.qp_iterations = c.qp_iterations;
  m.qp_solve_time_us = c.qp_solve_time_us;
  m.status = (c.reference_stale ? humanoid::wholebody_command_t::STATUS_REFERENCE_STALE : 0) |
             (c.qp_failed ? humanoid::wholebody_command_t::STATUS_QP_FAILED : 0) |
             (c.singular ? humanoid::wholebody_command_t::STATUS_SINGULAR : 0);
}

std::string from_message(const humanoid::wholebody_command_t& m, const std::vector<std::string>& free_names,
                         balance::WholebodyCommand& c) {
  balance::TaskReference& r = c.command;
  if (std::string why = detail::check_task(m, free_names); !why.empty()) return why;
  if (!detail::finite(m.quat_WB, 4) || !finite_all(m.quat_WF[0]) || !finite_all(m.quat_WF[1])) return "non-finite orientation";
  if (!detail::finite(m.l_cmd_W, 3) || !detail::finite(m.ldot_cmd_W, 3) || !detail::finite(m.l_ref_W, 3) ||
      !std::isfinite(m.posture_error) || !finite_all(m.xa_opt) || !finite_all(m.xad_opt) || !finite_all(m.xa_min) ||
      !finite_all(m.xa_max) || !finite_all(m.xad_min) || !finite_all(m.xad_max)) {
    return "non-finite CAM, posture error or adjusted coordinate";
  }
  for (const auto& l : m.segment_l_W) {
    if (!finite_all(l)) return "non-finite segment CAM";
  }
  const Eigen::Quaterniond qb = quat_wxyz(m.quat_WB);
  if (std::abs(qb.norm() - 1.0) > 1e-3) return "base quaternion not normalised";
  c.tick = m.tick;
  detail::get_task(m, r);
  r.R_base = qb.normalized().toRotationMatrix();
  for (size_t f = 0; f < 2; ++f) r.feet[f].X_WS.R = quat_wxyz(m.quat_WF[f].data()).normalized().toRotationMatrix();
  c.l_cmd = Eigen::Map<const Eigen::Vector3d>(m.l_cmd_W);
  c.ldot_cmd = Eigen::Map<const Eigen::Vector3d>(m.ldot_cmd_W);
  c.l_ref = Eigen::Map<const Eigen::Vector3d>(m.l_ref_W);
  const auto na = static_cast<Eigen::Index>(m.num_adjusted);
  c.adjusted.clear();  // indices into an optimiser's coordinates: not carried, the names are
  c.adjusted_name = m.adjusted_name;
  c.xa_opt = Eigen::Map<const Eigen::VectorXd>(m.xa_opt.data(), na);
  c.xad_opt = Eigen::Map<const Eigen::VectorXd>(m.xad_opt.data(), na);
  c.xa_min = Eigen::Map<const Eigen::VectorXd>(m.xa_min.data(), na);
  c.xa_max = Eigen::Map<const Eigen::VectorXd>(m.xa_max.data(), na);
  c.xad_min = Eigen::Map<const Eigen::VectorXd>(m.xad_min.data(), na);
  c.xad_max = Eigen::Map<const Eigen::VectorXd>(m.xad_max.data(), na);
  c.segment_names = m.segment_name;
  c.segment_l.resize(m.segment_l_W.size());
  for (size_t s = 0; s < m.segment_l_W.size(); ++s) c.segment_l[s] = Eigen::Map<const Eigen::Vector3d>(m.segment_l_W[s].data());
  c.posture_error = m.posture_error;
  c.qp_status = m.qp_status;
  c.qp_iterations = m.qp_iterations;
  c.qp_solve_time_us = m.qp_solve_time_us;
  c.reference_stale = (m.status & humanoid::wholebody_command_t::STATUS_REFERENCE_STALE) != 0;
  c.qp_failed = (m.status & humanoid::wholebody_command_t::STATUS_QP_FAILED) != 0;
  c.singular = (m.status & humanoid::wholebody_command_t::STATUS_SINGULAR) != 0;
  return "";
}

}  // namespace hpr::msg
