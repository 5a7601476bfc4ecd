#pragma once
/// \file
/// URDF loading (urdfdom) into a plain description shared by the model library and the simulator,
/// with validation: every error names the link or joint at fault.

#include <stdexcept>
#include <string>
#include <vector>

#include "hpr/model/spatial.hpp"

namespace hpr::model {

/// A malformed or physically inconsistent robot description.
class ModelError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct Geometry {
  enum class Type { kBox, kCylinder, kSphere, kMesh };
  Type type = Type::kBox;
  SE3 X_LG;                           ///< geometry frame in the link frame
  Vector3d size = Vector3d::Zero();   ///< box: full sizes; cylinder: (radius, length, 0); sphere: (radius, 0, 0)
  std::string mesh;                   ///< mesh file name (kMesh)
  Vector3d mesh_scale = Vector3d::Ones();
};

struct LinkDesc {
  std::string name;
  bool has_inertial = false;
  double mass = 0.0;                      ///< [kg]
  Vector3d com = Vector3d::Zero();        ///< centre of mass in the link frame [m]
  Matrix3d inertia = Matrix3d::Zero();    ///< about the centre of mass, link axes [kg m^2]
  std::vector<Geometry> collisions;
};

enum class JointType { kRevolute, kContinuous, kPrismatic, kFixed, kFloating, kPlanar };

struct JointDesc {
  std::string name;
  JointType type = JointType::kFixed;
  std::string parent, child;
  SE3 X_PJ;                               ///< joint frame (= child link frame at q = 0) in the parent link frame
  Vector3d axis = Vector3d::UnitZ();      ///< unit axis in the joint frame
  bool has_limits = false;
  double lower = 0, upper = 0;            ///< position limits [rad or m]
  double effort = 0, velocity = 0;        ///< [Nm or N], [rad/s or m/s]
  double damping = 0, friction = 0;
};

struct RobotDescription {
  std::string name;
  std::string source;      ///< file it came from
  std::string root_link;
  std::vector<LinkDesc> links;
  std::vector<JointDesc> joints;

  [[nodiscard]] const LinkDesc* find_link(const std::string& n) const;
  [[nodiscard]] const JointDesc* find_joint(const std::string& n) const;
  /// Joints whose parent is `link`, in file order.
  [[nodiscard]] std::vector<const JointDesc*> child_joints(const std::string& link) const;
  /// The joint whose child is `link` (nullptr for the root).
  [[nodiscard]] const JointDesc* parent_joint(const std::string& link) const;
  /// Total mass [kg].
  [[nodiscard]] double total_mass() const;
};

/// Parses and validates a URDF file. Throws ModelError naming the file and the link or joint.
RobotDescription load_urdf(const std::string& path);
/// Parses and validates URDF text; `source` names it in messages.
RobotDescription parse_urdf(const std::string& xml, const std::string& source);

/// Checks that a rotational inertia about the centre of mass is physically consistent: symmetric,
/// positive definite and satisfying the triangle inequality of its principal moments. Returns an
/// empty string when it is, else the reason.
std::string check_inertia(const Matrix3d& I_c);

}  // namespace hpr::model
