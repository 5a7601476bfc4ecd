#pragma once
/// \file
/// A robot as the stack uses it: the Model plus what configuration says about it (feet and soles,
/// legs, the free joints, the IMU, the standing posture, body segments). Nothing here is specific to
/// one robot; everything comes from the `robot` section of the configuration.

#include <array>
#include <map>
#include <string>
#include <vector>

#include "hpr/common/config.hpp"
#include "hpr/model/model.hpp"

namespace hpr::model {

/// Index of the feet in every foot-indexed array, following the paper: ν = (ν_r, ν_l).
enum Foot : int { kRight = 0, kLeft = 1 };
inline constexpr std::array<const char*, 2> kFootNames = {"right", "left"};

struct FootSpec {
  std::string link;            ///< URDF link of the foot
  int sole_frame = -1;         ///< frame at the sole centre, z along the sole normal
  double length = 0.0;         ///< sole size along its x axis [m]
  double width = 0.0;          ///< sole size along its y axis [m]
  std::vector<int> leg_joints; ///< joints from the base to the foot, in tree order
  std::string ft_link;         ///< link of the ankle force/torque sensor frame
  int ft_frame = -1;           ///< sensor frame (measures the wrench the foot applies to the leg)
};

/// A frame the configuration adds to a URDF link (soles, sensors), kept so that another model of the
/// same description (the simulator's, with the held joints free) can add it too.
struct AddedFrame {
  std::string name;
  std::string link;
  SE3 X_LF;  ///< in the link frame
};

/// How a simulator makes collision shapes of mesh geometry.
enum class MeshCollision { kConvexHull, kBox };

struct RobotSpec {
  std::string name;
  RobotDescription description;  ///< the URDF as loaded (repairs in description.repairs)
  Model model;                   ///< the controllers' model: held joints fixed, the file's inertias
  std::array<FootSpec, 2> feet;
  std::vector<int> leg_joints;   ///< right leg then left leg (12 for the paper's square J)
  std::vector<int> free_joints;  ///< every other joint, in model order (S_f selects them)
  int imu_frame = -1;
  Eigen::VectorXd q_joints_stand;                 ///< standing posture, joint positions (n)
  std::map<std::string, std::vector<int>> segments; ///< named joint groups (plots, Fig. 7d); held joints left out
  std::vector<AddedFrame> added_frames;           ///< sole, F/T and IMU frames, as added to `model`
  /// Held joints (robot.held_joints): not in `model`; a simulator or the hal holds them at these
  /// positions with a stiff joint impedance.
  std::map<std::string, double> held;
  MeshCollision mesh_collision = MeshCollision::kConvexHull;
  int mesh_hull_points = 64;                      ///< at most this many points per convex hull

  /// Reads and validates the `robot` section; errors name the file and key.
  static RobotSpec load(const Config& robot_section);
  /// Joint indices of `names`, with errors naming the configuration key.
  [[nodiscard]] std::vector<int> joints(const std::vector<std::string>& names, const Config& where,
                                        const std::string& key) const;
  /// The description as a simulator integrates it: the physically consistent inertias, the same
  /// added frames, and every joint free (held ones included), or with `held_rigid` the held joints
  /// fixed at their held positions as in `model` (their links welded to their parents).
  [[nodiscard]] Model full_model(bool held_rigid = false) const;
  /// Full configuration q of the standing posture with the soles flat at z = 0, centred on the origin.
  [[nodiscard]] Eigen::VectorXd standing_configuration() const;
};

}  // namespace hpr::model
