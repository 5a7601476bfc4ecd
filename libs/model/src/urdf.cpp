#include "hpr/model/urdf.hpp"

#include <console_bridge/console.h>
#include <fmt/format.h>
#include <tinyxml.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <urdf_parser/urdf_parser.h>

#include "hpr/model/mesh_path.hpp"

namespace hpr::model {
namespace {

// Captures what urdfdom reports through console_bridge while it parses.
class CaptureHandler : public console_bridge::OutputHandler {
 public:
  void log(const std::string& text, console_bridge::LogLevel level, const char* /*file*/, int /*line*/) override {
    if (level >= console_bridge::CONSOLE_BRIDGE_LOG_WARN) {
      if (!messages.empty()) messages += "; ";
      messages += text;
    }
  }
  std::string messages;
};

SE3 to_se3(const urdf::Pose& pose) {
  SE3 X;
  double qx = 0, qy = 0, qz = 0, qw = 1;
  pose.rotation.getQuaternion(qx, qy, qz, qw);
  X.R = Eigen::Quaterniond(qw, qx, qy, qz).normalized().toRotationMatrix();
  X.p = Vector3d(pose.position.x, pose.position.y, pose.position.z);
  return X;
}

// Structural checks on the raw joint list, before urdfdom builds its tree (so that a loop or a
// link with two parents gets a message naming the joints).
void check_structure(const RobotDescription& d) {
  std::map<std::string, const JointDesc*> parent_of;
  std::set<std::string> links;
  for (const auto& l : d.links) links.insert(l.name);
  const JointDesc* floating = nullptr;
  for (const auto& j : d.joints) {
    if (!links.count(j.parent)) {
      throw ModelError(fmt::format("{}: joint '{}' names parent link '{}', which does not exist", d.source, j.name, j.parent));
    }
    if (!links.count(j.child)) {
      throw ModelError(fmt::format("{}: joint '{}' names child link '{}', which does not exist", d.source, j.name, j.child));
    }
    if (auto it = parent_of.find(j.child); it != parent_of.end()) {
      throw ModelError(fmt::format("{}: link '{}' is the child of two joints, '{}' and '{}' (a kinematic loop)",
                                   d.source, j.child, it->second->name, j.name));
    }
    parent_of[j.child] = &j;
    if (j.type == JointType::kFloating) {
      if (floating != nullptr) {
        throw ModelError(fmt::format("{}: joint '{}' is a second floating joint (first: '{}'); the base is the only "
                                     "floating body", d.source, j.name, floating->name));
      }
      floating = &j;
    }
    if (j.type == JointType::kPlanar) {
      throw ModelError(fmt::format("{}: joint '{}' is planar, which is not supported", d.source, j.name));
    }
  }
  // Every link must reach a root without revisiting a link (loops without a root are caught here).
  std::vector<std::string> roots;
  for (const auto& l : d.links) {
    std::set<std::string> seen;
    std::string cur = l.name;
    while (parent_of.count(cur)) {
      if (!seen.insert(cur).second) {
        throw ModelError(fmt::format("{}: joint '{}' closes a kinematic loop through link '{}'", d.source,
                                     parent_of.at(cur)->name, cur));
      }
      cur = parent_of.at(cur)->parent;
    }
    if (!parent_of.count(l.name)) roots.push_back(l.name);
  }
  if (roots.size() != 1) {
    std::string list;
    for (const auto& r : roots) list += (list.empty() ? "" : ", ") + r;
    throw ModelError(fmt::format("{}: expected one root link, found {} ({})", d.source, roots.size(), list));
  }
  if (floating != nullptr && floating->parent != roots.front()) {
    throw ModelError(fmt::format("{}: floating joint '{}' does not attach to the root link '{}'", d.source,
                                 floating->name, roots.front()));
  }
}

// Link inertias: refuses what cannot be a body, repairs what real descriptions ship (each repair
// reported once in d.repairs).
void check_links(RobotDescription& d) {
  for (auto& l : d.links) {
    if (!l.has_inertial) continue;
    if (!std::isfinite(l.mass) || l.mass < 0.0) {
      throw ModelError(fmt::format("{}: link '{}' has mass {} kg; a link with <inertial> needs a positive mass",
                                   d.source, l.name, l.mass));
    }
    if (!l.com.allFinite() || !l.inertia.allFinite()) {
      throw ModelError(fmt::format("{}: link '{}' has a non-finite centre of mass or inertia", d.source, l.name));
    }
    if (l.mass == 0.0) {
      // A frame link (camera, sensor) written with an empty <inertial>: no inertia at all.
      d.repairs.push_back(fmt::format("link '{}': <inertial> with mass 0 is treated as no inertia{}", l.name,
                                      l.inertia.isZero(0.0) ? "" : " (its rotational inertia is ignored)"));
      l.has_inertial = false;
      l.inertia.setZero();
      l.com.setZero();
      continue;
    }
    const InertiaRepair r = regularise_inertia(l.mass, l.inertia);
    if (!r.error.empty()) throw ModelError(fmt::format("{}: link '{}': inertia {}", d.source, l.name, r.error));
    l.inertia_physical = r.I_c;
    l.inertia_regularised = !r.what.empty();
    if (l.inertia_regularised) {
      d.repairs.push_back(fmt::format("link '{}' ({:.4g} kg): {}; the simulator uses the regularised inertia, the "
                                      "controllers' model the file's",
                                      l.name, l.mass, r.what));
    }
  }
  for (const auto& j : d.joints) {
    if (j.type == JointType::kRevolute || j.type == JointType::kContinuous || j.type == JointType::kPrismatic) {
      if (!j.axis.allFinite() || !(j.axis.norm() > 1e-9)) {
        throw ModelError(fmt::format("{}: joint '{}' has a zero or non-finite axis", d.source, j.name));
      }
      if (j.has_limits) {
        for (const auto& [what, v] : {std::pair{"lower", j.lower}, std::pair{"upper", j.upper},
                                      std::pair{"effort", j.effort}, std::pair{"velocity", j.velocity}}) {
          if (!std::isfinite(v)) {
            throw ModelError(fmt::format("{}: joint '{}': <limit {}=\"{}\"> is not a finite number", d.source, j.name,
                                         what, v));
          }
        }
        if (j.effort < 0.0 || j.velocity < 0.0) {
          throw ModelError(fmt::format("{}: joint '{}': negative <limit> (effort {}, velocity {})", d.source, j.name,
                                       j.effort, j.velocity));
        }
      }
      if (j.has_limits && j.type != JointType::kContinuous && j.lower > j.upper) {
        throw ModelError(fmt::format("{}: joint '{}' has lower limit {} above upper limit {}", d.source, j.name,
                                     j.lower, j.upper));
      }
    }
    if (!j.X_PJ.p.allFinite() || !j.X_PJ.R.allFinite()) {
      throw ModelError(fmt::format("{}: joint '{}' has a non-finite <origin>", d.source, j.name));
    }
    if (!std::isfinite(j.damping) || !std::isfinite(j.friction) || j.damping < 0.0 || j.friction < 0.0) {
      throw ModelError(fmt::format("{}: joint '{}': <dynamics damping=\"{}\" friction=\"{}\"> must be finite and "
                                   "non-negative", d.source, j.name, j.damping, j.friction));
    }
    if (!j.mimic.empty()) {
      const JointDesc* leader = d.find_joint(j.mimic);
      if (leader == nullptr) {
        throw ModelError(fmt::format("{}: joint '{}' mimics joint '{}', which does not exist", d.source, j.name,
                                     j.mimic));
      }
      if (!std::isfinite(j.mimic_multiplier) || !std::isfinite(j.mimic_offset)) {
        throw ModelError(fmt::format("{}: joint '{}': non-finite <mimic> multiplier or offset", d.source, j.name));
      }
    }
  }
  for (const auto& l : d.links) {
    for (const auto* list : {&l.collisions, &l.visuals}) {
      for (const auto& g : *list) {
        if (!g.size.allFinite() || !g.mesh_scale.allFinite() || !g.X_LG.p.allFinite() || !g.X_LG.R.allFinite() ||
            (g.type != Geometry::Type::kMesh && (g.size.array() < 0.0).any())) {
          throw ModelError(fmt::format("{}: link '{}': a {} geometry has a non-finite or negative size or origin",
                                       d.source, l.name, list == &l.collisions ? "collision" : "visual"));
        }
      }
    }
  }
}

Geometry to_geometry(const urdf::Geometry& geometry, const urdf::Pose& origin) {
  Geometry g;
  g.X_LG = to_se3(origin);
  switch (geometry.type) {
    case urdf::Geometry::BOX: {
      const auto& b = dynamic_cast<const urdf::Box&>(geometry);
      g.type = Geometry::Type::kBox;
      g.size = Vector3d(b.dim.x, b.dim.y, b.dim.z);
      break;
    }
    case urdf::Geometry::CYLINDER: {
      const auto& cy = dynamic_cast<const urdf::Cylinder&>(geometry);
      g.type = Geometry::Type::kCylinder;
      g.size = Vector3d(cy.radius, cy.length, 0);
      break;
    }
    case urdf::Geometry::SPHERE: {
      const auto& sp = dynamic_cast<const urdf::Sphere&>(geometry);
      g.type = Geometry::Type::kSphere;
      g.size = Vector3d(sp.radius, 0, 0);
      break;
    }
    case urdf::Geometry::MESH: {
      const auto& me = dynamic_cast<const urdf::Mesh&>(geometry);
      g.type = Geometry::Type::kMesh;
      g.mesh_uri = me.filename;
      g.mesh = me.filename;
      g.mesh_scale = Vector3d(me.scale.x, me.scale.y, me.scale.z);
      break;
    }
  }
  return g;
}

RobotDescription convert(const urdf::ModelInterface& m, const std::string& source) {
  RobotDescription d;
  d.name = m.getName();
  d.source = source;
  for (const auto& [name, link] : m.links_) {
    LinkDesc l;
    l.name = name;
    if (link->inertial) {
      l.has_inertial = true;
      l.mass = link->inertial->mass;
      const SE3 X_LI = to_se3(link->inertial->origin);
      l.com = X_LI.p;
      Matrix3d I;
      const auto& in = *link->inertial;
      I << in.ixx, in.ixy, in.ixz, in.ixy, in.iyy, in.iyz, in.ixz, in.iyz, in.izz;
      l.inertia = X_LI.R * I * X_LI.R.transpose();
      l.inertia_physical = l.inertia;
    }
    for (const auto& c : link->collision_array) {
      if (c && c->geometry) l.collisions.push_back(to_geometry(*c->geometry, c->origin));
    }
    for (const auto& v : link->visual_array) {
      if (!v || !v->geometry) continue;
      Geometry g = to_geometry(*v->geometry, v->origin);
      if (v->material) {
        const auto& c = v->material->color;
        g.rgba = Eigen::Vector4f(c.r, c.g, c.b, c.a).cast<double>();
        // urdfdom leaves a material defined at the top level by name only on the visual.
        if (auto it = m.materials_.find(v->material_name); it != m.materials_.end() && it->second) {
          const auto& mc = it->second->color;
          g.rgba = Eigen::Vector4f(mc.r, mc.g, mc.b, mc.a).cast<double>();
        }
      }
      l.visuals.push_back(g);
    }
    d.links.push_back(std::move(l));
  }
  for (const auto& [name, joint] : m.joints_) {
    JointDesc j;
    j.name = name;
    j.parent = joint->parent_link_name;
    j.child = joint->child_link_name;
    j.X_PJ = to_se3(joint->parent_to_joint_origin_transform);
    j.axis = Vector3d(joint->axis.x, joint->axis.y, joint->axis.z);
    switch (joint->type) {
      case urdf::Joint::REVOLUTE: j.type = JointType::kRevolute; break;
      case urdf::Joint::CONTINUOUS: j.type = JointType::kContinuous; break;
      case urdf::Joint::PRISMATIC: j.type = JointType::kPrismatic; break;
      case urdf::Joint::FLOATING: j.type = JointType::kFloating; break;
      case urdf::Joint::PLANAR: j.type = JointType::kPlanar; break;
      default: j.type = JointType::kFixed; break;
    }
    if (joint->limits) {
      j.has_limits = true;
      j.lower = joint->limits->lower;
      j.upper = joint->limits->upper;
      j.effort = joint->limits->effort;
      j.velocity = joint->limits->velocity;
    }
    if (joint->dynamics) {
      j.damping = joint->dynamics->damping;
      j.friction = joint->dynamics->friction;
    }
    if (joint->mimic) {
      j.mimic = joint->mimic->joint_name;
      j.mimic_multiplier = joint->mimic->multiplier;
      j.mimic_offset = joint->mimic->offset;
    }
    if (j.type != JointType::kFixed && j.type != JointType::kFloating && j.axis.norm() > 0) j.axis.normalize();
    d.joints.push_back(std::move(j));
  }
  if (auto root = m.getRoot()) d.root_link = root->name;
  return d;
}

/// Where `text` stops being UTF-8 without NUL bytes (npos when it is). TinyXML 2.6 trusts a UTF-8
/// lead byte's length and reads past the end of the text when the bytes that follow are missing
/// (found by fuzzing), so only valid text reaches the XML parsers.
std::size_t first_invalid_utf8(const std::string& text) {
  const auto* p = reinterpret_cast<const unsigned char*>(text.data());
  const std::size_t n = text.size();
  for (std::size_t i = 0; i < n;) {
    const unsigned char c = p[i];
    std::size_t len = 0;
    if (c == 0) return i;
    if (c < 0x80) {
      len = 1;
    } else if ((c & 0xE0) == 0xC0 && c >= 0xC2) {
      len = 2;
    } else if ((c & 0xF0) == 0xE0) {
      len = 3;
    } else if ((c & 0xF8) == 0xF0 && c <= 0xF4) {
      len = 4;
    } else {
      return i;
    }
    if (i + len > n) return i;
    for (std::size_t k = 1; k < len; ++k) {
      if ((p[i + k] & 0xC0) != 0x80) return i;
    }
    i += len;
  }
  return std::string::npos;
}

// The link and joint names and the parent/child links of every joint, read with TinyXML before
// urdfdom builds its tree, so that a loop or a link with two parents gets a message naming the joints.
RobotDescription extract_structure(const std::string& xml, const std::string& source) {
  TiXmlDocument doc;
  doc.Parse(xml.c_str());
  if (doc.Error()) {
    throw ModelError(fmt::format("{}:{}: XML error: {}", source, doc.ErrorRow(), doc.ErrorDesc()));
  }
  const TiXmlElement* robot = doc.FirstChildElement("robot");
  if (robot == nullptr) throw ModelError(fmt::format("{}: no <robot> element", source));
  RobotDescription d;
  d.source = source;
  auto attr = [](const TiXmlElement* e, const char* key) -> std::string {
    const char* v = e != nullptr ? e->Attribute(key) : nullptr;
    return v != nullptr ? v : "";
  };
  for (const TiXmlElement* e = robot->FirstChildElement("link"); e; e = e->NextSiblingElement("link")) {
    LinkDesc l;
    l.name = attr(e, "name");
    d.links.push_back(l);
  }
  for (const TiXmlElement* e = robot->FirstChildElement("joint"); e; e = e->NextSiblingElement("joint")) {
    JointDesc j;
    j.name = attr(e, "name");
    const std::string type = attr(e, "type");
    j.type = type == "floating" ? JointType::kFloating : type == "planar" ? JointType::kPlanar : JointType::kRevolute;
    j.parent = attr(e->FirstChildElement("parent"), "link");
    j.child = attr(e->FirstChildElement("child"), "link");
    d.joints.push_back(j);
  }
  return d;
}

}  // namespace

const LinkDesc* RobotDescription::find_link(const std::string& n) const {
  for (const auto& l : links) {
    if (l.name == n) return &l;
  }
  return nullptr;
}

const JointDesc* RobotDescription::find_joint(const std::string& n) const {
  for (const auto& j : joints) {
    if (j.name == n) return &j;
  }
  return nullptr;
}

std::vector<const JointDesc*> RobotDescription::child_joints(const std::string& link) const {
  std::vector<const JointDesc*> out;
  for (const auto& j : joints) {
    if (j.parent == link) out.push_back(&j);
  }
  return out;
}

const JointDesc* RobotDescription::parent_joint(const std::string& link) const {
  for (const auto& j : joints) {
    if (j.child == link) return &j;
  }
  return nullptr;
}

double RobotDescription::total_mass() const {
  double m = 0;
  for (const auto& l : links) m += l.has_inertial ? l.mass : 0.0;
  return m;
}

RobotDescription parse_urdf(const std::string& xml, const std::string& source, const UrdfOptions& options) {
  if (const std::size_t bad = first_invalid_utf8(xml); bad != std::string::npos) {
    const auto line = 1 + std::count(xml.begin(), xml.begin() + static_cast<std::ptrdiff_t>(bad), '\n');
    throw ModelError(fmt::format("{}:{}: byte {} (0x{:02x}) is not UTF-8 text", source, line, bad,
                                 static_cast<unsigned>(static_cast<unsigned char>(xml[bad]))));
  }
  // Structure first, on a tolerant extraction, so that loops and double parents name the joints.
  check_structure(extract_structure(xml, source));
  CaptureHandler capture;
  console_bridge::useOutputHandler(&capture);
  urdf::ModelInterfaceSharedPtr m;
  try {
    m = urdf::parseURDF(xml);
  } catch (const std::exception& e) {
    console_bridge::restorePreviousOutputHandler();
    throw ModelError(fmt::format("{}: URDF rejected: {}", source, e.what()));
  }
  console_bridge::restorePreviousOutputHandler();
  if (!m) {
    throw ModelError(fmt::format("{}: URDF rejected by the parser: {}", source,
                                 capture.messages.empty() ? "malformed XML" : capture.messages));
  }
  RobotDescription d = convert(*m, source);
  check_structure(d);
  check_links(d);
  if (options.resolve_meshes) {
    const auto search = mesh_search_dirs(options.mesh_search_paths);
    for (auto& l : d.links) {
      for (auto* list : {&l.collisions, &l.visuals}) {
        for (auto& g : *list) {
          if (g.type == Geometry::Type::kMesh) g.mesh = resolve_mesh(g.mesh_uri, source, l.name, search);
        }
      }
    }
  }
  return d;
}

RobotDescription load_urdf(const std::string& path, const UrdfOptions& options) {
  std::ifstream f(path);
  if (!f) throw ModelError(fmt::format("{}: cannot open the URDF file", path));
  std::stringstream ss;
  ss << f.rdbuf();
  return parse_urdf(ss.str(), path, options);
}

}  // namespace hpr::model
