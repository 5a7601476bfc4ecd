#include "hpr/msg/sim_truth.hpp"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <cmath>

#include "arrays.hpp"

namespace hpr::msg {

using detail::finite;
using detail::get;
using detail::put;

void to_message(const SimTruth& t, const std::array<std::string, 2>& feet, humanoid::sim_truth_t& m) {
  m.tick = t.tick;
  m.utime = static_cast<int64_t>(std::llround(t.time * 1e6));
  put<3>(t.p_WB, m.p_WB);
  put<4>(t.quat_WB, m.quat_WB);
  put<3>(t.v_WB, m.v_WB);
  put<3>(t.omega_WB, m.omega_WB);
  put<3>(t.p_WCom, m.p_WCom);
  put<3>(t.v_WCom, m.v_WCom);
  put<3>(t.h_lin_W, m.h_lin_W);
  put<3>(t.l_WCom, m.l_WCom);
  put<3>(t.push_force_W, m.push_force_W);
  put<3>(t.push_impulse_W, m.push_impulse_W);
  put<3>(t.push_point_W, m.push_point_W);
  m.num_feet = 2;
  m.foot_name.assign(feet.begin(), feet.end());
  m.p_WF.resize(2);
  m.quat_WF.resize(2);
  m.contact_wrench_W.resize(2);
  m.foot_contact.resize(2);
  m.foot_tilt.resize(2);
  for (size_t f = 0; f < 2; ++f) {
    m.p_WF[f].assign(t.p_WF[f].data(), t.p_WF[f].data() + 3);
    m.quat_WF[f].assign(t.quat_WF[f].data(), t.quat_WF[f].data() + 4);
    m.contact_wrench_W[f].assign(t.contact_wrench_W[f].data(), t.contact_wrench_W[f].data() + 6);
    m.foot_contact[f] = t.foot_contact[f] ? 1 : 0;
    m.foot_tilt[f] = t.foot_tilt[f];
  }
  m.push_id = t.push_id;
  m.push_active = t.push_active;
  m.fallen = t.fallen;
  m.sim_time = t.time;
}

std::string from_message(const humanoid::sim_truth_t& m, SimTruth& t) {
  if (m.num_feet != 2) return fmt::format("num_feet {} != 2", m.num_feet);
  if (!finite(m.p_WB, 3) || !finite(m.quat_WB, 4) || !finite(m.v_WB, 3) || !finite(m.omega_WB, 3)) {
    return "non-finite root link pose or twist";
  }
  const double qn = Eigen::Map<const Eigen::Vector4d>(m.quat_WB).norm();
  if (std::abs(qn - 1.0) > 1e-3) return fmt::format("root link quaternion norm {} is not 1", qn);
  if (!finite(m.p_WCom, 3) || !finite(m.v_WCom, 3) || !finite(m.h_lin_W, 3) || !finite(m.l_WCom, 3) ||
      !finite(m.push_force_W, 3) || !finite(m.push_impulse_W, 3) || !finite(m.push_point_W, 3) ||
      !std::isfinite(m.sim_time)) {
    return "non-finite CoM, momentum, push or time";
  }
  for (size_t f = 0; f < 2; ++f) {
    if (!finite(m.p_WF[f].data(), 3) || !finite(m.quat_WF[f].data(), 4) || !finite(m.contact_wrench_W[f].data(), 6) ||
        !std::isfinite(m.foot_tilt[f])) {
      return "non-finite foot value";
    }
  }
  t.tick = m.tick;
  t.time = m.sim_time;
  t.p_WB = get<3>(m.p_WB);
  t.quat_WB = get<4>(m.quat_WB);
  t.v_WB = get<3>(m.v_WB);
  t.omega_WB = get<3>(m.omega_WB);
  t.p_WCom = get<3>(m.p_WCom);
  t.v_WCom = get<3>(m.v_WCom);
  t.h_lin_W = get<3>(m.h_lin_W);
  t.l_WCom = get<3>(m.l_WCom);
  t.push_force_W = get<3>(m.push_force_W);
  t.push_impulse_W = get<3>(m.push_impulse_W);
  t.push_point_W = get<3>(m.push_point_W);
  for (size_t f = 0; f < 2; ++f) {
    t.p_WF[f] = get<3>(m.p_WF[f].data());
    t.quat_WF[f] = get<4>(m.quat_WF[f].data());
    t.contact_wrench_W[f] = get<6>(m.contact_wrench_W[f].data());
    t.foot_contact[f] = m.foot_contact[f] != 0;
    t.foot_tilt[f] = m.foot_tilt[f];
  }
  t.push_id = m.push_id;
  t.push_active = m.push_active;
  t.fallen = m.fallen;
  return "";
}

}  // namespace hpr::msg
