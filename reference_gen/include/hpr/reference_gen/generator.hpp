#pragma once
/// \file
/// CAM reference generation in three phases (paper section III-C), independently per axis of the
/// virtual stance foot frame V:
///
///  idle      until |τ_v^ankle| exceeds τ^thres = α τ^min/max                          (23)
///  phase 1   l̇_c^ref = τ^thres − τ^ankle, integrated                                  (24)
///            until |τ^ankle| < |τ^thres| again (t₂)
///  phase 2   the cubic l(τ) = Σ a_j τʲ, τ = (t − t₂)/T, from (l(t₂), l̇(t₂)) to (0, 0),  (25)
///            T = 3 |l(t₂)| / (2 l̇^max),  l̇^max = β max|l̇^ref| over phase 1           (26), (27)
///  phase 3   l^ref = 0 while the posture task converges; idle again when the posture
///            error is small
///
/// A new push re-enters phase 1 from any phase, continuing from the current l^ref (no jump).
///
/// The lean budget (a bound the paper does not have, docs/results/paper-configuration.md): what builds l_c^ref is the
/// rotation of the adjusted coordinates (`motion_opt.adjusted`), and the angle they turn through in one
/// episode is ∫ l dt divided by their composite inertia, so their range bounds ∫ l dt. In phase 1
/// the generator predicts the episode's ∫ l dt if phase 2 began now (what was stored, plus
/// T (l₂/2 + l̇₂ T/12), the integral of the cubic (25)) and begins phase 2 when that reaches the
/// budget of l's sign; phase 1 is then not entered again until the axis is idle.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <limits>
#include <string_view>

#include "hpr/balance/ports.hpp"
#include "hpr/common/ports.hpp"
#include "hpr/common/component.hpp"
#include "hpr/common/config.hpp"
#include "hpr/common/parameters.hpp"

namespace hpr::reference_gen {

using Phase = balance::Phase;
using CamReference = balance::CamReference;
/// The generator reads τ_v^ankle, its limits, the yaw of V and the time of a BALANCE_STATUS.
using BalanceInput = balance::BalanceStatus;

struct AxisParams {
  double alpha = 0.9;  ///< α ∈ (0, 1]: activation at this fraction of the contact torque limit (23)
  double beta = 0.4;   ///< β ∈ (0, 1]: reduction rate as a fraction of the peak phase-1 rate (27)
  /// Lean budget: the largest ∫ l^ref dt of one episode for l^ref < 0 and for l^ref > 0 [N m s²]
  /// (keys lean_budget_negative, lean_budget_positive; ∞: the paper's unbounded phase 1).
  double budget_negative = std::numeric_limits<double>::infinity();
  double budget_positive = std::numeric_limits<double>::infinity();
};

struct GeneratorConfig {
  std::array<AxisParams, 3> axes;     ///< x, y, z of the virtual stance foot
  std::array<bool, 3> enabled{true, true, true};
  double posture_tolerance = 0.03;    ///< posture error below which phase 3 ends [rad]
  double min_recover_time = 0.2;      ///< phase 3 lasts at least this long [s]
  double max_recover_time = 5.0;      ///< and at most this long [s]
  double min_rate = 1e-3;             ///< floor of l̇^max [N m]
  double stale_hold_time = 0.02;      ///< BALANCE_STATUS older than this: hold l^ref [s]
  double stale_ramp_time = 0.1;       ///< then, after this much more: ramp to zero [s]
  double stale_ramp_rate = 5.0;       ///< l̇^max for that ramp when phase 1 gave none [N m]
  double dt = 1e-3;                   ///< control period [s]
  /// Reads and validates the `reference_gen` section (α, β per axis or for all; warns outside the
  /// paper's good ranges α ∈ [0.7, 0.9], β ∈ [0.3, 0.5]).
  static GeneratorConfig load(const Config& section);
};

/// One axis of the generator (scalar), stepping at a fixed period.
class AxisGenerator {
 public:
  explicit AxisGenerator(AxisParams p = {}) : params_(p) {}

  /// Advances to time t with the ankle torque and its limits (τ_min < 0 < τ_max) of that time.
  void step(double t, double dt, double tau_ankle, double tau_min, double tau_max, bool posture_converged,
            const GeneratorConfig& cfg);
  /// Starts the phase-2 reduction from the current value at time t (stale input); l̇^max = rate if
  /// phase 1 left none.
  void reduce_now(double t, double rate, const GeneratorConfig& cfg);

