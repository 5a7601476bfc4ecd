#pragma once
/// \file
/// A joint's drive as the hal and the simulator both see it: which joint it turns, its units
/// (q = sign · p + offset, τ = sign · t; kp and kd the same on both sides), the ranges it accepts in
/// drive units, and the hal's check of a JOINT_COMMAND against them. The simulator refuses what the
/// hal refuses by calling the same check; the hal adds its bus, id and protocol (hpr/hal/hal.hpp).
#include <concepts>
#include <functional>
#include <string>
#include <vector>

#include "hpr/common/config.hpp"
#include "hpr/common/robot_io.hpp"
#include "hpr/model/robot.hpp"

namespace hpr::drive {

/// Per-drive ranges in drive units (rad, rad/s, Nm/rad, Nm s/rad, Nm): what the drive accepts, and
/// what the 12- and 16-bit fields of an MIT-mode frame span.
struct DriveLimits {
  double p_min = -12.5, p_max = 12.5;
  double v_min = -45.0, v_max = 45.0;
  double kp_min = 0.0, kp_max = 500.0;
  double kd_min = 0.0, kd_max = 5.0;
  double t_min = -18.0, t_max = 18.0;
};

/// A drive's joint and units.
struct JointDrive {
  std::string joint;
  int joint_index = -1;   ///< a model joint, or nj + k for the k-th held joint
  double sign = 1.0, offset = 0.0;
  DriveLimits limits;
  double q_lower = -1e9, q_upper = 1e9;  ///< hard joint limits [rad] (soft-limit damping near them)
  bool held = false;      ///< a held joint (robot.held_joints): outside the commands, held by the hal
  double held_q = 0.0;    ///< its position [rad]
};

/// What a drive without a `limits` block accepts, from its joint's URDF limits (`hal.drive_defaults`).
struct DriveDefaults {
  double kp_max = 1000.0;         ///< [Nm/rad]
  double kd_max = 50.0;           ///< [Nm s/rad]
  double position_margin = 0.5;   ///< [rad] beyond the URDF position limits
  double velocity_scale = 1.5;    ///< × the URDF velocity limit
  double torque_scale = 1.0;      ///< × the URDF effort limit
  static DriveDefaults load(const Config& drive_defaults);
};

/// A drive's limits (drive units) from its joint's limits (`d.q_lower`, `d.q_upper`, sign and
/// offset set) and the defaults.
DriveLimits default_limits(const DriveDefaults& defaults, const JointDrive& d, double v_max, double tau_max);

/// A drive for every model joint with the defaults' limits (sign 1, offset 0): what the command
/// check uses where a configuration maps no drives (a simulated robot).
std::vector<JointDrive> default_drives(const model::RobotSpec& robot, const DriveDefaults& defaults = {});

/// Reads each entry of the `hal` section's `drives` list once: the joint it names (every joint, held
/// ones included, mapped exactly once: an error names the joint mapped twice or left without a
/// drive), its sign, offset and limits in drive units into `slot(j)` (from the joint's limits, the
/// model's or for a held joint the URDF's, with the section's drive_defaults; a `limits` block
/// overrides), then `more(entry, j)` for what the reader adds. j is the model joint, or nj + k for
/// the k-th held joint; `slot` must serve j < nj + the held joints.
void read_drive_entries(const Config& hal_section, const model::RobotSpec& robot, const std::function<JointDrive&(std::size_t j)>& slot,
                        const std::function<void(const Config& entry, std::size_t j)>& more);

/// The drives the `hal` section maps, one per model joint in model order, then one per held joint
/// (read_drive_entries), each completed by `more` (the hal: its bus, id and protocol).
template <std::derived_from<JointDrive> Drive>
std::vector<Drive> read_drives(const Config& hal_section, const model::RobotSpec& robot,
                               const std::function<void(const Config& entry, Drive& drive)>& more) {
  std::vector<Drive> drives(static_cast<std::size_t>(robot.model.nj) + robot.model.held_joint_name.size());
  read_drive_entries(hal_section, robot, [&](std::size_t j) -> JointDrive& { return drives[j]; },
                     [&](const Config& entry, std::size_t j) { more(entry, drives[j]); });
  return drives;
}

/// The joints' side of the `hal` section's drives, for a reader that is not the hal (the
/// simulator): the bus, id and protocol of each entry are left to the hal, which loads them.
std::vector<JointDrive> load_joint_drives(const Config& hal_section, const model::RobotSpec& robot);

/// Whether joint i of `c` (run mode) is inside drive `d`'s ranges: empty when it is, else the reason.
std::string check_joint_command(const JointCommand& c, int i, const JointDrive& d);

/// The hal's check of a JOINT_COMMAND against the first `controlled` of `drives`: the command's
/// own check (size, non-finite values, negative gains), then in run mode every joint's q_des, qd_des,
/// kp, kd and τ_ff inside its drive's range (drive side). Empty when acceptable, else the first
/// reason. The simulator applies the same check, so that what the hal refuses is refused there too.
template <std::derived_from<JointDrive> Drive>
std::string check_command(const JointCommand& c, const std::vector<Drive>& drives, int controlled) {
  std::string why = c.check(controlled);
  if (!why.empty() || c.mode != JointCommand::Mode::kRun) return why;
  for (int i = 0; i < controlled && why.empty(); ++i) why = check_joint_command(c, i, drives[static_cast<std::size_t>(i)]);
  return why;
}

}  // namespace hpr::drive
