#include "hpr/estimator/estimator.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace hpr::estimator {

using Eigen::Matrix3d;
using Eigen::Vector3d;
using model::SE3;
using model::Vector6d;

namespace {

constexpr int kRight = 0, kLeft = 1;
const Vector3d kZ = Vector3d::UnitZ();

/// The rotation with the yaw of R and no roll or pitch (heading of the x axis projected on the ground).
Matrix3d level(const Matrix3d& R) {
  const double yaw = std::atan2(R(1, 0), R(0, 0));
  return Eigen::AngleAxisd(yaw, kZ).toRotationMatrix();
}

double yaw_of(const Matrix3d& R) { return std::atan2(R(1, 0), R(0, 0)); }

}  // namespace

Eigen::Vector2d alpha_beta_gains(double dt, double accel_noise, double pos_noise) {
  // Constant-velocity model, white acceleration of density σ_a: Q = σ_a² [dt³/3 dt²/2; dt²/2 dt].
  Eigen::Matrix2d F;
  F << 1.0, dt, 0.0, 1.0;
  const double qa = accel_noise * accel_noise;
  Eigen::Matrix2d Q;
  Q << qa * dt * dt * dt / 3.0, qa * dt * dt / 2.0, qa * dt * dt / 2.0, qa * dt;
  const double R = pos_noise * pos_noise;
  Eigen::Matrix2d P = Q * 10.0 + Eigen::Matrix2d::Identity() * R;
  Eigen::Vector2d K = Eigen::Vector2d::Zero();
  for (int it = 0; it < 100000; ++it) {
    const Eigen::Matrix2d Pp = F * P * F.transpose() + Q;
    const Eigen::Vector2d Kn = Pp.col(0) / (Pp(0, 0) + R);
    P = Pp - Kn * Pp.row(0);
    const bool done = (Kn - K).cwiseAbs().maxCoeff() < 1e-14;
    K = Kn;
    if (done) break;
  }
  return {K(0), K(1) * dt};  // α, β (β scaled so that q̇ += β r / dt)
}

Estimator::Estimator(const model::RobotSpec& robot, EstimatorConfig config)
    : robot_(&robot), config_(config), data_(robot.model) {
  const model::Model& m = robot.model;
  q_local_ = m.neutral();
  v_local_ = Eigen::VectorXd::Zero(m.nv);
  qj_ = qdj_ = Eigen::VectorXd::Zero(m.nj);
  state_.q = m.neutral();
  state_.v = Eigen::VectorXd::Zero(m.nv);
  state_.tau = Eigen::VectorXd::Zero(m.nj);
  state_.status = kStatusInitialising;
  for (auto& w : wrench_W_) w.setZero();
  for (auto& R : R_WS_hold_) R.setIdentity();
}

void Estimator::reset() {
  initialised_ = false;
  anchored_ = false;
  state_.status = kStatusInitialising;
  contact_ = {};
  turned_ = {};
  implausible_.clear();
}

double Estimator::position_std() const { return std::sqrt(P_.diagonal().head<3>().maxCoeff()); }

