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
  std::string mesh;                   ///< mesh file, resolved to a path that exists (kMesh)
  std::string mesh_uri;               ///< the mesh as the URDF names it (package://, file://, relative)
  Vector3d mesh_scale = Vector3d::Ones();
  Eigen::Vector4d rgba{0.7, 0.7, 0.7, 1.0};  ///< colour of a visual (its material's, when it has one)
};

struct LinkDesc {
  std::string name;
  bool has_inertial = false;
  double mass = 0.0;                      ///< [kg]
  Vector3d com = Vector3d::Zero();        ///< centre of mass in the link frame [m]
  Matrix3d inertia = Matrix3d::Zero();    ///< about the centre of mass, link axes [kg m^2], as in the file
  /// `inertia` made physically consistent (positive definite, triangle inequality), for a simulator;
  /// equal to `inertia` unless `inertia_regularised`.
  Matrix3d inertia_physical = Matrix3d::Zero();
  bool inertia_regularised = false;
  std::vector<Geometry> collisions;
  std::vector<Geometry> visuals;
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
  std::string mimic;                      ///< leader joint of a <mimic> joint (empty: none)
  double mimic_multiplier = 1.0, mimic_offset = 0.0;  ///< q = multiplier q_leader + offset
};

struct RobotDescription {
  std::string name;
  std::string source;      ///< file it came from
  std::string root_link;
  std::vector<LinkDesc> links;
  std::vector<JointDesc> joints;
  /// One line per repair the loader made (massless <inertial>, regularised inertias), each naming
  /// the link and what was done.
  std::vector<std::string> repairs;

  [[nodiscard]] const LinkDesc* find_link(const std::string& n) const;
  [[nodiscard]] const JointDesc* find_joint(const std::string& n) const;
  /// Joints whose parent is `link`, in file order.
  [[nodiscard]] std::vector<const JointDesc*> child_joints(const std::string& link) const;
  /// The joint whose child is `link` (nullptr for the root).
  [[nodiscard]] const JointDesc* parent_joint(const std::string& link) const;
  /// Total mass [kg].
  [[nodiscard]] double total_mass() const;
};

struct UrdfOptions {
  /// Folders in which `package://NAME/...` and relative mesh paths are looked up besides the URDF's
  /// repository (hpr/model/mesh_path.hpp); HPR_MESH_PATH and ROS_PACKAGE_PATH (colon-separated) are added.
  std::vector<std::string> mesh_search_paths;
  /// Resolve every mesh to a file that exists (a missing one is an error naming it). Off only for
  /// URDF text without files behind it.
  bool resolve_meshes = true;
};

/// Parses and validates a URDF file. Throws ModelError naming the file and the link or joint.
///
/// What real robot descriptions ship is accepted and reported in `repairs`: an <inertial> of mass
/// 0 is no inertia; a point mass or an inertia slightly inconsistent (principal moments violating
/// the triangle inequality by at most 10 % of the largest, or negative by at most 0.1 % of it) is
/// kept as it is for the controllers' model and regularised minimally in `inertia_physical`.
/// Refused: non-finite or negative values, larger inconsistencies, loops, missing links or meshes.
RobotDescription load_urdf(const std::string& path, const UrdfOptions& options = {});
/// Parses and validates URDF text; `source` names it in messages (and its folder is where relative
/// mesh paths start).
RobotDescription parse_urdf(const std::string& xml, const std::string& source, const UrdfOptions& options = {});

/// Checks that a rotational inertia about the centre of mass is physically consistent: symmetric,
/// positive definite and satisfying the triangle inequality of its principal moments. Returns an
/// empty string when it is, else the reason.
std::string check_inertia(const Matrix3d& I_c);

/// The physically consistent inertia nearest to `I_c` (about the centre of mass) when `I_c` is only
/// slightly inconsistent: non-positive principal moments (within 0.1 % of the largest, or all zero:
/// a point mass) are raised to a radius of gyration of 2 mm, and a triangle-inequality deficit d of
/// at most 10 % of the largest moment is closed by the smallest change in the Frobenius norm (the
/// two smaller moments + d/3, the largest − d/3). `what` says what was changed (empty: nothing);
/// `error` is set instead when the inertia is too far from a physical one to repair.
struct InertiaRepair {
  Matrix3d I_c = Matrix3d::Zero();
  std::string what;
  std::string error;
};
InertiaRepair regularise_inertia(double mass, const Matrix3d& I_c);

}  // namespace hpr::model
