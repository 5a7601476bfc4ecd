#include "hpr/onboard/robot_check.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <set>

#include "hpr/mesh/mesh.hpp"
#include "hpr/model/algorithms.hpp"

namespace hpr::onboard {

using Eigen::Vector3d;
using model::Geometry;
using model::SE3;

namespace {

// Points of a geometry (in its link's frame) that can touch a plane below the link.
std::vector<Vector3d> contact_points(const Geometry& g, int hull_points) {
  std::vector<Vector3d> local;
  switch (g.type) {
    case Geometry::Type::kBox:
      for (int k = 0; k < 8; ++k) {
        local.emplace_back((k & 1 ? 0.5 : -0.5) * g.size.x(), (k & 2 ? 0.5 : -0.5) * g.size.y(),
                           (k & 4 ? 0.5 : -0.5) * g.size.z());
      }
      break;
    case Geometry::Type::kCylinder:
      for (int k = 0; k < 32; ++k) {
        const double a = 2.0 * M_PI * k / 32.0;
        for (double z : {-0.5, 0.5}) local.emplace_back(g.size.x() * std::cos(a), g.size.x() * std::sin(a), z * g.size.y());
      }
      break;
    case Geometry::Type::kSphere: {
      // The point that touches the ground below its centre (link z up at the zero configuration).
      const Vector3d down = g.X_LG.R.transpose() * Vector3d(0, 0, -g.size.x());
      local.push_back(down);
      break;
    }
    case Geometry::Type::kMesh:
      local = mesh::hull_points(mesh::load(g.mesh, g.mesh_scale).vertices, hull_points);
      break;
  }
  std::vector<Vector3d> out;
  out.reserve(local.size());
  for (const auto& p : local) out.push_back(g.X_LG.act(p));
  return out;
}

const char* type_name(Geometry::Type t) {
  switch (t) {
    case Geometry::Type::kBox: return "box";
    case Geometry::Type::kCylinder: return "cylinder";
    case Geometry::Type::kSphere: return "sphere";
    case Geometry::Type::kMesh: return "mesh hull";
  }
  return "?";
}

}  // namespace

Sole sole_from_geometry(const model::LinkDesc& link, int hull_points, double tolerance) {
  if (link.collisions.empty()) {
    throw model::ModelError(fmt::format("link '{}' has no collision geometry to take a sole from", link.name));
  }
  std::vector<Vector3d> pts;
  std::map<std::string, int> kinds;
  for (const auto& g : link.collisions) {
    const auto p = contact_points(g, hull_points);
    pts.insert(pts.end(), p.begin(), p.end());
    ++kinds[type_name(g.type)];
  }
  double z_min = std::numeric_limits<double>::infinity();
  for (const auto& p : pts) z_min = std::min(z_min, p.z());
  std::vector<Vector3d> low;
  for (const auto& p : pts) {
    if (p.z() <= z_min + tolerance) low.push_back(p);
  }
  double x_lo = low.front().x(), x_hi = x_lo;
  for (const auto& p : low) {
    x_lo = std::min(x_lo, p.x());
    x_hi = std::max(x_hi, p.x());
  }
  // The y-extent at the heel and at the toe (points within 1 cm of each end): a rectangle over the
  // whole length fits inside both (the support is convex), so its width is the smaller overlap.
  auto y_range = [&](double x_end) {
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (const auto& p : low) {
      if (std::abs(p.x() - x_end) <= 0.01) {
        lo = std::min(lo, p.y());
        hi = std::max(hi, p.y());
      }
    }
    return std::pair{lo, hi};
  };
  const auto [heel_lo, heel_hi] = y_range(x_lo);
  const auto [toe_lo, toe_hi] = y_range(x_hi);
  const double y_lo = std::max(heel_lo, toe_lo), y_hi = std::min(heel_hi, toe_hi);
  Sole s;
  s.length = x_hi - x_lo;
  s.width = std::max(0.0, y_hi - y_lo);
  s.centre = Vector3d(0.5 * (x_lo + x_hi), 0.5 * (y_lo + y_hi), z_min);
  for (const auto& [kind, n] : kinds) s.from += (s.from.empty() ? "" : ", ") + fmt::format("{} {}", n, kind) + (n > 1 ? "s" : "");
  return s;
}

std::array<FootCandidate, 2> find_feet(const model::Model& m, const model::RobotDescription& d, int min_leg_joints) {
  model::Data data(m);
  Eigen::VectorXd q = Eigen::VectorXd::Zero(m.nq);
  q(6) = 1.0;
  model::forward_kinematics(m, data, q);
  model::update_frame_placements(m, data);
  std::vector<FootCandidate> all;
  for (size_t f = 0; f < m.frames.size(); ++f) {
    const model::Frame& fr = m.frames[f];
    const model::LinkDesc* link = d.find_link(fr.name);
    if (link == nullptr || link->collisions.empty() || fr.body == 0) continue;
    if (static_cast<int>(m.support[static_cast<size_t>(fr.body)].size()) < min_leg_joints) continue;
    double z = std::numeric_limits<double>::infinity();
    for (const auto& g : link->collisions) {
      for (const auto& p : contact_points(g, 32)) z = std::min(z, data.oMf[f].act(p).z());
    }
    FootCandidate c;
    c.link = fr.name;
    c.body = fr.body;
    c.z_lowest = z;
    for (int j : m.support[static_cast<size_t>(fr.body)]) c.leg_joints.push_back(m.joint_name[static_cast<size_t>(j)]);
    all.push_back(c);
  }
  std::sort(all.begin(), all.end(), [](const auto& a, const auto& b) { return a.z_lowest < b.z_lowest; });
  std::array<FootCandidate, 2> feet;
  std::array<bool, 2> found{false, false};
  for (const auto& c : all) {
    const double y = data.oMi[static_cast<size_t>(c.body)].p.y();
    const int side = y < 0 ? 0 : 1;  // right: −y
    if (found[static_cast<size_t>(side)]) continue;
    // The lowest candidate on each side of the base's x-z plane.
    feet[static_cast<size_t>(side)] = c;
    found[static_cast<size_t>(side)] = true;
  }
  if (!found[0] || !found[1]) {
    throw model::ModelError(fmt::format("{}: no {} foot: no link with collision geometry at the end of a chain of {} "
                                        "or more joints on that side",
                                        m.source, !found[0] ? "right (-y)" : "left (+y)", min_leg_joints));
  }
  for (auto& f : feet) f.sole = sole_from_geometry(*d.find_link(f.link));
  return feet;
}

std::string check_report(const model::RobotDescription& d, const model::Model& m) {
  std::string out;
  auto line = [&out](const std::string& s) { out += s + "\n"; };
  std::map<std::string, int> types;
  for (const auto& j : d.joints) {
    static const char* names[] = {"revolute", "continuous", "prismatic", "fixed", "floating", "planar"};
    ++types[names[static_cast<int>(j.type)]];
  }
  std::string type_list;
  for (const auto& [t, n] : types) type_list += (type_list.empty() ? "" : ", ") + fmt::format("{} {}", n, t);
  line(fmt::format("robot '{}' ({})", d.name, d.source));
  line(fmt::format("  {} links, {} joints: {}", d.links.size(), d.joints.size(), type_list));
  line(fmt::format("  model: floating base '{}', {} joints ({} held, {} locked), {} bodies", m.body_name.front(), m.nj,
                   m.held_joint_name.size(), m.locked_joint_name.size(), m.nb));

  model::Data data(m);
  Eigen::VectorXd q = m.neutral();
  model::forward_kinematics(m, data, q);
  model::update_frame_placements(m, data);
  const Vector3d c = model::center_of_mass(m, data, q);
  line(fmt::format("  total mass {:.3f} kg; centre of mass at the neutral configuration ({:.3f}, {:.3f}, {:.3f}) m in the "
                   "base frame", m.mass, c.x(), c.y(), c.z()));

  std::set<std::string> mesh_files;
  int meshes = 0;
  for (const auto& l : d.links) {
    for (const auto* list : {&l.collisions, &l.visuals}) {
      for (const auto& g : *list) {
        if (g.type != Geometry::Type::kMesh) continue;
        ++meshes;
        mesh_files.insert(g.mesh);
      }
    }
  }
  line(fmt::format("  meshes: {} references to {} files, every one found", meshes, mesh_files.size()));

  line(fmt::format("repairs ({}):", d.repairs.size() + m.warnings.size()));
  for (const auto& r : d.repairs) line("  " + r);
  for (const auto& w : m.warnings) line("  " + w);

  line("kinematic tree (moving joints; [limits] rad, effort N m):");
  std::function<void(int, int)> tree = [&](int body, int depth) {
    for (int b = body + 1; b < m.nb; ++b) {
      if (m.parent[static_cast<size_t>(b)] != body) continue;
      const int j = b - 1;
      const auto ju = static_cast<size_t>(j);
      line(fmt::format("  {:{}}{} -> {} [{:.3g}, {:.3g}] {:.3g}", "", 2 * depth, m.joint_name[ju], m.body_name[static_cast<size_t>(b)],
                       m.q_lower[ju], m.q_upper[ju], m.tau_max[ju]));
      tree(b, depth + 1);
    }
  };
  tree(0, 0);
  try {
    const auto feet = find_feet(m, d);
    line("candidate feet (lowest links at the end of the leg chains):");
    for (int k = 0; k < 2; ++k) {
      const auto& f = feet[static_cast<size_t>(k)];
      line(fmt::format("  {}: {} ({} leg joints), sole {:.3f} x {:.3f} m centred at ({:.3f}, {:.3f}, {:.3f}) in the link "
                       "frame, from {}",
                       k == 0 ? "right" : "left", f.link, f.leg_joints.size(), f.sole.length, f.sole.width,
                       f.sole.centre.x(), f.sole.centre.y(), f.sole.centre.z(), f.sole.from));
    }
  } catch (const model::ModelError& e) {
    line(fmt::format("candidate feet: none ({})", e.what()));
  }
  return out;
}

}  // namespace hpr::onboard
