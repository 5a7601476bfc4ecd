#pragma once
/// \file
/// Spatial (6D) algebra after Featherstone, in the order used throughout this library:
/// a motion vector is (v, ω) (linear first), a force vector is (f, τ). Quantities carry their frame
/// in the name where it matters: X_AB maps coordinates in B to coordinates in A.

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace hpr::model {

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Matrix3d = Eigen::Matrix3d;
using Vector3d = Eigen::Vector3d;
using Matrix6Xd = Eigen::Matrix<double, 6, Eigen::Dynamic>;
using Matrix3Xd = Eigen::Matrix<double, 3, Eigen::Dynamic>;

/// Skew-symmetric matrix [x]× with [x]× y = x × y.
inline Matrix3d skew(const Vector3d& x) {
  Matrix3d S;
  S << 0, -x.z(), x.y(), x.z(), 0, -x.x(), -x.y(), x.x(), 0;
  return S;
}

/// A rigid transform X_AB = (R_AB, p_AB): a point with coordinates x_B in B has x_A = R x_B + p.
struct SE3 {
  Matrix3d R = Matrix3d::Identity();
  Vector3d p = Vector3d::Zero();

  static SE3 Identity() { return {}; }
  SE3 operator*(const SE3& o) const { return {R * o.R, R * o.p + p}; }
  [[nodiscard]] Vector3d act(const Vector3d& x) const { return R * x + p; }
  [[nodiscard]] SE3 inverse() const { return {R.transpose(), -(R.transpose() * p)}; }
  /// Twist (v, ω) given in B at B's origin -> the same twist in A at A's origin.
  [[nodiscard]] Vector6d act_motion(const Vector6d& m) const {
    Vector6d out;
    out.tail<3>() = R * m.tail<3>();
    out.head<3>() = R * m.head<3>() + p.cross(out.tail<3>());
    return out;
  }
  /// Wrench (f, τ) given in B at B's origin -> the same wrench in A at A's origin.
  [[nodiscard]] Vector6d act_force(const Vector6d& f) const {
    Vector6d out;
    out.head<3>() = R * f.head<3>();
    out.tail<3>() = R * f.tail<3>() + p.cross(out.head<3>());
    return out;
  }
  /// Inverse of act_force: wrench in A at A's origin -> in B at B's origin.
  [[nodiscard]] Vector6d act_inv_force(const Vector6d& f) const {
    Vector6d out;
    out.head<3>() = R.transpose() * f.head<3>();
    out.tail<3>() = R.transpose() * (f.tail<3>() - p.cross(f.head<3>()));
    return out;
  }
  /// Inverse of act_motion.
  [[nodiscard]] Vector6d act_inv_motion(const Vector6d& m) const {
    Vector6d out;
    out.tail<3>() = R.transpose() * m.tail<3>();
    out.head<3>() = R.transpose() * (m.head<3>() - p.cross(m.tail<3>()));
    return out;
  }
  /// The 6x6 motion transform matrix of act_motion.
  [[nodiscard]] Matrix6d motion_matrix() const {
    Matrix6d X;
    X.topLeftCorner<3, 3>() = R;
    X.topRightCorner<3, 3>() = skew(p) * R;
    X.bottomLeftCorner<3, 3>().setZero();
    X.bottomRightCorner<3, 3>() = R;
    return X;
  }
};

/// Motion cross product a × b (Featherstone's crm(a) b).
[[gnu::always_inline]] inline Vector6d cross_motion(const Vector6d& a, const Vector6d& b) {
  Vector6d out;
  out.head<3>() = a.tail<3>().cross(b.head<3>()) + a.head<3>().cross(b.tail<3>());
  out.tail<3>() = a.tail<3>().cross(b.tail<3>());
  return out;
}

/// Force cross product v ×* f (Featherstone's crf(v) f).
[[gnu::always_inline]] inline Vector6d cross_force(const Vector6d& v, const Vector6d& f) {
  Vector6d out;
  out.head<3>() = v.tail<3>().cross(f.head<3>());
  out.tail<3>() = v.tail<3>().cross(f.tail<3>()) + v.head<3>().cross(f.head<3>());
  return out;
}

/// Spatial inertia in some frame, stored compactly: mass m, first moment h = m c (c the centre of
/// mass in that frame) and the rotational inertia I_O about the frame's origin.
struct Inertia {
  double m = 0.0;
  Vector3d h = Vector3d::Zero();
  Matrix3d I = Matrix3d::Zero();

  /// From mass, centre of mass c and the rotational inertia about the centre of mass.
  static Inertia from_com(double mass, const Vector3d& c, const Matrix3d& I_c) {
    Inertia out;
    out.m = mass;
    out.h = mass * c;
    out.I = I_c + mass * (c.squaredNorm() * Matrix3d::Identity() - c * c.transpose());
    return out;
  }
  [[nodiscard]] Vector3d com() const { return m > 0 ? Vector3d(h / m) : Vector3d::Zero(); }
  /// Rotational inertia about the centre of mass.
  [[nodiscard]] Matrix3d inertia_about_com() const {
    const Vector3d c = com();
    return I - m * (c.squaredNorm() * Matrix3d::Identity() - c * c.transpose());
  }
  /// Momentum (f, τ) of a body moving with twist (v, ω) (both at the frame origin).
  [[nodiscard, gnu::always_inline]] Vector6d operator*(const Vector6d& twist) const {
    Vector6d out;
    const Vector3d v = twist.head<3>(), w = twist.tail<3>();
    out.head<3>() = m * v - h.cross(w);
    out.tail<3>() = h.cross(v) + I * w;
    return out;
  }
  Inertia& operator+=(const Inertia& o) {
    m += o.m;
    h += o.h;
    I += o.I;
    return *this;
  }
  /// The same body expressed in the parent frame A, given X_AB with this inertia in B.
  [[nodiscard]] Inertia transformed(const SE3& X_AB) const {
    Inertia out;
    out.m = m;
    const Vector3d Rh = X_AB.R * h;
    out.h = Rh + m * X_AB.p;
    // I_A = R I_B R^T + m(|p|^2 E - p p^T) + terms coupling p and h (parallel axis for a shifted frame).
    const Vector3d& p = X_AB.p;
    out.I = X_AB.R * I * X_AB.R.transpose();
    const double ph = p.dot(Rh);
    out.I += m * (p.squaredNorm() * Matrix3d::Identity() - p * p.transpose()) +
             (2.0 * ph) * Matrix3d::Identity() - p * Rh.transpose() - Rh * p.transpose();
    return out;
  }
  /// The 6x6 matrix such that matrix() * twist == (*this) * twist.
  [[nodiscard]] Matrix6d matrix() const {
    Matrix6d M;
    M.topLeftCorner<3, 3>() = m * Matrix3d::Identity();
    M.topRightCorner<3, 3>() = -skew(h);
    M.bottomLeftCorner<3, 3>() = skew(h);
    M.bottomRightCorner<3, 3>() = I;
    return M;
  }
};

/// Rotation by `angle` about the unit `axis` (Rodrigues).
inline Matrix3d axis_angle(const Vector3d& axis, double angle) {
  return Eigen::AngleAxisd(angle, axis).toRotationMatrix();
}

/// SO(3) exponential of a rotation vector.
inline Matrix3d exp3(const Vector3d& w) {
  const double th = w.norm();
  if (th < 1e-12) return Matrix3d::Identity() + skew(w);
  return Eigen::AngleAxisd(th, w / th).toRotationMatrix();
}

/// SO(3) logarithm: the rotation vector of R.
inline Vector3d log3(const Matrix3d& R) {
  const Eigen::AngleAxisd aa(R);
  return aa.axis() * aa.angle();
}

}  // namespace hpr::model
