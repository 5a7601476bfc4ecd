#pragma once
/// \file
/// The kinematic tree (Model, constant) and its workspace (Data), after Pinocchio's split.
///
/// The root link carries a 6-DoF floating base. Fixed joints are merged into their parent body;
/// every other body has one revolute or prismatic joint, so joint j (0-based, in tree order) moves
/// body j + 1 and sits at q[7 + j] and v[6 + j].
///
/// Coordinates:
///   q = (p_WB, quat_WB as (x, y, z, w), joint positions)           nq = 7 + n
///   v = (v_B, ω_B, joint velocities), base twist in the base frame  nv = 6 + n

#include <map>
#include <string>
#include <vector>

#include "hpr/model/spatial.hpp"
#include "hpr/model/urdf.hpp"

namespace hpr::model {

enum class JointKind { kFreeFlyer, kRevolute, kPrismatic };

/// A frame rigidly attached to a body (every URDF link is one; more can be added).
struct Frame {
  std::string name;
  int body = 0;   ///< index of the body it is attached to
  SE3 X_BF;       ///< placement in the body frame
};

/// How a description becomes a Model.
struct ModelOptions {
  std::string base_link;                 ///< floating base (empty: the URDF root, or the child of a floating joint at it)
  /// Joints removed from the model as fixed joints at the given position [rad or m] (Pinocchio's
  /// reduced model): fingers, head, grippers that the balance controller does not use.
  std::map<std::string, double> held;
  /// Positions at which free leaders lock their `<mimic>` followers (default 0): a simulator's model
  /// keeps the held joints free but locks their followers where the controllers' model has them.
  std::map<std::string, double> leader_positions;
  /// Use the links' physically consistent inertias (a simulator's model); otherwise the file's, except
  /// for a body that would not be positive definite without the repair.
  bool physical_inertia = false;
};

/// Empty when joint `name` of `description` can be held at `q` (it moves, is no <mimic> follower,
/// `q` is within its limits), else the reason.
std::string check_held_joint(const RobotDescription& description, const std::string& name, double q);

class Model {
 public:
  /// Builds the tree from a validated description, the floating base at `base_link` (default: the
  /// URDF root, or the child of a floating joint at the root). Throws ModelError for a moving body
  /// without inertia.
  static Model build(const RobotDescription& description, const std::string& base_link = "");
  /// Same with held joints and the choice of inertias. A `<mimic>` joint is locked at the position it
  /// takes when its leader is at zero (or at its held position), and said so in `warnings`.
  static Model build(const RobotDescription& description, const ModelOptions& options);
  static Model from_urdf(const std::string& path, const std::string& base_link = "");

  int nq = 7, nv = 6;     ///< configuration and velocity sizes
  int nj = 0;             ///< actuated joints
  int nb = 1;             ///< bodies (base included)

  // Per body (index 0: the base).
  std::vector<std::string> body_name;    ///< URDF link that defines the body
  std::vector<int> parent;               ///< parent body, -1 for the base
  std::vector<JointKind> kind;
  std::vector<SE3> X_PJ;                 ///< joint frame in the parent body frame
  std::vector<Vector3d> axis;            ///< unit joint axis in the joint (= body) frame
  std::vector<Inertia> inertia;          ///< body inertia in the body frame (merged links included)
  std::vector<std::vector<int>> support; ///< per body: the joints (0-based) from the base to it
  std::vector<int> subtree_size;         ///< per body: bodies in its subtree (itself included)
  // Precomputed for the kinematics: axis code (±1, ±2, ±3 for ±x, ±y, ±z, 0 otherwise), whether the
  // joint placement rotates, and each body's centre of mass and inertia about it (body frame).
  std::vector<int> axis_code;
  std::vector<char> placement_rotates;
  std::vector<Vector3d> com_body;
  std::vector<Matrix3d> inertia_com_body;

  // Per actuated joint.
  std::vector<std::string> joint_name;
  std::vector<double> q_lower, q_upper;  ///< position limits (±inf for continuous joints)
  std::vector<double> v_max, tau_max;    ///< velocity and effort limits (inf when absent)
  std::vector<double> damping, friction; ///< from <dynamics>

