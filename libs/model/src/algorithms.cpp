#include "hpr/model/algorithms.hpp"

#include "index.hpp"

#include <Eigen/Cholesky>
#include <cmath>

namespace hpr::model {

using detail::u;

namespace {

// Rotation of a revolute joint about its unit axis, with exact fast paths for coordinate axes.
inline Matrix3d joint_rotation(const Vector3d& a, double angle) {
  const double c = std::cos(angle), s = std::sin(angle);
  Matrix3d R;
  if (a.x() == 1.0 && a.y() == 0.0 && a.z() == 0.0) {
    R << 1, 0, 0, 0, c, -s, 0, s, c;
  } else if (a.x() == 0.0 && a.y() == 1.0 && a.z() == 0.0) {
    R << c, 0, s, 0, 1, 0, -s, 0, c;
  } else if (a.x() == 0.0 && a.y() == 0.0 && a.z() == 1.0) {
    R << c, -s, 0, s, c, 0, 0, 0, 1;
  } else {
    const double t = 1.0 - c;
    R << t * a.x() * a.x() + c, t * a.x() * a.y() - s * a.z(), t * a.x() * a.z() + s * a.y(),
        t * a.x() * a.y() + s * a.z(), t * a.y() * a.y() + c, t * a.y() * a.z() - s * a.x(),
        t * a.x() * a.z() - s * a.y(), t * a.y() * a.z() + s * a.x(), t * a.z() * a.z() + c;
  }
  return R;
}

// Spatial gravity acceleration used to fold gravity into the recursions: a_0 = -(g, 0).
inline Vector6d gravity_acc(const Model& model) {
  Vector6d a = Vector6d::Zero();
  a.head<3>() = -model.gravity;
  return a;
}

// Wrench at the world origin -> wrench about the CoM (world axes).
inline Vector6d to_com(const Vector6d& f, const Vector3d& c) {
  Vector6d out;
  out.head<3>() = f.head<3>();
  out.tail<3>() = f.tail<3>() - c.cross(f.head<3>());
  return out;
}

// Backward pass shared by the Newton-Euler variants: τ_i = S_iᵀ f_i, f_parent += f_i, base: S0ᵀ f_0.
void backward_pass(const Model& model, Data& data, Eigen::VectorXd& tau) {
  for (int i = model.nb - 1; i > 0; --i) {
    tau(5 + i) = data.S[u(i)].dot(data.f[u(i)]);
    data.f[u(model.parent[u(i)])] += data.f[u(i)];
  }
  tau.head<6>() = data.S0.transpose() * data.f[0];
}

void composite_inertias(const Model& model, Data& data) {
  for (int i = 0; i < model.nb; ++i) data.Yc[u(i)] = data.Iw[u(i)];
  for (int i = model.nb - 1; i > 0; --i) data.Yc[u(model.parent[u(i)])] += data.Yc[u(i)];
}

// M from the composite inertias (Yc must be current); also fills F. Entries of joints that do not
// support each other stay zero from construction.
void crba_from_composites(const Model& model, Data& data) {
  Eigen::MatrixXd& M = data.M;
  const SE3& X0 = data.oMi[0];
  for (int i = 1; i < model.nb; ++i) {
    const Vector6d Fi = data.Yc[u(i)] * data.S[u(i)];
    data.F[u(i)] = Fi;
    const int col = 5 + i;
    M(col, col) = data.S[u(i)].dot(Fi);
    for (int k = model.parent[u(i)]; k > 0; k = model.parent[u(k)]) {
      const double mk = data.S[u(k)].dot(Fi);
      M(5 + k, col) = mk;
      M(col, 5 + k) = mk;
    }
    const Vector6d Fb = X0.act_inv_force(Fi);  // S0ᵀ F_i
    M.block<6, 1>(0, col) = Fb;
    M.block<1, 6>(col, 0) = Fb.transpose();
  }
  // Base block: the composite inertia of the whole robot in the base frame.
  M.topLeftCorner<6, 6>() = data.Yc[0].transformed(X0.inverse()).matrix();
}

void centroidal_from_composites(const Model& model, Data& data) {
  const Inertia& Y = data.Yc[0];
  data.mass = Y.m;
  data.com = Y.h / Y.m;
  for (int k = 0; k < 6; ++k) data.Ag.col(k) = to_com(Y * data.S0.col(k), data.com);
  for (int i = 1; i < model.nb; ++i) data.Ag.col(5 + i) = to_com(data.F[u(i)], data.com);
  data.Jcom = data.Ag.topRows<3>() / Y.m;
  data.Ic = Y.inertia_about_com();
}

// R_child = R_parent * Rot(axis, angle) for a coordinate axis (code ±1..3), column by column.
inline void rotate_about_axis(const Matrix3d& Rp, int code, double angle, Matrix3d& R) {
  const double sgn = code > 0 ? 1.0 : -1.0;
  const double c = std::cos(angle), s = sgn * std::sin(angle);
  switch (code > 0 ? code : -code) {
    case 1:
      R.col(0) = Rp.col(0);
      R.col(1) = c * Rp.col(1) + s * Rp.col(2);
      R.col(2) = c * Rp.col(2) - s * Rp.col(1);
      break;
    case 2:
      R.col(1) = Rp.col(1);
      R.col(0) = c * Rp.col(0) - s * Rp.col(2);
      R.col(2) = c * Rp.col(2) + s * Rp.col(0);
      break;
    default:
      R.col(2) = Rp.col(2);
      R.col(0) = c * Rp.col(0) + s * Rp.col(1);
      R.col(1) = c * Rp.col(1) - s * Rp.col(0);
      break;
  }
}

// Inertia of a body at world placement X: m, h = m c_W, I_O = R I_c Rᵀ + m(|c_W|² E − c_W c_Wᵀ).
inline void world_inertia(double m, const Vector3d& c_B, const Matrix3d& Ic_B, const SE3& X, Inertia& out) {
  const Vector3d c = X.R * c_B + X.p;
  const Matrix3d T = X.R * Ic_B;
  out.m = m;
  out.h = m * c;
  const double cc = c.squaredNorm();
  Matrix3d& I = out.I;
  I(0, 0) = T.row(0).dot(X.R.row(0)) + m * (cc - c.x() * c.x());
  I(1, 1) = T.row(1).dot(X.R.row(1)) + m * (cc - c.y() * c.y());
  I(2, 2) = T.row(2).dot(X.R.row(2)) + m * (cc - c.z() * c.z());
  I(0, 1) = I(1, 0) = T.row(0).dot(X.R.row(1)) - m * c.x() * c.y();
  I(0, 2) = I(2, 0) = T.row(0).dot(X.R.row(2)) - m * c.x() * c.z();
  I(1, 2) = I(2, 1) = T.row(1).dot(X.R.row(2)) - m * c.y() * c.z();
}

}  // namespace

Eigen::Quaterniond base_quaternion(const ConstVector& q) {
  return Eigen::Quaterniond(q(6), q(3), q(4), q(5)).normalized();
}

namespace {

/// The root link's placement and motion subspace from q.
inline void root_placement(Data& data, const ConstVector& q) {
  SE3& X0 = data.oMi[0];
  X0.R = base_quaternion(q).toRotationMatrix();
  X0.p = q.head<3>();
  data.S0 = X0.motion_matrix();
}

/// Body i's placement oMi and motion subspace S_i (world axes) from its parent's placement.
inline void joint_placement(const Model& model, Data& data, const ConstVector& q, int i) {
  const SE3& Xp = data.oMi[u(model.parent[u(i)])];
  const SE3& XJ = model.X_PJ[u(i)];
  SE3& X = data.oMi[u(i)];
  const double qi = q(6 + i);
  const Vector3d& a = model.axis[u(i)];
  const int code = model.axis_code[u(i)];
  Matrix3d Rp;
  X.p.noalias() = Xp.R * XJ.p;
  X.p += Xp.p;
  if (model.placement_rotates[u(i)] != 0) {
    Rp.noalias() = Xp.R * XJ.R;
  } else {
    Rp = Xp.R;
  }
  Vector6d& S = data.S[u(i)];
  if (model.kind[u(i)] == JointKind::kRevolute) {
    if (code != 0) {
      rotate_about_axis(Rp, code, qi, X.R);
      S.tail<3>() = (code > 0 ? 1.0 : -1.0) * X.R.col((code > 0 ? code : -code) - 1);
    } else {
      X.R.noalias() = Rp * joint_rotation(a, qi);
      S.tail<3>().noalias() = X.R * a;
    }
    S.head<3>() = X.p.cross(S.tail<3>());
  } else {
    X.R = Rp;
    S.head<3>().noalias() = X.R * a;
    X.p += qi * S.head<3>();
    S.tail<3>().setZero();
  }
}

}  // namespace

void forward_kinematics(const Model& model, Data& data, const ConstVector& q) {
  root_placement(data, q);
  world_inertia(model.inertia[0].m, model.com_body[0], model.inertia_com_body[0], data.oMi[0], data.Iw[0]);
  for (int i = 1; i < model.nb; ++i) {
    joint_placement(model, data, q, i);
    world_inertia(model.inertia[u(i)].m, model.com_body[u(i)], model.inertia_com_body[u(i)], data.oMi[u(i)], data.Iw[u(i)]);
  }
}

void compute_frame_jacobian(const Model& model, Data& data, const ConstVector& q, int frame, ReferenceFrame rf,
                            Eigen::Ref<Matrix6Xd> J) {
  root_placement(data, q);
  for (int j : model.support[u(model.frames[u(frame)].body)]) joint_placement(model, data, q, j + 1);
  frame_jacobian(model, data, frame, rf, J);
}

void forward_kinematics(const Model& model, Data& data, const ConstVector& q, const ConstVector& v) {
  forward_kinematics(model, data, q);
  data.vel[0] = data.S0 * v.head<6>();
  for (int i = 1; i < model.nb; ++i) data.vel[u(i)] = data.vel[u(model.parent[u(i)])] + data.S[u(i)] * v(5 + i);
}

const SE3& update_frame_placement(const Model& model, Data& data, int frame) {
  const Frame& fr = model.frames[u(frame)];
  SE3& X = data.oMf[u(frame)];
  X.R.noalias() = data.oMi[u(fr.body)].R * fr.X_BF.R;
  X.p.noalias() = data.oMi[u(fr.body)].R * fr.X_BF.p;
  X.p += data.oMi[u(fr.body)].p;
  return X;
}

void update_frame_placements(const Model& model, Data& data) {
  for (size_t k = 0; k < model.frames.size(); ++k) {
    const Frame& fr = model.frames[k];
    data.oMf[k] = data.oMi[u(fr.body)] * fr.X_BF;
  }
}

const Eigen::MatrixXd& crba(const Model& model, Data& data, const ConstVector& q) {
  forward_kinematics(model, data, q);
  composite_inertias(model, data);
  crba_from_composites(model, data);
  return data.M;
}

const Eigen::VectorXd& passivity_rnea(const Model& model, Data& data, const ConstVector& q, const ConstVector& v,
                                      const ConstVector& v_r, const ConstVector& a_r, bool with_gravity) {
  forward_kinematics(model, data, q, v);
  return passivity_rnea_from_kinematics(model, data, v_r, a_r, with_gravity);
}

const Eigen::VectorXd& passivity_rnea_from_kinematics(const Model& model, Data& data, const ConstVector& v_r,
                                                      const ConstVector& a_r, bool with_gravity) {
  // Reference twists vr_i = J_i v_r and accelerations ar_i = J_i a_r + J̇_i v_r (J̇ from the actual motion).
  // data.acc holds ar_i; the reference twist of each body is kept in data.f until it is consumed.
  std::vector<Vector6d>& ar = data.acc;
  std::vector<Vector6d>& f = data.f;
  Vector6d vr0 = data.S0 * v_r.head<6>();
  ar[0] = data.S0 * a_r.head<6>() + cross_motion(data.vel[0], vr0);
  if (with_gravity) ar[0] += gravity_acc(model);
  f[0] = vr0;
  for (int i = 1; i < model.nb; ++i) {
    const int p = model.parent[u(i)];
    const Vector6d& S = data.S[u(i)];
    f[u(i)] = f[u(p)] + S * v_r(5 + i);
    ar[u(i)] = ar[u(p)] + S * a_r(5 + i) + cross_motion(data.vel[u(i)], S) * v_r(5 + i);
  }
  // Body Coriolis factorisation B(v) v_r = ½[v ×* (I v_r) − I (v × v_r) + v_r ×* (I v)]: Christoffel-
  // consistent, and its momentum part vanishes for every v_r (the CoM rows of C̄ are zero, (20)).
  for (int i = 0; i < model.nb; ++i) {
    const Inertia& I = data.Iw[u(i)];
    const Vector6d vr = f[u(i)];
    const Vector6d& vi = data.vel[u(i)];
    f[u(i)] = I * ar[u(i)] +
              0.5 * (cross_force(vi, I * vr) - I * cross_motion(vi, vr) + cross_force(vr, I * vi));
  }
  backward_pass(model, data, data.tau);
  return data.tau;
}

const Eigen::VectorXd& rnea(const Model& model, Data& data, const ConstVector& q, const ConstVector& v,
                            const ConstVector& a) {
  forward_kinematics(model, data, q, v);
  data.acc[0] = data.S0 * a.head<6>() + gravity_acc(model);  // Ṡ0 v_B = vel_0 × vel_0 = 0
  for (int i = 1; i < model.nb; ++i) {
    const Vector6d& S = data.S[u(i)];
    data.acc[u(i)] = data.acc[u(model.parent[u(i)])] + S * a(5 + i) + cross_motion(data.vel[u(i)], S) * v(5 + i);
  }
  for (int i = 0; i < model.nb; ++i) {
    const Inertia& I = data.Iw[u(i)];
    data.f[u(i)] = I * data.acc[u(i)] + cross_force(data.vel[u(i)], I * data.vel[u(i)]);
  }
  backward_pass(model, data, data.tau);
  return data.tau;
}

const Eigen::VectorXd& nonlinear_effects(const Model& model, Data& data, const ConstVector& q, const ConstVector& v) {
  forward_kinematics(model, data, q, v);
  data.acc[0] = gravity_acc(model);
  for (int i = 1; i < model.nb; ++i) {
    data.acc[u(i)] = data.acc[u(model.parent[u(i)])] + cross_motion(data.vel[u(i)], data.S[u(i)]) * v(5 + i);
  }
  for (int i = 0; i < model.nb; ++i) {
    const Inertia& I = data.Iw[u(i)];
    data.f[u(i)] = I * data.acc[u(i)] + cross_force(data.vel[u(i)], I * data.vel[u(i)]);
  }
  backward_pass(model, data, data.nle);
  return data.nle;
}

const Eigen::VectorXd& generalized_gravity(const Model& model, Data& data, const ConstVector& q) {
  forward_kinematics(model, data, q);
  composite_inertias(model, data);
  const Vector6d ag = gravity_acc(model);
  for (int i = 1; i < model.nb; ++i) data.g(5 + i) = data.S[u(i)].dot(data.Yc[u(i)] * ag);
  data.g.head<6>() = data.S0.transpose() * (data.Yc[0] * ag);
  return data.g;
}

void coriolis_matrix(const Model& model, Data& data, const ConstVector& q, const ConstVector& v, Eigen::MatrixXd& C) {
  C.resize(model.nv, model.nv);
  Eigen::VectorXd e = Eigen::VectorXd::Zero(model.nv);
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(model.nv);
  for (int k = 0; k < model.nv; ++k) {
    e.setZero();
    e(k) = 1.0;
    C.col(k) = passivity_rnea(model, data, q, v, e, zero, false);
  }
}

const Vector3d& center_of_mass(const Model& model, Data& data, const ConstVector& q) {
  forward_kinematics(model, data, q);
  Vector3d h = Vector3d::Zero();
  for (int i = 0; i < model.nb; ++i) h += data.Iw[u(i)].h;
  data.com = h / model.mass;
  return data.com;
}

const Vector3d& center_of_mass(const Model& model, Data& data, const ConstVector& q, const ConstVector& v) {
  forward_kinematics(model, data, q, v);
  Vector3d h = Vector3d::Zero(), p = Vector3d::Zero();
  for (int i = 0; i < model.nb; ++i) {
    h += data.Iw[u(i)].h;
    p += (data.Iw[u(i)] * data.vel[u(i)]).head<3>();
  }
  data.com = h / model.mass;
  data.vcom = p / model.mass;
  return data.com;
}

const Matrix6Xd& ccrba(const Model& model, Data& data, const ConstVector& q, const ConstVector& v) {
  forward_kinematics(model, data, q);
  composite_inertias(model, data);
  for (int i = 1; i < model.nb; ++i) data.F[u(i)] = data.Yc[u(i)] * data.S[u(i)];
  centroidal_from_composites(model, data);
  data.hg.noalias() = data.Ag * v;
  data.vcom = data.hg.head<3>() / data.mass;
  return data.Ag;
}

const Vector6d& centroidal_momentum_bias(const Model& model, Data& data, const ConstVector& q, const ConstVector& v) {
  forward_kinematics(model, data, q, v);
  data.acc[0].setZero();
  for (int i = 1; i < model.nb; ++i) {
    data.acc[u(i)] = data.acc[u(model.parent[u(i)])] + cross_motion(data.vel[u(i)], data.S[u(i)]) * v(5 + i);
  }
  Vector6d total = Vector6d::Zero();
  Vector3d h = Vector3d::Zero();
  for (int i = 0; i < model.nb; ++i) {
    const Inertia& I = data.Iw[u(i)];
    total += I * data.acc[u(i)] + cross_force(data.vel[u(i)], I * data.vel[u(i)]);
    h += I.h;
  }
  data.com = h / model.mass;
  // d/dt of the momentum about the moving CoM: the ċ × (m ċ) term vanishes.
  data.dAg_v = to_com(total, data.com);
  return data.dAg_v;
}

void compute_all_terms(const Model& model, Data& data, const ConstVector& q, const ConstVector& v) {
  forward_kinematics(model, data, q, v);
  composite_inertias(model, data);
  crba_from_composites(model, data);
  centroidal_from_composites(model, data);
  data.hg.noalias() = data.Ag * v;
  data.vcom = data.hg.head<3>() / data.mass;
  // One Newton-Euler pass with gravity gives C v + g; without the gravity part it gives Ȧ_G v.
  const Vector6d ag = gravity_acc(model);
  data.acc[0] = ag;
  for (int i = 1; i < model.nb; ++i) {
    data.acc[u(i)] = data.acc[u(model.parent[u(i)])] + cross_motion(data.vel[u(i)], data.S[u(i)]) * v(5 + i);
  }
  for (int i = 0; i < model.nb; ++i) {
    const Inertia& I = data.Iw[u(i)];
    data.f[u(i)] = I * data.acc[u(i)] + cross_force(data.vel[u(i)], I * data.vel[u(i)]);
  }
  for (int i = 1; i < model.nb; ++i) data.g(5 + i) = data.S[u(i)].dot(data.Yc[u(i)] * ag);
  data.g.head<6>() = data.S0.transpose() * (data.Yc[0] * ag);
  backward_pass(model, data, data.nle);
  data.dAg_v = to_com(data.f[0] - data.Yc[0] * ag, data.com);
}

namespace {
SE3 placement_of(const Model& model, const Data& data, int frame) {
  const Frame& fr = model.frames[u(frame)];
  return data.oMi[u(fr.body)] * fr.X_BF;
}
}  // namespace

void frame_jacobian(const Model& model, const Data& data, int frame, ReferenceFrame rf, Eigen::Ref<Matrix6Xd> J) {
  const Frame& fr = model.frames[u(frame)];
  const SE3 oMf = placement_of(model, data, frame);
  J.setZero();
  J.leftCols<6>() = data.S0;
  for (int j : model.support[u(fr.body)]) J.col(6 + j) = data.S[u(j + 1)];
  if (rf == ReferenceFrame::kWorld) return;
  const Vector3d& p = oMf.p;
  auto shift = [&](int c) { J.block<3, 1>(0, c) += J.block<3, 1>(3, c).cross(p); };
  for (int c = 0; c < 6; ++c) shift(c);
  for (int j : model.support[u(fr.body)]) shift(6 + j);
  if (rf == ReferenceFrame::kLocal) {
    const Matrix3d Rt = oMf.R.transpose();
    auto rot = [&](int c) {
      J.block<3, 1>(0, c) = Rt * J.block<3, 1>(0, c);
      J.block<3, 1>(3, c) = Rt * J.block<3, 1>(3, c);
    };
    for (int c = 0; c < 6; ++c) rot(c);
    for (int j : model.support[u(fr.body)]) rot(6 + j);
  }
}

Vector6d frame_velocity(const Model& model, const Data& data, int frame, ReferenceFrame rf) {
  const Frame& fr = model.frames[u(frame)];
  const Vector6d& V = data.vel[u(fr.body)];
  if (rf == ReferenceFrame::kWorld) return V;
  const SE3 oMf = placement_of(model, data, frame);
  Vector6d out;
  out.tail<3>() = V.tail<3>();
  out.head<3>() = V.head<3>() + V.tail<3>().cross(oMf.p);
  if (rf == ReferenceFrame::kLocal) {
    out.head<3>() = oMf.R.transpose() * out.head<3>().eval();
    out.tail<3>() = oMf.R.transpose() * out.tail<3>().eval();
  }
  return out;
}

Vector6d frame_jacobian_time_variation_times_v(const Model& model, const Data& data, int frame) {
  const Frame& fr = model.frames[u(frame)];
  // Spatial acceleration of the body at zero joint acceleration: Σ (v_j × S_j) q̇_j over the support.
  Vector6d a = Vector6d::Zero();
  const Vector6d& V = data.vel[u(fr.body)];
  for (int b = fr.body; b > 0; b = model.parent[u(b)]) {
    // (v_b × S_b) q̇_b, with q̇_b recovered from the twists: v_b - v_parent = S_b q̇_b.
    const Vector6d dv = data.vel[u(b)] - data.vel[u(model.parent[u(b)])];
    a += cross_motion(data.vel[u(b)], dv);
  }
  const Vector3d p = placement_of(model, data, frame).p;
  const Vector3d w = V.tail<3>();
  const Vector3d vp = V.head<3>() + w.cross(p);
  Vector6d out;
  out.head<3>() = a.head<3>() + a.tail<3>().cross(p) + w.cross(vp);
  out.tail<3>() = a.tail<3>();
  return out;
}

Eigen::VectorXd forward_dynamics(const Model& model, Data& data, const ConstVector& q, const ConstVector& v,
                                 const ConstVector& tau) {
  nonlinear_effects(model, data, q, v);
  const Eigen::VectorXd rhs = tau - data.nle;
  crba(model, data, q);
  return data.M.llt().solve(rhs);
}

namespace {
// V(φ) of the SE(3) exponential: p = V(φ) v for the twist (v, φ).
Matrix3d left_jacobian(const Vector3d& phi) {
  const double th = phi.norm();
  const Matrix3d K = skew(phi);
  if (th < 1e-8) return Matrix3d::Identity() + 0.5 * K + K * K / 6.0;
  return Matrix3d::Identity() + (1 - std::cos(th)) / (th * th) * K + (th - std::sin(th)) / (th * th * th) * K * K;
}
}  // namespace

Eigen::VectorXd integrate(const Model& model, const ConstVector& q, const ConstVector& v_dt) {
  Eigen::VectorXd out = q;
  const Matrix3d R = base_quaternion(q).toRotationMatrix();
  const Vector3d w = v_dt.segment<3>(3);
  out.head<3>() = q.head<3>() + R * (left_jacobian(w) * v_dt.head<3>());
  Eigen::Quaterniond qn(R * exp3(w));
  qn.normalize();
  out(3) = qn.x();
  out(4) = qn.y();
  out(5) = qn.z();
  out(6) = qn.w();
  out.tail(model.nj) += v_dt.tail(model.nj);
  return out;
}

Eigen::VectorXd difference(const Model& model, const ConstVector& q0, const ConstVector& q1) {
  Eigen::VectorXd v(model.nv);
  const Matrix3d R0 = base_quaternion(q0).toRotationMatrix(), R1 = base_quaternion(q1).toRotationMatrix();
  const Vector3d w = log3(R0.transpose() * R1);
  v.segment<3>(3) = w;
  v.head<3>() = left_jacobian(w).inverse() * (R0.transpose() * (q1.head<3>() - q0.head<3>()));
  v.tail(model.nj) = q1.tail(model.nj) - q0.tail(model.nj);
  return v;
}

}  // namespace hpr::model