bool Estimator::plausible(const SensorSample& s) {
  const model::Model& m = robot_->model;
  implausible_.clear();
  if (s.q.size() != m.nj || s.qd.size() != m.nj || s.tau.size() != m.nj) {
    implausible_ = fmt::format("joint arrays of size {}/{}/{}, the model has {} joints", s.q.size(), s.qd.size(),
                               s.tau.size(), m.nj);
    return false;
  }
  if (!std::isfinite(s.time)) implausible_ = "non-finite time";
  for (int j = 0; j < m.nj && implausible_.empty(); ++j) {
    const auto ju = static_cast<size_t>(j);
    if (!std::isfinite(s.q(j)) || !std::isfinite(s.qd(j)) || !std::isfinite(s.tau(j))) {
      implausible_ = fmt::format("joint '{}': non-finite reading", m.joint_name[ju]);
    } else if (s.q(j) < m.q_lower[ju] - config_.joint_limit_margin || s.q(j) > m.q_upper[ju] + config_.joint_limit_margin) {
      implausible_ = fmt::format("joint '{}': position {:.3f} rad outside [{:.3f}, {:.3f}]", m.joint_name[ju], s.q(j),
                                 m.q_lower[ju], m.q_upper[ju]);
    }
  }
  if (implausible_.empty()) {
    if (!s.imu_gyro_B.allFinite() || !s.imu_accel_B.allFinite()) {
      implausible_ = "IMU: non-finite reading";
    } else if (s.imu_accel_B.norm() > config_.max_accel) {
      implausible_ = fmt::format("IMU: specific force {:.1f} m/s² above {:.1f}", s.imu_accel_B.norm(), config_.max_accel);
    } else if (s.imu_gyro_B.norm() > config_.max_gyro) {
      implausible_ = fmt::format("IMU: angular rate {:.1f} rad/s above {:.1f}", s.imu_gyro_B.norm(), config_.max_gyro);
    }
  }
  for (int k = 0; k < 2 && implausible_.empty(); ++k) {
    const auto& w = s.ft_wrench_S[static_cast<size_t>(k)];
    if (!w.allFinite()) {
      implausible_ = fmt::format("{} force/torque sensor: non-finite reading", k == kRight ? "right" : "left");
    } else if (w.head<3>().norm() > config_.max_ft_force) {
      implausible_ = fmt::format("{} force/torque sensor: force {:.0f} N above {:.0f}", k == kRight ? "right" : "left",
                                 w.head<3>().norm(), config_.max_ft_force);
    }
  }
  if (implausible_.empty() && initialised_ && !(s.time > last_time_)) {
    implausible_ = fmt::format("time {:.6f} s does not advance (last {:.6f} s)", s.time, last_time_);
  }
  return implausible_.empty();
}

void Estimator::step(const Inputs& in, Outputs& out) {
  out.state = update(in.sensors);
  report(out.state, out.report);
}

void Estimator::report(const EstimatedState& s, StepReport& r) const {
  r.begin();
  r.set("implausible", !implausible_.empty(), implausible_);
  if ((s.status & kStatusCovariance) != 0) {
    r.raise("covariance", "position standard deviation {:.3f} m", position_std());
  } else {
    r.clear("covariance");
  }
  r.set("contact", (s.status & kStatusNoContact) != 0 && (s.status & kStatusInitialising) == 0, "no foot in contact");
  if ((s.status & kStatusInitialising) != 0) r.outcome = StepOutcome::kNotReady;
}

const EstimatedState& Estimator::update(const SensorSample& s) {
  if (!plausible(s)) {
    // The previous estimate, for this tick, flagged: consumers step on every tick and decide.
    state_.tick = s.tick;
    if (std::isfinite(s.time) && s.time > state_.time) state_.time = s.time;
    state_.status |= kStatusImplausible;
    return state_;
  }
  if (!initialised_) {
    // Only from a complete sample: a joint whose drive has not answered yet has no reading at all.
    bool complete = true;
    for (int j = 0; j < s.q.size(); ++j) complete = complete && !s.stale(j);
    if (!complete) {
      state_.tick = s.tick;
      if (s.time > state_.time) state_.time = s.time;  // the output's clock runs with the sample's
      state_.status = kStatusInitialising | kStatusSensorStale;  // no estimate yet: nothing to act on
      return state_;
    }
    initialise(s);
    output(s, 0.0);
    return state_;
  }
  const double dt = s.time - last_time_;
  last_time_ = s.time;
  update_joints(s, dt);
  leg_kinematics();
  update_contacts(s);
  if (!anchored_ && (contact_[kRight] || contact_[kLeft])) {
    // First contact after an initialisation in the air: place the world frame now.
    const double t0 = t0_;
    initialise(s);
    t0_ = t0;
    output(s, 0.0);
    return state_;
  }
  attitude(s, dt);
  position(s, dt);
  output(s, dt);
  return state_;
}

