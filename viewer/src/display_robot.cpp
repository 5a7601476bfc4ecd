#include "hpr/viewer/display_robot.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include <fmt/format.h>

#include <Eigen/Eigenvalues>

#include "hpr/common/text.hpp"
#include "hpr/mesh/mesh.hpp"

namespace hpr::viewer {
namespace {

using model::Geometry;
using model::JointType;
using model::SE3;

/// Full precision, so the display agrees with the model to the last bit that matters.
std::string g(double x) { return fmt::format("{:.17g}", x); }
std::string v3(const model::Vector3d& v) { return g(v.x()) + " " + g(v.y()) + " " + g(v.z()); }

std::string origin(const SE3& X) {
  return fmt::format("<origin xyz=\"{}\" rpy=\"{}\"/>", v3(X.p), v3(rpy_of(X.R)));
}

const char* joint_type(JointType t) {
  switch (t) {
    case JointType::kRevolute: return "revolute";
    case JointType::kContinuous: return "continuous";
    case JointType::kPrismatic: return "prismatic";
    case JointType::kFloating: return "floating";
    case JointType::kPlanar: return "planar";
    case JointType::kFixed: break;
  }
  return "fixed";
}

class Writer {
 public:
  std::string geometry(const Geometry& geo) {
    switch (geo.type) {
      case Geometry::Type::kBox: return fmt::format("<box size=\"{}\"/>", v3(geo.size));
      case Geometry::Type::kCylinder:
        return fmt::format("<cylinder radius=\"{}\" length=\"{}\"/>", g(geo.size.x()), g(geo.size.y()));
      case Geometry::Type::kSphere: return fmt::format("<sphere radius=\"{}\"/>", g(geo.size.x()));
      case Geometry::Type::kMesh: break;
    }
    return fmt::format("<mesh filename=\"{}\" scale=\"{}\"/>", xml_escape(mesh_url(geo.mesh)), v3(geo.mesh_scale));
  }

  std::string mesh_url(const std::string& file) {
    auto it = index_.find(file);
    if (it == index_.end()) {
      std::string ext = std::filesystem::path(file).extension().string();
      std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
      it = index_.emplace(file, out.mesh_files.size()).first;
      out.mesh_files.push_back(file);
      if (options.mesh_max_triangles > 0 && (ext == ".stl" || ext == ".obj")) {
        const auto full = mesh::load(file);
        const auto light = mesh::simplify(full, options.mesh_max_triangles, options.mesh_max_error);
        out.triangles_in += full.triangles.size();
        out.triangles_out += light.triangles.size();
        out.mesh_data.push_back(mesh::to_binary_stl(light));
        ext = ".stl";
      } else {
        std::ifstream in(file, std::ios::binary);
        std::ostringstream bytes;
        bytes << in.rdbuf();
        if (!in) throw mesh::MeshError(fmt::format("{}: cannot read the mesh file", file));
        out.mesh_data.push_back(bytes.str());
      }
      out.mesh_urls.push_back(fmt::format("/robot/mesh/{}{}", it->second, ext));
    }
    return out.mesh_urls[it->second];
  }

  DisplayOptions options;
  DisplayRobot out;

