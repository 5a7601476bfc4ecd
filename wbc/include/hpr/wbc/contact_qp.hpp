#pragma once
/// \file
/// Contact wrench distribution (section II-B): find the contact wrenches w_grf of the feet in
/// contact whose CoM-mapped sum Adᵀ w_grf best matches the desired CoM wrench,
///
///     min ½ ‖Adᵀ w − w_des‖²_W + ½ ε ‖w‖²
///     s.t. per foot, in its sole frame: f_z ≥ f_min (unilaterality), f_z ≤ load · f_max,
///          an 8-facet friction pyramid |f_t| ≤ μ f_z, the CoP inside the sole (less a margin),
///          |τ_z| ≤ γ f_z (bounded torsion).
///
/// Wrenches are (f, τ) at the sole centre in world axes. The QP is hot-started from tick to tick.

#include <array>

#include "hpr/model/spatial.hpp"
#include "hpr/qp/qp_solver.hpp"

namespace hpr::wbc {

struct ContactParams {
  double friction = 0.6;          ///< μ of the linearised Coulomb cone
  double torsion = 0.02;          ///< γ [m]: |τ_z| ≤ γ f_z
  double min_normal_force = 20;   ///< f_min [N]
  double max_normal_force = 1500; ///< f_max [N]
  double cop_margin = 0.005;      ///< the CoP stays this far inside the sole edges [m]
  double force_weight = 1.0;      ///< W for the force part of the CoM wrench error
  double torque_weight = 10.0;    ///< W for the torque part
  double regularization = 1e-4;   ///< ε
  int max_working_set_changes = 10;
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
  [[nodiscard]] const qp::Solver& solver(int contacts) const { return contacts == 2 ? double_ : single_; }
  [[nodiscard]] const ContactParams& params() const { return params_; }

  /// The 16 constraint rows of one foot in the form lb ≤ C w_i ≤ ub (world-axes wrench at the sole).
  static void foot_constraints(const Contact& c, const ContactParams& p, Eigen::Ref<Eigen::MatrixXd> C,
                               Eigen::Ref<Eigen::VectorXd> lb, Eigen::Ref<Eigen::VectorXd> ub);
  static constexpr int kRowsPerFoot = 16;

 private:
  ContactParams params_;
  qp::Solver double_, single_;
  int last_single_foot_ = -1;
  Eigen::MatrixXd H_, A_;
  Eigen::VectorXd g_, lb_, ub_, lbA_, ubA_;
  std::array<model::Vector6d, 2> w_{};
  model::Vector6d achieved_ = model::Vector6d::Zero();
  int iterations_ = 0;
  double solve_time_us_ = 0;
};

}  // namespace hpr::wbc
