#include "hpr/onboard/robot_check.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <set>
#include <tuple>

#include "hpr/mesh/mesh.hpp"
#include "hpr/model/algorithms.hpp"
#include "hpr/onboard/sole_outline.hpp"
#include "text.hpp"

namespace hpr::onboard {

using Eigen::Vector3d;
using model::Geometry;
using model::SE3;

namespace {

// Points of a geometry (in its link's frame) that can touch a plane below the link; a mesh gives
// `hull_points` points of its hull, or every vertex when hull_points is 0.
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
    case Geometry::Type::kMesh: {
      auto v = mesh::load(g.mesh, g.mesh_scale).vertices;
      local = hull_points > 0 ? mesh::hull_points(v, hull_points) : std::move(v);
      break;
    }
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
    case Geometry::Type::kMesh: return "mesh";
  }
  return "?";
}

}  // namespace

Sole sole_from_geometry(const model::LinkDesc& link, double tolerance, double forward_yaw) {
  if (link.collisions.empty()) {
    throw model::ModelError(fmt::format("link '{}' has no collision geometry to take a sole from", link.name));
  }
  std::vector<Vector3d> pts;
  std::map<std::string, int> kinds;
  for (const auto& g : link.collisions) {
    const auto p = contact_points(g, 0);
    pts.insert(pts.end(), p.begin(), p.end());
    ++kinds[type_name(g.type)];
  }
  double z_min = std::numeric_limits<double>::infinity();
  for (const auto& p : pts) z_min = std::min(z_min, p.z());
  std::vector<Eigen::Vector2d> outline;
  for (const auto& p : pts) {
    if (p.z() <= z_min + tolerance) outline.push_back(p.head<2>());
  }
  const SoleRectangle r = sole_rectangle(outline, forward_yaw);
  Sole s;
  s.length = r.length;
  s.width = r.width;
  s.yaw = r.yaw;
  s.centre = Vector3d(r.centre.x(), r.centre.y(), z_min);
  for (const auto& [kind, n] : kinds) s.from += (s.from.empty() ? "" : ", ") + fmt::format("{} {}", n, kind) + (n > 1 ? "s" : "");
  if (s.length < 0.01 || s.width < 0.01) {
    s.warnings.push_back(fmt::format("the sole of '{}' is degenerate ({:.3f} x {:.3f} m from {}: its lowest face, within {:.0f} mm "
                                     "of its lowest point, spans no area); give robot.feet.<side>.sole_xyz and sole_size by hand",
                                     link.name, s.length, s.width, s.from, tolerance * 1e3));
  }
  // Sideways offset of the sole's centre from the link's origin, across the sole.
  const double lateral = -std::sin(s.yaw) * s.centre.x() + std::cos(s.yaw) * s.centre.y();
  if (s.width > 0 && std::abs(lateral) > 0.25 * s.width) {
    s.warnings.push_back(fmt::format("the sole of '{}' is centred {:.1f} cm to the side of the link's origin, more than a quarter "
                                     "of its width ({:.3f} m): check its collision geometry",
                                     link.name, lateral * 100.0, s.width));
  }
  if (std::abs(std::remainder(s.yaw - forward_yaw, 2 * M_PI)) > 0.25 * M_PI && s.length > 0) {
    s.warnings.push_back(fmt::format("the sole of '{}' is longest {:.0f} deg away from the robot's forward direction",
                                     link.name, std::remainder(s.yaw - forward_yaw, 2 * M_PI) * 180.0 / M_PI));
  }
  return s;
}

