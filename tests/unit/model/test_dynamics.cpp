// Rigid-body algorithms checked against identities and finite differences, for both robots.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>

#include "hpr/model/centroidal.hpp"
#include "model_fixture.hpp"

namespace {

using namespace hpr::model;
using hpr::test::rel;
using Eigen::MatrixXd;
using Eigen::VectorXd;

class Dynamics : public ::testing::TestWithParam<std::string> {
 protected:
  void SetUp() override {
    robot = std::make_unique<RobotSpec>(hpr::test::load_robot(GetParam()));
    data = std::make_unique<Data>(robot->model);
  }
  const Model& model() const { return robot->model; }
  std::unique_ptr<RobotSpec> robot;
  std::unique_ptr<Data> data;
  static constexpr int kSamples = 100;
};

TEST_P(Dynamics, MassMatrixIsSymmetricPositiveDefiniteAndMatchesRnea) {
  hpr::test::RandomState rs(1);
  for (int s = 0; s < kSamples; ++s) {
    const VectorXd q = rs.q(model()), v = rs.v(model()), a = rs.v(model(), 3.0);
    const MatrixXd M = crba(model(), *data, q);
    EXPECT_LT((M - M.transpose()).norm(), 1e-12 * M.norm());
    EXPECT_GT(Eigen::SelfAdjointEigenSolver<MatrixXd>(M).eigenvalues().minCoeff(), 0.0);
    const VectorXd h = nonlinear_effects(model(), *data, q, v);
    const VectorXd tau = rnea(model(), *data, q, v, a);
    EXPECT_LT(rel(M * a + h, tau), 1e-12);
    const VectorXd g = generalized_gravity(model(), *data, q);
    EXPECT_LT(rel(g, rnea(model(), *data, q, VectorXd::Zero(model().nv), VectorXd::Zero(model().nv))), 1e-12);
  }
}

// dM/dt − 2C is skew-symmetric for the factorisation of passivity_rnea, and C v = h − g.
TEST_P(Dynamics, CoriolisMatrixIsChristoffelConsistent) {
  hpr::test::RandomState rs(2);
  const double dt = 1e-6;
  for (int s = 0; s < 20; ++s) {
    const VectorXd q = rs.q(model()), v = rs.v(model());
    MatrixXd C;
    coriolis_matrix(model(), *data, q, v, C);
    const VectorXd h = nonlinear_effects(model(), *data, q, v);
    const VectorXd g = generalized_gravity(model(), *data, q);
    EXPECT_LT(rel(C * v, h - g), 1e-11);
    const MatrixXd Mp = crba(model(), *data, integrate(model(), q, v * dt));
    const MatrixXd Mm = crba(model(), *data, integrate(model(), q, -v * dt));
    const MatrixXd N = (Mp - Mm) / (2 * dt) - 2 * C;
    EXPECT_LT((N + N.transpose()).norm() / std::max(1.0, C.norm()), 1e-6);
  }
}

// A_G v is the sum of the links' momenta, each computed from its own centre-of-mass velocity.
TEST_P(Dynamics, CentroidalMomentumIsTheSumOfLinkMomenta) {
  hpr::test::RandomState rs(3);
  for (int s = 0; s < kSamples; ++s) {
    const VectorXd q = rs.q(model()), v = rs.v(model());
    ccrba(model(), *data, q, v);
    const Vector6d hg = data->hg;
    const Vector3d com = data->com;
    forward_kinematics(model(), *data, q, v);
    Vector3d p = Vector3d::Zero(), l = Vector3d::Zero(), mc = Vector3d::Zero();
    for (int i = 0; i < model().nb; ++i) {
      const Inertia& I = model().inertia[static_cast<size_t>(i)];
      const SE3& X = data->oMi[static_cast<size_t>(i)];
      const Vector3d c = X.act(I.com());
      const Vector3d w = data->vel[static_cast<size_t>(i)].tail<3>();
      const Vector3d vc = data->vel[static_cast<size_t>(i)].head<3>() + w.cross(c);
      p += I.m * vc;
      mc += I.m * c;
      l += I.m * (c - com).cross(vc) + X.R * I.inertia_about_com() * X.R.transpose() * w;
    }
    EXPECT_LT((mc / model().mass - com).norm(), 1e-12);
    EXPECT_LT((hg.head<3>() - p).norm(), 1e-10 * std::max(1.0, p.norm()));
    EXPECT_LT((hg.tail<3>() - l).norm(), 1e-10 * std::max(1.0, l.norm()));
    // The linear rows are m times the CoM Jacobian.
    EXPECT_LT(rel(data->Ag.topRows<3>(), model().mass * data->Jcom), 1e-13);
  }
}

TEST_P(Dynamics, CentroidalMomentumBiasMatchesFiniteDifferences) {
  hpr::test::RandomState rs(4);
  const double dt = 1e-6;
  for (int s = 0; s < 20; ++s) {
    const VectorXd q = rs.q(model()), v = rs.v(model());
    const Vector6d bias = centroidal_momentum_bias(model(), *data, q, v);
    const Matrix6Xd Ap = ccrba(model(), *data, integrate(model(), q, v * dt), v);
    const Matrix6Xd Am = ccrba(model(), *data, integrate(model(), q, -v * dt), v);
    const Vector6d fd = (Ap - Am) * v / (2 * dt);
    EXPECT_LT((bias - fd).norm() / std::max(1.0, fd.norm()), 1e-6);
    compute_all_terms(model(), *data, q, v);
    EXPECT_LT((data->dAg_v - bias).norm(), 1e-10 * std::max(1.0, bias.norm()));
  }
}

TEST_P(Dynamics, ComputeAllTermsAgreesWithTheSingleAlgorithms) {
  hpr::test::RandomState rs(5);
  Data other(model());
  for (int s = 0; s < 10; ++s) {
    const VectorXd q = rs.q(model()), v = rs.v(model());
    compute_all_terms(model(), *data, q, v);
    EXPECT_LT(rel(data->M, crba(model(), other, q)), 1e-13);
    EXPECT_LT(rel(data->nle, nonlinear_effects(model(), other, q, v)), 1e-13);
    EXPECT_LT(rel(data->g, generalized_gravity(model(), other, q)), 1e-13);
    EXPECT_LT(rel(data->Ag, ccrba(model(), other, q, v)), 1e-13);
  }
}

// Frame Jacobians (world, local-world-aligned, local) against finite differences of the placements.
TEST_P(Dynamics, FrameJacobiansMatchFiniteDifferences) {
  hpr::test::RandomState rs(6);
  const double dt = 1e-6;
  std::vector<int> frames = {robot->feet[0].sole_frame, robot->feet[1].sole_frame, robot->imu_frame};
  for (const auto& [name, joints] : robot->segments) {
    (void)name;
    frames.push_back(model().frame_index(model().body_name[static_cast<size_t>(joints.back() + 1)]));
  }
  Matrix6Xd J(6, model().nv), Jl(6, model().nv), Jw(6, model().nv);
  for (int s = 0; s < 20; ++s) {
    const VectorXd q = rs.q(model()), v = rs.v(model());
    auto placements = [&](const VectorXd& qq) {
      forward_kinematics(model(), *data, qq);
      update_frame_placements(model(), *data);
      return data->oMf;
    };
    const auto Xp = placements(integrate(model(), q, v * dt));
    const auto Xm = placements(integrate(model(), q, -v * dt));
    forward_kinematics(model(), *data, q, v);
    update_frame_placements(model(), *data);
    for (int f : frames) {
      const auto fu = static_cast<size_t>(f);
      frame_jacobian(model(), *data, f, ReferenceFrame::kLocalWorldAligned, J);
      Vector6d fd;
      fd.head<3>() = (Xp[fu].p - Xm[fu].p) / (2 * dt);
      fd.tail<3>() = log3(Xp[fu].R * Xm[fu].R.transpose()) / (2 * dt);
      EXPECT_LT((J * v - fd).norm() / std::max(1.0, fd.norm()), 1e-6) << model().frames[fu].name;
      EXPECT_LT((frame_velocity(model(), *data, f, ReferenceFrame::kLocalWorldAligned) - J * v).norm(), 1e-12);
      frame_jacobian(model(), *data, f, ReferenceFrame::kLocal, Jl);
      const Matrix3d& R = data->oMf[fu].R;
      EXPECT_LT((Jl.topRows<3>() - R.transpose() * J.topRows<3>()).norm(), 1e-12);
      frame_jacobian(model(), *data, f, ReferenceFrame::kWorld, Jw);
      EXPECT_LT((Jw * v - data->vel[static_cast<size_t>(model().frames[fu].body)]).norm(), 1e-12);
      // From q alone, over the frame's support chain only (on a workspace whose other bodies hold
      // another configuration's placements): the same Jacobian, bit for bit.
      hpr::model::Data other(model());
      forward_kinematics(model(), other, rs.q(model()));
      Matrix6Xd Jq(6, model().nv);
      compute_frame_jacobian(model(), other, q, f, ReferenceFrame::kLocalWorldAligned, Jq);
      EXPECT_EQ(Jq, J) << model().frames[fu].name;
    }
    // CoM Jacobian.
    const Vector3d cp = center_of_mass(model(), *data, integrate(model(), q, v * dt));
    const Vector3d cm = center_of_mass(model(), *data, integrate(model(), q, -v * dt));
    ccrba(model(), *data, q, v);
    EXPECT_LT((data->Jcom * v - (cp - cm) / (2 * dt)).norm(), 1e-6);
  }
}

// J̇ v of a frame: d/dt(J v) along the motion, at zero acceleration.
TEST_P(Dynamics, FrameBiasAccelerationMatchesFiniteDifferences) {
  hpr::test::RandomState rs(7);
  const double dt = 1e-6;
  Matrix6Xd J(6, model().nv);
  const int f = robot->feet[0].sole_frame;
  for (int s = 0; s < 20; ++s) {
    const VectorXd q = rs.q(model()), v = rs.v(model());
    auto Jv = [&](const VectorXd& qq) {
      forward_kinematics(model(), *data, qq);
      update_frame_placements(model(), *data);
      frame_jacobian(model(), *data, f, ReferenceFrame::kLocalWorldAligned, J);
      return Vector6d(J * v);
    };
    const Vector6d fd = (Jv(integrate(model(), q, v * dt)) - Jv(integrate(model(), q, -v * dt))) / (2 * dt);
    forward_kinematics(model(), *data, q, v);
    update_frame_placements(model(), *data);
    const Vector6d bias = frame_jacobian_time_variation_times_v(model(), *data, f);
    EXPECT_LT((bias - fd).norm() / std::max(1.0, fd.norm()), 1e-6);
  }
}

// The paper's coordinates: the inertia matrix is the congruence of M, its CoM block is m E and
// decoupled, kinetic energy agrees, gravity acts on the CoM rows only.
TEST_P(Dynamics, CentroidalCoordinates) {
  hpr::test::RandomState rs(8);
  MatrixXd Jhat, Mbar;
  for (int s = 0; s < kSamples; ++s) {
    const VectorXd q = rs.q(model()), v = rs.v(model());
    compute_all_terms(model(), *data, q, v);
    centroidal_velocity_map(model(), *data, Jhat);
    centroidal_mass_matrix(model(), *data, Mbar);
    const MatrixXd congruence = Jhat.transpose() * data->M * Jhat;
    EXPECT_LT(rel(Mbar, congruence), 1e-12);
    EXPECT_LT((congruence.topLeftCorner<3, 3>() - model().mass * Matrix3d::Identity()).norm(), 1e-10);
    EXPECT_LT(congruence.topRightCorner(3, model().nv - 3).norm(), 1e-10);
    VectorXd nu(model().nv), v2(model().nv);
    model_to_centroidal_velocity(model(), *data, v, nu);
    centroidal_to_model_velocity(model(), *data, nu, v2);
    EXPECT_LT((v2 - v).norm(), 1e-12 * v.norm());
    EXPECT_NEAR(0.5 * v.dot(data->M * v), 0.5 * nu.dot(Mbar * nu), 1e-10 * v.dot(data->M * v));
    const VectorXd gbar = Jhat.transpose() * data->g;
    EXPECT_LT(std::abs(gbar(2) - model().mass * 9.81), 1e-9);
    EXPECT_LT(gbar.tail(model().nv - 3).norm() + gbar.head<2>().norm(), 1e-9);
  }
}

// y = M̄ ν̇ + C̄ ν from centroidal_inverse_dynamics against the dynamics in model coordinates, with ν̇
// from finite differences of ν(t) = Ĵ(q(t))⁻¹ v(t); and dM̄/dt − 2C̄ skew-symmetric.
TEST_P(Dynamics, CentroidalInverseDynamics) {
  hpr::test::RandomState rs(9);
  const double dt = 1e-5;
  MatrixXd Mbar, Mp, Mm, Cbar(model().nv, model().nv);
  for (int s = 0; s < 20; ++s) {
    const VectorXd q = rs.q(model()), v = rs.v(model()), a = rs.v(model(), 3.0);
    auto nu_of = [&](const VectorXd& qq, const VectorXd& vv) {
      compute_all_terms(model(), *data, qq, vv);
      VectorXd nu(model().nv);
      model_to_centroidal_velocity(model(), *data, vv, nu);
      return nu;
    };
    const VectorXd qp = integrate(model(), q, v * dt + 0.5 * a * dt * dt);
    const VectorXd qm = integrate(model(), q, -v * dt + 0.5 * a * dt * dt);
    const VectorXd nudot = (nu_of(qp, v + a * dt) - nu_of(qm, v - a * dt)) / (2 * dt);
    const VectorXd nu = nu_of(q, v);
    MatrixXd Jhat;
    centroidal_velocity_map(model(), *data, Jhat);
    const VectorXd expected = Jhat.transpose() * (rnea(model(), *data, q, v, a) - generalized_gravity(model(), *data, q));
    const VectorXd y = centroidal_inverse_dynamics(model(), *data, q, v, nu, nudot);
    // On the kinematics compute_all_terms made (the wbc's tick): the same, bit for bit.
    compute_all_terms(model(), *data, q, v);
    EXPECT_EQ(centroidal_inverse_dynamics_from_kinematics(model(), *data, v, nu, nudot), y);
    EXPECT_LT(rel(y, expected), 1e-6);
    // At rest the C̄ term vanishes: y = M̄ ν̇.
    const VectorXd zero = VectorXd::Zero(model().nv);
    compute_all_terms(model(), *data, q, zero);
    centroidal_mass_matrix(model(), *data, Mbar);
    EXPECT_LT(rel(centroidal_inverse_dynamics(model(), *data, q, zero, nu, nudot), Mbar * nudot), 1e-12);
    // Skew symmetry of dM̄/dt − 2C̄.
    VectorXd e = zero;
    for (int k = 0; k < model().nv; ++k) {
      e.setZero();
      e(k) = 1.0;
      Cbar.col(k) = centroidal_inverse_dynamics(model(), *data, q, v, e, zero);
    }
    compute_all_terms(model(), *data, integrate(model(), q, v * dt), v);
    centroidal_mass_matrix(model(), *data, Mp);
    compute_all_terms(model(), *data, integrate(model(), q, -v * dt), v);
    centroidal_mass_matrix(model(), *data, Mm);
    const MatrixXd N = (Mp - Mm) / (2 * dt) - 2 * Cbar;
    EXPECT_LT((N + N.transpose()).norm() / std::max(1.0, Cbar.norm()), 1e-5);
    // The CoM rows of C̄ are zero (M̄'s CoM block is constant and decoupled).
    EXPECT_LT(Cbar.topRows<3>().norm(), 1e-9 * std::max(1.0, Cbar.norm()));
  }
}

// The task Jacobian (2): J J⁻¹ = E, the foot rows give the foot twists, A ν is the CAM, Ā = A J⁻¹.
TEST_P(Dynamics, TaskJacobian) {
  hpr::test::RandomState rs(10);
  TaskSpace ts(*robot);
  MatrixXd J, Jinv;
  int checked = 0;
  for (int s = 0; s < kSamples; ++s) {
    VectorXd q = robot->standing_configuration();
    const VectorXd dq = rs.v(model(), 0.3);
    q = integrate(model(), q, dq);
    const VectorXd v = rs.v(model());
    compute_all_terms(model(), *data, q, v);
    if (!ts.update(model(), *data)) continue;
    ++checked;
    ts.jacobian(J);
    ts.jacobian_inverse(Jinv);
    EXPECT_LT((J * Jinv - MatrixXd::Identity(model().nv, model().nv)).norm(), 1e-9);
    VectorXd nu(model().nv), xdot(model().nv);
    model_to_centroidal_velocity(model(), *data, v, nu);
    ts.apply(nu, xdot);
    for (int k = 0; k < 2; ++k) {
      const Vector6d twist = frame_velocity(model(), *data, robot->feet[static_cast<size_t>(k)].sole_frame,
                                            ReferenceFrame::kLocalWorldAligned);
      EXPECT_LT((xdot.segment<6>(6 + 6 * k) - twist).norm(), 1e-10 * std::max(1.0, twist.norm()));
    }
    EXPECT_LT((ts.A() * nu - data->hg.tail<3>()).norm(), 1e-10 * std::max(1.0, data->hg.tail<3>().norm()));
    EXPECT_LT((ts.Abar() * xdot - data->hg.tail<3>()).norm(), 1e-9 * std::max(1.0, data->hg.tail<3>().norm()));
    EXPECT_LT(rel(ts.Abar(), ts.A() * Jinv), 1e-10);
    VectorXd w = rs.v(model()), out(model().nv);
    ts.apply_transpose(w, out);
    EXPECT_LT(rel(out, J.transpose() * w), 1e-12);
  }
  EXPECT_GT(checked, kSamples / 2);
}

TEST_P(Dynamics, StretchedKneeIsReportedSingular) {
  TaskSpace ts(*robot);
  VectorXd q = robot->standing_configuration();
  compute_all_terms(model(), *data, q, VectorXd::Zero(model().nv));
  EXPECT_TRUE(ts.update(model(), *data)) << "standing posture must be regular, rcond " << ts.rcond();
  const double rcond_bent = ts.rcond();
  // Straighten both legs: hip, knee and ankle pitch at zero.
  for (int j : robot->leg_joints) q(7 + j) = 0.0;
  compute_all_terms(model(), *data, q, VectorXd::Zero(model().nv));
  EXPECT_FALSE(ts.update(model(), *data));
  EXPECT_TRUE(ts.singular());
  EXPECT_LT(ts.rcond(), 1e-3 * rcond_bent);
}

INSTANTIATE_TEST_SUITE_P(Robots, Dynamics, ::testing::Values("toro", "h1_2"));

}  // namespace
