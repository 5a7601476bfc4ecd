#pragma once
// The fields of a task reference that WHOLEBODY_COMMAND and BALANCE_PLAN carry alike (the CoM, the
// base's angular motion, the soles but their orientation, the free joints and the stepping status),
// written and read once for both (private to hpr::msg). Each message carries orientations its own way.
#include <fmt/format.h>

#include <cmath>
#include <string>
#include <vector>

#include "arrays.hpp"
#include "hpr/balance/task_reference.hpp"
#include "hpr/msg/robot_io.hpp"

namespace hpr::msg::detail {

template <class T>
bool finite_all(const T& v) {
  for (double x : v) {
    if (!std::isfinite(x)) return false;
  }
  return true;
}

template <class M>
void put_task(const balance::TaskReference& r, const std::vector<std::string>& free_names, const RobotNames& names, M& m) {
  m.support = static_cast<int8_t>(r.support);
  for (int k = 0; k < 3; ++k) {
    m.p_WCom[k] = r.p_com(k);
    m.v_WCom[k] = r.v_com(k);
    m.a_WCom[k] = r.a_com(k);
    m.omega_WB[k] = r.omega_base(k);
    m.omegadot_WB[k] = r.omegadot_base(k);
  }
  m.num_feet = 2;
  m.foot_name.assign(names.feet.begin(), names.feet.end());
  m.p_WF.resize(2);
  m.v_WF.resize(2);
  m.a_WF.resize(2);
  m.foot_contact.resize(2);
  m.foot_load_limit.resize(2);
  for (size_t f = 0; f < 2; ++f) {
    const auto& ft = r.feet[f];
    m.p_WF[f].assign(ft.X_WS.p.data(), ft.X_WS.p.data() + 3);
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
}

/// Empty when the shared fields of `m` are valid for `free_names` (empty: any free joints), else the reason.
template <class M>
std::string check_task(const M& m, const std::vector<std::string>& free_names) {
  const int nf = free_names.empty() ? m.num_free : static_cast<int>(free_names.size());
  if (m.num_free != nf) return fmt::format("num_free {} != {} free joints", m.num_free, nf);
  if (!free_names.empty() && !m.free_joint.empty() && m.free_joint != free_names) {
    return "free joint names differ from the configured robot";
  }
  if (m.num_feet != 2) return fmt::format("num_feet {} != 2", m.num_feet);
  if (m.support < 0 || m.support > 2) return fmt::format("unknown support {}", static_cast<int>(m.support));
  if (!finite(m.p_WCom, 3) || !finite(m.v_WCom, 3) || !finite(m.a_WCom, 3) || !finite(m.omega_WB, 3) ||
      !finite(m.omegadot_WB, 3) || !finite_all(m.q_free) || !finite_all(m.qd_free) || !finite_all(m.qdd_free)) {
    return "non-finite value";
  }
  for (size_t f = 0; f < 2; ++f) {
    if (!finite_all(m.p_WF[f]) || !finite_all(m.v_WF[f]) || !finite_all(m.a_WF[f]) || !std::isfinite(m.foot_load_limit[f])) {
      return "non-finite foot value";
    }
  }
  if (!finite(m.xi_W, 2) || !std::isfinite(m.xi_excess) || !finite(m.step_target_W, 3) || !std::isfinite(m.step_time_left)) {
    return "non-finite capture point or step";
  }
  if (m.step_foot < -1 || m.step_foot > 1) return fmt::format("step_foot {} is no foot (-1, 0 or 1)", m.step_foot);
  return {};
}

/// The shared fields of `m` (checked by check_task) into `r`.
template <class M>
void get_task(const M& m, balance::TaskReference& r) {
  const int nf = m.num_free;
  r.time = static_cast<double>(m.utime) * 1e-6;
  r.support = static_cast<balance::Support>(m.support);
  r.p_com = Eigen::Vector3d(m.p_WCom[0], m.p_WCom[1], m.p_WCom[2]);
  r.v_com = Eigen::Vector3d(m.v_WCom[0], m.v_WCom[1], m.v_WCom[2]);
  r.a_com = Eigen::Vector3d(m.a_WCom[0], m.a_WCom[1], m.a_WCom[2]);
  r.omega_base = Eigen::Vector3d(m.omega_WB[0], m.omega_WB[1], m.omega_WB[2]);
  r.omegadot_base = Eigen::Vector3d(m.omegadot_WB[0], m.omegadot_WB[1], m.omegadot_WB[2]);
  for (size_t f = 0; f < 2; ++f) {
    auto& ft = r.feet[f];
    ft.X_WS.p = Eigen::Map<const Eigen::Vector3d>(m.p_WF[f].data());
    ft.twist = Eigen::Map<const Eigen::Matrix<double, 6, 1>>(m.v_WF[f].data());
    ft.accel = Eigen::Map<const Eigen::Matrix<double, 6, 1>>(m.a_WF[f].data());
    ft.contact = m.foot_contact[f] != 0;
    ft.load_limit = m.foot_load_limit[f];
  }
  r.q_free = Eigen::Map<const Eigen::VectorXd>(m.q_free.data(), nf);
  r.qd_free = Eigen::Map<const Eigen::VectorXd>(m.qd_free.data(), nf);
  r.qdd_free = Eigen::Map<const Eigen::VectorXd>(m.qdd_free.data(), nf);
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
}

}  // namespace hpr::msg::detail
