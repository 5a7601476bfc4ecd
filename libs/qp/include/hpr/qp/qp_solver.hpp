#pragma once
/// \file
/// Dense convex QP solver with hot start, after the style of qpOASES:
///
///     minimise ½ xᵀ H x + gᵀ x   subject to   lb ≤ x ≤ ub,   lbA ≤ A x ≤ ubA,
///
/// H symmetric positive definite; equalities as lbA = ubA (or lb = ub); infinite bounds allowed.
///
/// Method: an active-set method in the range-space form of Goldfarb and Idnani (1983). H = L Lᵀ and
/// the working-set normals N are kept as J = L⁻ᵀ Q, Jᵀ N = [R; 0] and updated by Givens rotations
/// when a constraint enters or leaves the working set (O(n²) each). Two phases share this
/// factorisation:
///  - dual phase (Goldfarb-Idnani): from a dual-feasible point, add violated constraints until the
///    iterate is feasible; it detects infeasibility and needs no feasible starting point;
///  - primal phase: from a feasible point, drop constraints with negative multipliers and add
///    blocking ones; every iterate stays feasible.
/// A hot start rebuilds the factorisation for the previous working set on the new data and starts
/// from the solution of that working set: when it is feasible and dual feasible the solve is done
/// with no working-set change; otherwise the matching phase continues from there.
///
/// Every outcome has a status. When the cap on working-set changes is reached, the best feasible
/// point seen (lowest objective) is returned with kIterationLimit; if none was feasible, the last
/// iterate is returned, flagged by primal_feasible() == false. The KKT residuals of the returned point
/// are always available. No allocation happens in a solve once the solver is constructed.

#include <Eigen/Core>
#include <cstdint>
#include <string_view>
#include <vector>

namespace hpr::qp {

enum class Status : int {
  kOptimal = 0,              ///< KKT point within tolerances
  kIterationLimit = 1,       ///< working-set change cap reached; see primal_feasible()
  kInfeasible = 2,           ///< the constraints admit no point
  kInvalidDimensions = 3,    ///< input sizes differ from the solver's
  kNonFinite = 4,            ///< NaN or Inf in H, g, A, or NaN in a bound
  kInconsistentBounds = 5,   ///< a lower bound above its upper bound
  kNotPositiveDefinite = 6,  ///< H is not symmetric positive definite
  kNumericalFailure = 7,     ///< the factorisation broke down
};

/// Human-readable name of a status.
std::string_view to_string(Status s);
/// True for kOptimal and for kIterationLimit with a feasible point.
inline bool usable(Status s) { return s == Status::kOptimal || s == Status::kIterationLimit; }

/// State of one bound or constraint in the working set.
enum class Active : std::int8_t { kInactive = 0, kLower = 1, kUpper = -1, kEquality = 2 };

struct Options {
  int max_working_set_changes = 1000;  ///< cap per solve (the paper's controller uses 10 per tick)
  double primal_tolerance = 1e-10;     ///< feasibility tolerance, relative to 1 + |bound|
  double dual_tolerance = 1e-12;       ///< multiplier sign tolerance (relative to the gradient scale)
  double dependency_tolerance = 1e-12; ///< linear dependence of a normal on the working set
};

struct KktResiduals {
  double stationarity = 0;     ///< ‖H x + g − y_bᵀ − Aᵀ y_A‖∞
  double primal = 0;           ///< largest bound or constraint violation
  double dual = 0;             ///< largest multiplier of the wrong sign
  double complementarity = 0;  ///< largest |y_i| × slack_i
  [[nodiscard]] double max() const;
};

class Solver {
 public:
  /// A solver for n variables and m general constraints (m may be 0).
  Solver(int n, int m, Options options = {});

  using Matrix = Eigen::MatrixXd;
  using Vector = Eigen::VectorXd;
  using ConstMatrix = Eigen::Ref<const Matrix>;
  using ConstVector = Eigen::Ref<const Vector>;

  /// Solves from scratch (empty working set).
  Status solve_cold(const ConstMatrix& H, const ConstVector& g, const ConstMatrix& A, const ConstVector& lb,
                    const ConstVector& ub, const ConstVector& lbA, const ConstVector& ubA);
  /// Solves starting from the working set of the previous successful solve (cold if none).
  Status solve_hot(const ConstMatrix& H, const ConstVector& g, const ConstMatrix& A, const ConstVector& lb,
                   const ConstVector& ub, const ConstVector& lbA, const ConstVector& ubA);
  /// Forgets the working set (the next solve_hot starts cold).
  void reset();

  [[nodiscard]] int num_variables() const { return n_; }
  [[nodiscard]] int num_constraints() const { return m_; }
  [[nodiscard]] Status status() const { return status_; }
  /// Primal solution (or best iterate, see Status).
  [[nodiscard]] const Vector& x() const { return x_; }
  /// Multipliers: positive at an active lower bound, negative at an active upper bound, so that
  /// H x + g = y_bounds + Aᵀ y_constraints at a KKT point.
  [[nodiscard]] const Vector& y_bounds() const { return y_bounds_; }
  [[nodiscard]] const Vector& y_constraints() const { return y_constraints_; }
  [[nodiscard]] double objective() const;
  /// Working-set changes (additions and removals) in the last solve.
  [[nodiscard]] int working_set_changes() const { return changes_; }
  [[nodiscard]] bool primal_feasible() const { return primal_feasible_; }
  /// KKT residuals of the returned point (computed on first request after a solve).
  [[nodiscard]] const KktResiduals& kkt() const;
  /// Working set of the returned point, per bound and per constraint.
  [[nodiscard]] const std::vector<Active>& active_bounds() const { return bound_state_; }
  [[nodiscard]] const std::vector<Active>& active_constraints() const { return constraint_state_; }
  [[nodiscard]] const Options& options() const { return options_; }
  Options& options() { return options_; }