void Estimator::update_joints(const SensorSample& s, double dt) {
  // A joint whose drive did not answer this tick holds an old reading: predicted only.
  if (!config_.filter_joints) {
    for (int j = 0; j < qj_.size(); ++j) {
      if (s.stale(j)) {
        qj_(j) += qdj_(j) * dt;
      } else {
        qj_(j) = s.q(j);
        qdj_(j) = s.qd(j);
      }
    }
    return;
  }
  if (std::abs(dt - ab_dt_) > 0.01 * ab_dt_) {
    ab_ = alpha_beta_gains(dt, config_.joint_accel_noise, config_.encoder_noise);
    ab_dt_ = dt;
  }
  for (int j = 0; j < qj_.size(); ++j) {
    const double pred = qj_(j) + qdj_(j) * dt;
    if (s.stale(j)) {
      qj_(j) = pred;
      continue;
    }
    const double r = s.q(j) - pred;
    qj_(j) = pred + ab_(0) * r;
    qdj_(j) += ab_(1) * r / dt;
  }
}

void Estimator::leg_kinematics() {
  const model::Model& m = robot_->model;
  q_local_.tail(m.nj) = qj_;
  v_local_.tail(m.nj) = qdj_;
  model::forward_kinematics(m, data_, q_local_, v_local_);
  const int imu = robot_->imu_frame;
  const SE3& X_BI = model::update_frame_placement(m, data_, imu);
  p_BI_ = X_BI.p;
  R_BI_ = X_BI.R;
  const Vector6d vi = model::frame_velocity(m, data_, imu, model::ReferenceFrame::kLocalWorldAligned);
  v_BI_ = vi.head<3>();
  w_BI_ = vi.tail<3>();
  for (int k = 0; k < 2; ++k) {
    const auto ku = static_cast<size_t>(k);
    const model::FootSpec& foot = robot_->feet[ku];
    X_BS_[ku] = model::update_frame_placement(m, data_, foot.sole_frame);
    const Vector6d vs = model::frame_velocity(m, data_, foot.sole_frame, model::ReferenceFrame::kLocalWorldAligned);
    v_BS_[ku] = vs.head<3>();
    w_BS_[ku] = vs.tail<3>();
    X_BF_[ku] = model::update_frame_placement(m, data_, foot.ft_frame);
    // The part below the sensor: the sensor's body and its subtree.
    const int fb = m.frames[static_cast<size_t>(foot.ft_frame)].body;
    double mass = 0.0;
    Vector3d moment = Vector3d::Zero();
    for (int b = fb; b < fb + m.subtree_size[static_cast<size_t>(fb)]; ++b) {
      mass += data_.Iw[static_cast<size_t>(b)].m;
      moment += data_.Iw[static_cast<size_t>(b)].h;
    }
    m_F_[ku] = mass;
    c_BF_[ku] = mass > 0 ? Vector3d(moment / mass) : X_BF_[ku].p;
  }
}

constexpr double kTouchdownSettle = 0.03;  // [s]

