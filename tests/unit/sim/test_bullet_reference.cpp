// The model library against an independent implementation: Bullet's own Featherstone dynamics
// (btMultiBody's articulated-body algorithm and constraint Jacobians, double precision), for both
// robots at 100 random configurations and velocities.
#include <gtest/gtest.h>

#include "hpr/model/algorithms.hpp"
#include "hpr/sim/multibody.hpp"
#include "model_fixture.hpp"

namespace {

using namespace hpr;
using Eigen::VectorXd;

class BulletReference : public ::testing::TestWithParam<std::string> {
 protected:
  void SetUp() override {
    robot = std::make_unique<model::RobotSpec>(test::load_robot(GetParam()));
    data = std::make_unique<model::Data>(robot->model);
    bullet = std::make_unique<sim::MultiBodyRobot>(robot->model);
  }
  // Bullet's forward dynamics at (q, v) under the model's generalized force τ, with gravity applied
  // as link forces; returns the model's v̇.
  VectorXd bullet_forward_dynamics(const VectorXd& q, const VectorXd& v, const VectorXd& tau, bool gravity) {
    btMultiBody* mb = bullet->multibody();
    bullet->set_state(q, v);
    mb->clearForcesAndTorques();
    bullet->add_generalized_force(tau);
    if (gravity) {
      const btVector3 g = sim::to_bt(robot->model.gravity);
      mb->addBaseForce(mb->getBaseMass() * g);
      for (int i = 0; i < mb->getNumLinks(); ++i) mb->addLinkForce(i, mb->getLink(i).m_mass * g);
    }
    const int n = 6 + mb->getNumDofs();
    VectorXd before(n), after(n);
    for (int k = 0; k < n; ++k) before(k) = mb->getVelocityVector()[k];
    btAlignedObjectArray<btScalar> r;
    btAlignedObjectArray<btVector3> vv;
    btAlignedObjectArray<btMatrix3x3> mm;
    mb->computeAccelerationsArticulatedBodyAlgorithmMultiDof(1.0, r, vv, mm, false, false, false);
    for (int k = 0; k < n; ++k) after(k) = mb->getVelocityVector()[k];
    return bullet->to_model_acceleration(after - before, v);
  }
  std::unique_ptr<model::RobotSpec> robot;
  std::unique_ptr<model::Data> data;
  std::unique_ptr<sim::MultiBodyRobot> bullet;
};

TEST_P(BulletReference, StateRoundTrips) {
  test::RandomState rs(11);
  for (int s = 0; s < 10; ++s) {
    const VectorXd q = rs.q(robot->model), v = rs.v(robot->model);
    bullet->set_state(q, v);
    VectorXd q2, v2;
    bullet->get_state(q2, v2);
    EXPECT_LT(model::difference(robot->model, q, q2).norm(), 1e-12);
    EXPECT_LT((v2 - v).norm(), 1e-12);
  }
}

// Mass matrix: at rest without gravity, Bullet's acceleration under τ = M a is a.
TEST_P(BulletReference, MassMatrixAgrees) {
  test::RandomState rs(12);
  const VectorXd zero = VectorXd::Zero(robot->model.nv);
  for (int s = 0; s < 100; ++s) {
    const VectorXd q = rs.q(robot->model), a = rs.v(robot->model, 5.0);
    const VectorXd tau = model::crba(robot->model, *data, q) * a;
    const VectorXd a_bullet = bullet_forward_dynamics(q, zero, tau, false);
    EXPECT_LT(test::rel(a_bullet, a), 1e-9) << "sample " << s;
  }
}

// Inverse dynamics: Bullet's acceleration under τ = rnea(q, v, a) (gravity included) is a.
TEST_P(BulletReference, InverseDynamicsAgrees) {
  test::RandomState rs(13);
  for (int s = 0; s < 100; ++s) {
    const VectorXd q = rs.q(robot->model), v = rs.v(robot->model, 2.0), a = rs.v(robot->model, 5.0);
    const VectorXd tau = model::rnea(robot->model, *data, q, v, a);
    const VectorXd a_bullet = bullet_forward_dynamics(q, v, tau, true);
    EXPECT_LT(test::rel(a_bullet, a), 1e-9) << "sample " << s;
  }
}

// Jacobians: Bullet's constraint Jacobian rows (point velocity along world axes, angular velocity)
// times Bullet's velocity vector equal the model's frame Jacobian times v.
TEST_P(BulletReference, FrameJacobiansAgree) {
  test::RandomState rs(14);
  model::Matrix6Xd J(6, robot->model.nv);
  btMultiBody* mb = bullet->multibody();
  const int n = 6 + mb->getNumDofs();
  std::vector<btScalar> row(static_cast<size_t>(n));
  btAlignedObjectArray<btScalar> r;
  btAlignedObjectArray<btVector3> vv;
  btAlignedObjectArray<btMatrix3x3> mm;
  for (int s = 0; s < 100; ++s) {
    const VectorXd q = rs.q(robot->model), v = rs.v(robot->model);
    bullet->set_state(q, v);
    model::forward_kinematics(robot->model, *data, q, v);
    for (int foot = 0; foot < 2; ++foot) {
      const int frame = robot->feet[static_cast<size_t>(foot)].sole_frame;
      const int body = robot->model.frames[static_cast<size_t>(frame)].body;
      const model::SE3 X = model::update_frame_placement(robot->model, *data, frame);
      model::frame_jacobian(robot->model, *data, frame, model::ReferenceFrame::kLocalWorldAligned, J);
      const model::Vector6d twist = J * v;
      for (int k = 0; k < 6; ++k) {
        btVector3 lin(0, 0, 0), ang(0, 0, 0);
        (k < 3 ? lin : ang)[k % 3] = 1.0;
        mb->fillConstraintJacobianMultiDof(body - 1, sim::to_bt(X.p), ang, lin, row.data(), r, vv, mm);
        double dot = 0;
        for (int c = 0; c < n; ++c) dot += row[static_cast<size_t>(c)] * mb->getVelocityVector()[c];
        EXPECT_NEAR(dot, twist(k), 1e-9 * std::max(1.0, twist.norm())) << "sample " << s << " foot " << foot;
      }
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Robots, BulletReference, ::testing::Values("toro", "h1_2"));

}  // namespace