 private:
  struct Entry {
    int c;        // constraint id: [0, n) bound, [n, n + m) general row
    double sign;  // +1: lower side active (n·x >= l), -1: upper side (−n·x >= −u)
    bool equality;
  };
  enum class Phase { kDual, kPrimal };

  Status solve(bool hot, const ConstMatrix& H, const ConstVector& g, const ConstMatrix& A, const ConstVector& lb,
               const ConstVector& ub, const ConstVector& lbA, const ConstVector& ubA);
  Status validate(const ConstMatrix& H, const ConstVector& g, const ConstMatrix& A, const ConstVector& lb,
                  const ConstVector& ub, const ConstVector& lbA, const ConstVector& ubA) const;
  // The steps of solve (active_set.cpp), in order.
  Status take_data(const ConstMatrix& H, const ConstVector& g, const ConstMatrix& A, const ConstVector& lb, const ConstVector& ub,
                   const ConstVector& lbA, const ConstVector& ubA);  // copies; kNonFinite, kNotPositiveDefinite (asymmetric)
  bool hot_start_fast_path();             // true: the previous working set (or one change of it) is optimal
  bool start_working_set(bool hot);       // factorisation, equalities, the previous working set; false: H not PD
  Status iterate();                       // the dual or primal phase from there
  int most_negative_multiplier() const;   // of an inequality in the working set, beyond the tolerance; -1: none
  bool factorize();
  // Working-set algebra.
  void normal_times_J(int c, double sign);     // d_ = Jᵀ (sign N_c)
  bool add_to_factorization(const Entry& e);   // false if dependent
  void drop_from_factorization(int k);
  double lower(int c) const;
  double upper(int c) const;
  double rhs(const Entry& e) const { return e.sign * (e.sign > 0 ? lower(e.c) : upper(e.c)); }
  double value(int c) const;                   // N_c x (uses Ax_ for rows)
  void solve_working_set();                    // x_ and u_ from the EQP of the working set
  void compute_multipliers();                  // u_ = R⁻¹ J1ᵀ (H x + g)
  void update_constraint_values();
  int most_violated(double* slack, double* sign);
  bool is_feasible() const;
  double evaluate_objective(const Vector& x) const;
  // Fast path: the EQP of working set W by a Schur complement, accepted only at a KKT point. If
  // not, what one working-set change would do next: add the most violated constraint (`add`) or
  // drop the most negative multiplier (`drop`, an index into W); kFailed when neither applies.
  enum class FastPath { kOptimal, kAdd, kDrop, kFailed };
  FastPath try_working_set(const std::vector<Entry>& W, Entry* add, int* drop);
  // Its steps (hot_start.cpp), in order.
  bool load_working_set(const std::vector<Entry>& W, bool* any_bound);  // states, free_, rows_; false: not applicable
  void reduce_to_free(bool any_bound);                                  // Hf_ = H_FF, gf_ = g_F + H_FB x_B
  bool factor_free_hessian();                                           // Hf_ <- L (lower), rinv_ = 1 / L_jj
  void lsolve_free(double* v) const;                                    // v <- L⁻¹ v
  void ltsolve_free(double* v) const;                                   // v <- L⁻ᵀ v
  bool solve_rows(bool any_bound);                                      // x_F with the rows of W (Schur complement)
  FastPath multipliers(bool any_bound, int* drop);                      // kDrop: the most negative multiplier
  Status run_dual();
  Status run_primal();
  void finish(Status s);
  void consider_candidate();

  int n_, m_;
  Options options_;
  // Problem data (copies, so that a hot start can compare and the caller may reuse buffers).
  Matrix H_, A_;
  Vector g_, lb_, ub_, lbA_, ubA_;
  Vector row_norm_;
  bool row_norms_current_ = false;
  // Factorisation.
  Matrix L_, J_, J0_, R_;  // J0_ = L⁻ᵀ, kept while H is unchanged
  bool H_factorized_ = false;
  // Working set and iterates.
  std::vector<Entry> active_, previous_active_;
  std::vector<Active> bound_state_, constraint_state_;
  Vector x_, u_, Ax_, d_, z_, r_, grad_, tmp_, b_w_, best_x_, prev_x_;
  Vector y_bounds_, y_constraints_;
  // Fast-path workspace (reduced Hessian, Schur complement).
  Matrix Hf_, Nf_, Y_, S_;
  Vector gf_, xf_, xb_, rhs_, uf_, rinv_;
  std::vector<int> free_, rows_;
  std::vector<int> row_entry_, bound_entry_;  // index in W of each row in rows_ / of each bound
  std::vector<Entry> trial_;                  // the fast path's working set while it retries
  double best_obj_ = 0;
  bool have_best_ = false, have_previous_ = false;
  int changes_ = 0;
  Status status_ = Status::kOptimal;
  bool primal_feasible_ = false;
  mutable double objective_ = 0;
  mutable KktResiduals kkt_;
  mutable bool kkt_current_ = false, objective_current_ = false;
};

}  // namespace hpr::qp
