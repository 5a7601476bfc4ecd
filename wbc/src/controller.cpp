#include "hpr/wbc/controller.hpp"

#include <Eigen/Cholesky>
#include <cmath>

#include "hpr/common/log.hpp"

namespace hpr::wbc {

using Eigen::Matrix3d;
using Eigen::Vector3d;
using Eigen::VectorXd;

namespace {
Vector3d vec3_or_scalar(const Config& c, const std::string& key, const Vector3d& fallback, double lo, double hi) {
  if (!c.has(key)) return fallback;
  if (c.is_scalar(key)) return Vector3d::Constant(c.real(key, lo, hi));
  return c.vec3(key, lo, hi);
}

Vector6d vec6(const Config& c, const std::string& key, const Vector6d& fallback, double lo, double hi) {
  if (!c.has(key)) return fallback;
  const auto v = c.reals(key, 6, lo, hi);
  return Eigen::Map<const Vector6d>(v.data());
}
}  // namespace

WbcConfig WbcConfig::load(const Config& c, const model::RobotSpec& robot) {
  WbcConfig w;
  if (c.has("com")) {
    const Config s = c.section("com");
    w.K_com = vec3_or_scalar(s, "stiffness", w.K_com, 0, 1e6);
    w.D_com = vec3_or_scalar(s, "damping", w.D_com, 0, 1e5);
  }
  if (c.has("base")) {
    const Config s = c.section("base");
    w.K_base = vec3_or_scalar(s, "stiffness", w.K_base, 0, 1e5);
    w.D_base = vec3_or_scalar(s, "damping", w.D_base, 0, 1e4);
  }
  const int nf = static_cast<int>(robot.free_joints.size());
  w.K_free = VectorXd::Constant(nf, 300.0);
  w.D_free = VectorXd::Constant(nf, 30.0);
  if (c.has("free_joints")) {
    const Config s = c.section("free_joints");
    w.K_free.setConstant(s.real_or("stiffness", 300.0, 0, 1e5));
    w.D_free.setConstant(s.real_or("damping", 30.0, 0, 1e4));
    w.drive_period = s.real_or("drive_period", w.drive_period, 1e-5, 0.1);
    for (const char* which : {"stiffness_overrides", "damping_overrides"}) {
      if (!s.has(which)) continue;
      const Config o = s.section(which);
      for (const auto& name : o.keys()) {
        const int j = robot.joints({name}, o, name).front();
        bool found = false;
        for (int i = 0; i < nf; ++i) {
          if (robot.free_joints[static_cast<size_t>(i)] == j) {
            (std::string(which) == "stiffness_overrides" ? w.K_free : w.D_free)(i) = o.real(name, 0, 1e5);
            found = true;
          }
        }
        if (!found) o.fail(name, "is a leg joint; only free joints have a joint impedance");
      }
    }
  }
  if (c.has("swing_foot")) {
    const Config s = c.section("swing_foot");
    w.K_swing = vec6(s, "stiffness", w.K_swing, 0, 1e6);
    w.D_swing = vec6(s, "damping", w.D_swing, 0, 1e5);
    w.control_period = s.real_or("control_period", w.control_period, 1e-5, 0.1);
  }
  if (c.has("contact")) {
    const Config s = c.section("contact");
    ContactParams& p = w.contact;
    p.friction = s.real_or("friction", p.friction, 0.05, 2.0);
    p.torsion = s.real_or("torsion", p.torsion, 0.0, 0.5);
    p.sole_torsion = s.boolean_or("sole_torsion", p.sole_torsion);
    p.min_normal_force = s.real_or("min_normal_force", p.min_normal_force, 0.0, 1e4);
    p.max_normal_force = s.real_or("max_normal_force", p.max_normal_force, 1.0, 1e5);
    p.cop_margin = s.real_or("cop_margin", p.cop_margin, 0.0, 0.05);
  }
  if (c.has("qp")) {
    const Config s = c.section("qp");
    ContactParams& p = w.contact;
    p.force_weight = s.real_or("force_weight", p.force_weight, 1e-6, 1e6);
    p.torque_weight = s.real_or("torque_weight", p.torque_weight, 1e-6, 1e6);
    p.regularization = s.real_or("regularization", p.regularization, 1e-12, 1e3);
    p.distribution_force = s.real_or("distribution_force", p.distribution_force, 1e-9, 1e3);
    p.distribution_torque = s.real_or("distribution_torque", p.distribution_torque, 1e-9, 1e3);
    p.tangential_weight = s.real_or("tangential_weight", p.tangential_weight, 0.0, 1e3);
    p.torsion_weight = s.real_or("torsion_weight", p.torsion_weight, 0.0, 1e3);
    p.max_working_set_changes = static_cast<int>(s.integer_or("max_working_set_changes", p.max_working_set_changes, 1, 10000));
  }
  w.impedance_at_drive = c.boolean_or("impedance_at_drive", w.impedance_at_drive);
  w.joint_damping = c.real_or("joint_damping", w.joint_damping, 0.0, 100.0);
  w.tau_z_limit = c.real_or("tau_z_limit", w.tau_z_limit, 0.0, 1e4);
  w.max_torque_fraction = c.real_or("max_torque_fraction", w.max_torque_fraction, 0.1, 1.0);
  return w;
}

WbcConfig cap_impedances(WbcConfig w, const model::RobotSpec& robot) {
  const int nf = static_cast<int>(robot.free_joints.size());
  if (w.K_free.size() == 0) w.K_free = VectorXd::Constant(nf, 300.0);
  if (w.D_free.size() == 0) w.D_free = VectorXd::Constant(nf, 30.0);
  if (w.K_free.size() != nf || w.D_free.size() != nf) {
    throw std::invalid_argument("wbc: " + std::to_string(w.K_free.size()) + " free-joint stiffnesses and " +
                                std::to_string(w.D_free.size()) + " dampings for " + std::to_string(nf) + " free joints");
  }
  const model::Model& m = robot.model;
  model::Data data(m);
  model::crba(m, data, robot.standing_configuration());
  const Eigen::MatrixXd Minv = data.M.llt().solve(Eigen::MatrixXd::Identity(m.nv, m.nv));
  // An explicitly evaluated spring-damper on a light link is stable only for kp ≤ 0.2 I/h², kd ≤ 0.5 I/h,
  // with I = 1/(M⁻¹)_jj the inertia the joint torque meets.
  {
    for (int i = 0; i < nf; ++i) {
      const int j = robot.free_joints[static_cast<size_t>(i)];
      const double I = 1.0 / Minv(6 + j, 6 + j);
      const double kmax = 0.2 * I / (w.drive_period * w.drive_period), dmax = 0.5 * I / w.drive_period;
      if (w.K_free(i) > kmax || w.D_free(i) > dmax) {
        log::debug("wbc: joint {} impedance limited to kp {:.3g}, kd {:.3g} (inertia {:.3g} kg m², drive period {} s)",
                   robot.model.joint_name[static_cast<size_t>(j)], std::min(w.K_free(i), kmax),
                   std::min(w.D_free(i), dmax), I, w.drive_period);
      }
      w.K_free(i) = std::min(w.K_free(i), kmax);
      w.D_free(i) = std::min(w.D_free(i), dmax);
    }
  }
  // The swing foot impedance is evaluated by the controller every period: cap it like the joints,
  // with the foot's apparent inertia Λ_ii = 1 / (J M⁻¹ Jᵀ)_ii along each Cartesian direction.
  {
    model::Matrix6Xd J(6, m.nv);
    for (int k = 0; k < 2; ++k) {
      model::frame_jacobian(m, data, robot.feet[static_cast<size_t>(k)].sole_frame, model::ReferenceFrame::kLocalWorldAligned, J);
      const Eigen::Matrix<double, 6, 6> Linv = J * Minv * J.transpose();
      for (int i = 0; i < 6; ++i) {
        const double L = 1.0 / Linv(i, i);
        w.K_swing(i) = std::min(w.K_swing(i), 0.2 * L / (w.control_period * w.control_period));
        w.D_swing(i) = std::min(w.D_swing(i), 0.5 * L / w.control_period);
      }
    }
  }
  return w;
}

WholeBodyController::WholeBodyController(const model::RobotSpec& robot, WbcConfig config)
    : robot_(&robot), config_(cap_impedances(std::move(config), robot)), data_(robot.model), task_(robot), qp_(config_.contact) {
  const int n = robot.model.nj, nbar = robot.model.nv;
  command_.resize(n);
  xdot_cmd_ = xddot_cmd_ = nu_cmd_ = nudot_cmd_ = y_ = w_task_ = jt_ = VectorXd::Zero(nbar);
  tau_f_imp_ = VectorXd::Zero(static_cast<int>(robot.free_joints.size()));
  tau_total_ = VectorXd::Zero(n);
  for (auto& w : w_feet_) w.setZero();
  for (auto& w : last_valid_grf_) w.setZero();
}

const JointCommand& WholeBodyController::step(const RobotState& state, const balance::TaskReference& cmd) {
  const model::Model& m = robot_->model;
  status_.tick = state.tick;
  status_.time = state.time;
  model::compute_all_terms(m, data_, state.q, state.v);
  status_.singular = !task_.update(m, data_);
  command_velocities(cmd);

  // Feedforward (20): M̄ ν̇^cmd + C̄ ν^cmd, on the kinematics compute_all_terms made (once per tick).
  y_ = model::centroidal_inverse_dynamics_from_kinematics(m, data_, state.v, nu_cmd_, nudot_cmd_);
  const Vector6d w_ff = y_.head<6>();
  impedances(state, cmd);

  // Desired CoM wrench (8): Adᵀ w_grf = w_ff − w_g − w_imp − Ad_swᵀ w_sw.
  Vector6d w_rest = Vector6d::Zero();
  w_rest.head<3>() = -m.mass * m.gravity;  // −w_g
  w_rest -= w_imp_;
  for (int k = 0; k < 2; ++k) {
    if (cmd.feet[static_cast<size_t>(k)].contact) continue;
    w_rest -= task_.Ad().block<6, 6>(6 * k, 0).transpose() * w_swing_[static_cast<size_t>(k)];
  }
  const Vector6d w_des = w_ff + w_rest;
  distribute(cmd, w_des);

  // Joint torques (9): τ = τ^ff − J'ᵀ w_feet − S_fᵀ τ_f^imp (the joint rows of Jᵀ (w_imp, w_feet, τ_f^imp)).
  const int n = m.nj, nf = static_cast<int>(robot_->free_joints.size());
  w_task_.head<6>() = w_imp_;
  w_task_.segment<6>(6) = w_feet_[0];
  w_task_.segment<6>(12) = w_feet_[1];
  w_task_.tail(nf) = tau_f_imp_;
  task_.apply_transpose(w_task_, jt_);
  tau_total_ = y_.tail(n) - jt_.tail(n);
  joint_command(state, cmd);

  status_.w_des = w_des;
  status_.support = cmd.support;
  virtual_stance_foot(cmd, w_ff, w_rest);
  return command_;
}

void WholeBodyController::command_velocities(const balance::TaskReference& cmd) {
  // Commanded task velocities and accelerations, ordered as ẋ = (ν_c, ν_r, ν_l, q̇_f).
  const int nf = static_cast<int>(robot_->free_joints.size());
  xdot_cmd_.segment<3>(0) = cmd.v_com;
  xdot_cmd_.segment<3>(3) = cmd.omega_base;
  xddot_cmd_.segment<3>(0) = cmd.a_com;
  xddot_cmd_.segment<3>(3) = cmd.omegadot_base;
  for (int k = 0; k < 2; ++k) {
    xdot_cmd_.segment<6>(6 + 6 * k) = cmd.feet[static_cast<size_t>(k)].twist;
    xddot_cmd_.segment<6>(6 + 6 * k) = cmd.feet[static_cast<size_t>(k)].accel;
  }
  xdot_cmd_.tail(nf) = cmd.qd_free;
  xddot_cmd_.tail(nf) = cmd.qdd_free;
  task_.solve(xdot_cmd_, nu_cmd_);
  task_.solve(xddot_cmd_, nudot_cmd_);
}

void WholeBodyController::impedances(const RobotState& state, const balance::TaskReference& cmd) {
  const model::Model& m = robot_->model;
  const auto& free = robot_->free_joints;
  const int nf = static_cast<int>(free.size());
  const Eigen::VectorXd& q = state.q;
  const Eigen::VectorXd& v = state.v;
  const Vector3d c = data_.com, cd = data_.vcom;
  const Matrix3d R_b = data_.oMi[0].R;
  const Vector3d w_b = R_b * v.segment<3>(3);
  // Impedances (6): CoM spring-damper; rotational spring on SO(3) from the quaternion of R_cmdᵀ R_b.
  w_imp_.head<3>() = config_.K_com.cwiseProduct(c - cmd.p_com) + config_.D_com.cwiseProduct(cd - cmd.v_com);
  Eigen::Quaterniond qe(cmd.R_base.transpose() * R_b);
  if (qe.w() < 0) qe.coeffs() = -qe.coeffs();
  const Vector3d spring = cmd.R_base * config_.K_base.cwiseProduct(2.0 * qe.w() * qe.vec());
  w_imp_.tail<3>() = spring + config_.D_base.cwiseProduct(w_b - cmd.omega_base);
  // (7) free joints.
  for (int i = 0; i < nf; ++i) {
    const int j = free[static_cast<size_t>(i)];
    tau_f_imp_(i) = config_.K_free(i) * (q(7 + j) - cmd.q_free(i)) + config_.D_free(i) * (v(6 + j) - cmd.qd_free(i));
  }
  // Swing feet: Cartesian impedance wrench at the sole (world axes).
  for (int k = 0; k < 2; ++k) {
    const auto ku = static_cast<size_t>(k);
    w_swing_[ku].setZero();
    if (cmd.feet[ku].contact) continue;
    const model::SE3& X = task_.sole(k);
    const Vector6d twist = model::frame_velocity(m, data_, robot_->feet[ku].sole_frame, model::ReferenceFrame::kLocalWorldAligned);
    Vector6d e;
    e.head<3>() = X.p - cmd.feet[ku].X_WS.p;
    e.tail<3>() = cmd.feet[ku].X_WS.R * model::log3(cmd.feet[ku].X_WS.R.transpose() * X.R);
    w_swing_[ku] = config_.K_swing.cwiseProduct(e) + config_.D_swing.cwiseProduct(twist - cmd.feet[ku].twist);
  }
}

void WholeBodyController::distribute(const balance::TaskReference& cmd, const Vector6d& w_des) {
  // Contact wrench distribution.
  std::array<Contact, 2> contacts;
  for (int k = 0; k < 2; ++k) {
    const auto ku = static_cast<size_t>(k);
    contacts[ku].active = cmd.feet[ku].contact;
    contacts[ku].X_WS = task_.sole(k);
    contacts[ku].length = robot_->feet[ku].length;
    contacts[ku].width = robot_->feet[ku].width;
    contacts[ku].load_limit = cmd.feet[ku].load_limit;
  }
  const qp::Status qs = qp_.solve(contacts, data_.com, w_des);
  status_.qp_status = static_cast<int>(qs);
  status_.qp_iterations = qp_.iterations();
  status_.qp_solve_time_us = qp_.solve_time_us();
  const bool qp_ok = qp_.valid();
  status_.qp_fallback = !qp_ok;
  status_.qp_exact = qp_ok && qp_.exact();
  std::array<Vector6d, 2> w_grf = qp_ok ? qp_.wrenches() : last_valid_grf_;
  if (qp_ok) {
    last_valid_grf_ = w_grf;
    have_valid_grf_ = true;
  }
  for (int k = 0; k < 2; ++k) {
    const auto ku = static_cast<size_t>(k);
    if (!contacts[ku].active) w_grf[ku].setZero();
    w_feet_[ku] = contacts[ku].active ? w_grf[ku] : w_swing_[ku];
    status_.contact_wrench_W[ku] = w_grf[ku];
    status_.contact_active[ku] = contacts[ku].active;
  }
  status_.w_achieved = qp_ok ? qp_.achieved() : status_.w_achieved;
}

void WholeBodyController::joint_command(const RobotState& state, const balance::TaskReference& cmd) {
  const model::Model& m = robot_->model;
  const int n = m.nj;
  const auto& free = robot_->free_joints;
  const int nf = static_cast<int>(free.size());
  const Eigen::VectorXd& q = state.q;
  // The free joints' impedance may be left to the drives.
  command_.tick = state.tick;
  command_.time = state.time;
  command_.mode = JointCommand::Mode::kRun;
  command_.tau_ff = tau_total_;
  command_.kp.setZero();
  command_.kd.setConstant(config_.joint_damping);
  command_.q_des = q.tail(n);
  command_.qd_des = nu_cmd_.tail(n);
  if (config_.impedance_at_drive) {
    for (int i = 0; i < nf; ++i) {
      const int j = free[static_cast<size_t>(i)];
      command_.tau_ff(j) += tau_f_imp_(i);
      command_.kp(j) = config_.K_free(i);
      command_.kd(j) = config_.D_free(i) + config_.joint_damping;
      command_.q_des(j) = cmd.q_free(i);
      command_.qd_des(j) = cmd.qd_free(i);
    }
  }
  // Within the joint's limits: torque (a fraction of the effort limit), velocity and position
  // targets (a drive refuses a command outside its ranges; near a stretched knee J⁻¹ asks for more).
  status_.saturated = false;
  auto saturate = [&](double& x, double lo, double hi) {
    if (!(x < lo || x > hi)) return;
    x = std::clamp(x, lo, hi);
    status_.saturated = true;
  };
  for (int j = 0; j < n; ++j) {
    const auto ju = static_cast<size_t>(j);
    const double lim = config_.max_torque_fraction * m.tau_max[ju];
    saturate(command_.tau_ff(j), -lim, lim);
    if (std::isfinite(m.v_max[ju]) && m.v_max[ju] > 0) saturate(command_.qd_des(j), -m.v_max[ju], m.v_max[ju]);
    if (command_.kp(j) > 0 && m.q_lower[ju] < m.q_upper[ju]) saturate(command_.q_des(j), m.q_lower[ju], m.q_upper[ju]);
  }
  if (!command_.tau_ff.allFinite() || !command_.q_des.allFinite() || !command_.qd_des.allFinite()) {
    // Never a non-finite number to a motor: damp instead.
    command_.mode = JointCommand::Mode::kDamp;
    command_.tau_ff.setZero();
    command_.kp.setZero();
    command_.kd.setConstant(std::max(config_.joint_damping, 5.0));
    command_.q_des = q.tail(n).allFinite() ? Eigen::VectorXd(q.tail(n)) : Eigen::VectorXd::Zero(n);
    command_.qd_des.setZero();
  }
}

void WholeBodyController::virtual_stance_foot(const balance::TaskReference& cmd, const Vector6d& w_ff,
                                              const Vector6d& w_rest) {
  // Origin: between the soles in contact (or the stance sole); axes: yaw of the support.
  std::array<model::SE3, 2> soles{task_.sole(model::kRight), task_.sole(model::kLeft)};
  const bool r = cmd.feet[model::kRight].contact, l = cmd.feet[model::kLeft].contact;
  Vector3d p_v;
  double yaw;
  if (r && l) {
    p_v = 0.5 * (soles[0].p + soles[1].p);
    const Vector3d d = soles[1].p - soles[0].p;
    yaw = std::atan2(d.y(), d.x()) - M_PI / 2;
  } else {
    const model::SE3& s = soles[r ? 0 : 1];
    p_v = s.p;
    yaw = std::atan2(s.R(1, 0), s.R(0, 0));
  }
  const Matrix3d R_v = Eigen::AngleAxisd(yaw, Vector3d::UnitZ()).toRotationMatrix();
  const Vector3d r_vc = data_.com - p_v;
  // (18), (19): torques about the virtual stance foot of the CoM wrench parts. The hip torque is
  // taken as (21), the feedforward torque τ_b^ff alone: the paper's balancing has a resting CoM
  // reference (f_c^ff = 0) and there (19) and (21) agree; a CoM reference that moves by design (a
  // step's inverted pendulum) asks for its feedforward force from the CoP, the ankle strategy.
  const Vector3d hip = w_ff.tail<3>();
  const Vector3d ankle = w_rest.tail<3>() + r_vc.cross(w_rest.head<3>() + w_ff.head<3>());
  status_.p_WV = p_v;
  status_.yaw_WV = yaw;
  status_.tau_hip_V = R_v.transpose() * hip;
  status_.tau_ankle_V = R_v.transpose() * ankle;
  status_.tau_V = status_.tau_hip_V + status_.tau_ankle_V;
  const double fz = w_ff.z() + w_rest.z();
  status_.f_vz = fz;
  // Support area in V: the box around the corners of the soles in contact.
  double xmin = 1e9, xmax = -1e9, ymin = 1e9, ymax = -1e9;
  for (int k = 0; k < 2; ++k) {
    const auto ku = static_cast<size_t>(k);
    if (!cmd.feet[ku].contact) continue;
    for (int sx : {-1, 1}) {
      for (int sy : {-1, 1}) {
        const Vector3d corner = soles[ku].act(Vector3d(0.5 * sx * robot_->feet[ku].length, 0.5 * sy * robot_->feet[ku].width, 0));
        const Vector3d cv = R_v.transpose() * (corner - p_v);
        xmin = std::min(xmin, cv.x());
        xmax = std::max(xmax, cv.x());
        ymin = std::min(ymin, cv.y());
        ymax = std::max(ymax, cv.y());
      }
    }
  }
  // (22): p_v = (−τ_y, τ_x) / f_vz inside [xmin, xmax] x [ymin, ymax].
  const double f = std::max(fz, 0.0);
  status_.tau_min_V = Vector3d(f * ymin, -f * xmax, -config_.tau_z_limit);
  status_.tau_max_V = Vector3d(f * ymax, -f * xmin, config_.tau_z_limit);
  status_.cop_V = fz > 1e-6 ? Eigen::Vector2d(-status_.tau_V.y() / fz, status_.tau_V.x() / fz) : Eigen::Vector2d::Zero();
  // CoP of the distributed contact wrenches.
  Vector3d tau_m = Vector3d::Zero();
  double fz_m = 0;
  for (int k = 0; k < 2; ++k) {
    const auto ku = static_cast<size_t>(k);
    if (!cmd.feet[ku].contact) continue;
    const Vector6d& w = status_.contact_wrench_W[ku];
    tau_m += w.tail<3>() + (soles[ku].p - p_v).cross(w.head<3>());
    fz_m += w.z();
  }
  const Vector3d tm = R_v.transpose() * tau_m;
  status_.cop_measured_V = fz_m > 1e-6 ? Eigen::Vector2d(-tm.y() / fz_m, tm.x() / fz_m) : Eigen::Vector2d::Zero();
}

}  // namespace hpr::wbc
