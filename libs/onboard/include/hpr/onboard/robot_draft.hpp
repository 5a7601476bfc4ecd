#pragma once
/// \file
/// A first configuration for a new robot, worked out from its description: feet and soles, IMU,
/// held joints, a standing posture found by inverse kinematics, segments, the motion optimiser's
/// adjusted coordinates and gains scaled to the robot's mass and inertia.

#include <array>
#include <string>
#include <utility>
#include <vector>

#include "hpr/model/model.hpp"
#include "hpr/onboard/robot_check.hpp"

namespace hpr::onboard {

struct DraftOptions {
  std::string name;                       ///< robot name (default: the URDF's)
  std::string base_link;                  ///< floating base (default: the URDF's root body)
  /// Standing height of each hip above its sole, as a fraction of the straight leg's length. Knees
  /// bent that far leave the hip strategy room to pitch the upper body before the legs stretch.
  double leg_height_fraction = 0.90;
  /// A moving joint outside the legs whose name contains one of these (case-insensitive) is held.
  std::vector<std::string> hold_patterns = {"hand", "finger", "thumb", "index", "middle", "ring", "pinky",
                                            "little", "gripper", "head", "neck", "eye"};
  std::vector<std::string> hold;          ///< further joints to hold
  std::vector<std::string> keep;          ///< joints never held
};

using NamedValues = std::vector<std::pair<std::string, double>>;
using NamedLists = std::vector<std::pair<std::string, std::vector<std::string>>>;

struct RobotDraft {
  std::string name;
  std::string base_link;
  std::array<FootCandidate, 2> feet;     ///< right, left
  std::string imu_link;
  NamedValues held;                      ///< held joints and their positions, in tree order
  NamedValues posture;                   ///< standing posture, joints away from zero
  NamedLists segments;                   ///< torso, arms, head, legs
  std::vector<std::string> adjusted_double, adjusted_single;  ///< x_a of (10), (11)
  double mass = 0.0;                     ///< [kg]
  Eigen::Matrix3d I_com = Eigen::Matrix3d::Zero();  ///< composite rotational inertia about the CoM, standing [kg m²]
  double base_height = 0.0;              ///< base above the soles when standing [m]
  double com_height = 0.0;               ///< CoM above the soles when standing [m]
  double lightest_body = 0.0;            ///< lightest moving body of the controllers' model [kg]
  Eigen::Vector3d com_stiffness, com_damping, base_stiffness, base_damping;
  double free_stiffness = 0.0, free_damping = 0.0;
  int substeps = 1;
  double shift_time = 1.2;               ///< CoM shift onto one foot (balance.shift_time) [s]
  std::vector<std::string> notes;        ///< what was decided and why, one line each
};

/// Works the draft out. Throws ModelError when the description has no two feet or the inverse
/// kinematics of the posture does not converge.
RobotDraft draft_robot(const model::RobotDescription& description, const DraftOptions& options = {});

/// The configuration file: `template_text` (config/templates/robot.yaml) with the draft filled in;
/// `urdf_in_config` is the URDF path as the file names it (relative to the file's folder), and
/// `mesh_paths_in_config` the folders its meshes were found in besides the URDF's repository
/// (robot.mesh_search_paths, relative to the file's folder: `init --mesh-path`).
std::string write_config(const RobotDraft& draft, const std::string& template_text, const std::string& urdf_in_config,
                         const std::string& command, const std::vector<std::string>& mesh_paths_in_config = {});

}  // namespace hpr::onboard
