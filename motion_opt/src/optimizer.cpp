#include "hpr/motion_opt/optimizer.hpp"

#include <algorithm>
#include <cmath>

#include "hpr/common/log.hpp"
#include "hpr/common/time.hpp"

namespace hpr::motion_opt {

using Eigen::Vector3d;
using Eigen::VectorXd;

MotionOptConfig MotionOptConfig::load(const Config& c, const model::RobotSpec& robot) {
  MotionOptConfig m;
  m.dt = c.real_or("dt", m.dt, 1e-5, 0.1);
  const Config adj = c.section("adjusted");
  m.adjusted_double = adj.strings("double");
  m.adjusted_single = adj.strings("single");
  for (const char* key : {"double", "single"}) {
    for (const auto& name : adj.strings(key)) {
      if (name == "base_rotation" || name == "swing_foot") continue;
      const int j = robot.joints({name}, adj, key).front();
      if (std::find(robot.free_joints.begin(), robot.free_joints.end(), j) == robot.free_joints.end()) {
        adj.fail(key, "'" + name + "' is a leg joint; legs follow the feet and the CoM, adjust 'swing_foot' instead");
      }
    }
  }
  if (c.has("weights")) {
    const Config w = c.section("weights");
    if (w.has("cam")) {
      m.Q_l = w.is_scalar("cam") ? Vector3d::Constant(w.real("cam", 0, 1e6)) : w.vec3("cam", 0, 1e6);
    }
    m.Q_p = w.real_or("posture", m.Q_p, 1e-9, 1e6);
    m.cam_idle_fraction = w.real_or("cam_idle_fraction", m.cam_idle_fraction, 0.0, 1.0);
    m.cam_release_time = w.real_or("cam_release_time", m.cam_release_time, 0.0, 10.0);
    if (w.has("posture_overrides")) {
      const Config o = w.section("posture_overrides");
      for (const auto& k : o.keys()) m.Q_p_overrides[k] = o.real(k, 1e-9, 1e6);
    }
  }
  if (c.has("gains")) {
    const Config g = c.section("gains");
    m.K_p = g.real_or("posture", m.K_p, 0.0, 1e3);
    m.K_a = g.real_or("limits", m.K_a, 0.0, 1e4);
  }
  if (c.has("limits")) {
    const Config l = c.section("limits");
    if (l.has("base_rotation")) {
      const Config b = l.section("base_rotation");
      m.base_min = b.vec3_or("min", m.base_min, -1.5, 0.0);
      m.base_max = b.vec3_or("max", m.base_max, 0.0, 1.5);
      m.base_velocity = b.real_or("velocity", m.base_velocity, 0.0, 50.0);
    }
    m.joint_limit_margin = l.real_or("joint_margin", m.joint_limit_margin, 0.0, 1.0);
    m.joint_velocity_fraction = l.real_or("joint_velocity_fraction", m.joint_velocity_fraction, 0.01, 1.0);
    if (l.has("swing_foot")) {
      const Config s = l.section("swing_foot");
      m.swing_range = s.real_or("range", m.swing_range, 0.0, 1.0);
      m.swing_clearance = s.real_or("clearance", m.swing_clearance, 0.0, 0.5);
      m.swing_velocity = s.real_or("velocity", m.swing_velocity, 0.0, 10.0);
      m.swing_return_rate = s.real_or("return_rate", m.swing_return_rate, 0.0, 1e3);
    }
  }
  m.acceleration_filter = c.real_or("acceleration_filter", m.acceleration_filter, 0.0, 1.0);
  m.max_working_set_changes = static_cast<int>(c.integer_or("max_working_set_changes", m.max_working_set_changes, 1, 10000));
  return m;
}

MotionOptimizer::MotionOptimizer(const model::RobotSpec& robot, MotionOptConfig config)
    : robot_(&robot), config_(std::move(config)), data_(robot.model), task_(robot) {
  const char* ax = "xyz";
  for (int i = 0; i < 3; ++i) {
    coords_.push_back({Coordinate::Kind::kBaseRotation, i, 0, model::TaskSpace::kBaseRot + i, std::string("base_rotation_") + ax[i]});
  }
  for (size_t f = 0; f < robot.free_joints.size(); ++f) {
    coords_.push_back({Coordinate::Kind::kFreeJoint, 0, static_cast<int>(f), model::TaskSpace::kFree + static_cast<int>(f),
                       robot.model.joint_name[static_cast<size_t>(robot.free_joints[f])]});
  }
  for (int k = 0; k < 2; ++k) {
    for (int i = 0; i < 3; ++i) {
      coords_.push_back({Coordinate::Kind::kFoot, i, k, 6 + 6 * k + i,
                         std::string(model::kFootNames[static_cast<size_t>(k)]) + "_foot_" + ax[i]});
    }
  }
  const int nc = static_cast<int>(coords_.size());
  delta_ = delta_dot_ = delta_dot_prev_ = delta_acc_ = VectorXd::Zero(nc);
  xdot_ref_ = xdot_cmd_ = xu_ = VectorXd::Zero(robot.model.nv);
  set_.reserve(coords_.size());
  last_set_.reserve(coords_.size());
  out_.adjusted.reserve(coords_.size());
  adjusted_.assign(coords_.size(), 0);
  // Segments for the CAM contributions (Fig. 7d): the trunk (CoM and base rotation), the
  // configured joint groups among the free joints, and each foot.
  out_.segment_names.push_back("trunk");
  segment_coords_.push_back({0, 1, 2, 3, 4, 5});
  for (const auto& [name, joints] : robot.segments) {
    std::vector<int> tasks;
    for (int j : joints) {
      for (size_t f = 0; f < robot.free_joints.size(); ++f) {
        if (robot.free_joints[f] == j) tasks.push_back(model::TaskSpace::kFree + static_cast<int>(f));
      }
    }
    if (tasks.empty()) continue;
    out_.segment_names.push_back(name);
    segment_coords_.push_back(tasks);
  }
  for (int k = 0; k < 2; ++k) {
    out_.segment_names.push_back(std::string(model::kFootNames[static_cast<size_t>(k)]) + "_foot");
    std::vector<int> tasks;
    for (int i = 0; i < 6; ++i) tasks.push_back(6 + 6 * k + i);
    segment_coords_.push_back(tasks);
  }
  out_.segment_l.assign(out_.segment_names.size(), Vector3d::Zero());
}

void MotionOptimizer::adjusted_set(const balance::TaskReference& ref, std::vector<int>& set) const {
  const bool single = ref.support != balance::Support::kDouble;
  const int swing = ref.support == balance::Support::kRight ? model::kLeft : model::kRight;
  set.clear();  // capacity: every coordinate, reserved at construction
  for (const auto& name : single ? config_.adjusted_single : config_.adjusted_double) {
    for (int c = 0; c < static_cast<int>(coords_.size()); ++c) {
      const Coordinate& co = coords_[static_cast<size_t>(c)];
      if ((name == "base_rotation" && co.kind == Coordinate::Kind::kBaseRotation) ||
          (name == "swing_foot" && single && ref.settled && co.kind == Coordinate::Kind::kFoot && co.index == swing &&
           !ref.feet[static_cast<size_t>(swing)].contact) ||
          (co.kind == Coordinate::Kind::kFreeJoint && co.name == name)) {
        set.push_back(c);
      }
    }
  }
}

void MotionOptimizer::limits(int c, const balance::TaskReference& ref, double& dmin, double& dmax, double& vmax) const {
  const Coordinate& co = coords_[static_cast<size_t>(c)];
  switch (co.kind) {
    case Coordinate::Kind::kBaseRotation:
      dmin = config_.base_min(co.axis);
      dmax = config_.base_max(co.axis);
      vmax = config_.base_velocity;
      break;
    case Coordinate::Kind::kFreeJoint: {
      const auto j = static_cast<size_t>(robot_->free_joints[static_cast<size_t>(co.index)]);
      const double q_ref = ref.q_free(co.index);
      dmin = robot_->model.q_lower[j] + config_.joint_limit_margin - q_ref;
      dmax = robot_->model.q_upper[j] - config_.joint_limit_margin - q_ref;
      vmax = config_.joint_velocity_fraction * robot_->model.v_max[j];
      break;
    }
    case Coordinate::Kind::kFoot: {
      dmin = -config_.swing_range;
      dmax = config_.swing_range;
      vmax = config_.swing_velocity;
      if (co.axis == 2) {
        // Downwards no further than `swing_clearance` above the stance sole: a swing foot that
        // touches the ground carries load the contact plan does not know of, and tips the robot.
        const auto swing = static_cast<size_t>(co.index);
        const double height = ref.feet[swing].X_WS.p.z() - ref.feet[1 - swing].X_WS.p.z();
        dmin = std::min(0.0, std::max(dmin, config_.swing_clearance - height));
      }
      break;
    }
  }
}

const MotionOptOutput& MotionOptimizer::step(const VectorXd& q, const VectorXd& v, const balance::TaskReference& ref,
                                             const Vector3d& l_ref, bool l_ref_fresh, double dt, bool cam_active) {
  model::ccrba(robot_->model, data_, q, v);  // A_G, I_c, the CoM and its Jacobian: all Ā needs
  out_.singular = !task_.update(robot_->model, data_);
  select_adjusted(ref);
  decay_unadjusted(ref);
  build_qp(ref, l_ref_fresh ? l_ref : Vector3d::Zero(), dt, cam_active);
  out_.reference_stale = !l_ref_fresh;
  solve_qp();
  integrate_offsets(ref, dt);
  compose_command(ref, dt);
  first_ = false;
  return out_;
}

void MotionOptimizer::select_adjusted(const balance::TaskReference& ref) {
  adjusted_set(ref, set_);
  const int k = static_cast<int>(set_.size());
  if (set_ != last_set_) {
    // A new QP size (a change of support) allocates its solver once; within a support mode, nothing.
    if (k != solver_size_) {
      solver_ = std::make_unique<qp::Solver>(k, 0, qp::Options{config_.max_working_set_changes, 1e-10, 1e-12, 1e-12});
      solver_size_ = k;
      H_.resize(k, k);
      g_.resize(k);
      lb_.resize(k);
      ub_.resize(k);
      A_.resize(0, k);
      lbA_.resize(0);
      ubA_.resize(0);
      xd_.resize(k);
      xa_.resize(k);
      Aa_.resize(3, k);
      for (VectorXd* o : {&out_.xa_opt, &out_.xad_opt, &out_.xa_min, &out_.xa_max, &out_.xad_min, &out_.xad_max}) o->resize(k);
    } else {
      solver_->reset();
    }
    last_set_ = set_;
    out_.adjusted = set_;
    out_.adjusted_name.resize(set_.size());
    for (size_t a = 0; a < set_.size(); ++a) out_.adjusted_name[a] = coords_[static_cast<size_t>(set_[a])].name;
  }
  std::fill(adjusted_.begin(), adjusted_.end(), 0);
  for (int c : set_) adjusted_[static_cast<size_t>(c)] = 1;
}

void MotionOptimizer::decay_unadjusted(const balance::TaskReference& ref) {
  const int nc = static_cast<int>(coords_.size());
  // Reference task velocity ẋ^ref = (ẋ_c, ω_b, ν_r, ν_l, q̇_f).
  xdot_ref_.segment<3>(0) = ref.v_com;
  xdot_ref_.segment<3>(3) = ref.omega_base;
  xdot_ref_.segment<6>(6) = ref.feet[0].twist;
  xdot_ref_.segment<6>(12) = ref.feet[1].twist;
  xdot_ref_.tail(ref.qd_free.size()) = ref.qd_free;

  // Coordinates outside x_a: their offsets decay (feet faster, and not at all once in contact).
  for (int c = 0; c < nc; ++c) {
    if (adjusted_[static_cast<size_t>(c)] != 0) continue;
    const Coordinate& co = coords_[static_cast<size_t>(c)];
    const double rate = co.kind == Coordinate::Kind::kFoot ? config_.swing_return_rate : config_.K_p;
    double dmin = 0, dmax = 0, vmax = 0;
    limits(c, ref, dmin, dmax, vmax);
    delta_dot_(c) = std::clamp(-rate * delta_(c), -vmax, vmax);
  }
  xdot_cmd_ = xdot_ref_;
  for (int c = 0; c < nc; ++c) {
    if (adjusted_[static_cast<size_t>(c)] == 0) xdot_cmd_(coords_[static_cast<size_t>(c)].task) += delta_dot_(c);
  }
}

void MotionOptimizer::build_qp(const balance::TaskReference& ref, const Vector3d& lref, double dt, bool cam_active) {
  const auto& Abar = task_.Abar();
  const int k = static_cast<int>(set_.size());
  // Ā_u ẋ_u: the CAM of everything but the adjusted coordinates.
  xu_ = xdot_cmd_;
  for (int c : set_) xu_(coords_[static_cast<size_t>(c)].task) = 0.0;
  const Vector3d l_u = Abar * xu_;
  out_.l_ref = lref;
  // The CAM task asks for l_c^ref on top of the CAM the reference motion itself carries, Ā ẋ^ref:
  // zero while the reference rests (the paper's balancing, where (14a) is Ā ẋ = l_c^ref), the
  // swinging leg's during a step (which the upper body should not cancel).
  const Vector3d l_target = lref + Abar * xdot_ref_;

  // QP (13) over ẋ_a.
  for (int a = 0; a < k; ++a) {
    const int c = set_[static_cast<size_t>(a)];
    const Coordinate& co = coords_[static_cast<size_t>(c)];
    Aa_.col(a) = Abar.col(co.task);
    const double xref_dot = xdot_ref_(co.task);
    xd_(a) = xref_dot - config_.K_p * delta_(c);  // (16)
    double dmin = 0, dmax = 0, vmax = 0;
    limits(c, ref, dmin, dmax, vmax);
    // (17) in offset form: x_min − x^opt = δ_min − δ.
    double lo = std::max(xref_dot + config_.K_a * (dmin - delta_(c)), -vmax);
    double hi = std::min(xref_dot + config_.K_a * (dmax - delta_(c)), vmax);
    if (lo > hi) lo = hi = 0.5 * (lo + hi);
    lb_(a) = lo;
    ub_(a) = hi;
    out_.xa_min(a) = dmin;
    out_.xa_max(a) = dmax;
    out_.xad_min(a) = lo;
    out_.xad_max(a) = hi;
    const auto it = config_.Q_p_overrides.find(co.name);
    const double qp_w = it != config_.Q_p_overrides.end() ? it->second : config_.Q_p;
    H_.row(a).setZero();
    H_(a, a) = qp_w;
    g_(a) = -qp_w * xd_(a);
  }
  // CAM weight: full while CAM is generated, ramped down to the idle fraction otherwise.
  // The release follows a smoothstep in time (C¹), so that the posture return starts without a
  // jump in the commanded accelerations.
  const double idle = config_.cam_idle_fraction;
  if (cam_active) {
    cam_scale_ = 1.0;
    release_progress_ = 0.0;
  } else if (first_ || config_.cam_release_time <= 0.0) {
    cam_scale_ = idle;
    release_progress_ = 1.0;
  } else {
    release_progress_ = std::min(1.0, release_progress_ + dt / config_.cam_release_time);
    const double s = release_progress_ * release_progress_ * (3.0 - 2.0 * release_progress_);
    cam_scale_ = 1.0 - s * (1.0 - idle);
  }
  out_.cam_weight_scale = cam_scale_;
  const Eigen::Matrix3d Ql = (cam_scale_ * config_.Q_l).asDiagonal();
  H_.noalias() += Aa_.transpose() * Ql * Aa_;
  g_.noalias() += Aa_.transpose() * Ql * (l_u - l_target);
}

void MotionOptimizer::solve_qp() {
  const int k = static_cast<int>(set_.size());
  const double t0 = monotonic_s();
  const qp::Status st = k > 0 ? solver_->solve_hot(H_, g_, A_, lb_, ub_, lbA_, ubA_) : qp::Status::kOptimal;
  out_.qp_solve_time_us = (monotonic_s() - t0) * 1e6;
  out_.qp_status = static_cast<int>(st);
  out_.qp_iterations = k > 0 ? solver_->working_set_changes() : 0;
  out_.qp_failed = !(qp::usable(st) && (k == 0 || solver_->primal_feasible()));
  if (!out_.qp_failed && k > 0) {
    xa_ = solver_->x();
  } else {
    xa_ = xd_.cwiseMax(lb_).cwiseMin(ub_);  // the posture task alone, within the limits
  }
}

void MotionOptimizer::integrate_offsets(const balance::TaskReference& ref, double dt) {
  const int nc = static_cast<int>(coords_.size());
  const int k = static_cast<int>(set_.size());
  for (int a = 0; a < k; ++a) {
    const int c = set_[static_cast<size_t>(a)];
    delta_dot_(c) = xa_(a) - xdot_ref_(coords_[static_cast<size_t>(c)].task);
  }
  // Feet that carry load have no offset.
  for (int c = 0; c < nc; ++c) {
    const Coordinate& co = coords_[static_cast<size_t>(c)];
    if (co.kind == Coordinate::Kind::kFoot && ref.feet[static_cast<size_t>(co.index)].contact) delta_dot_(c) = -delta_(c) / dt;
  }
  // Integrate the offsets, differentiate for the accelerations (low-passed).
  delta_ += delta_dot_ * dt;
  if (first_) delta_dot_prev_ = delta_dot_;
  const double alpha = config_.acceleration_filter > 0 ? dt / (config_.acceleration_filter + dt) : 1.0;
  delta_acc_ += alpha * ((delta_dot_ - delta_dot_prev_) / dt - delta_acc_);
  delta_dot_prev_ = delta_dot_;
  xdot_cmd_ = xdot_ref_;
  for (int c = 0; c < nc; ++c) xdot_cmd_(coords_[static_cast<size_t>(c)].task) += delta_dot_(c);
  for (int a = 0; a < k; ++a) {
    const int c = set_[static_cast<size_t>(a)];
    out_.xa_opt(a) = delta_(c);
    out_.xad_opt(a) = xa_(a);
  }
}

void MotionOptimizer::compose_command(const balance::TaskReference& ref, double dt) {
  const auto& Abar = task_.Abar();
  // The commanded trajectory: the reference with the offsets applied.
  balance::TaskReference& cmd = out_.command;
  cmd = ref;
  const Vector3d drot = delta_.segment<3>(0), drot_dot = delta_dot_.segment<3>(0), drot_acc = delta_acc_.segment<3>(0);
  cmd.R_base = model::exp3(drot) * ref.R_base;
  cmd.omega_base = ref.omega_base + drot_dot;
  cmd.omegadot_base = ref.omegadot_base + drot_acc;
  const int nf = static_cast<int>(robot_->free_joints.size());
  cmd.q_free = ref.q_free + delta_.segment(3, nf);
  cmd.qd_free = ref.qd_free + delta_dot_.segment(3, nf);
  cmd.qdd_free = ref.qdd_free + delta_acc_.segment(3, nf);
  for (int f = 0; f < 2; ++f) {
    const int c0 = 3 + nf + 3 * f;
    cmd.feet[static_cast<size_t>(f)].X_WS.p += delta_.segment<3>(c0);
    cmd.feet[static_cast<size_t>(f)].twist.head<3>() += delta_dot_.segment<3>(c0);
    cmd.feet[static_cast<size_t>(f)].accel.head<3>() += delta_acc_.segment<3>(c0);
  }

  // Commanded CAM Ā ẋ^cmd, its rate, and the share of each segment.
  out_.l_cmd = Abar * xdot_cmd_;
  // The rate by differences, except across a change of contacts: a foot's reference twist (the
  // swing at touchdown, say) jumps to zero in one tick there, and its difference quotient is an
  // impulse no CoM wrench should follow; the rate of the tick before is kept.
  const std::array<bool, 2> contact{ref.feet[0].contact, ref.feet[1].contact};
  if (first_) {
    out_.ldot_cmd.setZero();
  } else if (contact == contact_prev_) {
    out_.ldot_cmd = (out_.l_cmd - l_cmd_prev_) / dt;
  }
  contact_prev_ = contact;
  l_cmd_prev_ = out_.l_cmd;
  for (size_t s = 0; s < segment_coords_.size(); ++s) {
    Vector3d l = Vector3d::Zero();
    for (int t : segment_coords_[s]) l += Abar.col(t) * xdot_cmd_(t);
    out_.segment_l[s] = l;
  }
  out_.posture_error = delta_.cwiseAbs().maxCoeff();
}

void MotionOptimizer::reset() {
  delta_.setZero();
  delta_dot_.setZero();
  delta_dot_prev_.setZero();
  delta_acc_.setZero();
  l_cmd_prev_.setZero();
  contact_prev_ = {true, true};
  last_set_.clear();
}

}  // namespace hpr::motion_opt
