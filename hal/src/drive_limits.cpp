#include "hpr/hal/hal.hpp"

#include <algorithm>
#include <cmath>

// The drives' ranges and the hal's check of a JOINT_COMMAND against them (shared by the hal and
// the simulator, hal/include/hpr/hal/hal.hpp).
namespace hpr::hal {

DriveLimits default_limits(const DriveDefaults& dd, const DriveConfig& dc, double v_max, double tau_max) {
  DriveLimits l;
  if (std::isfinite(dc.q_lower) && std::isfinite(dc.q_upper) && dc.q_lower > -1e8) {
    const double a = dc.sign * (dc.q_lower - dd.position_margin - dc.offset), b = dc.sign * (dc.q_upper + dd.position_margin - dc.offset);
    l.p_min = std::min(a, b);
    l.p_max = std::max(a, b);
  }
  if (std::isfinite(v_max) && v_max > 0) l.v_max = dd.velocity_scale * v_max, l.v_min = -l.v_max;
  if (std::isfinite(tau_max) && tau_max > 0) l.t_max = dd.torque_scale * tau_max, l.t_min = -l.t_max;
  l.kp_min = 0.0, l.kp_max = dd.kp_max;
  l.kd_min = 0.0, l.kd_max = dd.kd_max;
  return l;
}

DriveDefaults DriveDefaults::load(const Config& c) {
  DriveDefaults d;
  d.kp_max = c.real_or("kp_max", d.kp_max, 1.0, 1e5);
  d.kd_max = c.real_or("kd_max", d.kd_max, 0.1, 1e4);
  d.position_margin = c.real_or("position_margin", d.position_margin, 0.0, 10.0);
  d.velocity_scale = c.real_or("velocity_scale", d.velocity_scale, 1.0, 10.0);
  d.torque_scale = c.real_or("torque_scale", d.torque_scale, 0.1, 10.0);
  return d;
}

std::vector<DriveConfig> default_drives(const model::RobotSpec& robot, const DriveDefaults& defaults) {
  const model::Model& m = robot.model;
  std::vector<DriveConfig> out(static_cast<std::size_t>(m.nj));
  for (int j = 0; j < m.nj; ++j) {
    const auto ju = static_cast<std::size_t>(j);
    DriveConfig& dc = out[ju];
    dc.joint = m.joint_name[ju];
    dc.joint_index = j;
    dc.q_lower = m.q_lower[ju];
    dc.q_upper = m.q_upper[ju];
    dc.limits = default_limits(defaults, dc, m.v_max[ju], m.tau_max[ju]);
  }
  return out;
}

std::string check_command(const JointCommand& c, const std::vector<DriveConfig>& drives, int controlled) {
  std::string why = c.check(controlled);
  if (!why.empty() || c.mode != JointCommand::Mode::kRun) return why;
  for (int i = 0; i < controlled; ++i) {
    const DriveConfig& d = drives[static_cast<std::size_t>(i)];
    const DriveLimits& l = d.limits;
    const double p = d.sign * (c.q_des(i) - d.offset), v = d.sign * c.qd_des(i), t = d.sign * c.tau_ff(i);
    auto out = [&](const char* what, double x, double lo, double hi) {
      if (x >= lo - 1e-9 && x <= hi + 1e-9) return false;
      why = std::string(what) + " of joint '" + d.joint + "' = " + std::to_string(x) + " outside [" + std::to_string(lo) + ", " +
            std::to_string(hi) + "]";
      return true;
    };
    if (out("q_des (drive side)", p, l.p_min, l.p_max) || out("qd_des", v, l.v_min, l.v_max) ||
        out("kp", c.kp(i), l.kp_min, l.kp_max) || out("kd", c.kd(i), l.kd_min, l.kd_max) || out("tau_ff", t, l.t_min, l.t_max)) {
      break;
    }
  }
  return why;
}

}  // namespace hpr::hal
