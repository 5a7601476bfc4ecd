#pragma once
// Problem generators shared by the QP tests and bench_qp: control-loop-like sequences of slowly
// varying problems.
#include <Eigen/Core>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

namespace hpr::qp::testing {

struct Problem {
  Eigen::MatrixXd H, A;
  Eigen::VectorXd g, lb, ub, lbA, ubA;
};

inline constexpr double kInf = std::numeric_limits<double>::infinity();

/// Contact wrench distribution for two feet (12 variables, 30 one-sided rows): per foot an 8-facet
/// friction pyramid, the CoP inside a 0.20 x 0.10 m sole, |τz| ≤ γ fz and fz ≥ f_min. The desired
/// CoM wrench sways forward/backward and sideways beyond what the soles can take, so that CoP
/// limits and the minimum normal force switch on and off along the sequence.
inline std::vector<Problem> contact_sequence(int steps, unsigned seed, double dt = 1e-3) {
  std::mt19937 gen(seed);
  std::uniform_real_distribution<double> jitter(-1, 1);
  const double m = 79.2, g0 = 9.81, mu = 0.7, gamma = 0.02, fmin = 10.0, L = 0.20, W = 0.10;
  const double mu_in = mu * std::cos(M_PI / 8);
  std::vector<Problem> seq;
  for (int k = 0; k < steps; ++k) {
    const double t = k * dt;
    const Eigen::Vector3d c(0.01 * std::sin(2 * M_PI * 0.7 * t), 0.02 * std::sin(2 * M_PI * 0.5 * t), 0.9);
    const Eigen::Vector3d p[2] = {{0.0, -0.1, 0.0}, {0.0, 0.1, 0.0}};
    Eigen::Matrix<double, 6, 1> wdes;
    wdes << 30 * std::sin(2 * M_PI * 0.9 * t), 20 * std::sin(2 * M_PI * 0.6 * t), m * g0,
        110 * std::sin(2 * M_PI * 0.5 * t) + 2 * jitter(gen), 130 * std::sin(2 * M_PI * 0.8 * t), 3 * std::sin(2 * M_PI * t);
    // Contact map G (6 x 12): CoM wrench = G w.
    Eigen::Matrix<double, 6, 12> G = Eigen::Matrix<double, 6, 12>::Zero();
    for (int i = 0; i < 2; ++i) {
      G.block<3, 3>(0, 6 * i).setIdentity();
      G.block<3, 3>(3, 6 * i + 3).setIdentity();
      const Eigen::Vector3d r = p[i] - c;
      Eigen::Matrix3d S;
      S << 0, -r.z(), r.y(), r.z(), 0, -r.x(), -r.y(), r.x(), 0;
      G.block<3, 3>(3, 6 * i) = S;
    }
    Eigen::Matrix<double, 6, 1> wt;
    wt << 1, 1, 1, 10, 10, 10;
    Problem pr;
    pr.H = G.transpose() * wt.asDiagonal() * G + 1e-4 * Eigen::MatrixXd::Identity(12, 12);
    pr.g = -G.transpose() * wt.asDiagonal() * wdes;
    pr.A = Eigen::MatrixXd::Zero(30, 12);
    pr.lbA = Eigen::VectorXd::Constant(30, -kInf);
    pr.ubA = Eigen::VectorXd::Zero(30);
    for (int i = 0; i < 2; ++i) {
      const int r0 = 15 * i, c0 = 6 * i;
      for (int f = 0; f < 8; ++f) {  // cos θ fx + sin θ fy − μ_in fz ≤ 0
        const double th = f * M_PI / 4;
        pr.A(r0 + f, c0) = std::cos(th);
        pr.A(r0 + f, c0 + 1) = std::sin(th);
        pr.A(r0 + f, c0 + 2) = -mu_in;
      }
      const double half[4] = {W / 2, W / 2, L / 2, L / 2};
      const int axis[4] = {3, 3, 4, 4};
      const double sgn[4] = {1, -1, 1, -1};
      for (int f = 0; f < 4; ++f) {  // ±τx ≤ (W/2) fz, ±τy ≤ (L/2) fz
        pr.A(r0 + 8 + f, c0 + axis[f]) = sgn[f];
        pr.A(r0 + 8 + f, c0 + 2) = -half[f];
      }
      for (int f = 0; f < 2; ++f) {  // ±τz ≤ γ fz
        pr.A(r0 + 12 + f, c0 + 5) = f == 0 ? 1 : -1;
        pr.A(r0 + 12 + f, c0 + 2) = -gamma;
      }
      pr.A(r0 + 14, c0 + 2) = 1.0;  // fz ≥ f_min
      pr.lbA(r0 + 14) = fmin;
      pr.ubA(r0 + 14) = kInf;
    }
    pr.lb = Eigen::VectorXd::Constant(12, -kInf);
    pr.ub = Eigen::VectorXd::Constant(12, kInf);
    seq.push_back(pr);
  }
  return seq;
}

/// Bounds-only problems like the motion optimisation (13)-(17): H = Āᵀ Q_l Ā + Q_p with Ā slowly
/// rotating, a gradient pushing several variables against their (slowly moving) bounds.
inline std::vector<Problem> box_sequence(int n, int steps, unsigned seed, double dt = 1e-3) {
  std::mt19937 gen(seed);
  std::normal_distribution<double> nd;
  Eigen::MatrixXd A0(3, n), A1(3, n);
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < n; ++j) {
      A0(i, j) = nd(gen);
      A1(i, j) = nd(gen);
    }
  }
  std::vector<Problem> seq;
  for (int k = 0; k < steps; ++k) {
    const double t = k * dt;
    const Eigen::MatrixXd Abar = A0 + 0.3 * std::sin(2 * M_PI * 0.5 * t) * A1;
    const Eigen::Vector3d lref(20 * std::sin(2 * M_PI * 0.7 * t), 15 * std::cos(2 * M_PI * 0.4 * t), 5.0);
    Problem pr;
    pr.H = 10.0 * Abar.transpose() * Abar + Eigen::MatrixXd::Identity(n, n);
    pr.g = -10.0 * Abar.transpose() * lref;
    pr.A = Eigen::MatrixXd::Zero(0, n);
    pr.lbA = Eigen::VectorXd::Zero(0);
    pr.ubA = Eigen::VectorXd::Zero(0);
    pr.lb.resize(n);
    pr.ub.resize(n);
    for (int j = 0; j < n; ++j) {
      pr.lb(j) = -1.0 - 0.5 * std::sin(2 * M_PI * 0.3 * t + j);
      pr.ub(j) = 1.0 + 0.5 * std::cos(2 * M_PI * 0.2 * t + j);
    }
    seq.push_back(pr);
  }
  return seq;
}

}  // namespace hpr::qp::testing
