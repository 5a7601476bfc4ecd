#pragma once
/// \file
/// What a new robot description offers the stack: its feet (end links of the leg chains) with the
/// sole rectangle their collision geometry gives, the standing support, and a report a user reads
/// before writing a configuration.

#include <array>
#include <string>
#include <vector>

#include "hpr/model/model.hpp"

namespace hpr::onboard {

/// The support rectangle of a foot, in the foot link's frame (z of the link taken as the sole
/// normal at the zero configuration).
struct Sole {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();  ///< centre of the lowest face [m]
  double yaw = 0.0;                                  ///< of the sole's x (its length) about the link's z [rad]
  double length = 0.0, width = 0.0;                  ///< along the sole's x and y [m]
  std::string from;                                  ///< which geometry gave it ("4 spheres", "box", "mesh")
  std::vector<std::string> warnings;                 ///< a degenerate or off-centre rectangle, said in words
};

struct FootCandidate {
  std::string link;
  int body = -1;                       ///< in the model
  std::vector<std::string> leg_joints; ///< from the base to the foot
  double z_lowest = 0.0;               ///< lowest point of its collision geometry at q = 0 [m], base at the origin
  Sole sole;
};

/// The lowest point of every moving body's collision geometry at the zero configuration: the two
/// lowest bodies on either side of the base's x-z plane, each at the end of a chain of at least
/// `min_leg_joints` joints, as (right, left). Throws ModelError when there are not two.
std::array<FootCandidate, 2> find_feet(const model::Model& model, const model::RobotDescription& description,
                                       int min_leg_joints = 5);

/// The sole of a foot: the points of its collision geometry within `tolerance` of the lowest (boxes
/// their bottom face, spheres their lowest points, cylinders their bottom disc, meshes every vertex
/// of their lowest face, whatever the geometry's rotation in the link) outline the sole; its
/// rectangle is the largest along the outline's long axis that fits inside it (sole_rectangle, the
/// end nearer `forward_yaw`, the robot's forward direction in the link's x-y plane, taken as +x).
/// `warnings` says when the rectangle is degenerate (a side under 1 cm) or its centre is off the
/// link's origin sideways by more than a quarter of its width. Throws ModelError when the link has
/// no collision geometry.
Sole sole_from_geometry(const model::LinkDesc& link, double tolerance = 0.003, double forward_yaw = 0.0);

/// The link an IMU is taken from, and why in words.
struct ImuChoice {
  std::string link;
  std::string why;
};

/// The IMU of a description, by name anywhere on the tree: a link called `imu` or `imu_link`, else
/// one named `*_imu*` or `imu_*`, else one whose name contains "imu"; of equals, the one with the
/// fewest moving joints between it and the base (rigidly on the base first: the estimator takes
/// the base's orientation from any of them through the joints' encoders). Without one, the base
/// link, said so.
ImuChoice find_imu(const model::Model& model);

/// A human-readable report of a description and its model: tree, joints by type, mass, centre of
/// mass, repairs, meshes, candidate feet.
std::string check_report(const model::RobotDescription& description, const model::Model& model);

}  // namespace hpr::onboard
