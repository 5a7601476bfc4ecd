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
  double length = 0.0, width = 0.0;                  ///< along the link's x and y [m]
  std::string from;                                  ///< which geometry gave it ("4 spheres", "box", "mesh hull")
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

/// The largest axis-aligned rectangle in the link's x-y plane that the foot's lowest contact points
/// (within `tolerance` of the lowest) span over their whole length: boxes give their bottom face,
/// spheres their lowest points, cylinders their bottom disc, meshes their hull points. Throws
/// ModelError when the link has no collision geometry.
Sole sole_from_geometry(const model::LinkDesc& link, int hull_points = 64, double tolerance = 0.003);

/// A human-readable report of a description and its model: tree, joints by type, mass, centre of
/// mass, repairs, meshes, candidate feet.
std::string check_report(const model::RobotDescription& description, const model::Model& model);

}  // namespace hpr::onboard
