#include "hpr/model/urdf.hpp"

#include <console_bridge/console.h>
#include <fmt/format.h>
#include <tinyxml.h>

#include <Eigen/Eigenvalues>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <urdf_parser/urdf_parser.h>

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

void check_links(const RobotDescription& d) {
  for (const auto& l : d.links) {
    if (!l.has_inertial) continue;
    if (!(l.mass > 0.0) || !std::isfinite(l.mass)) {
      throw ModelError(fmt::format("{}: link '{}' has mass {} kg; a link with <inertial> needs a positive mass",
                                   d.source, l.name, l.mass));
    }
    if (!l.com.allFinite() || !l.inertia.allFinite()) {
      throw ModelError(fmt::format("{}: link '{}' has a non-finite centre of mass or inertia", d.source, l.name));
    }
    if (const std::string why = check_inertia(l.inertia); !why.empty()) {
      throw ModelError(fmt::format("{}: link '{}': inertia {}", d.source, l.name, why));
    }
  }
  for (const auto& j : d.joints) {
    if (j.type == JointType::kRevolute || j.type == JointType::kContinuous || j.type == JointType::kPrismatic) {
      if (!(j.axis.norm() > 1e-9)) {
        throw ModelError(fmt::format("{}: joint '{}' has a zero axis", d.source, j.name));
      }
      if (j.has_limits && j.type != JointType::kContinuous && j.lower > j.upper) {
        throw ModelError(fmt::format("{}: joint '{}' has lower limit {} above upper limit {}", d.source, j.name,
                                     j.lower, j.upper));
      }
    }
  }
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
    }
    for (const auto& c : link->collision_array) {
      if (!c || !c->geometry) continue;
      Geometry g;
      g.X_LG = to_se3(c->origin);
      switch (c->geometry->type) {
        case urdf::Geometry::BOX: {
          const auto& b = dynamic_cast<const urdf::Box&>(*c->geometry);
          g.type = Geometry::Type::kBox;
          g.size = Vector3d(b.dim.x, b.dim.y, b.dim.z);
          break;
        }
        case urdf::Geometry::CYLINDER: {
          const auto& cy = dynamic_cast<const urdf::Cylinder&>(*c->geometry);
          g.type = Geometry::Type::kCylinder;
          g.size = Vector3d(cy.radius, cy.length, 0);
          break;
        }
        case urdf::Geometry::SPHERE: {
          const auto& s = dynamic_cast<const urdf::Sphere&>(*c->geometry);
          g.type = Geometry::Type::kSphere;
          g.size = Vector3d(s.radius, 0, 0);
          break;
        }
        case urdf::Geometry::MESH: {
          const auto& me = dynamic_cast<const urdf::Mesh&>(*c->geometry);
          g.type = Geometry::Type::kMesh;
          g.mesh = me.filename;
          g.mesh_scale = Vector3d(me.scale.x, me.scale.y, me.scale.z);
          break;
        }
      }
      l.collisions.push_back(g);
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
    if (j.type != JointType::kFixed && j.type != JointType::kFloating && j.axis.norm() > 0) j.axis.normalize();
    d.joints.push_back(std::move(j));
  }
  if (auto root = m.getRoot()) d.root_link = root->name;
  return d;
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

std::string check_inertia(const Matrix3d& I_c) {
  if (!I_c.allFinite()) return "has non-finite entries";
  if ((I_c - I_c.transpose()).cwiseAbs().maxCoeff() > 1e-12 * (1.0 + I_c.cwiseAbs().maxCoeff())) {
    return "is not symmetric";
  }
  const Eigen::SelfAdjointEigenSolver<Matrix3d> es(I_c);
  const Vector3d e = es.eigenvalues();  // ascending
  if (!(e(0) > 0.0)) {
    return fmt::format("is not positive definite (principal moments {:.3g}, {:.3g}, {:.3g})", e(0), e(1), e(2));
  }
  const double tol = 1e-9 * e(2);
  if (e(0) + e(1) < e(2) - tol) {
    return fmt::format("violates the triangle inequality (principal moments {:.6g} + {:.6g} < {:.6g})", e(0), e(1), e(2));
  }
  return "";
}

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

RobotDescription parse_urdf(const std::string& xml, const std::string& source) {
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
  return d;
}

RobotDescription load_urdf(const std::string& path) {
  std::ifstream f(path);
  if (!f) throw ModelError(fmt::format("{}: cannot open the URDF file", path));
  std::stringstream ss;
  ss << f.rdbuf();
  return parse_urdf(ss.str(), path);
}

}  // namespace hpr::model
