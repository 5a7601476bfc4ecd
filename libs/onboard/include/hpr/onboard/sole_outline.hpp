#pragma once
/// \file
/// The support rectangle of a foot from the points of its lowest face, in the plane of the sole:
/// the outline's convex hull, its long axis (the sole's own x, whatever the foot's yaw in its link),
/// and the largest rectangle along that axis inside the outline.

#include <Eigen/Core>
#include <vector>

namespace hpr::onboard {

/// Counter-clockwise convex hull of points in a plane (Andrew's monotone chain); collinear and
/// repeated points dropped. Fewer than 3 vertices when the points are collinear or fewer than 3.
std::vector<Eigen::Vector2d> convex_hull_2d(std::vector<Eigen::Vector2d> points);

/// A rectangle in the sole's plane: centred at `centre`, its length along the direction at `yaw`
/// [rad] from the plane's x axis, its width across it.
struct SoleRectangle {
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  double yaw = 0.0;
  double length = 0.0, width = 0.0;
};

/// The sole rectangle of an outline (the points of a foot's lowest face in the link's x-y plane).
/// Its axis is the outline's long principal axis (second moments of the hull's area), the end of it
/// nearer `forward_yaw` (the robot's forward direction in this plane) taken as +x; an outline too
/// close to round or square to have one (principal moments within 10 %) takes `forward_yaw`, and
/// an axis within 0.5° of `forward_yaw` is snapped to it. The rectangle is the largest by area,
/// along that axis, that fits inside the hull: rounded or chamfered toes and heels are left out,
/// a box's bottom face is returned exactly. A collinear outline gives width 0, a single point
/// length 0.
SoleRectangle sole_rectangle(const std::vector<Eigen::Vector2d>& outline, double forward_yaw = 0.0);

}  // namespace hpr::onboard