std::array<FootCandidate, 2> find_feet(const model::Model& m, const model::RobotDescription& d, int min_leg_joints) {
  model::Data data(m);
  Eigen::VectorXd q = Eigen::VectorXd::Zero(m.nq);
  q(6) = 1.0;
  model::forward_kinematics(m, data, q);
  model::update_frame_placements(m, data);
  // A body with a child body is no end of a chain.
  std::vector<bool> leaf(static_cast<size_t>(m.nb), true);
  for (int b = 1; b < m.nb; ++b) leaf[static_cast<size_t>(m.parent[static_cast<size_t>(b)])] = false;
  std::vector<FootCandidate> all, bare;
  for (size_t f = 0; f < m.frames.size(); ++f) {
    const model::Frame& fr = m.frames[f];
    const model::LinkDesc* link = d.find_link(fr.name);
    if (link == nullptr || fr.body == 0) continue;
    if (static_cast<int>(m.support[static_cast<size_t>(fr.body)].size()) < min_leg_joints) continue;
    if (link->collisions.empty()) {
      // Without geometry: the link at the end of a leg chain, by its origin's height.
      if (!leaf[static_cast<size_t>(fr.body)] || fr.name != m.body_name[static_cast<size_t>(fr.body)]) continue;
      FootCandidate c;
      c.link = fr.name;
      c.body = fr.body;
      c.z_lowest = data.oMf[f].p.z();
      for (int j : m.support[static_cast<size_t>(fr.body)]) c.leg_joints.push_back(m.joint_name[static_cast<size_t>(j)]);
      bare.push_back(c);
      continue;
    }
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
  const auto by_height = [](const auto& a, const auto& b) { return a.z_lowest < b.z_lowest; };
  std::sort(all.begin(), all.end(), by_height);
  std::sort(bare.begin(), bare.end(), by_height);
  std::array<FootCandidate, 2> feet;
  std::array<bool, 2> found{false, false};
  // The lowest candidate on each side of the base's x-z plane; one without collision geometry only
  // where no leg chain of that side has any.
  for (const auto* list : {&all, &bare}) {
    for (const auto& c : *list) {
      const double y = data.oMi[static_cast<size_t>(c.body)].p.y();
      const int side = y < 0 ? 0 : 1;  // right: −y
      if (found[static_cast<size_t>(side)]) continue;
      feet[static_cast<size_t>(side)] = c;
      found[static_cast<size_t>(side)] = true;
    }
  }
  if (!found[0] || !found[1]) {
    throw model::ModelError(fmt::format("{}: no {} foot: no link at the end of a chain of {} or more joints on that side",
                                        m.source, !found[0] ? "right (-y)" : "left (+y)", min_leg_joints));
  }
  for (auto& f : feet) {
    // The base's x at q = 0, seen in the foot link's x-y plane: the robot's forward direction.
    const SE3& X_WF = data.oMf[static_cast<size_t>(m.frame_index(f.link))];
    const Vector3d fwd = X_WF.R.transpose() * Vector3d::UnitX();
    double forward_yaw = std::atan2(fwd.y(), fwd.x());
    if (std::abs(forward_yaw) < 1e-9) forward_yaw = 0.0;
    const model::LinkDesc& link = *d.find_link(f.link);
    if (!link.collisions.empty()) {
      f.sole = sole_from_geometry(link, 0.003, forward_yaw);
      continue;
    }
    // No geometry to measure: a sole of human proportions to the leg's length (hip joint to foot).
    const int hip = m.support[static_cast<size_t>(f.body)].front() + 1;
    const double leg = (X_WF.p - data.oMi[static_cast<size_t>(hip)].p).norm();
    f.sole.length = 0.3 * leg;
    f.sole.width = 0.4 * f.sole.length;
    f.sole.yaw = forward_yaw;
    f.sole.from = "no collision geometry: a guess from the leg's length";
    f.sole.warnings.push_back(fmt::format("the foot link '{}' has no collision geometry: its sole is a guess, {:.3f} x {:.3f} m at the "
                                          "link's origin (0.3 and 0.12 of the leg's length); measure the real sole and set "
                                          "robot.feet.<side>.sole_xyz and sole_size (the simulator stands the foot on that rectangle)",
                                          f.link, f.sole.length, f.sole.width));
  }
  return feet;
}

ImuChoice find_imu(const model::Model& m) {
  auto rank = [](const std::string& name) {
    const std::string n = detail::lower(name);
    if (n == "imu" || n == "imu_link") return 0;
    if (n.rfind("imu_", 0) == 0 || n.find("_imu") != std::string::npos) return 1;
    return n.find("imu") != std::string::npos ? 2 : 3;
  };
  const model::Frame* best = nullptr;
  std::tuple<int, size_t, std::string> best_key{3, 0, ""};
  for (const auto& f : m.frames) {
    const std::tuple<int, size_t, std::string> key{rank(f.name), m.support[static_cast<size_t>(f.body)].size(), f.name};
    if (std::get<0>(key) < 3 && (best == nullptr || key < best_key)) {
      best = &f;
      best_key = key;
    }
  }
  if (best == nullptr) {
    return {m.body_name.front(), "no link named like an IMU (imu, imu_link, *_imu*): the base link; set robot.imu.link and "
                                 "xyz/rpy to where the IMU is mounted"};
  }
  const auto& chain = m.support[static_cast<size_t>(best->body)];
  if (chain.empty()) return {best->name, "named like an IMU, rigidly on the base"};
  std::vector<std::string> joints;
  for (int j : chain) joints.push_back(m.joint_name[static_cast<size_t>(j)]);
  return {best->name, fmt::format("named like an IMU, on '{}', {} moving joint{} from the base ({}): the estimator takes the "
                                  "base's orientation through {} encoder{}",
                                  m.body_name[static_cast<size_t>(best->body)], chain.size(), chain.size() > 1 ? "s" : "",
                                  fmt::join(joints, ", "), chain.size() > 1 ? "their" : "its", chain.size() > 1 ? "s" : "")};
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

  const ImuChoice imu = find_imu(m);
  line(fmt::format("  IMU: '{}' ({})", imu.link, imu.why));

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
      line(fmt::format("  {}: {} ({} leg joints), sole {:.3f} x {:.3f} m centred at ({:.3f}, {:.3f}, {:.3f}){} in the link "
                       "frame, from {}",
                       k == 0 ? "right" : "left", f.link, f.leg_joints.size(), f.sole.length, f.sole.width,
                       f.sole.centre.x(), f.sole.centre.y(), f.sole.centre.z(),
                       f.sole.yaw != 0.0 ? fmt::format(", its length {:.1f} deg from the link's x", f.sole.yaw * 180.0 / M_PI) : "",
                       f.sole.from));
      for (const auto& w : f.sole.warnings) line("  warning: " + w);
    }
  } catch (const model::ModelError& e) {
    line(fmt::format("candidate feet: none ({})", e.what()));
  }
  return out;
}

}  // namespace hpr::onboard
