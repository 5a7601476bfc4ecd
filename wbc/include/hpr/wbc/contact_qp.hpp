#pragma once
/// \file
/// Contact wrench distribution (section II-B): find the contact wrenches w_grf of the feet in
/// contact whose CoM-mapped sum Adᵀ w_grf is the desired CoM wrench, subject to, per foot in its
/// sole frame: f_z ≥ f_min (unilaterality), f_z ≤ load · f_max, an 8-facet friction pyramid
/// |f_t| ≤ μ f_z, the CoP inside the sole (less a margin), |τ_z| ≤ γ f_z (bounded torsion), and
/// with `sole_torsion` the torsion that four corner contacts in the pyramid |f_x|, |f_y| ≤ μ/√2 f_z
/// hold with the CoP where it is (none beyond the corner force's own at a corner, about which a
/// sole on its corner turns).
///
/// When the desired wrench is feasible it is met exactly (equality constraints), and among the
/// distributions that meet it the one of least ½ wᵀ R w is chosen. When it is not, the error is
/// minimised instead, under the same contact constraints:
///   min ½ ‖Adᵀ w − w_des‖²_W + ½ ε wᵀ R w + Σ_feet ½ (ρ_t (f_x² + f_y²) + ρ_z τ_z²)
/// with (f_x, f_y) the force along the ground and τ_z the torsion about its normal (world axes: the
/// ground is level), the last sum with both feet on the ground only. Internal forces (equal and
/// opposite along the ground) and opposite torsions change Adᵀ w by nothing, or only through the
/// soles' tilt and height; without ρ_t, ρ_z the least-squares optimum spends them at the friction
/// and torsion limits to gain a fraction of a newton metre (a sole tilted 1° on its heel lends its
/// normal a newton per 57 N of sideways force), and the feet turn on the ground.
///
/// Wrenches are (f, τ) at the sole centre in world axes. Both QPs are hot-started from tick to tick.

#include <array>
#include <memory>

#include "hpr/model/spatial.hpp"
#include "hpr/qp/qp_solver.hpp"

namespace hpr::wbc {

struct ContactParams {
  double friction = 0.6;          ///< μ of the linearised Coulomb cone
  double torsion = 0.02;          ///< γ [m]: |τ_z| ≤ γ f_z
  bool sole_torsion = false;      ///< also the torsion four corner contacts hold with the CoP where it is
  double min_normal_force = 20;   ///< f_min [N]
  double max_normal_force = 1500; ///< f_max [N]
  double cop_margin = 0.005;      ///< the CoP stays this far inside the sole edges [m]
  double force_weight = 1.0;      ///< W for the force part of the CoM wrench error
  double torque_weight = 10.0;    ///< W for the torque part
  double regularization = 1e-4;   ///< ε of the least-squares fallback
  double distribution_force = 1e-3;  ///< R for the forces (distribution among the feet)
  double distribution_torque = 1.0;  ///< R for the torques (keeps the CoPs central)
  double tangential_weight = 0.01;   ///< ρ_t of the least-squares fallback: horizontal forces [per N², against W]
  double torsion_weight = 0.1;       ///< ρ_z of the least-squares fallback: torsions about z [per (N m)², against W]
  int max_working_set_changes = 10;  ///< per tick for the exact QP; the fallback gets three times as many
};

struct Contact {
  bool active = false;
  model::SE3 X_WS;           ///< sole frame (z along the sole normal)
  double length = 0.2, width = 0.1;
  double load_limit = 1.0;   ///< fraction of f_max
};

class ContactQp {
 public:
  explicit ContactQp(ContactParams params);
  /// Distributes `w_des` (CoM wrench, world axes about the CoM `com`) over the active contacts.
  /// Returns the solver status; the wrenches of inactive feet are zero.
  qp::Status solve(const std::array<Contact, 2>& contacts, const Eigen::Vector3d& com, const model::Vector6d& w_des);

  [[nodiscard]] const std::array<model::Vector6d, 2>& wrenches() const { return w_; }
  /// Adᵀ w of the returned wrenches.
  [[nodiscard]] const model::Vector6d& achieved() const { return achieved_; }
  [[nodiscard]] int iterations() const { return iterations_; }
  [[nodiscard]] double solve_time_us() const { return solve_time_us_; }
  /// True when the desired wrench was met exactly (the equality QP was feasible).
  [[nodiscard]] bool exact() const { return exact_; }
  /// True when wrenches() holds a feasible distribution from this solve.
  [[nodiscard]] bool valid() const { return valid_; }
  [[nodiscard]] const ContactParams& params() const { return params_; }
  /// μ of the friction cone, from the next solve.
  void set_friction(double mu) { params_.friction = mu; }

  /// The constraint rows of one foot (rows_per_foot(p) of them) in the form lb ≤ C w_i ≤ ub
  /// (world-axes wrench at the sole).
  static void foot_constraints(const Contact& c, const ContactParams& p, Eigen::Ref<Eigen::MatrixXd> C,
                               Eigen::Ref<Eigen::VectorXd> lb, Eigen::Ref<Eigen::VectorXd> ub);
  static constexpr int kBaseRowsPerFoot = 16;  ///< friction, CoP, torsion γ, normal force
  static constexpr int kMaxRowsPerFoot = 24;   ///< and the sole's torsion (ContactParams::sole_torsion)
  static int rows_per_foot(const ContactParams& p) { return p.sole_torsion ? kMaxRowsPerFoot : kBaseRowsPerFoot; }

 private:
  qp::Status solve_mode(bool exact, int na, const int* active, const std::array<Contact, 2>& contacts,
                        const Eigen::Vector3d& com, const model::Vector6d& w_des);

  ContactParams params_;
  // [exact][contacts - 1]
  std::array<std::array<std::unique_ptr<qp::Solver>, 2>, 2> solvers_;
  std::array<int, 2> last_single_foot_{-1, -1};
  bool exact_ = false, valid_ = false;
  Eigen::MatrixXd H_, A_;
  Eigen::VectorXd g_, lb_, ub_, lbA_, ubA_;
  std::array<model::Vector6d, 2> w_{};
  model::Vector6d achieved_ = model::Vector6d::Zero();
  int iterations_ = 0;
  double solve_time_us_ = 0;
};

}  // namespace hpr::wbc
