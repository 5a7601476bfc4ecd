#include "hpr/reference_gen/generator.hpp"

#include <algorithm>
#include <cmath>

#include "hpr/common/log.hpp"

namespace hpr::reference_gen {

GeneratorConfig GeneratorConfig::load(const Config& c) {
  GeneratorConfig g;
  const char* names[3] = {"x", "y", "z"};
  double alpha = c.real_or("alpha", 0.9, 0.0, 1.0);
  double beta = c.real_or("beta", 0.4, 1e-3, 1.0);
  if (c.has("alpha") && !(alpha > 0)) c.fail("alpha", "must be positive");
  for (int i = 0; i < 3; ++i) {
    AxisParams& a = g.axes[static_cast<size_t>(i)];
    a.alpha = alpha;
    a.beta = beta;
    if (c.has(names[i])) {
      const Config ax = c.section(names[i]);
      a.alpha = ax.real_or("alpha", alpha, 1e-3, 1.0);
      a.beta = ax.real_or("beta", beta, 1e-3, 1.0);
      a.budget_negative = ax.real_or("lean_budget_negative", a.budget_negative, 1e-6);  // [N m s²], .inf: none
      a.budget_positive = ax.real_or("lean_budget_positive", a.budget_positive, 1e-6);
      g.enabled[static_cast<size_t>(i)] = ax.boolean_or("enabled", true);
    }
    if (a.alpha < 0.7 || a.alpha > 0.9) {
      log::warn("reference_gen: axis {} alpha {} is outside the paper's good range [0.7, 0.9]", names[i], a.alpha);
    }
    if (a.beta < 0.3 || a.beta > 0.5) {
      log::warn("reference_gen: axis {} beta {} is outside the paper's good range [0.3, 0.5]", names[i], a.beta);
    }
  }
  g.posture_tolerance = c.real_or("posture_tolerance", g.posture_tolerance, 1e-4, 1.0);
  g.min_recover_time = c.real_or("min_recover_time", g.min_recover_time, 0.0, 60.0);
  g.max_recover_time = c.real_or("max_recover_time", g.max_recover_time, 0.0, 600.0);
  g.min_rate = c.real_or("min_rate", g.min_rate, 1e-9, 1e3);
  g.stale_hold_time = c.real_or("stale_hold_time", g.stale_hold_time, 1e-3, 10.0);
  g.stale_ramp_time = c.real_or("stale_ramp_time", g.stale_ramp_time, 0.0, 10.0);
  g.stale_ramp_rate = c.real_or("stale_ramp_rate", g.stale_ramp_rate, 1e-3, 1e3);
  g.dt = c.real_or("dt", g.dt, 1e-5, 0.1);
  return g;
}

void AxisGenerator::begin_reduction(double t, const GeneratorConfig& cfg) {
  phase_ = Phase::kReduce;
  t2_ = t;
  t_start_[1] = t;
  ldot_max_ = reduction_rate(cfg);
  T_ = 3.0 * std::abs(l_) / (2.0 * ldot_max_);  // (26)
  if (T_ <= 0.0) {
    phase_ = Phase::kRecover;
    t_start_[2] = t;
    l_ = ldot_ = 0;
    return;
  }
  // (25) with l(0) = l₂, l̇(0) = l̇₂, l(1) = 0, l̇(1) = 0 in τ = (t − t₂)/T.
  a_[0] = l_;
  a_[1] = ldot_ * T_;
  a_[2] = -3.0 * a_[0] - 2.0 * a_[1];
  a_[3] = 2.0 * a_[0] + a_[1];
}

double AxisGenerator::reduction_rate(const GeneratorConfig& cfg) const {
  return std::max(params_.beta * peak_rate_, cfg.min_rate);  // (27)
}

double AxisGenerator::predicted_integral(const GeneratorConfig& cfg) const {
  const double T = 3.0 * std::abs(l_) / (2.0 * reduction_rate(cfg));  // (26)
  // ∫₀¹ Σ a_j τʲ T dτ of (25) = T (a₀ + a₁/2 + a₂/3 + a₃/4) = T (l₂/2 + l̇₂ T/12)
  return stored_ + T * (l_ / 2.0 + ldot_ * T / 12.0);
}

Eigen::Vector2d AxisGenerator::cubic(double t) const {
  const double tau = (t - t2_) / T_;
  return {a_[0] + tau * (a_[1] + tau * (a_[2] + tau * a_[3])), (a_[1] + tau * (2 * a_[2] + tau * 3 * a_[3])) / T_};
}

void AxisGenerator::reduce_now(double t, double rate, const GeneratorConfig& cfg) {
  if (phase_ == Phase::kReduce || l_ == 0.0) return;
  if (peak_rate_ <= 0.0) peak_rate_ = rate / std::max(params_.beta, 1e-6);
  begin_reduction(t, cfg);
}

void AxisGenerator::step(double t, double dt, double tau_ankle, double tau_min, double tau_max, bool posture_converged,
                         const GeneratorConfig& cfg) {
  // (23): the threshold on the side the ankle torque is on.
  const double lim = tau_ankle >= 0 ? tau_max : tau_min;
  thres_ = params_.alpha * lim;
  const bool exceeded = tau_ankle >= 0 ? tau_ankle > thres_ : tau_ankle < thres_;
  // A spent lean budget keeps phase 1 shut until the posture is back (idle).
  if (exceeded && phase_ != Phase::kGenerate && !spent_) {
    // A push: phase 1 from whatever phase, continuing from the current l^ref. Entered again during
    // the reduction, it continues the same momentum: the peak rate of (27) stays that of the whole
    // episode, so that a brief re-entry with small rates does not stretch the reduction of a large
    // l^ref over tens of seconds (T = 3 |l| / (2 β max |l̇|), (26)).
    if (phase_ != Phase::kReduce) peak_rate_ = 0.0;
    phase_ = Phase::kGenerate;
    t_start_ = {t, -1, -1};
  }
  switch (phase_) {
    case Phase::kIdle:
      l_ = ldot_ = 0;
      break;
    case Phase::kGenerate:
      if (!exceeded) {
        begin_reduction(t, cfg);
        if (phase_ == Phase::kReduce) {
          // Evaluate the cubic at its start (continuity at t₂).
          l_ = a_[0];
          ldot_ = a_[1] / T_;
        }
        break;
      }
      ldot_ = thres_ - tau_ankle;  // (24)
      peak_rate_ = std::max(peak_rate_, std::abs(ldot_));
      l_ += ldot_ * dt;
      stored_ += l_ * dt;
      if (const double s = predicted_integral(cfg); s >= params_.budget_positive || -s >= params_.budget_negative) {
        spent_ = true;
        begin_reduction(t, cfg);
      }
      break;
    case Phase::kReduce: {
      const double tau = (t - t2_) / T_;
      if (tau >= 1.0) {
        l_ = ldot_ = 0;
        phase_ = Phase::kRecover;
        t_start_[2] = t;
        break;
      }
      l_ = a_[0] + tau * (a_[1] + tau * (a_[2] + tau * a_[3]));
      ldot_ = (a_[1] + tau * (2 * a_[2] + tau * 3 * a_[3])) / T_;
      stored_ += l_ * dt;
      break;
    }
    case Phase::kRecover: {
      l_ = ldot_ = 0;
      const double in_phase = t - t_start_[2];
      if ((posture_converged && in_phase >= cfg.min_recover_time) || in_phase >= cfg.max_recover_time) {
        phase_ = Phase::kIdle;
        t_start_ = {-1, -1, -1};
        stored_ = 0;
        spent_ = false;
      }
      break;
    }
  }
}

ReferenceGenerator::ReferenceGenerator(GeneratorConfig config) : config_(config) {
  for (int i = 0; i < 3; ++i) axes_[static_cast<size_t>(i)] = AxisGenerator(config_.axes[static_cast<size_t>(i)]);
}

void ReferenceGenerator::reset() { *this = ReferenceGenerator(config_); }

void ReferenceGenerator::set_axis_params(int i, AxisParams p) {
  config_.axes[static_cast<size_t>(i)] = p;
  axes_[static_cast<size_t>(i)].params() = p;
}

void ReferenceGenerator::step(const Inputs& in, Outputs& out) {
  static const balance::BalanceStatus kNone{};
  step(in.time, config_.dt, in.balance ? *in.balance : kNone, in.balance.has_value(), in.posture_error);
  out_.tick = in.tick;
  out_.balance_tick = in.balance ? in.balance->tick : -1;
  out.reference = out_;
  out.report.begin();
  out.report.set("balance", out_.stale && in.tick > 1,
                 out_.ramping ? "BALANCE_STATUS stale: CAM reference ramped to zero" : "BALANCE_STATUS stale: CAM reference held");
}

const CamReference& ReferenceGenerator::step(double t, double dt, const BalanceInput& b, bool balance_valid,
                                             double posture_error) {
  out_.time = t;
  const double age = t - b.time;
  const bool stale = !balance_valid || age > config_.stale_hold_time;
  const bool converged = posture_error < config_.posture_tolerance;
  out_.stale = stale;
  if (!stale) {
    ramping_ = false;
    for (int i = 0; i < 3; ++i) {
      if (!config_.enabled[static_cast<size_t>(i)]) continue;
      axes_[static_cast<size_t>(i)].step(t, dt, b.tau_ankle_V(i), b.tau_min_V(i), b.tau_max_V(i), converged, config_);
    }
    out_.yaw_WV = b.yaw_WV;
  } else if (age > config_.stale_hold_time + config_.stale_ramp_time || !balance_valid) {
    // Stale for long: ramp to zero with the phase-2 law, then stay at rest.
    ramping_ = true;
    for (auto& a : axes_) {
      if (a.phase() == Phase::kGenerate || a.phase() == Phase::kRecover || a.phase() == Phase::kIdle) {
        a.reduce_now(t, config_.stale_ramp_rate, config_);
      }
      // Without ankle torque information only the reduction continues.
      if (a.phase() == Phase::kReduce) a.step(t, dt, 0.0, -1.0, 1.0, converged, config_);
    }
  }  // else: hold
  out_.ramping = ramping_;
  for (int i = 0; i < 3; ++i) {
    const AxisGenerator& a = axes_[static_cast<size_t>(i)];
    out_.l_ref_V(i) = a.l();
    out_.ldot_ref_V(i) = stale && !ramping_ ? 0.0 : a.ldot();
    out_.phase[static_cast<size_t>(i)] = a.phase();
    out_.t_phase_start[static_cast<size_t>(i)] = a.phase_start();
    out_.tau_thres_V(i) = a.threshold();
    out_.ldot_max_V(i) = a.ldot_max();
  }
  const Eigen::Matrix3d R = Eigen::AngleAxisd(out_.yaw_WV, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  out_.l_ref_W = R * out_.l_ref_V;
  out_.ldot_ref_W = R * out_.ldot_ref_V;
  return out_;
}

}  // namespace hpr::reference_gen