void Estimator::update_contacts(const SensorSample& s) {
  const Vector3d g = robot_->model.gravity;
  const std::array<double, 2> z_low{lowest_corner_z(kRight), lowest_corner_z(kLeft)};
  for (int k = 0; k < 2; ++k) {
    const auto ku = static_cast<size_t>(k);
    const Matrix3d R_WF = R_ * X_BF_[ku].R;
    const Vector6d& w_S = s.ft_wrench_S[ku];
    // The sensor reads (foot on leg) = ground wrench + the foot's weight − its momentum rate; the
    // last term is neglected (a foot in contact is at rest).
    const Vector3d f_W = R_WF * w_S.head<3>();
    const Vector3d tau_F = R_WF * w_S.tail<3>();
    const Vector3d weight = m_F_[ku] * g;
    const Vector3d f_ground = f_W - weight;
    const Vector3d tau_ground_F = tau_F - (R_ * (c_BF_[ku] - X_BF_[ku].p)).cross(weight);
    // Moved to the sole centre.
    const Vector3d r_SF = R_ * (X_BF_[ku].p - X_BS_[ku].p);
    wrench_W_[ku].head<3>() = f_ground;
    wrench_W_[ku].tail<3>() = tau_ground_F + r_SF.cross(f_ground);
    fz_[ku] = f_ground.z();
    const bool was = contact_[ku];
    contact_[ku] = was ? fz_[ku] > config_.contact_off : fz_[ku] > config_.contact_on;
    // On level ground a sole well above the other one is in the air, whatever its sensor reads (a
    // swinging foot's own inertia loads it). Heights of the lowest corners: a sole rolling on its
    // toe lifts its centre, not its edge.
    if (config_.level_ground && config_.contact_max_height > 0.0) {
      const double dz = z_low[ku] - z_low[1 - ku];
      if (dz > config_.contact_max_height) contact_[ku] = false;
    }
    // Centre of pressure in the sole frame: near an edge the sole may be rotating about it.
    const model::FootSpec& foot = robot_->feet[ku];
    const Matrix3d R_WSole = R_ * X_BS_[ku].R;
    const Vector3d f_S = R_WSole.transpose() * f_ground, tau_S = R_WSole.transpose() * wrench_W_[ku].tail<3>();
    const bool pressed = contact_[ku] && f_S.z() > config_.contact_off;
    bool flat = pressed;
    if (pressed) {
      const double cx = -tau_S.y() / f_S.z(), cy = tau_S.x() / f_S.z();
      cop_S_[ku] = Vector3d(std::clamp(cx, -0.5 * foot.length, 0.5 * foot.length), std::clamp(cy, -0.5 * foot.width, 0.5 * foot.width), 0.0);
      flat = 0.5 * foot.length - std::abs(cx) > config_.cop_edge_margin && 0.5 * foot.width - std::abs(cy) > config_.cop_edge_margin;
    }
    // A sole that turns (base rate plus the leg's, from the last tick) rolls about an edge or has
    // not settled: its centre is not at rest.
    const bool turning = pressed && config_.anchor_max_rate > 0.0 && (w_ + w_BS_[ku]).norm() > config_.anchor_max_rate;
    if (contact_[ku] && !was && initialised_) touchdown_time_[ku] = s.time;  // (standing at the start: settle_at_start)
    // A sole that turned in contact (rolled on an edge) and stops with its CoP back inside has
    // landed on its face: the impact, like a touchdown's, is in the leg's filtered joint rates
    // (settle_after_roll).
    if (config_.settle_after_roll && flat && !turning && turned_[ku]) touchdown_time_[ku] = s.time;
    turned_[ku] = contact_[ku] && (turning || (turned_[ku] && !flat));
    if (turning) flat = false;
    // Right after a touchdown the sole settles and the leg's joint rates, filtered, still carry the
    // swing: its kinematics correct nothing yet.
    if (s.time - touchdown_time_[ku] < kTouchdownSettle) flat = false;
    // A sole that is no anchor follows the leg in the position filter and the estimate in heading
    // (position()); when it becomes one, it is seated where the estimate puts it: its heading held
    // (and, on uneven ground, its tilt) and its position started from the leg kinematics. So a sole
    // that turned or slid while it rolled on an edge (or before a touchdown settled) corrects
    // nothing with where it used to be.
    const bool seat = flat && !anchor_[ku];
    anchor_[ku] = flat;
    // Settled, no anchor, and carrying a good part of the weight (friction holds its CoP point): it
    // rolls on an edge or turns about that point, which stays at rest.
    rolling_[ku] = pressed && !flat && f_S.z() > config_.edge_min_load * robot_->model.mass * g.norm() &&
                   s.time - touchdown_time_[ku] >= kTouchdownSettle;
    if (seat) {
      const Matrix3d R_WS = R_ * X_BS_[ku].R;
      R_WS_hold_[ku] = config_.level_ground ? level(R_WS) : R_WS;
      const int i = 6 + 3 * k;
      const Vector3d d = R_ * (X_BS_[ku].p - p_BI_);
      x_.segment<3>(i) = x_.head<3>() + d;
      P_.middleRows<3>(i) = P_.topRows<3>();
      P_.middleCols<3>(i) = P_.leftCols<3>();
      P_.block<3, 3>(i, i) = P_.topLeftCorner<3, 3>() + Matrix3d::Identity() * std::pow(config_.kinematic_position_noise, 2);
    }
  }
}

