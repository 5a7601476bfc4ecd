#pragma once
/// \file
/// The horizontal external force on a standing robot, by a momentum observer: no differentiation
/// of a measured velocity, a first-order estimate of m c̈ − Σ f_ground with time constant τ,
///
///   F̂(t) = (m ċ(t) − m ċ(t₀) − ∫_{t₀}^{t} (Σ f_ground + F̂) dt) / τ,
///
/// so that under a constant external force F it follows F̂ → F as 1 − e^{−t/τ} (in discrete time:
/// F̂_k = F (1 − (1 − Δt/τ)^k) for steps Δt from rest). It also keeps the force the controller
/// compensates (F̂ low-passed and clamped: balance.push_compensation) and when a push began (|F̂|
/// above an onset). It restarts on a gap in time and on a non-finite estimate.

#include <Eigen/Core>

namespace hpr::balance {

class ExternalForceObserver {
 public:
  struct Config {
    double mass = 1.0;                ///< m [kg]
    double time_constant = 0.04;      ///< τ [s] (balance.stepping.force_filter)
    double push_onset = 10.0;         ///< [N] |F̂| above which a push counts as under way
    bool compensate = false;          ///< keep the compensated force (balance.push_compensation.enabled)
    double compensation_filter = 0.1;  ///< [s] its low-pass time constant
    double max_force = 150.0;         ///< [N] its largest magnitude
  };
  /// Longest step between two updates [s]: a longer gap restarts the observer.
  static constexpr double kMaxGap = 0.1;

  explicit ExternalForceObserver(const Config& config) : config_(config) {}

  /// One update at time t with the CoM velocity ċ (horizontal, world) [m/s] and the sum of the
  /// horizontal ground forces on the feet in contact [N]. The first update after a start, a gap
  /// or a non-finite estimate only starts the integration (F̂ = 0).
  void update(double t, const Eigen::Vector2d& v_com, const Eigen::Vector2d& f_ground);
  /// Starts again at the next update, as new: F̂, the compensated force and the push's start
  /// forgotten (a clock that restarted). A gap in the updates restarts the estimate only: the
  /// compensated force then decays through its low-pass.
  void restart();

  /// F̂ [N], world.
  [[nodiscard]] const Eigen::Vector2d& force() const { return f_ext_; }
  /// F̂ low-passed and clamped to max_force [N] (zero unless compensate).
  [[nodiscard]] const Eigen::Vector2d& compensated() const { return f_comp_; }
  /// When |F̂| last rose above push_onset [s]; < 0 while it is below.
  [[nodiscard]] double push_start() const { return push_start_; }

 private:
  Config config_;
  Eigen::Vector2d f_ext_ = Eigen::Vector2d::Zero();
  Eigen::Vector2d f_comp_ = Eigen::Vector2d::Zero();
  Eigen::Vector2d v_prev_ = Eigen::Vector2d::Zero();            ///< ċ(t₀)
  Eigen::Vector2d momentum_integral_ = Eigen::Vector2d::Zero();  ///< ∫ (Σ f_ground + F̂) dt [N s]
  double t_prev_ = -1.0;
  double push_start_ = -1.0;
};

}  // namespace hpr::balance
