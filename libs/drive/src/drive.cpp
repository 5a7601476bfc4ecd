#include "hpr/drive/drive.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

namespace hpr::drive {

DriveLimits default_limits(const DriveDefaults& dd, const JointDrive& d, double v_max, double tau_max) {
  DriveLimits l;
  if (std::isfinite(d.q_lower) && std::isfinite(d.q_upper) && d.q_lower > -1e8) {
    const double a = d.sign * (d.q_lower - dd.position_margin - d.offset), b = d.sign * (d.q_upper + dd.position_margin - d.offset);
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

std::vector<JointDrive> default_drives(const model::RobotSpec& robot, const DriveDefaults& defaults) {
  const model::Model& m = robot.model;
  std::vector<JointDrive> out(static_cast<std::size_t>(m.nj));
  for (int j = 0; j < m.nj; ++j) {
    const auto ju = static_cast<std::size_t>(j);
    JointDrive& d = out[ju];
    d.joint = m.joint_name[ju];
    d.joint_index = j;
    d.q_lower = m.q_lower[ju];
    d.q_upper = m.q_upper[ju];
    d.limits = default_limits(defaults, d, m.v_max[ju], m.tau_max[ju]);
  }
  return out;
}

namespace {

std::pair<double, double> range(const Config& c, const std::string& key, double lo, double hi) {
  if (!c.has(key)) return {lo, hi};
  const auto v = c.reals(key, 2);
  if (!(v[0] < v[1])) throw ConfigError(c.file() + ": " + c.full_key(key) + ": [" + std::to_string(v[0]) + ", " +
                                        std::to_string(v[1]) + "] is not an interval with min < max");
  return {v[0], v[1]};
}

/// The joint an entry of `hal.drives` names: a controlled joint's index, or nj + k for the k-th held one.
int drive_joint(const Config& d, const model::Model& m) {
  const std::string joint = d.string("joint");
  for (std::size_t k = 0; k < m.held_joint_name.size(); ++k) {
    if (m.held_joint_name[k] == joint) return m.nj + static_cast<int>(k);
  }
  try {
    return m.joint_index(joint);
  } catch (const std::exception&) {
    throw ConfigError(d.file() + ": " + d.full_key("joint") + ": '" + joint + "' is not a joint of " + m.source);
  }
}

/// An entry of `hal.drives` into `dc` (joint `j`): its sign, offset, and limits in drive units.
void load_joint_drive(const Config& d, int j, const model::RobotSpec& robot, const DriveDefaults& defaults, JointDrive& dc) {
  const model::Model& m = robot.model;
  dc.joint = d.string("joint");
  dc.joint_index = j;
  const double sign = d.real_or("sign", 1.0);
  if (sign != 1.0 && sign != -1.0) throw ConfigError(d.file() + ": " + d.full_key("sign") + ": " + std::to_string(sign) + " is not 1 or -1");
  dc.sign = sign;
  dc.offset = d.real_or("offset", 0.0, -10.0, 10.0);
  double q_lower = -1e9, q_upper = 1e9, v_max = 0.0, tau_max = 0.0;
  if (j < m.nj) {
    const auto ju = static_cast<std::size_t>(j);
    q_lower = m.q_lower[ju], q_upper = m.q_upper[ju], v_max = m.v_max[ju], tau_max = m.tau_max[ju];
  } else {
    const model::JointDesc& jd = *robot.description.find_joint(dc.joint);
    dc.held = true;
    dc.held_q = m.held_q[static_cast<std::size_t>(j - m.nj)];
    if (jd.has_limits && jd.type != model::JointType::kContinuous) q_lower = jd.lower, q_upper = jd.upper;
    if (jd.has_limits) v_max = jd.velocity, tau_max = jd.effort;
  }
  dc.q_lower = q_lower;
  dc.q_upper = q_upper;
  dc.limits = default_limits(defaults, dc, v_max, tau_max);
  DriveLimits& l = dc.limits;
  if (d.has("limits")) {
    const Config lc = d.section("limits");
    std::tie(l.p_min, l.p_max) = range(lc, "position", l.p_min, l.p_max);
    std::tie(l.v_min, l.v_max) = range(lc, "velocity", l.v_min, l.v_max);
    std::tie(l.kp_min, l.kp_max) = range(lc, "kp", l.kp_min, l.kp_max);
    std::tie(l.kd_min, l.kd_max) = range(lc, "kd", l.kd_min, l.kd_max);
    std::tie(l.t_min, l.t_max) = range(lc, "torque", l.t_min, l.t_max);
    if (l.kp_min != 0.0 || l.kd_min != 0.0) throw ConfigError(lc.file() + ": " + lc.full_key("kp") + ": gain ranges must start at 0");
  }
}

}  // namespace

void read_drive_entries(const Config& c, const model::RobotSpec& robot, const std::function<JointDrive&(std::size_t j)>& slot,
                        const std::function<void(const Config& entry, std::size_t j)>& more) {
  const model::Model& m = robot.model;
  const DriveDefaults defaults = DriveDefaults::load(c.has("drive_defaults") ? c.section("drive_defaults") : c);
  const std::size_t n = static_cast<std::size_t>(m.nj) + m.held_joint_name.size();
  std::vector<char> mapped(n, 0);
  for (const Config& d : c.items("drives")) {
    const int j = drive_joint(d, m);
    const auto ju = static_cast<std::size_t>(j);
    if (mapped[ju] != 0) {
      throw ConfigError(d.file() + ": " + d.full_key("joint") + ": joint '" + d.string("joint") + "' is mapped twice");
    }
    mapped[ju] = 1;
    load_joint_drive(d, j, robot, defaults, slot(ju));
    if (more) more(d, ju);
  }
  for (std::size_t j = 0; j < n; ++j) {
    if (mapped[j] == 0) {
      const std::string name = j < static_cast<std::size_t>(m.nj) ? m.joint_name[j] : m.held_joint_name[j - static_cast<std::size_t>(m.nj)];
      throw ConfigError(c.file() + ": " + c.full_key("drives") + ": joint '" + name + "' has no drive" +
                        (j < static_cast<std::size_t>(m.nj) ? "" : " (a held joint: the hal holds it)"));
    }
  }
}

std::vector<JointDrive> load_joint_drives(const Config& c, const model::RobotSpec& robot) {
  return read_drives<JointDrive>(c, robot, [](const Config& entry, JointDrive&) {
    entry.known({"bus", "id", "protocol", "cia402", "eds"});  // the hal's
  });
}

std::string check_joint_command(const JointCommand& c, int i, const JointDrive& d) {
  const DriveLimits& l = d.limits;
  const double p = d.sign * (c.q_des(i) - d.offset), v = d.sign * c.qd_des(i), t = d.sign * c.tau_ff(i);
  std::string why;
  auto out = [&](const char* what, double x, double lo, double hi) {
    if (x >= lo - 1e-9 && x <= hi + 1e-9) return false;
    why = std::string(what) + " of joint '" + d.joint + "' = " + std::to_string(x) + " outside [" + std::to_string(lo) + ", " +
          std::to_string(hi) + "]";
    return true;
  };
  (void)(out("q_des (drive side)", p, l.p_min, l.p_max) || out("qd_des", v, l.v_min, l.v_max) || out("kp", c.kp(i), l.kp_min, l.kp_max) ||
         out("kd", c.kd(i), l.kd_min, l.kd_max) || out("tau_ff", t, l.t_min, l.t_max));
  return why;
}

}  // namespace hpr::drive
