// The stepping side of the posture reference (docs/results/stepping.md, "Stepping, the third strategy"): the
// external-force observer, the capture point and the step decision, the stepping stages (unload, swing, settle,
// recover) and the swing trajectory.
#include <algorithm>
#include <cmath>

#include "hpr/balance/task_reference.hpp"
#include "hpr/model/algorithms.hpp"

namespace hpr::balance {

using Eigen::Matrix3d;
using Eigen::Vector3d;
using model::SE3;

void PostureReference::observe(double t, const EstimatedState& state) {
  if ((config_.stepping.enabled || config_.push_compensation.enabled) && omega_ > 0.0) {
    observe_external_force(t, state);
  }
  if (config_.stepping.enabled && omega_ > 0.0) {
    const Eigen::Vector2d v = state.v_com.head<2>();
    const double m = robot_->model.mass;
    // The external force counts until the first touchdown of a series of steps: after it, the
    // impacts of the landing feet and their sensors' transients are no push. How long it will
    // last is not known: it is taken to last push_duration_ratio times as long again as it has.
    const double t_pushed = observer_.push_start() < 0.0 ? 0.0 : t - observer_.push_start();
    xi_ = balance::capture_point(state.p_com.head<2>(), v, omega_);
    if (!stepped_) xi_ += balance::push_shift(observer_.force(), m, omega_, config_.step.push_duration_ratio * t_pushed);
    // The base's lean from its standing orientation: the horizontal part of its z axis, from
    // q = (p, quat (x, y, z, w), ...), less that of the standing base's.
    const Eigen::Vector4d quat = state.q.segment<4>(3);
    lean_ = 2.0 * Eigen::Vector2d(quat(0) * quat(2) + quat(3) * quat(1), quat(1) * quat(2) - quat(3) * quat(0)) -
            R1_.col(2).head<2>();
    excess_ = planner_.excess(soles(), {true, true}, xi_, lean_);
  }
  if (config_.stepping.enabled && target_ == Support::kDouble && current_ == Support::kDouble &&
      (stage_ == Stage::kHold || ((stage_ == Stage::kStepSettle || stage_ == Stage::kStepRecover) &&
                                  t - stage_start_ > 2 * config_.step.landing_load_time))) {
    check_step(t, state);
  }
}

void PostureReference::stage_step_unload(double t, double elapsed, const EstimatedState* state) {
  // Both feet still on the ground; the swing foot's load limit falls to the unloaded fraction.
  const auto mu = static_cast<size_t>(moving_foot_);
  const double T = std::max(config_.step.unload_time, 1e-9);
  ref_.feet[mu].load_limit = 1.0 - std::min(elapsed / T, 1.0) * (1.0 - config_.unloaded_fraction);
  if (state != nullptr) {
    const std::array<bool, 2> stance{moving_foot_ != model::kRight, moving_foot_ != model::kLeft};
    follow_lip(*state, support_point(soles(), stance, xi_, config_.step.cop_margin));
  }
  ref_.support = Support::kDouble;
  ref_.settled = false;
  if (!(elapsed >= config_.step.unload_time)) return;
  stage_ = Stage::kStepSwing;
  stage_start_ = t;
  swing_start_ = t;
  // The swing starts from the sole as it is (a trailing sole may have rolled onto its toe).
  const model::SE3 X = state != nullptr ? measured_sole(*state, moving_foot_) : ground_soles_[mu];
  swing_R0_ = X.R;
  swing_p_ = X.p;
  swing_z0_ = swing_p_.z() - ground_soles_[mu].p.z();
  swing_v_.setZero();
  swing_a_.setZero();
  ref_.support = moving_foot_ == model::kRight ? Support::kLeft : Support::kRight;
  update_swing(t, state);
}

void PostureReference::stage_step_swing(double t, const EstimatedState* state) {
  ref_.support = moving_foot_ == model::kRight ? Support::kLeft : Support::kRight;
  ref_.settled = false;
  if (state != nullptr) {
    // The CMP on the stance sole nearest the capture point: the ankle strategy slows ξ as much
    // as the sole allows.
    const std::array<bool, 2> stance{moving_foot_ != model::kRight, moving_foot_ != model::kLeft};
    follow_lip(*state, support_point(soles(), stance, xi_, config_.step.cop_margin));
  }
  update_swing(t, state);
  // Touchdown: once the swing is mostly done and the foot's sensor reports the ground; without
  // a state, at the planned time; at the latest 0.15 s after it.
  const double tau_s = (t - swing_start_) / swing_time_;
  const bool touched = state != nullptr && state->contact[static_cast<size_t>(moving_foot_)] && tau_s > 0.6 &&
                       measured_sole(*state, moving_foot_).p.z() - ground_soles_[static_cast<size_t>(moving_foot_)].p.z() <
                           config_.step.touchdown_height;
  if (touched || (state == nullptr && tau_s >= 1.0) || t - swing_start_ >= swing_time_ + 0.15) land(t, state);
}

void PostureReference::stage_step_settle(double t, double elapsed, const EstimatedState* state) {
  ramp_landing_load(t - land_time_);
  ref_.support = Support::kDouble;
  ref_.settled = false;
  const bool settled = state == nullptr || settle_dcm(*state);
  if (settled || elapsed >= config_.step.settle_time) begin_recover(t, state);
}

void PostureReference::stage_step_recover(double t, double elapsed) {
  const double T = config_.step.recover_time;
  for (int i = 0; i < 3; ++i) {
    const Vector3d s = quintic_to_rest(com0_(i), com_v0_(i), 0.0, com1_(i), T, std::min(elapsed, T));
    ref_.p_com(i) = s(0);
    ref_.v_com(i) = s(1);
    ref_.a_com(i) = s(2);
  }
  ramp_landing_load(t - land_time_);
  ref_.support = Support::kDouble;
  ref_.settled = false;
  if (elapsed >= T) {
    stage_ = Stage::kHold;
    stage_start_ = t;
    stepped_ = false;
  }
}

void PostureReference::report_stepping(double t) {
  StepStatus& st = ref_.stepping;
  st.enabled = config_.stepping.enabled;
  st.xi_W = xi_;
  st.excess = excess_;
  st.swing = step_.swing;
  st.target_W = step_.target;
  st.target_yaw = step_.yaw;
  st.time_left = step_.swing >= 0 ? std::max(step_start_ + config_.step.unload_time + swing_time_ - t, 0.0) : 0.0;
  st.steps_taken = steps_taken_;
  st.follow_steps = follow_steps_;
}

std::array<Sole, 2> PostureReference::soles() const {
  std::array<Sole, 2> s;
  for (size_t k = 0; k < 2; ++k) {
    const model::SE3& X = ground_soles_[k];
    s[k] = {X.p.head<2>(), std::atan2(X.R(1, 0), X.R(0, 0)), 0.5 * robot_->feet[k].length, 0.5 * robot_->feet[k].width};
  }
  return s;
}

void PostureReference::check_step(double t, const EstimatedState& state) {
  const auto sole = soles();
  // After a step the trailing foot follows when it stays nearly unloaded (the DCM came to rest
  // over the landed foot): a sole that carries almost nothing cannot hold the leg's torques.
  bool follow = false;
  if (stage_ != Stage::kHold && last_swing_ >= 0) {
    const auto trailing = static_cast<size_t>(1 - last_swing_);
    const double fz = state.foot_force_z[0] + state.foot_force_z[1];
    const double share = fz > 0 ? state.foot_force_z[trailing] / fz : 0.0;
    if (share >= config_.step.follow_load) {
      unloaded_since_ = -1.0;
    } else if (unloaded_since_ < 0.0) {
      unloaded_since_ = t;
    }
    // ... and the DCM is over the landed sole: a DCM still crossing towards it (the CoM swinging
    // over it) unloads the trailing foot for a moment, and a swing begun then lifts the foot the
    // CoM swings back onto.
    std::array<bool, 2> landed{false, false};
    landed[static_cast<size_t>(last_swing_)] = true;
    follow = unloaded_since_ >= 0.0 && t - unloaded_since_ >= config_.step.follow_delay &&
             support_distance(sole, landed, xi_) <= config_.step.follow_reach;
  }
  const bool needed = excess_ > 0.0;  // update() computed it this tick, for these soles and ξ
  if (!follow && !needed) return;
  int swing = -1;
  if (stage_ == Stage::kHold || last_swing_ < 0) {
    const double fz = state.foot_force_z[0] + state.foot_force_z[1];
    const std::array<double, 2> load = fz > 0 ? std::array<double, 2>{state.foot_force_z[0] / fz, state.foot_force_z[1] / fz}
                                              : std::array<double, 2>{0.5, 0.5};
    swing = planner_.choose_swing(sole, xi_, load);
  } else {
    swing = 1 - last_swing_;  // still settling from a step: the trailing foot follows
  }
  const StepPlan plan = planner_.plan(sole, swing, xi_, omega_);
  // No landing within reach on the declared ground: no step; the ankle and hip strategies do what
  // they can.
  if (!plan.placeable) return;
  step_ = plan;
  begin_step(t);
  if (!needed) ++follow_steps_;
}

void PostureReference::begin_step(double t) {
  if (!stepped_ && stage_ == Stage::kHold) {
    drop_start_ = t;
    drop_z0_ = ref_.p_com.z();
    // Backwards: the landing behind the stance sole (x < 0 in its frame).
    const bool backward = soles()[static_cast<size_t>(1 - step_.swing)].to_local(step_.target).x() < 0.0;
    drop_ = backward ? config_.step.com_drop_backward : config_.step.com_drop;
  }
  moving_foot_ = step_.swing;
  last_swing_ = step_.swing;
  step_start_ = t;
  swing_time_ = std::max(step_.duration - config_.step.unload_time, 0.05);
  ++steps_taken_;
  begin_stage(Stage::kStepUnload, t);
}

void PostureReference::follow_lip(const EstimatedState& state, const Eigen::Vector2d& p) {
  p_hold_ = p;
  // The measured CoM as the reference (no spring pulls it back), accelerating as the LIP does with
  // the CMP at p: the wbc's CoM wrench then puts the CoP there. The height is held.
  ref_.p_com.head<2>() = state.p_com.head<2>();
  ref_.v_com.head<2>() = state.v_com.head<2>();
  ref_.a_com.head<2>() = omega_ * omega_ * (state.p_com.head<2>() - p);
  // The height sinks by com_drop (com_drop_backward) over drop_time from the first step on: bent
  // knees reach further.
  const double z1 = com_target(Support::kDouble).z() - drop_;
  const double T = std::max(config_.step.drop_time, 1e-3);
  const Vector3d sz = quintic((state.time - drop_start_) / T);
  ref_.p_com.z() = drop_z0_ + sz(0) * (z1 - drop_z0_);
  ref_.v_com.z() = sz(1) / T * (z1 - drop_z0_);
  ref_.a_com.z() = sz(2) / (T * T) * (z1 - drop_z0_);
}

bool PostureReference::settle_dcm(const EstimatedState& state) {
  // DCM regulation: ξ̇ = ω (ξ − p) and p = ξ + (k/ω)(ξ − ξ_d) give ξ̇ = −k (ξ − ξ_d); p kept
  // cop_margin inside the support.
  const Eigen::Vector2d c = state.p_com.head<2>(), cd = state.v_com.head<2>();
  const Eigen::Vector2d xi = balance::capture_point(c, cd, omega_);
  const Eigen::Vector2d xi_d = com1_.head<2>();
  const Eigen::Vector2d p_want = xi + config_.step.settle_gain / omega_ * (xi - xi_d);
  Eigen::Vector2d p = support_point(soles(), {true, true}, p_want, config_.step.cop_margin);
  // The load moves from the stance foot to the landed one over transfer_time: the CMP starts where
  // the swing held it.
  const double T = config_.step.transfer_time;
  if (T > 0.0 && state.time - land_time_ < T) {
    const double sb = quintic((state.time - land_time_) / T)(0);
    p = p_hold_ + sb * (p - p_hold_);
  }
  follow_lip(state, p);
  return (xi - xi_d).norm() < 0.01 && cd.norm() < 0.03;
}

void PostureReference::begin_recover(double t, const EstimatedState* state) {
  com0_ = ref_.p_com;
  com_v0_ = ref_.v_com;
  if (state != nullptr) {
    com0_.head<2>() = state->p_com.head<2>();
    com_v0_.head<2>() = state->v_com.head<2>();
  }
  com_v0_.z() = 0.0;
  stage_ = Stage::kStepRecover;
  stage_start_ = t;
}

void PostureReference::ramp_landing_load(double since_touchdown) {
  const double Tl = config_.step.landing_load_time;
  for (auto& f : ref_.feet) {
    f.load_limit = Tl > 0 ? std::max(f.load_limit, std::min(1.0, config_.unloaded_fraction + since_touchdown / Tl)) : 1.0;
  }
}

model::SE3 PostureReference::measured_sole(const EstimatedState& state, int foot) {
  const auto fu = static_cast<size_t>(foot);
  if (state.q.size() != robot_->model.nq) return ground_soles_[fu];
  model::forward_kinematics(robot_->model, *fk_, state.q);
  return model::update_frame_placement(robot_->model, *fk_, robot_->feet[fu].sole_frame);
}

void PostureReference::update_swing(double t, const EstimatedState* state) {
  const auto mu = static_cast<size_t>(moving_foot_);
  const double tau_s = (t - swing_start_) / swing_time_;
  const double remaining = swing_start_ + swing_time_ - t;
  const double dt = std::max(t - last_t_, 0.0);
  if (state != nullptr && tau_s < config_.step.replan_fraction && remaining > config_.step.replan_min_time) {
    // The landing follows the capture point, at most target_rate fast (the estimate is noisy).
    const StepPlan p = planner_.plan_landing(soles(), moving_foot_, xi_, omega_, remaining);
    // (A stance sole that slid may leave no landing on the declared ground: the last one stays.)
    const Eigen::Vector2d d = p.placeable ? Eigen::Vector2d(p.target - step_.target) : Eigen::Vector2d::Zero();
    const double max_d = config_.step.target_rate * dt;
    step_.target += d.norm() > max_d ? Eigen::Vector2d(d * (max_d / d.norm())) : d;
    step_.xi_touchdown = p.xi_touchdown;
    step_.reachable = p.reachable;
  }
  // Horizontal: a quintic from the reference's own motion to the landing, re-drawn each tick.
  for (int i = 0; i < 2; ++i) {
    const Vector3d s = quintic_to_rest(swing_p_(i), swing_v_(i), swing_a_(i), step_.target(i), remaining + dt, dt);
    swing_p_(i) = s(0);
    swing_v_(i) = s(1);
    swing_a_(i) = s(2);
  }
  // Vertical: the swing height (swing_height), aimed touchdown_depth below the ground (the
  // impedance's lag would otherwise hold the sole above it), going on down past the planned
  // touchdown until the foot's sensor reports the ground.
  const double T = swing_time_;
  const Vector3d z = swing_height(tau_s, T, ground_soles_[mu].p.z(), swing_z0_, config_.step.swing_height, config_.step.touchdown_depth);
  swing_p_(2) = z(0);
  swing_v_(2) = z(1);
  swing_a_(2) = z(2);
  // Orientation: from the sole's at lift-off to the ground's.
  const SwingOrientation o = swing_orientation(swing_R0_, ground_soles_[mu].R, tau_s, T);
  FootReference& f = ref_.feet[mu];
  f.contact = false;
  f.X_WS.R = o.R;
  f.X_WS.p = swing_p_;
  f.twist.setZero();
  f.accel.setZero();
  f.twist.head<3>() = swing_v_;
  f.accel.head<3>() = swing_a_;
  f.twist.tail<3>() = o.omega;
  f.accel.tail<3>() = o.omegadot;
}

void PostureReference::land(double t, const EstimatedState* state) {
  const auto mu = static_cast<size_t>(moving_foot_);
  ground_soles_[mu].p.head<2>() = swing_p_.head<2>();
  FootReference& f = ref_.feet[mu];
  f.contact = true;
  f.load_limit = config_.unloaded_fraction;
  f.X_WS = ground_soles_[mu];
  f.twist.setZero();
  f.accel.setZero();
  com1_ = com_target(Support::kDouble);
  current_ = Support::kDouble;
  ref_.support = Support::kDouble;
  step_.swing = -1;
  land_time_ = t;
  stepped_ = true;
  unloaded_since_ = -1.0;
  if (state != nullptr) {
    stage_ = Stage::kStepSettle;
    stage_start_ = t;
  } else {
    begin_recover(t, state);
  }
}

void PostureReference::observe_external_force(double t, const EstimatedState& state) {
  // The ground's force on the feet in contact only: the sensor of a foot in the air reads that
  // foot's own inertia (tens of newtons while it swings), which is no ground force.
  Eigen::Vector2d f_ground = Eigen::Vector2d::Zero();
  for (size_t k = 0; k < 2; ++k) {
    if (state.contact[k]) f_ground += state.foot_wrench_W[k].head<2>();
  }
  observer_.update(t, state.v_com.head<2>(), f_ground);
}

}  // namespace hpr::balance
