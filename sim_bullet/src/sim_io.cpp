#include "hpr/sim/sim_io.hpp"

#include <fmt/format.h>

#include <cmath>

namespace hpr::sim {

void to_message(const TruthData& t, const std::array<std::string, 2>& feet, humanoid::sim_truth_t& m) {
  m.tick = t.tick;
  m.utime = static_cast<int64_t>(std::llround(t.time * 1e6));
  for (int k = 0; k < 3; ++k) {
    m.p_WB[k] = t.p_WB(k);
    m.v_WB[k] = t.v_WB(k);
    m.omega_WB[k] = t.omega_WB(k);
    m.p_WCom[k] = t.p_WCom(k);
    m.v_WCom[k] = t.v_WCom(k);
    m.h_lin_W[k] = t.h_lin_W(k);
    m.l_WCom[k] = t.l_WCom(k);
    m.push_force_W[k] = t.push_force_W(k);
    m.push_impulse_W[k] = t.push_impulse_W(k);
    m.push_point_W[k] = t.push_point_W(k);
  }
  for (int k = 0; k < 4; ++k) m.quat_WB[k] = t.quat_WB(k);
  m.num_feet = 2;
  m.foot_name = {feet[0], feet[1]};
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

std::optional<Push> from_message(const humanoid::push_t& p, const model::Model& m, std::string* why) {
  Push push;
  push.id = p.id;
  push.link = p.link;
  push.point_L = Eigen::Vector3d(p.point_L[0], p.point_L[1], p.point_L[2]);
  push.force_W = Eigen::Vector3d(p.force_W[0], p.force_W[1], p.force_W[2]);
  push.start = p.start_time;
  push.duration = p.duration;
  std::string reason;
  if (!m.has_frame(push.link)) {
    reason = fmt::format("link '{}' is not a link of {}", p.link, m.source);
  } else if (!push.force_W.allFinite() || push.force_W.cwiseAbs().maxCoeff() > Push::kMaxForce) {
    reason = fmt::format("force ({}, {}, {}) N outside +-{} N per axis", p.force_W[0], p.force_W[1], p.force_W[2],
                         Push::kMaxForce);
  } else if (!push.point_L.allFinite() || push.point_L.cwiseAbs().maxCoeff() > Push::kMaxPoint) {
    reason = fmt::format("point ({}, {}, {}) m farther than {} m from the link frame", p.point_L[0], p.point_L[1],
                         p.point_L[2], Push::kMaxPoint);
  } else if (!(push.duration >= Push::kMinDuration && push.duration <= Push::kMaxDuration)) {
    reason = fmt::format("duration {} s outside [{}, {}] s", p.duration, Push::kMinDuration, Push::kMaxDuration);
  } else if (!(push.start <= Push::kMaxStart)) {  // negative: at once
    reason = fmt::format("start time {} s after {} s", p.start_time, Push::kMaxStart);
  } else if (p.profile != humanoid::push_t::PROFILE_HALF_SINE && p.profile != humanoid::push_t::PROFILE_RECTANGLE) {
    reason = fmt::format("profile {} is not PROFILE_HALF_SINE (0) or PROFILE_RECTANGLE (1)", static_cast<int>(p.profile));
  }
  if (!reason.empty()) {
    if (why) *why = reason;
    return std::nullopt;
  }
  push.profile = p.profile == humanoid::push_t::PROFILE_RECTANGLE ? Push::Profile::kRectangle : Push::Profile::kHalfSine;
  return push;
}

}  // namespace hpr::sim