  // Joints of the description that are not joints of the model: held (configured; a simulator and
  // the hal hold them) and locked (<mimic>; fixed everywhere).
  std::vector<std::string> held_joint_name;
  std::vector<double> held_q;            ///< their positions [rad or m]
  std::vector<std::string> locked_joint_name;
  std::vector<double> locked_q;
  std::vector<std::string> warnings;     ///< what the build decided that a user should know (one line each)

  std::vector<Frame> frames;
  Vector3d gravity{0.0, 0.0, -9.81};     ///< g_0 [m/s^2], world frame
  double mass = 0.0;                     ///< total mass m [kg]
  std::string source;                    ///< URDF it came from

  /// Index lookups; each throws ModelError naming what is missing.
  [[nodiscard]] int joint_index(const std::string& name) const;
  [[nodiscard]] int body_index(const std::string& name) const;
  [[nodiscard]] int frame_index(const std::string& name) const;
  [[nodiscard]] bool has_frame(const std::string& name) const;
  /// Replaces a body's inertia and what is derived from it (its centre of mass and inertia about
  /// it, the total mass): e.g. a simulated robot that differs from the description.
  void set_inertia(int body, const Inertia& I);
  /// Adds a frame on the body of frame `parent_frame`, at X_PF relative to that frame.
  int add_frame(const std::string& name, const std::string& parent_frame, const SE3& X_PF);

  /// The neutral configuration: base at the origin, identity orientation, joints at zero (or the
  /// middle of their range when zero is outside it).
  [[nodiscard]] Eigen::VectorXd neutral() const;
};

/// Workspace of the algorithms; allocated once for a model, then reused without allocation.
struct Data {
  explicit Data(const Model& model);

  // Kinematics (world frame W; spatial quantities at the world origin).
  std::vector<SE3> oMi;            ///< body placements X_WB_i
  std::vector<SE3> oMf;            ///< frame placements (after update_frame_placements)
  std::vector<Vector6d> S;         ///< joint motion subspace of body i in W (i >= 1)
  Eigen::Matrix<double, 6, 6> S0;  ///< base motion subspace: maps the local base twist to W
  std::vector<Vector6d> vel;       ///< body twists in W
  std::vector<Inertia> Iw;         ///< body inertias in W
  std::vector<Inertia> Yc;         ///< composite (subtree) inertias in W

  // Dynamics.
  Eigen::MatrixXd M;               ///< joint-space inertia (CRBA), symmetric
  Eigen::VectorXd nle;             ///< C(q, v) v + g(q)
  Eigen::VectorXd g;               ///< g(q)
  Eigen::VectorXd tau;             ///< RNEA output
  std::vector<Vector6d> acc, f;    ///< RNEA workspace
  std::vector<Vector6d> F;         ///< CRBA: Yc_i S_i (momentum of the subtree per unit joint rate)

  // Centroidal quantities (world axes, about the CoM).
  double mass = 0.0;
  Vector3d com = Vector3d::Zero();       ///< x_c
  Vector3d vcom = Vector3d::Zero();      ///< ẋ_c
  Matrix6Xd Ag;                          ///< centroidal momentum matrix A_G (6 x nv): linear then angular
  Vector6d hg = Vector6d::Zero();        ///< centroidal momentum A_G v
  Vector6d dAg_v = Vector6d::Zero();     ///< Ȧ_G v
  Matrix3Xd Jcom;                        ///< CoM Jacobian (3 x nv)
  Matrix3d Ic = Matrix3d::Zero();        ///< composite rotational inertia about the CoM (world axes)

  Matrix6Xd J;                           ///< frame Jacobian workspace (6 x nv)

  // Workspace of the paper's coordinates (centroidal.hpp).
  Eigen::VectorXd v_r, a_r;              ///< reference velocity and acceleration in model coordinates
  Eigen::VectorXd y;                     ///< centroidal_inverse_dynamics output (nv)
};

}  // namespace hpr::model