 private:
  std::map<std::string, std::size_t> index_;
};

nlohmann::json pose_json(const SE3& X) {
  const Eigen::Quaterniond q(X.R);
  return {{"xyz", {X.p.x(), X.p.y(), X.p.z()}}, {"quat_wxyz", {q.w(), q.x(), q.y(), q.z()}}};
}

}  // namespace

Geometry inertia_box(const model::LinkDesc& link) {
  // Principal axes and moments of the (physically consistent) inertia about the CoM; a uniform box
  // of mass m and sides a, b, c has I_x = m (b² + c²) / 12, so a² = 6 (I_y + I_z - I_x) / m, ...
  const Eigen::SelfAdjointEigenSolver<model::Matrix3d> eig(link.inertia_physical);
  model::Matrix3d R = eig.eigenvectors();
  if (R.determinant() < 0) R.col(2) = -R.col(2);
  const model::Vector3d I = eig.eigenvalues();
  Geometry g;
  g.type = Geometry::Type::kBox;
  for (int k = 0; k < 3; ++k) {
    const double s2 = 6.0 * (I.sum() - 2.0 * I(k)) / link.mass;
    g.size(k) = std::sqrt(std::max(s2, 1e-6));
  }
  g.X_LG.R = R;
  g.X_LG.p = link.com;
  return g;
}

model::Vector3d rpy_of(const model::Matrix3d& R) {
  // cos(pitch) from the first column's norm, not asin(-R(2,0)), which loses half the digits near ±90°.
  const double c = std::hypot(R(0, 0), R(1, 0));
  const double pitch = std::atan2(-R(2, 0), c);
  if (c > 1e-12) return {std::atan2(R(2, 1), R(2, 2)), pitch, std::atan2(R(1, 0), R(0, 0))};
  // Gimbal lock: only roll - yaw (pitch = +90°) or roll + yaw (pitch = -90°) is defined; yaw = 0.
  return {std::atan2(-R(1, 2), R(1, 1)), pitch, 0.0};
}

DisplayRobot display_robot(const model::RobotSpec& robot, const DisplayOptions& options) {
  const auto& d = robot.description;
  Writer w;
  w.options = options;
  std::string x = fmt::format("<?xml version=\"1.0\"?>\n<robot name=\"{}\">\n", xml_escape(d.name));
  std::size_t inertia_boxes = 0;
  for (const auto& link : d.links) {
    x += fmt::format("  <link name=\"{}\">\n", xml_escape(link.name));
    const bool own = !link.visuals.empty();
    if (link.visuals.empty() && link.collisions.empty() && link.mass > 0.0) {
      const Geometry box = inertia_box(link);
      x += fmt::format("    <visual>{}<geometry>{}</geometry><material name=\"\"><color rgba=\"0.74 0.77 0.82 1\"/></material>"
                       "</visual>\n", origin(box.X_LG), w.geometry(box));
      ++inertia_boxes;
    }
    for (const auto& geo : own ? link.visuals : link.collisions) {
      x += fmt::format("    <visual>{}<geometry>{}</geometry>", origin(geo.X_LG), w.geometry(geo));
      const auto& c = own ? geo.rgba : Eigen::Vector4d(0.62, 0.66, 0.72, 1.0);
      x += fmt::format("<material name=\"\"><color rgba=\"{} {} {} {}\"/></material></visual>\n", g(c[0]), g(c[1]), g(c[2]),
                       g(c[3]));
    }
    x += "  </link>\n";
  }
  for (const auto& j : d.joints) {
    x += fmt::format("  <joint name=\"{}\" type=\"{}\"><parent link=\"{}\"/><child link=\"{}\"/>{}", xml_escape(j.name),
                     joint_type(j.type), xml_escape(j.parent), xml_escape(j.child), origin(j.X_PJ));
    if (j.type != JointType::kFixed) x += fmt::format("<axis xyz=\"{}\"/>", v3(j.axis));
    if (j.has_limits && (j.type == JointType::kRevolute || j.type == JointType::kPrismatic)) {
      x += fmt::format("<limit lower=\"{}\" upper=\"{}\" effort=\"{}\" velocity=\"{}\"/>", g(j.lower), g(j.upper), g(j.effort),
                       g(j.velocity));
    }
    if (!j.mimic.empty()) {
      x += fmt::format("<mimic joint=\"{}\" multiplier=\"{}\" offset=\"{}\"/>", xml_escape(j.mimic), g(j.mimic_multiplier),
                       g(j.mimic_offset));
    }
    x += "</joint>\n";
  }
  x += "</robot>\n";
  w.out.urdf = std::move(x);

  const auto& m = robot.model;
  nlohmann::json feet = nlohmann::json::array();
  static constexpr std::array<const char*, 2> kSide{"right", "left"};
  for (std::size_t k = 0; k < 2; ++k) {
    const auto& f = robot.feet[k];
    const auto& frame = m.frames[static_cast<std::size_t>(f.sole_frame)];
    // The sole's placement in the foot link frame (the frame may sit on a merged body).
    const SE3 X_BL = m.frames[static_cast<std::size_t>(m.frame_index(f.link))].X_BF;
    const SE3 X_LS = X_BL.inverse() * frame.X_BF;
    feet.push_back({{"side", kSide[k]}, {"link", f.link}, {"sole", pose_json(X_LS)}, {"length", f.length}, {"width", f.width}});
  }
  nlohmann::json held = nlohmann::json::object();
  for (std::size_t i = 0; i < m.held_joint_name.size(); ++i) held[m.held_joint_name[i]] = m.held_q[i];
  nlohmann::json locked = nlohmann::json::object();
  for (std::size_t i = 0; i < m.locked_joint_name.size(); ++i) locked[m.locked_joint_name[i]] = m.locked_q[i];
  w.out.info = {{"name", robot.name},
                {"urdf_file", d.source},
                {"base_link", m.body_name.front()},
                {"mass_kg", m.mass},
                {"joints", m.joint_name},
                {"held", held},
                {"locked", locked},
                {"feet", feet},
                {"meshes", w.out.mesh_files.size()},
                {"inertia_boxes", inertia_boxes},
                {"mesh_triangles", {{"file", w.out.triangles_in}, {"shown", w.out.triangles_out}}}};
  return std::move(w.out);
}

}  // namespace hpr::viewer