Vector3d Estimator::imu_velocity_at_rest(size_t k, const Vector3d& r_S) const {
  // v_I = −R (ω × d + ḋ), d = p_BC − p_BI, C the point r_S of sole k (sole frame), ḋ its velocity
  // relative to the IMU point through the leg.
  const Vector3d r_SC = X_BS_[k].R * r_S;
  const Vector3d d = X_BS_[k].p + r_SC - p_BI_;
  return -R_ * (w_.cross(d) + v_BS_[k] + w_BS_[k].cross(r_SC) - v_BI_);
}

double Estimator::lowest_corner_z(size_t k) const {
  const model::FootSpec& foot = robot_->feet[k];
  double z = std::numeric_limits<double>::infinity();
  for (const double sx : {-0.5, 0.5}) {
    for (const double sy : {-0.5, 0.5}) {
      const Vector3d corner = X_BS_[k].p + X_BS_[k].R * Vector3d(sx * foot.length, sy * foot.width, 0.0);
      z = std::min(z, (R_ * corner).z());
    }
  }
  return z;
}

void Estimator::initialise(const SensorSample& s) {
  const model::Model& m = robot_->model;
  qj_ = s.q;
  qdj_ = config_.filter_joints ? Eigen::VectorXd::Zero(m.nj) : s.qd;
  leg_kinematics();
  // Heading from the IMU's own orientation output when it is a unit quaternion, else zero.
  const Eigen::Vector4d& qi = s.imu_quat_WB;
  double yaw = 0.0;
  if (qi.allFinite() && std::abs(qi.norm() - 1.0) < 0.05) {
    const Eigen::Quaterniond quat(qi(0), qi(1), qi(2), qi(3));
    yaw = yaw_of(quat.normalized().toRotationMatrix() * R_BI_.transpose());
  }
  // Roll and pitch: the soles flat (feet loaded), else the accelerometer's gravity direction. A
  // second pass keeps only the soles that are anchors (CoP inside the sole) when there are any.
  auto orientation_from = [&](const std::array<bool, 2>& use) {
    Matrix3d R0;
    const Matrix3d Rr = X_BS_[kRight].R.transpose(), Rl = X_BS_[kLeft].R.transpose();
    if (use[kRight] && use[kLeft]) {
      R0 = Rr * model::exp3(0.5 * model::log3(Rr.transpose() * Rl));
    } else if (use[kRight] || use[kLeft]) {
      R0 = use[kRight] ? Rr : Rl;
    } else {
      const Vector3d u = (R_BI_ * s.imu_accel_B).normalized();  // gravity's "up" in B
      R0 = Eigen::Quaterniond::FromTwoVectors(u, kZ).toRotationMatrix();
    }
    R_ = Eigen::AngleAxisd(yaw - yaw_of(R0), kZ).toRotationMatrix() * R0;
    contact_ = {};
    update_contacts(s);
  };
  R_.setIdentity();
  orientation_from({s.ft_wrench_S[kRight].head<3>().norm() > config_.contact_on,
                    s.ft_wrench_S[kLeft].head<3>().norm() > config_.contact_on});
  const bool any_anchor = anchor_[kRight] || anchor_[kLeft];
  if (any_anchor && anchor_ != contact_) orientation_from(anchor_);
  b_.setZero();
  P_att_.setZero();
  P_att_.topLeftCorner<3, 3>() = Matrix3d::Identity() * std::pow(0.01, 2);
  P_att_.bottomRightCorner<3, 3>() = Matrix3d::Identity() * std::pow(config_.gyro_bias_initial, 2);
  // Position: the soles in contact (both when none) on the ground, centred on the origin.
  const bool any = contact_[kRight] || contact_[kLeft];
  anchored_ = any;
  const std::array<bool, 2> place = any ? contact_ : std::array<bool, 2>{true, true};
  Vector3d mid = Vector3d::Zero();
  int n = 0;
  for (int k = 0; k < 2; ++k) {
    if (place[static_cast<size_t>(k)]) {
      mid += R_ * X_BS_[static_cast<size_t>(k)].p;
      ++n;
    }
  }
  const Vector3d p_WB = -mid / n;
  x_.setZero();
  x_.head<3>() = p_WB + R_ * p_BI_;
  for (int k = 0; k < 2; ++k) {
    const auto ku = static_cast<size_t>(k);
    x_.segment<3>(6 + 3 * k) = p_WB + R_ * X_BS_[ku].p;
    R_WS_hold_[ku] = config_.level_ground ? level(R_ * X_BS_[ku].R) : Matrix3d(R_ * X_BS_[ku].R);
  }
  P_.setZero();
  P_.diagonal().segment<3>(0).setConstant(1e-6);
  P_.diagonal().segment<3>(3).setConstant(0.01);
  P_.diagonal().segment<6>(6).setConstant(1e-6);
  for (int k = 0; k < 2; ++k) P_.block<3, 3>(0, 6 + 3 * k) = P_.block<3, 3>(6 + 3 * k, 0) = Matrix3d::Identity() * 1e-6;
  P_.block<3, 3>(6, 9) = P_.block<3, 3>(9, 6) = Matrix3d::Identity() * 1e-6;
  P_.diagonal().segment<6>(6).array() += std::pow(config_.kinematic_position_noise, 2);
  w_ = R_BI_ * s.imu_gyro_B;
  P_w_ = std::pow(config_.gyro_bias_initial, 2);
  // settle_at_start: standing at the start is taken as a touchdown. The soles settle
  // (kTouchdownSettle) while the joint filter, started at rest, converges on the legs' rates: one
  // tick's rates of a sole still seating itself, taken for the base's velocity and integrated until
  // a sole is an anchor again, once put the G1's estimate 2.5 cm off its feet.
  for (int k = 0; k < 2 && config_.settle_at_start; ++k) {
    if (contact_[static_cast<size_t>(k)]) touchdown_time_[static_cast<size_t>(k)] = s.time;
  }
  initialised_ = true;
  t0_ = last_time_ = s.time;
  l_hat_.setZero();  // set from the kinematic momentum in output()
}

