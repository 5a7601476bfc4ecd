#include "hpr/msg/balance.hpp"

#include <fmt/format.h>

#include <cmath>

#include "arrays.hpp"

namespace hpr::msg {

namespace {
std::int64_t to_utime(double t) { return static_cast<std::int64_t>(std::llround(t * 1e6)); }
double from_utime(std::int64_t u) { return static_cast<double>(u) * 1e-6; }
}  // namespace

using detail::finite;
using detail::get;
using detail::put;

void to_message(const balance::BalanceStatus& s, const RobotNames& names, humanoid::balance_status_t& m) {
  m.tick = s.tick;
  m.utime = to_utime(s.time);
  m.support = static_cast<int8_t>(s.support);
  m.yaw_WV = s.yaw_WV;
  put<3>(s.p_WV, m.p_WV);
  put<3>(s.tau_ankle_V, m.tau_ankle_V);
  put<3>(s.tau_hip_V, m.tau_hip_V);
  put<3>(s.tau_V, m.tau_V);
  put<3>(s.tau_min_V, m.tau_min_V);
  put<3>(s.tau_max_V, m.tau_max_V);
  put<2>(s.cop_V, m.cop_V);
  put<2>(s.cop_measured_V, m.cop_measured_V);
  m.f_vz = s.f_vz;
  put<6>(s.w_des, m.w_des_WCom);
  put<6>(s.w_achieved, m.w_achieved_WCom);
  m.num_contacts = 2;
  m.contact_name.resize(2);
  m.contact_wrench_W.resize(2);
  for (size_t f = 0; f < 2; ++f) {
    m.contact_name[f] = names.feet[f];
    m.contact_wrench_W[f].assign(s.contact_wrench_W[f].data(), s.contact_wrench_W[f].data() + 6);
  }
  m.qp_status = s.qp_status;
  m.qp_iterations = s.qp_iterations;
  m.qp_solve_time_us = s.qp_solve_time_us;
  m.qp_fallback = s.qp_fallback;
  m.compute_time_us = s.compute_time_us;
}

std::string from_message(const humanoid::balance_status_t& m, balance::BalanceStatus& s) {
  if (m.support < 0 || m.support > 2) return fmt::format("unknown support {}", static_cast<int>(m.support));
  if (!finite(m.tau_ankle_V, 3) || !finite(m.tau_min_V, 3) || !finite(m.tau_max_V, 3) || !finite(m.tau_hip_V, 3) ||
      !finite(m.tau_V, 3)) {
    return "non-finite torque or limit";
  }
  for (int k = 0; k < 3; ++k) {
    if (m.tau_min_V[k] > m.tau_max_V[k]) {
      return fmt::format("torque limits inverted on axis {} ({} > {})", k, m.tau_min_V[k], m.tau_max_V[k]);
    }
  }
  if (!std::isfinite(m.yaw_WV) || !finite(m.p_WV, 3)) return "non-finite virtual stance foot";
  if (!finite(m.cop_V, 2) || !finite(m.cop_measured_V, 2) || !std::isfinite(m.f_vz) || !finite(m.w_des_WCom, 6) ||
      !finite(m.w_achieved_WCom, 6)) {
    return "non-finite CoP, force or wrench";
  }
  if (m.num_contacts > 2) return fmt::format("num_contacts {} > 2", m.num_contacts);
  for (const auto& w : m.contact_wrench_W) {
    if (!finite(w.data(), static_cast<int>(w.size()))) return "non-finite contact wrench";
  }
  s.tick = m.tick;
  s.time = from_utime(m.utime);
  s.support = static_cast<balance::Support>(m.support);
  s.yaw_WV = m.yaw_WV;
  s.p_WV = get<3>(m.p_WV);
  s.tau_ankle_V = get<3>(m.tau_ankle_V);
  s.tau_hip_V = get<3>(m.tau_hip_V);
  s.tau_V = get<3>(m.tau_V);
  s.tau_min_V = get<3>(m.tau_min_V);
  s.tau_max_V = get<3>(m.tau_max_V);
  s.cop_V = get<2>(m.cop_V);
  s.cop_measured_V = get<2>(m.cop_measured_V);
  s.f_vz = m.f_vz;
  s.w_des = get<6>(m.w_des_WCom);
  s.w_achieved = get<6>(m.w_achieved_WCom);
  for (size_t f = 0; f < 2; ++f) {
    s.contact_wrench_W[f] = f < m.contact_wrench_W.size() && m.contact_wrench_W[f].size() == 6
                                ? get<6>(m.contact_wrench_W[f].data())
                                : balance::Vector6d::Zero();
  }
  s.qp_status = m.qp_status;
  s.qp_iterations = m.qp_iterations;
  s.qp_solve_time_us = m.qp_solve_time_us;
  s.qp_fallback = m.qp_fallback;
  s.compute_time_us = m.compute_time_us;
  return "";
}

void to_message(const balance::CamReference& r, humanoid::cam_reference_t& m) {
  m.tick = r.tick;
  m.utime = to_utime(r.time);
  m.yaw_WV = r.yaw_WV;
  put<3>(r.l_ref_W, m.l_ref_W);
  put<3>(r.ldot_ref_W, m.ldot_ref_W);
  put<3>(r.l_ref_V, m.l_ref_V);
  put<3>(r.ldot_ref_V, m.ldot_ref_V);
  put<3>(r.tau_thres_V, m.tau_thres_V);
  put<3>(r.ldot_max_V, m.ldot_max_V);
  for (size_t k = 0; k < 3; ++k) {
    m.phase[k] = static_cast<int8_t>(r.phase[k]);
    for (size_t p = 0; p < 3; ++p) m.t_phase_start[k][p] = r.t_phase_start[k][p];
  }
  m.status = (r.stale ? humanoid::cam_reference_t::STATUS_BALANCE_STALE : 0) |
             (r.ramping ? humanoid::cam_reference_t::STATUS_RAMPING_DOWN : 0);
  m.balance_tick = r.balance_tick;
}

std::string from_message(const humanoid::cam_reference_t& m, balance::CamReference& r) {
  if (!finite(m.l_ref_W, 3) || !finite(m.ldot_ref_W, 3) || !finite(m.l_ref_V, 3) || !finite(m.ldot_ref_V, 3)) {
    return "non-finite CAM reference";
  }
  if (!std::isfinite(m.yaw_WV) || !finite(m.tau_thres_V, 3) || !finite(m.ldot_max_V, 3)) {
    return "non-finite yaw, threshold or rate";
  }
  for (int k = 0; k < 3; ++k) {
    if (m.phase[k] < humanoid::cam_reference_t::PHASE_IDLE || m.phase[k] > humanoid::cam_reference_t::PHASE_RECOVER) {
      return fmt::format("unknown phase {} on axis {}", static_cast<int>(m.phase[k]), k);
    }
    if (!finite(m.t_phase_start[k], 3)) return "non-finite phase start";
  }
  r.tick = m.tick;
  r.time = from_utime(m.utime);
  r.yaw_WV = m.yaw_WV;
  r.l_ref_W = get<3>(m.l_ref_W);
  r.ldot_ref_W = get<3>(m.ldot_ref_W);
  r.l_ref_V = get<3>(m.l_ref_V);
  r.ldot_ref_V = get<3>(m.ldot_ref_V);
  r.tau_thres_V = get<3>(m.tau_thres_V);
  r.ldot_max_V = get<3>(m.ldot_max_V);
  for (size_t k = 0; k < 3; ++k) {
    r.phase[k] = static_cast<balance::Phase>(m.phase[k]);
    for (size_t p = 0; p < 3; ++p) r.t_phase_start[k][p] = m.t_phase_start[k][p];
  }
  r.stale = (m.status & humanoid::cam_reference_t::STATUS_BALANCE_STALE) != 0;
  r.ramping = (m.status & humanoid::cam_reference_t::STATUS_RAMPING_DOWN) != 0;
  r.balance_tick = m.balance_tick;
  return "";
}

}  // namespace hpr::msg
