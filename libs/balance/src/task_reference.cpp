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
    e.follow_reach = st.real_or("follow_reach", e.follow_reach, -0.05, 1.0);
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

PostureReference::PostureReference(const model::RobotSpec& robot, PostureReferenceConfig config)
    : robot_(&robot),
      config_(config),
      planner_(config.stepping),
      observer_({.mass = robot.model.mass,
                 .time_constant = config.step.force_filter,
                 .push_onset = config.step.push_onset,
                 .compensate = config.push_compensation.enabled,
                 .compensation_filter = config.push_compensation.filter,
                 .max_force = config.push_compensation.max_force}),
      fk_(std::in_place, robot.model) {
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
  observer_.restart();
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

const char* to_string(PlanStage s) {
  using Stage = PlanStage;
  switch (s) {
    case Stage::kInit: return "init";
    case Stage::kHold: return "hold";
    case Stage::kShift: return "shift";
    case Stage::kLift: return "lift";
    case Stage::kLower: return "lower";
    case Stage::kShiftBack: return "shift back";
    case Stage::kStepUnload: return "step unload";
    case Stage::kStepSwing: return "step swing";
    case Stage::kStepSettle: return "step settle";
    case Stage::kStepRecover: return "step recover";
  }
  return "?";
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

const TaskReference& PostureReference::update(double t, const EstimatedState* state) {
  ref_.time = t;
  if (state != nullptr) observe(t, *state);
  const double elapsed = t - stage_start_;
  switch (stage_) {
    case Stage::kInit: stage_init(t, elapsed); break;
    case Stage::kHold: stage_hold(state); break;
    case Stage::kShift: stage_shift(t, elapsed); break;
    case Stage::kLift:
    case Stage::kLower: stage_lift_or_lower(t, elapsed); break;
    case Stage::kShiftBack: stage_shift_back(t, elapsed); break;
    case Stage::kStepUnload: stage_step_unload(t, elapsed, state); break;
    case Stage::kStepSwing: stage_step_swing(t, state); break;
    case Stage::kStepSettle: stage_step_settle(t, elapsed, state); break;
    case Stage::kStepRecover: stage_step_recover(t, elapsed); break;
  }
  last_t_ = t;
  if (stage_ == Stage::kHold && target_ != current_) {
    begin_stage(current_ == Support::kDouble ? Stage::kShift : Stage::kLower, t);
  }
  // During the shift both feet still carry load; from the lift on the robot is in single support.
  if (stage_ == Stage::kShift) ref_.support = Support::kDouble;
  if (stage_ == Stage::kLift) ref_.support = target_;
  report_stepping(t);
  return ref_;
}

bool PostureReference::blend_com(double elapsed, double duration) {
  const Vector3d s = quintic(elapsed / duration);
  ref_.p_com = com0_ + s(0) * (com1_ - com0_);
  ref_.v_com = s(1) / duration * (com1_ - com0_);
  ref_.a_com = s(2) / (duration * duration) * (com1_ - com0_);
  return s(0) >= 1.0;
}

void PostureReference::stage_init(double t, double elapsed) {
  const double T = config_.init_time;
  const Vector3d s = quintic(elapsed / T);
  blend_com(elapsed, T);
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
}

void PostureReference::stage_hold(const EstimatedState* state) {
  ref_.v_com.setZero();
  ref_.a_com.setZero();
  // The push's feedforward (push_compensation): none without an estimate to observe it in, nor
  // after a step until the robot is at rest (the landings' impacts are no push).
  if (config_.push_compensation.enabled && state != nullptr && !stepped_) ref_.a_com.head<2>() = -observer_.compensated() / robot_->model.mass;
  ref_.qd_free.setZero();
  ref_.qdd_free.setZero();
  ref_.settled = true;
}

void PostureReference::stage_shift(double t, double elapsed) {
  const auto mu = static_cast<size_t>(moving_foot_);
  const bool done = blend_com(elapsed, config_.shift_time);
  const double s = quintic(elapsed / config_.shift_time)(0);
  ref_.feet[mu].load_limit = 1.0 - s * (1.0 - config_.unloaded_fraction);
  ref_.settled = false;
  if (done) begin_stage(Stage::kLift, t);
}

void PostureReference::stage_lift_or_lower(double t, double elapsed) {
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
  if (!(s(0) >= 1.0)) return;
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

void PostureReference::stage_shift_back(double t, double elapsed) {
  const auto mu = static_cast<size_t>(moving_foot_);
  const bool done = blend_com(elapsed, config_.shift_time);
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
}

}  // namespace hpr::balance