void Estimator::output(const SensorSample& s, double dt) {
  const model::Model& m = robot_->model;
  EstimatedState& st = state_;
  st.tick = s.tick;
  st.time = s.time;
  const Vector3d p_WB = x_.head<3>() - R_ * p_BI_;
  const Vector3d v_WB = x_.segment<3>(3) - R_ * (w_.cross(p_BI_) + v_BI_);
  st.q.head<3>() = p_WB;
  const Eigen::Quaterniond quat(R_);
  st.q.segment<4>(3) = quat.normalized().coeffs();
  st.q.tail(m.nj) = qj_;
  st.v.head<3>() = R_.transpose() * v_WB;
  st.v.segment<3>(3) = w_;
  st.v.tail(m.nj) = qdj_;
  st.tau = s.tau;
  model::ccrba(m, data_, st.q, st.v);
  st.p_com = data_.com;
  st.v_com = data_.vcom;
  const Vector3d l_kin = data_.hg.tail<3>();
  // Momentum observer (see the file comment): contact moments about the CoM.
  Vector3d tau_c = Vector3d::Zero();
  for (int k = 0; k < 2; ++k) {
    const auto ku = static_cast<size_t>(k);
    st.contact[ku] = contact_[ku];
    st.foot_force_z[ku] = fz_[ku];
    st.foot_wrench_W[ku] = wrench_W_[ku];
    if (!contact_[ku]) continue;
    const Vector3d p_S = p_WB + R_ * X_BS_[ku].p;
    tau_c += wrench_W_[ku].tail<3>() + (p_S - data_.com).cross(wrench_W_[ku].head<3>());
  }
  if (dt <= 0.0) {
    l_hat_ = l_kin;
    st.ldot_com.setZero();
  } else {
    st.ldot_com = tau_c + config_.cam_observer_gain * (l_kin - l_hat_);
    l_hat_ += st.ldot_com * dt;
  }
  st.l_com = l_hat_;
  std::int32_t status = kStatusOk;
  if (!contact_[kRight] && !contact_[kLeft]) status |= kStatusNoContact;
  if (position_std() > config_.max_position_std || !x_.allFinite() || !R_.allFinite()) status |= kStatusCovariance;
  if (s.time - t0_ < config_.initialisation_time) status |= kStatusInitialising;
  st.status = status;
}

}  // namespace hpr::estimator
