#include "hpr/sim/sim_io.hpp"

#include <fmt/format.h>

#include <cmath>

namespace hpr::sim {

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
