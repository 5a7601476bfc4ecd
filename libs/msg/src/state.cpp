#include "hpr/msg/state.hpp"

#include <fmt/format.h>

#include <cmath>

#include "arrays.hpp"

namespace hpr::msg {

namespace {
template <class T>
bool finite_all(const T& v) {
  for (double x : v) {
    if (!std::isfinite(x)) return false;
  }
  return true;
}
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
  m.support = static_cast<int8_t>(r.support);
  for (int k = 0; k < 3; ++k) {
    m.p_WCom[k] = r.p_com(k);
    m.v_WCom[k] = r.v_com(k);
    m.a_WCom[k] = r.a_com(k);
    m.omega_WB[k] = r.omega_base(k);
    m.omegadot_WB[k] = r.omegadot_base(k);
  }
  put_quat(Eigen::Quaterniond(r.R_base), m.quat_WB);
  m.num_feet = 2;
  m.foot_name.assign(names.feet.begin(), names.feet.end());
  m.p_WF.resize(2);
  m.quat_WF.resize(2);
  m.v_WF.resize(2);
  m.a_WF.resize(2);
  m.foot_contact.resize(2);
  m.foot_load_limit.resize(2);
  for (size_t f = 0; f < 2; ++f) {
    const auto& ft = r.feet[f];
    m.p_WF[f].assign(ft.X_WS.p.data(), ft.X_WS.p.data() + 3);
    m.quat_WF[f].resize(4);
    put_quat(Eigen::Quaterniond(ft.X_WS.R), m.quat_WF[f].data());
    m.v_WF[f].assign(ft.twist.data(), ft.twist.data() + 6);
    m.a_WF[f].assign(ft.accel.data(), ft.accel.data() + 6);
    m.foot_contact[f] = ft.contact ? 1 : 0;
    m.foot_load_limit[f] = ft.load_limit;
  }
  const int nf = static_cast<int>(free_names.size());
  m.num_free = nf;
  m.free_joint = free_names;
  m.q_free.assign(r.q_free.data(), r.q_free.data() + nf);
  m.qd_free.assign(r.qd_free.data(), r.qd_free.data() + nf);
  m.qdd_free.assign(r.qdd_free.data(), r.qdd_free.data() + nf);
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
  const balance::StepStatus& st = r.stepping;
  m.stepping = st.enabled;
  m.xi_W[0] = st.xi_W.x();
  m.xi_W[1] = st.xi_W.y();
  m.xi_excess = st.excess;
  m.step_foot = st.swing;
  m.step_target_W[0] = st.target_W.x();
  m.step_target_W[1] = st.target_W.y();
  m.step_target_W[2] = st.target_yaw;
  m.step_time_left = st.time_left;
  m.steps_taken = st.steps_taken;
  m.follow_steps = st.follow_steps;
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
  const int nf = free_names.empty() ? m.num_free : static_cast<int>(free_names.size());
  if (m.num_free != nf) return fmt::format("num_free {} != {} free joints", m.num_free, nf);
  if (!free_names.empty() && !m.free_joint.empty() && m.free_joint != free_names) {
    return "free joint names differ from the configured robot";
  }
  if (m.num_feet != 2) return fmt::format("num_feet {} != 2", m.num_feet);
  if (m.support < 0 || m.support > 2) return fmt::format("unknown support {}", static_cast<int>(m.support));
  if (!detail::finite(m.p_WCom, 3) || !detail::finite(m.v_WCom, 3) || !detail::finite(m.a_WCom, 3) ||
      !detail::finite(m.quat_WB, 4) || !detail::finite(m.omega_WB, 3) || !detail::finite(m.omegadot_WB, 3) ||
      !finite_all(m.q_free) || !finite_all(m.qd_free) || !finite_all(m.qdd_free)) {
    return "non-finite value";
  }
  for (size_t f = 0; f < 2; ++f) {
    if (!finite_all(m.p_WF[f]) || !finite_all(m.quat_WF[f]) || !finite_all(m.v_WF[f]) || !finite_all(m.a_WF[f]) ||
        !std::isfinite(m.foot_load_limit[f])) {
      return "non-finite foot value";
    }
  }
  if (!detail::finite(m.l_cmd_W, 3) || !detail::finite(m.ldot_cmd_W, 3) || !detail::finite(m.l_ref_W, 3) ||
      !std::isfinite(m.posture_error) || !finite_all(m.xa_opt) || !finite_all(m.xad_opt) || !finite_all(m.xa_min) ||
      !finite_all(m.xa_max) || !finite_all(m.xad_min) || !finite_all(m.xad_max)) {
    return "non-finite CAM, posture error or adjusted coordinate";
  }
  for (const auto& l : m.segment_l_W) {
    if (!finite_all(l)) return "non-finite segment CAM";
  }
  if (!detail::finite(m.xi_W, 2) || !std::isfinite(m.xi_excess) || !detail::finite(m.step_target_W, 3) ||
      !std::isfinite(m.step_time_left)) {
    return "non-finite capture point or step";
  }
  if (m.step_foot < -1 || m.step_foot > 1) return fmt::format("step_foot {} is no foot (-1, 0 or 1)", m.step_foot);
  const Eigen::Quaterniond qb = quat_wxyz(m.quat_WB);
  if (std::abs(qb.norm() - 1.0) > 1e-3) return "base quaternion not normalised";
  c.tick = m.tick;
  r.time = static_cast<double>(m.utime) * 1e-6;
  r.support = static_cast<balance::Support>(m.support);
  r.p_com = Eigen::Vector3d(m.p_WCom[0], m.p_WCom[1], m.p_WCom[2]);
  r.v_com = Eigen::Vector3d(m.v_WCom[0], m.v_WCom[1], m.v_WCom[2]);
  r.a_com = Eigen::Vector3d(m.a_WCom[0], m.a_WCom[1], m.a_WCom[2]);
  r.R_base = qb.normalized().toRotationMatrix();
  r.omega_base = Eigen::Vector3d(m.omega_WB[0], m.omega_WB[1], m.omega_WB[2]);
  r.omegadot_base = Eigen::Vector3d(m.omegadot_WB[0], m.omegadot_WB[1], m.omegadot_WB[2]);
  for (size_t f = 0; f < 2; ++f) {
    auto& ft = r.feet[f];
    ft.X_WS.p = Eigen::Map<const Eigen::Vector3d>(m.p_WF[f].data());
    ft.X_WS.R = quat_wxyz(m.quat_WF[f].data()).normalized().toRotationMatrix();
    ft.twist = Eigen::Map<const Eigen::Matrix<double, 6, 1>>(m.v_WF[f].data());
    ft.accel = Eigen::Map<const Eigen::Matrix<double, 6, 1>>(m.a_WF[f].data());
    ft.contact = m.foot_contact[f] != 0;
    ft.load_limit = m.foot_load_limit[f];
  }
  r.q_free = Eigen::Map<const Eigen::VectorXd>(m.q_free.data(), nf);
  r.qd_free = Eigen::Map<const Eigen::VectorXd>(m.qd_free.data(), nf);
  r.qdd_free = Eigen::Map<const Eigen::VectorXd>(m.qdd_free.data(), nf);
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
  balance::StepStatus& st = r.stepping;
  st.enabled = m.stepping != 0;
  st.xi_W = Eigen::Vector2d(m.xi_W[0], m.xi_W[1]);
  st.excess = m.xi_excess;
  st.swing = m.step_foot;
  st.target_W = Eigen::Vector2d(m.step_target_W[0], m.step_target_W[1]);
  st.target_yaw = m.step_target_W[2];
  st.time_left = m.step_time_left;
  st.steps_taken = m.steps_taken;
  st.follow_steps = m.follow_steps;
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
