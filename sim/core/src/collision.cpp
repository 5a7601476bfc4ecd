// The simulated robot's collision geometry, engine-neutral: the shapes both engines build theirs from.
#include <fmt/format.h>

#include "hpr/common/log.hpp"
#include "hpr/mesh/mesh.hpp"
#include "hpr/sim/engine.hpp"
#include "hpr/sim/simulator.hpp"

namespace hpr::sim {

using Eigen::Vector3d;
using model::SE3;

namespace {

/// A URDF collision geometry of `link` as a shape, `X_BG` its placement in the body frame.
CollisionShape shape_of(const model::Geometry& g, const model::RobotSpec& robot, const model::Model& m,
                        const model::LinkDesc& link, const SE3& X_BG) {
  CollisionShape s;
  s.X_BG = X_BG;
  switch (g.type) {
    case model::Geometry::Type::kBox:
      s.type = CollisionShape::Type::kBox;
      s.size = 0.5 * g.size;
      break;
    case model::Geometry::Type::kCylinder:
      s.type = CollisionShape::Type::kCylinder;
      s.size = Vector3d(g.size.x(), 0.5 * g.size.y(), 0.0);
      break;
    case model::Geometry::Type::kSphere:
      s.type = CollisionShape::Type::kSphere;
      s.size = Vector3d(g.size.x(), 0.0, 0.0);
      break;
    case model::Geometry::Type::kMesh: {
      std::vector<Vector3d> points;
      try {
        points = mesh::load(g.mesh, g.mesh_scale).vertices;
      } catch (const mesh::MeshError& e) {
        throw model::ModelError(fmt::format("{}: link '{}': {}", m.source, link.name, e.what()));
      }
      if (robot.mesh_collision == model::MeshCollision::kBox) {
        Vector3d lo = points.front(), hi = points.front();
        for (const auto& p : points) {
          lo = lo.cwiseMin(p);
          hi = hi.cwiseMax(p);
        }
        s.type = CollisionShape::Type::kBox;
        s.size = 0.5 * (hi - lo);
        SE3 X_GC;
        X_GC.p = 0.5 * (hi + lo);
        s.X_BG = X_BG * X_GC;
      } else {
        s.type = CollisionShape::Type::kHull;
        s.points = mesh::hull_points(points, robot.mesh_hull_points);
      }
      break;
    }
  }
  return s;
}

}  // namespace

std::vector<std::vector<CollisionShape>> collision_shapes(const model::RobotSpec& robot, const model::Model& m,
                                                          const SimConfig& config, const std::array<int, 2>& foot_body) {
  std::vector<std::vector<CollisionShape>> out(static_cast<std::size_t>(m.nb));
  for (int b = 0; b < m.nb; ++b) {
    if (config.feet_only_collisions && b != foot_body[0] && b != foot_body[1]) continue;
    auto& shapes = out[static_cast<std::size_t>(b)];
    for (const auto& frame : m.frames) {
      if (frame.body != b) continue;
      const model::LinkDesc* link = robot.description.find_link(frame.name);
      if (link == nullptr) continue;
      for (const auto& g : link->collisions) shapes.push_back(shape_of(g, robot, m, *link, frame.X_BF * g.X_LG));
    }
    for (std::size_t k = 0; k < 2; ++k) {
      // A foot without collision geometry (a description with inertias only) stands on its sole.
      if (b != foot_body[k] || !shapes.empty()) continue;
      const model::FootSpec& foot = robot.feet[k];
      constexpr double kThickness = 0.02;
      const SE3& X_BS = m.frames[static_cast<std::size_t>(m.frame_index(robot.model.frames[static_cast<std::size_t>(foot.sole_frame)].name))].X_BF;
      CollisionShape s;
      s.type = CollisionShape::Type::kBox;
      s.size = Vector3d(0.5 * foot.length, 0.5 * foot.width, 0.5 * kThickness);
      SE3 X_SC;
      X_SC.p = Vector3d(0.0, 0.0, 0.5 * kThickness);
      s.X_BG = X_BS * X_SC;
      shapes.push_back(s);
      log::info("the {} foot link '{}' has no collision geometry: it collides with its configured sole, a box of {:.3f} x {:.3f} x {:.3f} m",
                model::kFootNames[k], foot.link, foot.length, foot.width, kThickness);
    }
  }
  return out;
}

const char* to_string(EngineKind kind) { return kind == EngineKind::kMujoco ? "mujoco" : "bullet"; }

}  // namespace hpr::sim
