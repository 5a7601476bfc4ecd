#include "hpr/common/robot_io.hpp"

#include <fmt/format.h>

namespace hpr {

std::string JointCommand::check(int joints) const {
  if (tau_ff.size() != joints || q_des.size() != joints || qd_des.size() != joints || kp.size() != joints ||
      kd.size() != joints) {
    return fmt::format("expected {} joints, got {}", joints, tau_ff.size());
  }
  if (!tau_ff.allFinite() || !q_des.allFinite() || !qd_des.allFinite() || !kp.allFinite() || !kd.allFinite()) {
    return "non-finite value";
  }
  if ((kp.array() < 0).any() || (kd.array() < 0).any()) return "negative gain";
  return "";
}

}  // namespace hpr