  [[nodiscard]] double l() const { return l_; }
  [[nodiscard]] double ldot() const { return ldot_; }
  [[nodiscard]] Phase phase() const { return phase_; }
  [[nodiscard]] double threshold() const { return thres_; }
  [[nodiscard]] double ldot_max() const { return ldot_max_; }
  [[nodiscard]] double peak_rate() const { return peak_rate_; }
  [[nodiscard]] double duration() const { return T_; }
  /// ∫ l^ref dt since the axis left idle [N m s²], and whether it reached the lean budget.
  [[nodiscard]] double stored() const { return stored_; }
  [[nodiscard]] bool budget_spent() const { return spent_; }
  /// The phase-2 cubic (25) and its rate at time t (for analysis; valid once phase 2 began).
  [[nodiscard]] Eigen::Vector2d cubic(double t) const;
  [[nodiscard]] double t2() const { return t2_; }
  /// Start time of phases 1..3 (index 0..2), -1 when not reached since the last idle.
  [[nodiscard]] const std::array<double, 3>& phase_start() const { return t_start_; }
  AxisParams& params() { return params_; }
  [[nodiscard]] const AxisParams& params() const { return params_; }

 private:
  void begin_reduction(double t, const GeneratorConfig& cfg);
  /// l̇^max of the reduction, β times the episode's peak phase-1 rate (27).
  [[nodiscard]] double reduction_rate(const GeneratorConfig& cfg) const;
  /// ∫ l dt of the episode if phase 2 began now, from the current l, l̇ and peak rate.
  [[nodiscard]] double predicted_integral(const GeneratorConfig& cfg) const;

  AxisParams params_;
  Phase phase_ = Phase::kIdle;
  double l_ = 0, ldot_ = 0, thres_ = 0, peak_rate_ = 0, ldot_max_ = 0, T_ = 0;
  std::array<double, 4> a_{};  // cubic coefficients (25)
  double t2_ = 0;
  double stored_ = 0;   // ∫ l dt since idle
  bool spent_ = false;  // the lean budget ended phase 1
  std::array<double, 3> t_start_{-1, -1, -1};
};

class ReferenceGenerator {
 public:
  explicit ReferenceGenerator(GeneratorConfig config);

  /// The component's tick (hpr/common/component.hpp): CAM_REFERENCE of tick k from ROBOT_STATE k
  /// (its tick and time), the BALANCE_STATUS of tick k−1 (the paper's one-period lag between the
  /// torque computation and the reference update) and the posture error of the last
  /// WHOLEBODY_COMMAND. Fault "balance": BALANCE_STATUS stale (the reference held, then ramped to
  /// zero) after the first two ticks.
  static constexpr std::array<std::string_view, 1> kFaultKeys{"balance"};
  /// The reference_gen process's ports.
  static constexpr Read kReads[] = {
      {channel::kRobotState, 0, true, false, "tick and time"},
      {channel::kBalanceStatus, -1, false, true, "the ankle torque and its limits (the paper's one-period lag)"},
      {channel::kWholebodyCommand, -1, false, true, "the posture error that ends phase 3"}};
  static constexpr std::string_view kWrites[] = {channel::kCamReference};
  static constexpr Ports kPorts{"reference_gen", kReads, kWrites};
  struct Inputs {
    std::int64_t tick = 0;
    double time = 0.0;                              ///< [s]
    OptionalRef<balance::BalanceStatus> balance;    ///< latest BALANCE_STATUS; empty before the first
    double posture_error = 0.0;                     ///< [rad]
  };
  struct Outputs {
    CamReference reference;  ///< CAM_REFERENCE of tick k
    StepReport report{kFaultKeys};
  };
  /// One tick of the configured period (no allocation).
  void step(const Inputs& in, Outputs& out);

  /// One tick at time t. `balance` is the latest BALANCE_STATUS (its time says how old it is);
  /// `posture_error` the motion optimisation's distance to the reference posture.
  const CamReference& step(double t, double dt, const BalanceInput& balance, bool balance_valid, double posture_error);
  /// Back to the state after construction (every axis in its first phase), keeping the parameters:
  /// for a clock that restarted.
  void reset();

  [[nodiscard]] const CamReference& output() const { return out_; }
  [[nodiscard]] const AxisGenerator& axis(int i) const { return axes_[static_cast<size_t>(i)]; }
  [[nodiscard]] const GeneratorConfig& config() const { return config_; }
  /// Changes α, β of one axis while running: α acts from the next step, β from the next phase 2.
  void set_axis_params(int i, AxisParams p);
  /// The phase-3 posture tolerance [rad], from the next step.
  void set_posture_tolerance(double tolerance) { config_.posture_tolerance = tolerance; }

 private:
  GeneratorConfig config_;
  std::array<AxisGenerator, 3> axes_;
  CamReference out_;
  bool ramping_ = false;
};

/// Registers the live-tunable parameters (alpha and beta (all axes, or x./y./z. each) and posture_tolerance) under the keys of the
/// configuration section, with the ranges its loader accepts; the process that runs the component
/// (its own node, or the composed controllers) answers OPERATOR sets with them.
void add_parameters(ParameterSet& params, ReferenceGenerator& gen);

}  // namespace hpr::reference_gen
