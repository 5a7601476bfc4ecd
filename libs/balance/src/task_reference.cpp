#include "hpr/balance/task_reference.hpp"

#include <cmath>

#include "hpr/model/algorithms.hpp"

namespace hpr::balance {

using Eigen::Matrix3d;
using Eigen::Vector3d;
using model::SE3;

const char* to_string(Support s) {
  switch (s) {
    case Support::kDouble: return "double";
    case Support::kLeft: return "left";
    case Support::kRight: return "right";
  }
  return "?";
}

Support support_from_string(const std::string& s) {
  if (s == "left") return Support::kLeft;
  if (s == "right") return Support::kRight;
  return Support::kDouble;
}

Eigen::Vector3d quintic(double tau) {
  if (tau <= 0) return Vector3d::Zero();
  if (tau >= 1) return Vector3d(1, 0, 0);
  const double t2 = tau * tau, t3 = t2 * tau;
  return {t3 * (10 - 15 * tau + 6 * t2), 30 * t2 * (1 - 2 * tau + t2), 60 * tau * (1 - 3 * tau + 2 * t2)};
}

PostureReferenceConfig PostureReferenceConfig::load(const Config& c) {
  PostureReferenceConfig p;
  if (c.has("com_offset")) {
    const auto v = c.reals("com_offset", 2, -0.5, 0.5);
    p.com_offset = Eigen::Vector2d(v[0], v[1]);
  }
  p.com_height = c.real_or("com_height", p.com_height, 0.0, 3.0);
  if (c.has("base_tilt")) {
    const auto v = c.reals("base_tilt", 2, -0.5, 0.5);
    p.base_tilt = Eigen::Vector2d(v[0], v[1]);
  }
  p.init_time = c.real_or("init_time", p.init_time, 0.01, 30.0);
  p.shift_time = c.real_or("shift_time", p.shift_time, 0.1, 30.0);
  p.lift_time = c.real_or("lift_time", p.lift_time, 0.1, 30.0);
  p.lift_height = c.real_or("lift_height", p.lift_height, 0.0, 0.5);
  p.unloaded_fraction = c.real_or("unloaded_fraction", p.unloaded_fraction, 0.0, 0.5);
  p.support = support_from_string(c.choice_or("support", "double", {"double", "left", "right"}));
  if (c.has("push_compensation")) {
    const Config pc = c.section("push_compensation");
    pc.reject_unknown({"enabled", "filter", "max_force"});
    auto& k = p.push_compensation;
    k.enabled = pc.boolean_or("enabled", k.enabled);
    k.filter = pc.real_or("filter", k.filter, 0.001, 10.0);
    k.max_force = pc.real_or("max_force", k.max_force, 0.0, 1.0e4);
  }
  if (c.has("stepping")) {
    const Config st = c.section("stepping");
    p.stepping = SteppingConfig::load(st);
    auto& e = p.step;
    e.unload_time = st.real_or("unload_time", e.unload_time, 0.0, 0.5 * p.stepping.t_min);
    e.swing_height = st.real_or("swing_height", e.swing_height, 0.0, 0.3);
    e.replan_fraction = st.real_or("replan_fraction", e.replan_fraction, 0.0, 1.0);
    e.target_rate = st.real_or("target_rate", e.target_rate, 0.0, 100.0);
    e.replan_min_time = st.real_or("replan_min_time", e.replan_min_time, 0.0, 1.0);
    e.touchdown_depth = st.real_or("touchdown_depth", e.touchdown_depth, 0.0, 0.1);
    e.follow_load = st.real_or("follow_load", e.follow_load, 0.0, 0.5);
    e.com_drop = st.real_or("com_drop", e.com_drop, 0.0, 0.3);
    e.com_drop_backward = st.real_or("com_drop_backward", e.com_drop, 0.0, 0.3);
    e.drop_time = st.real_or("drop_time", e.drop_time, 0.01, 5.0);
    e.touchdown_height = st.real_or("touchdown_height", e.touchdown_height, 0.0, 0.2);
    e.transfer_time = st.real_or("transfer_time", e.transfer_time, 0.0, 2.0);
    e.follow_delay = st.real_or("follow_delay", e.follow_delay, 0.0, 2.0);
    e.force_filter = st.real_or("force_filter", e.force_filter, 0.001, 1.0);
    e.push_onset = st.real_or("push_onset", e.push_onset, 0.0, 1000.0);
    e.push_duration_ratio = st.real_or("push_duration_ratio", e.push_duration_ratio, 0.0, 1000.0);
    e.cop_margin = st.real_or("cop_margin", e.cop_margin, 0.0, 0.1);
    e.settle_gain = st.real_or("settle_gain", e.settle_gain, 0.0, 100.0);
    e.settle_time = st.real_or("settle_time", e.settle_time, 0.0, 10.0);
    e.recover_time = st.real_or("recover_time", e.recover_time, 0.05, 10.0);
    e.landing_load_time = st.real_or("landing_load_time", e.landing_load_time, 0.0, 1.0);
  }
  return p;
}

Eigen::Vector3d quintic_to_rest(double p0, double v0, double a0, double p1, double T, double t) {
  if (T <= 0.0 || t >= T) return {p1, 0.0, 0.0};
  const double d = p1 - p0, T2 = T * T, T3 = T2 * T;
  const double c3 = (20 * d - 12 * v0 * T - 3 * a0 * T2) / (2 * T3);
  const double c4 = (-30 * d + 16 * v0 * T + 3 * a0 * T2) / (2 * T3 * T);
  const double c5 = (12 * d - 6 * v0 * T - a0 * T2) / (2 * T3 * T2);
  const double t2 = t * t, t3 = t2 * t;
  return {p0 + v0 * t + 0.5 * a0 * t2 + c3 * t3 + c4 * t3 * t + c5 * t3 * t2,
          v0 + a0 * t + 3 * c3 * t2 + 4 * c4 * t3 + 5 * c5 * t3 * t, a0 + 6 * c3 * t + 12 * c4 * t2 + 20 * c5 * t3};
}

PostureReference::PostureReference(const model::RobotSpec& robot, PostureReferenceConfig config)
    : robot_(&robot), config_(config), planner_(config.stepping), fk_(std::in_place, robot.model) {
  const int nf = static_cast<int>(robot.free_joints.size());
  ref_.q_free = ref_.qd_free = ref_.qdd_free = Eigen::VectorXd::Zero(nf);
  qf0_ = qf1_ = Eigen::VectorXd::Zero(nf);
}

Vector3d PostureReference::com_target(Support s) const {
  const SE3& r = ground_soles_[model::kRight];
  const SE3& l = ground_soles_[model::kLeft];
  Vector3d centre;
  double yaw = 0;
  if (s == Support::kDouble) {
    centre = 0.5 * (r.p + l.p);
    const Vector3d d = l.p - r.p;  // from right to left foot: the frame's y axis
    yaw = std::atan2(d.y(), d.x()) - M_PI / 2;
  } else {
    const SE3& st = ground_soles_[s == Support::kRight ? model::kRight : model::kLeft];
    centre = st.p;
    yaw = std::atan2(st.R(1, 0), st.R(0, 0));
  }
  const Eigen::Rotation2Dd Ryaw(yaw);
  Vector3d c;
  c.head<2>() = centre.head<2>() + Ryaw * config_.com_offset;
  c.z() = centre.z() + com_height_;
  return c;
}

void PostureReference::start(const Eigen::VectorXd& q, double t) {
  const model::Model& m = robot_->model;
  model::Data data(m);
  model::forward_kinematics(m, data, q);
  model::update_frame_placements(m, data);
  for (int k = 0; k < 2; ++k) {
    ground_soles_[static_cast<size_t>(k)] = data.oMf[static_cast<size_t>(robot_->feet[static_cast<size_t>(k)].sole_frame)];
  }
  com0_ = model::center_of_mass(m, data, q);
  R0_ = data.oMi[0].R;
  for (size_t i = 0; i < robot_->free_joints.size(); ++i) qf0_(static_cast<int>(i)) = q(7 + robot_->free_joints[i]);
  // CoM height of the standing posture above its soles, unless configured.
  if (config_.com_height > 0) {
    com_height_ = config_.com_height;
  } else {
    const Eigen::VectorXd qs = robot_->standing_configuration();
    model::Data ds(m);
    com_height_ = model::center_of_mass(m, ds, qs).z();  // soles at z = 0 in the standing configuration
  }
  com1_ = com_target(Support::kDouble);
  const Vector3d d = ground_soles_[model::kLeft].p - ground_soles_[model::kRight].p;
  const double yaw = std::atan2(d.y(), d.x()) - M_PI / 2;
  R1_ = (Eigen::AngleAxisd(yaw, Vector3d::UnitZ()) * Eigen::AngleAxisd(config_.base_tilt.y(), Vector3d::UnitY()) *
         Eigen::AngleAxisd(config_.base_tilt.x(), Vector3d::UnitX()))
            .toRotationMatrix();
  for (size_t i = 0; i < robot_->free_joints.size(); ++i) {
    qf1_(static_cast<int>(i)) = robot_->q_joints_stand(robot_->free_joints[i]);
  }
  for (int k = 0; k < 2; ++k) {
    FootReference& f = ref_.feet[static_cast<size_t>(k)];
    f.X_WS = ground_soles_[static_cast<size_t>(k)];
    f.twist.setZero();
    f.accel.setZero();
    f.contact = true;
    f.load_limit = 1.0;
  }
  current_ = Support::kDouble;
  target_ = config_.support;
  started_ = true;
  omega_ = lip_omega(com_height_);
  step_ = StepPlan{};
  steps_taken_ = 0;
  drop_ = 0.0;
  follow_steps_ = 0;
  last_t_ = t;
  t_prev_state_ = -1.0;
  f_ext_.setZero();
  push_start_ = -1.0;
  momentum_integral_.setZero();
  last_swing_ = -1;
  stepped_ = false;
  begin_stage(Stage::kInit, t);
  update(t);
}

void PostureReference::request_support(Support s, double t) {
  target_ = s;
  if (stage_ == Stage::kHold && s != current_) {
    // From double: shift over the stance foot; from single: set the swing foot down first.
    begin_stage(current_ == Support::kDouble ? Stage::kShift : Stage::kLower, t);
  }
  (void)t;
}

void PostureReference::begin_stage(Stage s, double t) {
  stage_ = s;
  stage_start_ = t;
  com0_ = stage_ == Stage::kInit ? com0_ : ref_.p_com;
  if (s == Stage::kShift) {
    moving_foot_ = target_ == Support::kRight ? model::kLeft : model::kRight;
    com1_ = com_target(target_);
  } else if (s == Stage::kShiftBack) {
    com1_ = com_target(Support::kDouble);
  } else if (s == Stage::kLower) {
    moving_foot_ = current_ == Support::kRight ? model::kLeft : model::kRight;
  }
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
    follow = unloaded_since_ >= 0.0 && t - unloaded_since_ >= config_.step.follow_delay;
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
  // Vertical: 64 τ³ (1 − τ)³ of the swing height, zero velocity and acceleration at lift-off and
  // at the planned touchdown, aimed touchdown_depth below the ground (the impedance's lag would
  // otherwise hold the sole above it); past the planned touchdown (the sole not yet loaded) the
  // reference goes on down at kProbeSpeed until the foot's sensor reports the ground.
  constexpr double kProbeSpeed = 0.3;  // [m/s]
  const double h = config_.step.swing_height, T = swing_time_, depth = config_.step.touchdown_depth;
  const double tc = std::clamp(tau_s, 0.0, 1.0), u = 1.0 - tc;
  const Vector3d sink = quintic(tc);  // from the lift-off height to touchdown_depth below the ground
  const double dz = swing_z0_ + depth;
  swing_p_(2) = ground_soles_[mu].p.z() + 64 * h * tc * tc * tc * u * u * u + swing_z0_ - dz * sink(0);
  swing_v_(2) = 64 * h * 3 * tc * tc * u * u * (u - tc) / T - dz * sink(1) / T;
  swing_a_(2) = 64 * h * 6 * tc * u * (u * u - 3 * tc * u + tc * tc) / (T * T) - dz * sink(2) / (T * T);
  if (tau_s > 1.0) {
    swing_p_(2) = ground_soles_[mu].p.z() - depth - kProbeSpeed * (tau_s - 1.0) * T;
    swing_v_(2) = -kProbeSpeed;
    swing_a_(2) = 0.0;
  }
  // Orientation: from the sole's at lift-off to the ground's, a quintic blend on SO(3).
  const Vector3d phi = model::log3(swing_R0_.transpose() * ground_soles_[mu].R);
  const Vector3d so = quintic(std::min(tc, 1.0));
  FootReference& f = ref_.feet[mu];
  f.contact = false;
  f.X_WS.R = swing_R0_ * model::exp3(so(0) * phi);
  f.X_WS.p = swing_p_;
  f.twist.setZero();
  f.accel.setZero();
  f.twist.head<3>() = swing_v_;
  f.accel.head<3>() = swing_a_;
  f.twist.tail<3>() = swing_R0_ * phi * (so(1) / T);
  f.accel.tail<3>() = swing_R0_ * phi * (so(2) / (T * T));
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
  // The horizontal external force by a momentum observer (no differentiation):
  // F̂ = K (m ċ − m ċ_0 − ∫ (Σ f_ground + F̂) dt), a first-order estimate of m c̈ − Σ f_ground
  // with time constant 1/K.
  const Eigen::Vector2d v = state.v_com.head<2>();
  const double m = robot_->model.mass;
  // The ground's force on the feet in contact only: the sensor of a foot in the air reads that
  // foot's own inertia (tens of newtons while it swings), which is no ground force.
  Eigen::Vector2d f_ground = Eigen::Vector2d::Zero();
  for (size_t k = 0; k < 2; ++k) {
    if (state.contact[k]) f_ground += state.foot_wrench_W[k].head<2>();
  }
  const double dt = t - t_prev_state_;
  const bool running = t_prev_state_ >= 0.0 && dt > 0.0 && dt < 0.1;
  if (running) {
    momentum_integral_ += (f_ground + f_ext_) * dt;
    f_ext_ = (m * (v - v_prev_) - momentum_integral_) / config_.step.force_filter;
  }
  // The observer's start, and its restart after a sensor's NaN (the compensation with it).
  if (!running || !f_ext_.allFinite()) {
    if (!f_ext_.allFinite()) f_comp_.setZero();
    v_prev_ = v;
    momentum_integral_.setZero();
    f_ext_.setZero();
  } else if (config_.push_compensation.enabled) {
    f_comp_ += std::min(1.0, dt / config_.push_compensation.filter) * (f_ext_ - f_comp_);
    const double n = f_comp_.norm(), f_max = config_.push_compensation.max_force;
    if (n > f_max) f_comp_ *= f_max / n;
  }
  // When the push began: |F̂| last rose above push_onset (a restart above sets F̂ to zero).
  if (f_ext_.norm() < config_.step.push_onset) {
    push_start_ = -1.0;
  } else if (push_start_ < 0.0) {
    push_start_ = t;
  }
  t_prev_state_ = t;
}

const TaskReference& PostureReference::update(double t, const EstimatedState* state) {
  ref_.time = t;
  if (state != nullptr && (config_.stepping.enabled || config_.push_compensation.enabled) && omega_ > 0.0) {
    observe_external_force(t, *state);
  }
  if (state != nullptr && config_.stepping.enabled && omega_ > 0.0) {
    const Eigen::Vector2d v = state->v_com.head<2>();
    const double m = robot_->model.mass;
    // The external force counts until the first touchdown of a series of steps: after it, the
    // impacts of the landing feet and their sensors' transients are no push. How long it will
    // last is not known: it is taken to last push_duration_ratio times as long again as it has.
    const double t_pushed = push_start_ < 0.0 ? 0.0 : t - push_start_;
    xi_ = balance::capture_point(state->p_com.head<2>(), v, omega_);
    if (!stepped_) xi_ += balance::push_shift(f_ext_, m, omega_, config_.step.push_duration_ratio * t_pushed);
    // The base's lean from its standing orientation: the horizontal part of its z axis, from
    // q = (p, quat (x, y, z, w), ...), less that of the standing base's.
    const Eigen::Vector4d quat = state->q.segment<4>(3);
    lean_ = 2.0 * Eigen::Vector2d(quat(0) * quat(2) + quat(3) * quat(1), quat(1) * quat(2) - quat(3) * quat(0)) -
            R1_.col(2).head<2>();
    excess_ = planner_.excess(soles(), {true, true}, xi_, lean_);
  }
  if (state != nullptr && config_.stepping.enabled && target_ == Support::kDouble && current_ == Support::kDouble &&
      (stage_ == Stage::kHold || ((stage_ == Stage::kStepSettle || stage_ == Stage::kStepRecover) &&
                                  t - stage_start_ > 2 * config_.step.landing_load_time))) {
    check_step(t, *state);
  }
  const double elapsed = t - stage_start_;
  auto blend_com = [&](double duration) {
    const Vector3d s = quintic(elapsed / duration);
    ref_.p_com = com0_ + s(0) * (com1_ - com0_);
    ref_.v_com = s(1) / duration * (com1_ - com0_);
    ref_.a_com = s(2) / (duration * duration) * (com1_ - com0_);
    return s(0) >= 1.0;
  };
  switch (stage_) {
    case Stage::kInit: {
      const double T = config_.init_time;
      const Vector3d s = quintic(elapsed / T);
      blend_com(T);
      const Vector3d phi = model::log3(R0_.transpose() * R1_);
      ref_.R_base = R0_ * model::exp3(s(0) * phi);
      ref_.omega_base = R0_ * phi * (s(1) / T);
      ref_.omegadot_base = R0_ * phi * (s(2) / (T * T));
      ref_.q_free = qf0_ + s(0) * (qf1_ - qf0_);
      ref_.qd_free = s(1) / T * (qf1_ - qf0_);
      ref_.qdd_free = s(2) / (T * T) * (qf1_ - qf0_);
      ref_.settled = false;
      if (s(0) >= 1.0) {
        ref_.R_base = R1_;
        ref_.omega_base.setZero();
        ref_.omegadot_base.setZero();
        stage_ = Stage::kHold;
        stage_start_ = t;
        if (target_ != current_) begin_stage(Stage::kShift, t);
      }
      break;
    }
    case Stage::kHold:
      ref_.v_com.setZero();
      ref_.a_com.setZero();
      // The push's feedforward (push_compensation): none without an estimate to observe it in, nor
      // after a step until the robot is at rest (the landings' impacts are no push).
      if (config_.push_compensation.enabled && state != nullptr && !stepped_) ref_.a_com.head<2>() = -f_comp_ / robot_->model.mass;
      ref_.qd_free.setZero();
      ref_.qdd_free.setZero();
      ref_.settled = true;
      break;
    case Stage::kShift: {
      const auto mu = static_cast<size_t>(moving_foot_);
      const bool done = blend_com(config_.shift_time);
      const double s = quintic(elapsed / config_.shift_time)(0);
      ref_.feet[mu].load_limit = 1.0 - s * (1.0 - config_.unloaded_fraction);
      ref_.settled = false;
      if (done) begin_stage(Stage::kLift, t);
      break;
    }
    case Stage::kLift:
    case Stage::kLower: {
      const auto mu = static_cast<size_t>(moving_foot_);
      const double T = config_.lift_time;
      Vector3d s = quintic(elapsed / T);
      const double dir = stage_ == Stage::kLift ? 1.0 : -1.0;
      const double z0 = ground_soles_[mu].p.z() + (stage_ == Stage::kLift ? 0.0 : config_.lift_height);
      FootReference& f = ref_.feet[mu];
      f.contact = false;
      f.X_WS = ground_soles_[mu];
      f.X_WS.p.z() = z0 + dir * config_.lift_height * s(0);
      f.twist.setZero();
      f.accel.setZero();
      f.twist(2) = dir * config_.lift_height * s(1) / T;
      f.accel(2) = dir * config_.lift_height * s(2) / (T * T);
      ref_.v_com.setZero();
      ref_.a_com.setZero();
      ref_.settled = false;
      if (s(0) >= 1.0) {
        f.twist.setZero();
        f.accel.setZero();
        if (stage_ == Stage::kLift) {
          current_ = target_;
          ref_.support = current_;
          stage_ = Stage::kHold;
          stage_start_ = t;
        } else {
          f.contact = true;
          f.load_limit = config_.unloaded_fraction;
          f.X_WS = ground_soles_[mu];
          begin_stage(Stage::kShiftBack, t);
        }
      }
      break;
    }
    case Stage::kShiftBack: {
      const auto mu = static_cast<size_t>(moving_foot_);
      const bool done = blend_com(config_.shift_time);
      const double s = quintic(elapsed / config_.shift_time)(0);
      ref_.feet[mu].load_limit = config_.unloaded_fraction + s * (1.0 - config_.unloaded_fraction);
      ref_.support = Support::kDouble;
      ref_.settled = false;
      if (done) {
        current_ = Support::kDouble;
        stage_ = Stage::kHold;
        stage_start_ = t;
        if (target_ != current_) begin_stage(Stage::kShift, t);
      }
      break;
    }
    case Stage::kStepUnload: {
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
      if (elapsed >= config_.step.unload_time) {
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
      break;
    }
    case Stage::kStepSwing: {
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
      break;
    }
    case Stage::kStepSettle: {
      ramp_landing_load(t - land_time_);
      ref_.support = Support::kDouble;
      ref_.settled = false;
      const bool settled = state == nullptr || settle_dcm(*state);
      if (settled || elapsed >= config_.step.settle_time) begin_recover(t, state);
      break;
    }
    case Stage::kStepRecover: {
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
      break;
    }
  }
  last_t_ = t;
  if (stage_ == Stage::kHold && target_ != current_) {
    begin_stage(current_ == Support::kDouble ? Stage::kShift : Stage::kLower, t);
  }
  // During the shift both feet still carry load; from the lift on the robot is in single support.
  if (stage_ == Stage::kShift) ref_.support = Support::kDouble;
  if (stage_ == Stage::kLift) ref_.support = target_;
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
  return ref_;
}

}  // namespace hpr::balance
