// The whole-body controller on its own: the contact wrench QP, and the torques (9) against the
// model's constrained dynamics, which must reproduce the desired closed loop (4).
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <limits>
#include <random>
#include <tuple>
#include <vector>

#include "hpr/model/centroidal.hpp"
#include "hpr/planner/component.hpp"
#include "hpr/wbc/component.hpp"
#include "hpr/wbc/controller.hpp"
#include "model_fixture.hpp"

namespace {

using namespace hpr;
using Eigen::MatrixXd;
using Eigen::Vector3d;
using Eigen::VectorXd;
using wbc::Vector6d;

model::SE3 random_sole(std::mt19937& gen, double y) {
  std::uniform_real_distribution<double> u(-1, 1);
  model::SE3 X;
  X.p = Vector3d(0.05 * u(gen), y + 0.03 * u(gen), 0.01 * u(gen));
  X.R = (Eigen::AngleAxisd(0.3 * u(gen), Vector3d::UnitZ()) * Eigen::AngleAxisd(0.05 * u(gen), Vector3d::UnitY()) *
         Eigen::AngleAxisd(0.05 * u(gen), Vector3d::UnitX()))
            .toRotationMatrix();
  return X;
}

// A wrench strictly inside the contact constraints of a sole (local frame), expressed in world axes.
Vector6d feasible_wrench(std::mt19937& gen, const wbc::Contact& c, const wbc::ContactParams& p) {
  std::uniform_real_distribution<double> u(-1, 1), fz(100, 600);
  const double f = fz(gen);
  const double mu = 0.7 * p.friction * std::cos(M_PI / 8) / std::sqrt(2.0);
  const double hx = 0.7 * (0.5 * c.length - p.cop_margin), hy = 0.7 * (0.5 * c.width - p.cop_margin);
  Vector6d local;
  local << mu * f * u(gen), mu * f * u(gen), f, hy * f * u(gen), hx * f * u(gen), 0.7 * p.torsion * f * u(gen);
  Vector6d w;
  w.head<3>() = c.X_WS.R * local.head<3>();
  w.tail<3>() = c.X_WS.R * local.tail<3>();
  return w;
}

Vector6d com_wrench(const std::array<wbc::Contact, 2>& c, const std::array<Vector6d, 2>& w, const Vector3d& com) {
  Vector6d out = Vector6d::Zero();
  for (int k = 0; k < 2; ++k) {
    if (!c[static_cast<size_t>(k)].active) continue;
    const Vector6d& wk = w[static_cast<size_t>(k)];
    out.head<3>() += wk.head<3>();
    out.tail<3>() += wk.tail<3>() + (c[static_cast<size_t>(k)].X_WS.p - com).cross(wk.head<3>());
  }
  return out;
}

void expect_constraints_hold(const std::array<wbc::Contact, 2>& c, const std::array<Vector6d, 2>& w,
                             const wbc::ContactParams& p) {
  for (int k = 0; k < 2; ++k) {
    if (!c[static_cast<size_t>(k)].active) continue;
    const int rows = wbc::ContactQp::rows_per_foot(p);
    MatrixXd C(rows, 6);
    VectorXd lb(rows), ub(rows);
    wbc::ContactQp::foot_constraints(c[static_cast<size_t>(k)], p, C, lb, ub);
    const VectorXd r = C * w[static_cast<size_t>(k)];
    for (int i = 0; i < r.size(); ++i) {
      EXPECT_GE(r(i), lb(i) - 1e-7) << "foot " << k << " row " << i;
      EXPECT_LE(r(i), ub(i) + 1e-7) << "foot " << k << " row " << i;
    }
  }
}

TEST(ContactQp, FeasibleWrenchIsMetExactly) {
  std::mt19937 gen(31);
  wbc::ContactParams p;
  wbc::ContactQp qp(p);
  for (int s = 0; s < 200; ++s) {
    std::array<wbc::Contact, 2> c;
    c[0] = {true, random_sole(gen, -0.1), 0.2, 0.1, 1.0};
    c[1] = {s % 5 != 0, random_sole(gen, 0.1), 0.2, 0.1, 1.0};  // some single support
    const Vector3d com(0.02, 0.0, 0.9);
    const std::array<Vector6d, 2> w_true{feasible_wrench(gen, c[0], p), feasible_wrench(gen, c[1], p)};
    const Vector6d w_des = com_wrench(c, w_true, com);
    ASSERT_EQ(qp.solve(c, com, w_des), qp::Status::kOptimal) << "sample " << s;
    EXPECT_TRUE(qp.exact());
    EXPECT_LT((qp.achieved() - w_des).norm(), 1e-8 * w_des.norm()) << "sample " << s;
    EXPECT_LT((com_wrench(c, qp.wrenches(), com) - w_des).norm(), 1e-8 * w_des.norm());
    expect_constraints_hold(c, qp.wrenches(), p);
  }
}

// The sole's torsion bound (ContactParams::sole_torsion) against an independent model of the same
// contact: four corner points, each in the friction pyramid |f_x|, |f_y| <= mu_p f_z. For a force
// and a CoP, the largest and smallest torsion the corners can hold is a linear programme, solved
// here as a QP with a vanishing regularisation; the closed form must give the same interval.
TEST(ContactQp, SoleTorsionIsWhatFourCornerContactsHold) {
  std::mt19937 gen(35);
  std::uniform_real_distribution<double> u(-1, 1);
  wbc::ContactParams p;
  p.sole_torsion = true;
  p.cop_margin = 0.0;
  p.torsion = 10.0;  // the constant bound out of the way
  const wbc::Contact c{true, model::SE3{}, 0.2, 0.1, 1.0};
  const double X = 0.1, Y = 0.05, mu_p = p.friction / std::sqrt(2.0);
  MatrixXd C(wbc::ContactQp::kMaxRowsPerFoot, 6);
  VectorXd lb(wbc::ContactQp::kMaxRowsPerFoot), ub(wbc::ContactQp::kMaxRowsPerFoot);
  wbc::ContactQp::foot_constraints(c, p, C, lb, ub);
  // Corner forces x = (f_x1..4, f_y1..4, f_z1..4) at (±X, ±Y).
  const double cx[4] = {X, X, -X, -X}, cy[4] = {Y, -Y, Y, -Y};
  MatrixXd A = MatrixXd::Zero(5 + 16, 12);
  for (int i = 0; i < 4; ++i) {
    A(0, i) = A(1, 4 + i) = A(2, 8 + i) = 1;  // the force
    A(3, 8 + i) = cy[i];                     // tau_x = sum y_i f_zi
    A(4, 8 + i) = -cx[i];                    // tau_y = -sum x_i f_zi
    for (int axis = 0; axis < 2; ++axis) {
      for (const double s : {1.0, -1.0}) {
        const int r = 5 + 8 * axis + 4 * (s > 0 ? 0 : 1) + i;
        A(r, 4 * axis + i) = s;
        A(r, 8 + i) = -mu_p;
      }
    }
  }
  constexpr double kInf = std::numeric_limits<double>::infinity();
  VectorXd g(12), lbx = VectorXd::Constant(12, -kInf), ubx = VectorXd::Constant(12, kInf);
  lbx.tail<4>().setZero();
  for (int i = 0; i < 4; ++i) {
    g(i) = cy[i];       // minimise -tau_z = -sum (x_i f_yi - y_i f_xi)
    g(4 + i) = -cx[i];
    g(8 + i) = 0;
  }
  const MatrixXd H = 1e-7 * MatrixXd::Identity(12, 12);  // the optimum moves by about 1e-7 of a unit force
  qp::Solver lp(12, 21);
  int corners = 0;
  for (int s = 0; s < 300; ++s) {
    // f_z = 1; a CoP anywhere in the sole (next to its edge or corner one sample in five; exactly on
    // them the corners' LP is degenerate, which the active-set solver reports infeasible); a force along
    // the ground within the pyramid.
    const double edge = s % 5 == 0 ? 0.999 : 0.98;
    Vector6d w;
    w << 0.9 * mu_p * u(gen), 0.9 * mu_p * u(gen), 1.0, 0, 0, 0;
    double px = X * u(gen), py = Y * u(gen);
    if (s % 5 == 0) (s % 10 == 0 ? px : py) = (u(gen) > 0 ? 1 : -1) * (s % 10 == 0 ? X : Y) * edge;
    if (s % 15 == 0) { px = (u(gen) > 0 ? X : -X) * 0.999; py = (u(gen) > 0 ? Y : -Y) * 0.999; ++corners; }
    w(3) = py;   // tau_x = p_y f_z
    w(4) = -px;  // tau_y = -p_x f_z
    VectorXd lbA = VectorXd::Constant(21, -kInf), ubA = VectorXd::Zero(21);
    lbA.head<5>() = w.head<5>();
    ubA.head<5>() = w.head<5>();
    double tau[2];
    for (int k = 0; k < 2; ++k) {
      const double sign = k == 0 ? 1.0 : -1.0;  // max, then min
      ASSERT_EQ(lp.solve_cold(H, sign * g, A, lbx, ubx, lbA, ubA), qp::Status::kOptimal) << "sample " << s;
      const VectorXd& f = lp.x();
      tau[k] = 0;
      for (int i = 0; i < 4; ++i) tau[k] += cx[i] * f(4 + i) - cy[i] * f(i);
    }
    // The closed form: the torsion rows (coefficient ±1 on tau_z) bound it given the rest of w.
    double hi = kInf, lo = -kInf;
    for (int r = wbc::ContactQp::kBaseRowsPerFoot; r < wbc::ContactQp::kMaxRowsPerFoot; ++r) {
      const double rest = C.row(r).head<5>().dot(w.head<5>()), a = C(r, 5);
      ASSERT_NEAR(std::abs(a), 1.0, 1e-12);
      if (a > 0) hi = std::min(hi, (ub(r) - rest) / a);
      else lo = std::max(lo, (ub(r) - rest) / a);
    }
    EXPECT_NEAR(hi, tau[0], 1e-5) << "sample " << s << ": p = (" << px << ", " << py << ")";
    EXPECT_NEAR(lo, tau[1], 1e-5) << "sample " << s;
    EXPECT_LE(lo, hi + 1e-9);
  }
  EXPECT_GT(corners, 10);
  // And the contact QP keeps within it: one sole, its CoP asked 0.999 of the way to a corner with a
  // force along the ground and 3 N m of torsion the constant bound allows. The four corners hold
  // only the torsion of that force at the corner (about -3 N m): bounded, the QP returns a torsion
  // in the corners' interval for the wrench it returns; unbounded, the asked one.
  const auto interval = [&](const Vector6d& w) {
    const double hi = mu_p * (X + Y) * w(2) - std::abs(Y * w(0) + mu_p * w(3)) - std::abs(X * w(1) + mu_p * w(4));
    const double lo = -mu_p * (X + Y) * w(2) + std::abs(Y * w(0) - mu_p * w(3)) + std::abs(X * w(1) - mu_p * w(4));
    return std::pair{lo, hi};
  };
  Vector6d asked;
  asked << 30.0, -15.0, 300.0, 0.999 * Y * 300.0, -0.999 * X * 300.0, 3.0;
  const std::array<wbc::Contact, 2> one{c, wbc::Contact{}};
  for (const bool bounded : {false, true}) {
    p.sole_torsion = bounded;
    wbc::ContactQp qp(p);
    ASSERT_TRUE(qp::usable(qp.solve(one, Vector3d::Zero(), asked))) << bounded;
    const Vector6d& w = qp.wrenches()[0];
    const auto [lo, hi] = interval(w);
    if (bounded) {
      EXPECT_GE(w(5), lo - 1e-6);
      EXPECT_LE(w(5), hi + 1e-6);
      EXPECT_LT(w(5), 0.0);
    } else {
      EXPECT_TRUE(qp.exact());
      EXPECT_NEAR(w(5), 3.0, 1e-6);
      EXPECT_GT(w(5), hi + 1.0);  // what four corners cannot hold
    }
  }
}

TEST(ContactQp, InfeasibleWrenchKeepsTheConstraintsAndMinimisesTheError) {
  std::mt19937 gen(32);
  wbc::ContactParams p;
  p.max_working_set_changes = 100;  // every sample is a new problem: no hot start to rely on
  wbc::ContactQp qp(p);
  // Reference: the same least-squares problem with a far smaller regularisation and no weight on
  // the forces along the soles and the torsions, solved cold: those cost the error next to nothing.
  wbc::ContactParams pr = p;
  pr.regularization = 1e-7;
  pr.tangential_weight = pr.torsion_weight = 0;
  for (int s = 0; s < 100; ++s) {
    std::array<wbc::Contact, 2> c;
    c[0] = {true, random_sole(gen, -0.1), 0.2, 0.1, 1.0};
    c[1] = {true, random_sole(gen, 0.1), 0.2, 0.1, 1.0};
    const Vector3d com(0.0, 0.0, 0.9);
    Vector6d w_des;
    std::uniform_real_distribution<double> u(-1, 1);
    w_des << 150 * u(gen), 150 * u(gen), 780, 400 * u(gen), 400 * u(gen), 60 * u(gen);  // CoP far outside
    const qp::Status st = qp.solve(c, com, w_des);
    ASSERT_TRUE(qp.valid()) << "sample " << s << " status " << qp::to_string(st) << " changes " << qp.iterations();
    if (qp.exact()) continue;
    expect_constraints_hold(c, qp.wrenches(), p);
    wbc::ContactQp ref(pr);
    ref.solve(c, com, w_des);
    ASSERT_TRUE(ref.valid());
    auto err = [&](const Vector6d& achieved) {
      const Vector6d e = achieved - w_des;
      return std::sqrt(p.force_weight * e.head<3>().squaredNorm() + p.torque_weight * e.tail<3>().squaredNorm());
    };
    EXPECT_LE(err(qp.achieved()), err(ref.achieved()) + 1e-3 * w_des.norm()) << "sample " << s;
  }
}

// The H1-2 standing on its heels, both soles tilted 1.5° (toes up, turned ±1°), as a 45 N s push
// from the front leaves it: the CoM wrench the impedances ask for has its CMP behind the heels.
// Without ρ_t, ρ_z the least-squares distribution squeezed the feet together with 186 N each
// (the friction limit at 0.55 f_z) and twisted them with ±6.5 N m (the torsion limit) for 0.1 N m
// less pitch error; in simulation the soles then turned 27° on the ground.
TEST(ContactQp, AnOutOfReachWrenchIsDistributedWithoutInternalForces) {
  std::array<wbc::Contact, 2> c;
  c[0].active = c[1].active = true;
  c[0].X_WS.p = Vector3d(0.0015, -0.1647, 0.0023);
  c[0].X_WS.R = Eigen::AngleAxisd(0.02553, Vector3d(-0.0048, -0.7258, -0.6879).normalized()).toRotationMatrix();
  c[1].X_WS.p = Vector3d(0.0012, 0.1647, 0.0027);
  c[1].X_WS.R = Eigen::AngleAxisd(0.02518, Vector3d(0.0050, -0.8650, 0.5018).normalized()).toRotationMatrix();
  for (auto& foot : c) {
    foot.length = 0.26;
    foot.width = 0.086;
  }
  const Vector3d com(-0.0508, 0.0001, 0.8975);
  Vector6d w_des;
  w_des << 87.2, 0.0, 673.7, 1.2, 32.1, 0.1;

  wbc::ContactParams p;
  p.max_working_set_changes = 100;
  wbc::ContactParams p0 = p;
  p0.tangential_weight = p0.torsion_weight = 0;
  wbc::ContactQp qp(p), qp0(p0);
  qp.solve(c, com, w_des);
  qp0.solve(c, com, w_des);
  ASSERT_TRUE(qp.valid());
  ASSERT_TRUE(qp0.valid());
  ASSERT_FALSE(qp.exact());  // out of reach: the least-squares fallback
  expect_constraints_hold(c, qp.wrenches(), p);
  auto err = [&](const Vector6d& achieved) {
    const Vector6d e = achieved - w_des;
    return std::sqrt(p.force_weight * e.head<3>().squaredNorm() + p.torque_weight * e.tail<3>().squaredNorm());
  };
  // The scenario is the one described: without the weights the feet are squeezed and twisted.
  EXPECT_GT(std::abs(qp0.wrenches()[0].y()), 100.0);
  EXPECT_GT(std::abs(qp0.wrenches()[0](5)), 5.0);
  for (int k = 0; k < 2; ++k) {
    const Vector6d& w = qp.wrenches()[static_cast<size_t>(k)];
    EXPECT_LT(std::abs(w.y()), 5.0) << "foot " << k << ": sideways force " << w.y() << " N";
    EXPECT_LT(w.head<2>().norm(), 0.2 * w.z()) << "foot " << k << ": well inside the friction cone";
    EXPECT_LT(std::abs(w(5)), 1.0) << "foot " << k << ": torsion";
  }
  // And the CoM wrench is as close to the desired one, to a fraction of a percent of the error.
  EXPECT_LE(err(qp.achieved()), 1.005 * err(qp0.achieved()));
  EXPECT_NEAR(qp.achieved()(0), qp0.achieved()(0), 2.0);  // the forward force the sole can give
}

// Torques (9) in the model's constrained dynamics (both feet fixed) reproduce the closed loop (4):
//   M̄ Δν̇ + C̄ Δν = Jᵀ(0; λ; 0) − Jᵀ(w_imp; w_feet; τ_f^imp)
// with λ the contact wrenches of the constrained dynamics. Checked in model coordinates through
// M̄ ν̇ + C̄ ν = Ĵᵀ (M a + C v) and M̄ ν̇^cmd + C̄ ν^cmd = the controller's feedforward.
TEST(Wbc, TorquesReproduceTheDesiredClosedLoop) {
  for (const char* name : {"toro", "h1_2"}) {
    const auto robot = test::load_robot(name);
    const model::Model& m = robot.model;
    const Config cfg = Config::load(test::source_dir() + "/config/" + name + ".yaml");
    wbc::WholeBodyController ctl(robot, wbc::WbcConfig::load(cfg.section("wbc"), robot));
    test::RandomState rs(41);
    int checked = 0;
    for (int s = 0; s < 20; ++s) {
      const VectorXd q = model::integrate(m, robot.standing_configuration(), rs.v(m, 0.03));
      VectorXd v = rs.v(m, 0.3);
      balance::PostureReference pref(robot, {});
      pref.start(q, 0.0);
      balance::TaskReference cmd = pref.update(0.3);
      // A commanded motion of the base and free joints on top of the reference.
      cmd.omega_base = 0.2 * Vector3d(rs.uniform(-1, 1), rs.uniform(-1, 1), rs.uniform(-1, 1));
      cmd.omegadot_base = Vector3d(rs.uniform(-1, 1), rs.uniform(-1, 1), rs.uniform(-1, 1));
      for (int i = 0; i < cmd.qd_free.size(); ++i) {
        cmd.qd_free(i) = rs.uniform(-0.5, 0.5);
        cmd.qdd_free(i) = rs.uniform(-2, 2);
      }
      // Feet in contact do not move: zero the feet velocities of the state (a constrained motion).
      model::Data d(m);
      model::forward_kinematics(m, d, q, v);
      MatrixXd Jc(12, m.nv);
      model::Matrix6Xd Jf(6, m.nv);
      for (int k = 0; k < 2; ++k) {
        model::frame_jacobian(m, d, robot.feet[static_cast<size_t>(k)].sole_frame, model::ReferenceFrame::kLocalWorldAligned, Jf);
        Jc.middleRows<6>(6 * k) = Jf;
      }
      const MatrixXd N = MatrixXd::Identity(m.nv, m.nv) - Jc.transpose() * (Jc * Jc.transpose()).ldlt().solve(Jc);
      v = N * v;  // project onto J_c v = 0
      wbc::RobotState st;
      st.q = q;
      st.v = v;
      ctl.step(st, cmd);
      // (4) holds when the desired CoM wrench (8) is met: skip the samples where it is not feasible.
      if (!ctl.status().qp_exact || ctl.status().singular || ctl.status().saturated) continue;
      ++checked;
      // Torque the drives apply: τ_ff plus their impedance.
      const JointCommand& c = ctl.command();
      const VectorXd tau = c.tau_ff + c.kp.cwiseProduct(c.q_des - q.tail(m.nj)) + c.kd.cwiseProduct(c.qd_des - v.tail(m.nj));
      EXPECT_LT((tau - ctl.tau_total()).norm(), 1e-9 * (1 + tau.norm())) << name;
      // Constrained forward dynamics: [M −J_cᵀ; J_c 0] [a; λ] = [Sᵀτ − h; −J̇_c v].
      model::compute_all_terms(m, d, q, v);
      const MatrixXd M = d.M;
      const VectorXd h = d.nle, g = d.g;
      MatrixXd K = MatrixXd::Zero(m.nv + 12, m.nv + 12);
      K.topLeftCorner(m.nv, m.nv) = M;
      K.topRightCorner(m.nv, 12) = -Jc.transpose();
      K.bottomLeftCorner(12, m.nv) = Jc;
      VectorXd rhs(m.nv + 12);
      rhs.head(m.nv) = -h;
      rhs.segment(6, m.nj) += tau;
      for (int k = 0; k < 2; ++k) {
        rhs.segment<6>(m.nv + 6 * k) = -model::frame_jacobian_time_variation_times_v(m, d, robot.feet[static_cast<size_t>(k)].sole_frame);
      }
      const VectorXd sol = K.fullPivLu().solve(rhs);
      const VectorXd a = sol.head(m.nv), lambda = sol.tail(12);
      // Left side of (4).
      MatrixXd Jhat;
      model::centroidal_velocity_map(m, d, Jhat);
      const VectorXd lhs = Jhat.transpose() * (M * a + h - g) - ctl.feedforward();
      // Right side of (4).
      model::TaskSpace ts(robot);
      ts.update(m, d);
      VectorXd w_contact = VectorXd::Zero(m.nv), w_ctl(m.nv), out_contact(m.nv), out_ctl(m.nv);
      w_contact.segment(6, 12) = lambda;
      ts.apply_transpose(w_contact, out_contact);
      w_ctl.head<6>() = ctl.w_imp();
      w_ctl.segment<6>(6) = ctl.foot_wrenches()[0];
      w_ctl.segment<6>(12) = ctl.foot_wrenches()[1];
      w_ctl.tail(m.nj - 12) = ctl.tau_free_imp();
      ts.apply_transpose(w_ctl, out_ctl);
      const VectorXd rhs4 = out_contact - out_ctl;
      EXPECT_LT((lhs - rhs4).norm(), 1e-6 * (1 + rhs4.norm())) << name << " sample " << s;
    }
    EXPECT_GT(checked, 10) << name;
  }
}

TEST(Wbc, TheHipTorqueIsTheFeedforwardTorqueAndAMovingCoMReferenceLoadsTheAnkles) {
  // (19) split τ_v between the feedforward (hip) and gravity plus impedance (ankle) for a resting
  // CoM reference, where the feedforward force is zero; (21) names the hip torque τ_b^ff. With a
  // CoM reference that accelerates (a step's pendulum) the feedforward force m c̈^ref is the CoP's
  // work: it counts to the ankle, the hip keeps τ_b^ff, and the sum is τ_v of the desired wrench.
  const auto robot = test::load_robot("toro");
  const model::Model& m = robot.model;
  const Config cfg = Config::load(test::source_dir() + "/config/toro.yaml");
  wbc::WholeBodyController ctl(robot, wbc::WbcConfig::load(cfg.section("wbc"), robot));
  const VectorXd q = robot.standing_configuration();
  wbc::RobotState st;
  st.q = q;
  st.v = VectorXd::Zero(m.nv);
  balance::PostureReference pref(robot, {});
  pref.start(q, 0.0);
  balance::TaskReference cmd = pref.update(3.0);
  model::Data d(m);
  const Vector3d com = model::center_of_mass(m, d, q);
  for (const Vector3d& a_com : {Vector3d(0, 0, 0), Vector3d(0.8, -0.5, 0.0)}) {
    cmd.a_com = a_com;
    ctl.step(st, cmd);
    const balance::BalanceStatus s = ctl.status();  // a copy: the controller steps again below
    const Vector6d w_ff = ctl.feedforward().head<6>();
    EXPECT_LT((w_ff.head<3>() - m.mass * a_com).norm(), 1e-6 * (1.0 + m.mass * a_com.norm())) << "f_ff = m c̈^ref";
    const Eigen::Matrix3d R_v = Eigen::AngleAxisd(s.yaw_WV, Vector3d::UnitZ()).toRotationMatrix();
    const Vector3d r = com - s.p_WV;
    EXPECT_LT((s.tau_hip_V - R_v.transpose() * w_ff.tail<3>()).norm(), 1e-9);
    const Vector3d tau_v = R_v.transpose() * (s.w_des.tail<3>() + r.cross(s.w_des.head<3>()));
    EXPECT_LT((s.tau_V - tau_v).norm(), 1e-6 * (1.0 + tau_v.norm()));
    EXPECT_LT((s.tau_ankle_V + s.tau_hip_V - s.tau_V).norm(), 1e-9);
    if (a_com.isZero()) {
      // At rest (the paper's case) the old split (19) gives the same hip torque.
      EXPECT_LT((s.tau_hip_V - R_v.transpose() * (w_ff.tail<3>() + r.cross(w_ff.head<3>()))).norm(), 1e-6);
    } else {
      // The CoM's own acceleration shows in the ankle torque: m r × c̈ of it.
      ctl.step(st, [&] { balance::TaskReference c = cmd; c.a_com.setZero(); return c; }());
      const Vector3d ankle_rest = ctl.status().tau_ankle_V;
      EXPECT_LT((s.tau_ankle_V - ankle_rest - R_v.transpose() * r.cross(m.mass * a_com)).norm(), 1e-3 * m.mass * a_com.norm());
    }
  }
}

TEST(PushCompensation, TheWbcAsksTheContactsToCancelTheObservedPushWithinItsBound) {
  // balance.push_compensation: standing settled, the CoM reference's acceleration is −F̂ / m, F̂ the
  // momentum observer's m c̈ − Σ f_ground. A robot at rest whose soles resist a steady push F (the
  // ground's horizontal force −F) gets c̈^ref = −F / m and the CoM wrench the wbc asks of the
  // contacts cancels F; the same when nothing on the ground resists and the CoM accelerates
  // (F̂ = m c̈); the force is clamped to max_force along its direction; a sensor's NaN restarts the
  // observer; off (unless configured) and without an estimate, nothing changes.
  const auto robot = test::load_robot("toro");
  const model::Model& m = robot.model;
  const Config cfg = Config::load(test::source_dir() + "/config/toro.yaml");
  wbc::WholeBodyController ctl(robot, wbc::WbcConfig::load(cfg.section("wbc"), robot));
  const auto on = balance::PostureReferenceConfig::load(
      Config::parse("balance: {push_compensation: {enabled: true, filter: 0.1, max_force: 150}}", "test.yaml").section("balance"));
  EXPECT_FALSE(balance::PostureReferenceConfig{}.push_compensation.enabled) << "off unless configured";
  EXPECT_TRUE(balance::PostureReferenceConfig::load(cfg.section("balance")).push_compensation.enabled) << "on in config/toro.yaml";
  EXPECT_THROW((void)balance::PostureReferenceConfig::load(
                   Config::parse("balance: {push_compensation: {filter: 0}}", "test.yaml").section("balance")),
               ConfigError);
  EXPECT_THROW((void)balance::PostureReferenceConfig::load(
                   Config::parse("balance: {push_compensation: {enable: true}}", "test.yaml").section("balance")),
               ConfigError)
      << "a misspelt key is refused, not ignored";
  const VectorXd q = robot.standing_configuration();
  model::Data d(m);
  const Vector3d com = model::center_of_mass(m, d, q);
  // `ground` resists a push at rest; `accel` is the CoM's acceleration with no ground force.
  struct Case {
    Eigen::Vector2d ground, accel, expected_force;
  };
  const std::vector<Case> cases{{{-60.0, 20.0}, {0.0, 0.0}, {60.0, -20.0}},
                                {{0.0, 0.0}, {0.3, -0.1}, {0.3 * m.mass, -0.1 * m.mass}},
                                {{-300.0, 100.0}, {0.0, 0.0}, Eigen::Vector2d(300.0, -100.0).normalized() * 150.0}};
  for (const Case& c : cases) {
    balance::PostureReference pref(robot, on), off(robot, {});
    pref.start(q, 0.0);
    off.start(q, 0.0);
    EstimatedState st;
    st.q = q;
    st.v = VectorXd::Zero(m.nv);
    st.p_com = com;
    st.contact = {true, true};
    balance::TaskReference ref, ref_off;
    for (int i = 0; i <= 2000; ++i) {
      const double t = 1e-3 * i;
      st.time = t;
      st.v_com.head<2>() = c.accel * t;
      for (auto& w : st.foot_wrench_W) {
        w.setZero();
        w.head<2>() = 0.5 * c.ground;
        w(2) = 0.5 * m.mass * 9.81;
      }
      if (i == 1500) st.foot_wrench_W[0](0) = std::numeric_limits<double>::quiet_NaN();
      ref = pref.update(t, &st);
      ref_off = off.update(t, &st);
      ASSERT_TRUE(ref.a_com.allFinite()) << t;
      if (t < 1.0) {
        EXPECT_EQ(ref.a_com, ref_off.a_com) << "no compensation before the start's blend ends: " << t;
      } else {
        EXPECT_TRUE(ref_off.a_com.isZero()) << "off: " << t;
      }
      EXPECT_LT((ref.p_com - ref_off.p_com).norm(), 1e-12) << "the CoM reference itself does not move";
      if (i == 1499) {
        EXPECT_LT((-m.mass * ref.a_com.head<2>() - c.expected_force).norm(), 1e-3 * c.expected_force.norm());
      }
      if (i == 1500) {
        EXPECT_TRUE(ref.a_com.isZero()) << "the NaN sample restarts the observer";
      }
    }
    // 0.5 s after the restart the filtered force is back (τ = 40 ms observer, 0.1 s low-pass).
    EXPECT_LT((-m.mass * ref.a_com.head<2>() - c.expected_force).norm(), 0.02 * c.expected_force.norm()) << c.expected_force.transpose();
    EXPECT_EQ(ref.a_com.z(), 0.0);
    // The wbc, the robot at rest: the CoM force it asks for differs from the one without
    // compensation by −F̂, horizontally (the moment changes too: the leg accelerations that
    // would move the CoM carry angular momentum).
    wbc::RobotState rs;
    rs.q = q;
    rs.v = VectorXd::Zero(m.nv);
    ctl.step(rs, ref_off);
    const Vector6d w_off = ctl.status().w_des;
    ctl.step(rs, ref);
    const Vector6d dw = ctl.status().w_des - w_off;
    EXPECT_LT((dw.head<2>() + c.expected_force).norm(), 0.02 * c.expected_force.norm()) << c.expected_force.transpose();
    EXPECT_LT(std::abs(dw(2)), 1e-6 * c.expected_force.norm()) << dw.transpose();
    // Without an estimate the observer has nothing to go on: no feedforward.
    EXPECT_TRUE(pref.update(2.001, nullptr).a_com.isZero());
  }
}

TEST(Wbc, CommandsStayWithinTheJointLimits) {
  // A commanded motion far beyond what the joints can follow (J⁻¹ turns 4 m/s of CoM into leg
  // rates above their limits): the drives get targets inside their ranges, and the step says so.
  const auto robot = test::load_robot("toro");
  const model::Model& m = robot.model;
  const Config cfg = Config::load(test::source_dir() + "/config/toro.yaml");
  const wbc::WbcConfig config = wbc::WbcConfig::load(cfg.section("wbc"), robot);
  wbc::WholeBodyController ctl(robot, config);
  balance::PostureReference pref(robot, {});
  pref.start(robot.standing_configuration(), 0.0);
  balance::TaskReference cmd = pref.update(0.3);
  cmd.v_com = Vector3d(4.0, 0.0, -2.0);
  cmd.omega_base = Vector3d(0.0, 6.0, 0.0);
  wbc::RobotState st;
  st.q = robot.standing_configuration();
  st.v = VectorXd::Zero(m.nv);
  const JointCommand& c = ctl.step(st, cmd);
  EXPECT_TRUE(ctl.status().saturated);
  int at_limit = 0;
  for (int j = 0; j < m.nj; ++j) {
    const auto ju = static_cast<size_t>(j);
    EXPECT_LE(std::abs(c.qd_des(j)), m.v_max[ju] + 1e-12) << m.joint_name[ju];
    EXPECT_LE(std::abs(c.tau_ff(j)), config.max_torque_fraction * m.tau_max[ju] + 1e-12) << m.joint_name[ju];
    at_limit += std::abs(c.qd_des(j)) >= m.v_max[ju] - 1e-12 ? 1 : 0;
  }
  EXPECT_GT(at_limit, 0) << "some joint was asked for more than its velocity limit";
}

// The wbc process waits for the motion optimiser's command exactly when the component will use it
// (balances), so the processes and the composed pipeline step on the same inputs: the
// predicate must agree with what step() then does, tick by tick, over a start without an estimate,
// balancing, a run of unusable estimates up to the bad-state damp, recovery and an operator damp.
TEST(WbcComponent, UsesTheMotionOptimisersCommandExactlyWhenItBalances) {
  const auto robot = test::load_robot("toro");
  const Config cfg = Config::load(test::source_dir() + "/config/toro.yaml");
  constexpr int kBadStateTicks = 3;
  wbc::WbcComponent wbc(robot, wbc::WbcConfig::load(cfg.section("wbc"), robot), kBadStateTicks);
  planner::BalancePlanner planner(robot, balance::PostureReferenceConfig{});
  planner::BalancePlanner::Outputs plan;
  balance::PostureReference pref(robot, {});
  pref.start(robot.standing_configuration(), 0.0);
  const balance::TaskReference wholebody = pref.update(0.0);
  EstimatedState s;
  s.q = robot.standing_configuration();
  s.v = VectorXd::Zero(robot.model.nv);
  wbc::WbcComponent::Outputs out;
  // Per tick: the estimate's status, whether the operator damps, and whether the wbc balances.
  const std::vector<std::tuple<std::int32_t, bool, bool>> ticks{
      {EstimatedState::kImplausible, false, false},  // nothing to start the posture from
      {0, false, true},
      {EstimatedState::kNoContact, false, true},  // usable: no contact is the estimate's news, not a fault
      {EstimatedState::kImplausible, false, true},
      {EstimatedState::kSensorStale, false, true},
      {EstimatedState::kCovariance, false, false},  // the third unusable estimate in a row: damp
      {EstimatedState::kImplausible, false, false},
      {0, false, true},
      {0, true, false},  // the operator's damp
      {0, false, true},
  };
  for (size_t k = 0; k < ticks.size(); ++k) {
    const auto [status, damp, balances] = ticks[k];
    s.tick = static_cast<std::int64_t>(k);
    s.time = 0.001 * static_cast<double>(k);
    s.status = status;
    wbc.set_damping(damp);
    const bool uses = wbc.balances(s, planner.will_plan(s));
    planner.step({s}, plan);
    EXPECT_EQ(plan.valid, k > 0) << "tick " << k << ": the first usable estimate starts the plan";
    wbc.step({.state = s,
              .plan = plan.reference(),
              .wholebody = OptionalRef<balance::TaskReference>::when(uses, wholebody)},
             out);
    EXPECT_EQ(out.mode == wbc::WbcComponent::Mode::kBalance, balances) << "tick " << k;
    EXPECT_EQ(uses, balances) << "tick " << k;
    // The report says the same: the damping fault while it damps (not ready before the posture
    // started, damping after), cleared once it balances.
    EXPECT_EQ(out.report.raised("damping"), !balances) << "tick " << k;
    EXPECT_EQ(out.report.fault("damping").change == StepReport::Change::kCleared, balances) << "tick " << k;
    const StepOutcome expected = balances ? StepOutcome::kRunning : k == 0 ? StepOutcome::kNotReady : StepOutcome::kDamping;
    EXPECT_EQ(out.report.outcome, expected) << "tick " << k;
  }
}

// Without a plan the wbc damps: not ready before the first plan; once a plan has come and is
// lost (the planner stopped), damping, with the reason; a plan again, balancing again.
TEST(WbcComponent, DampsWithoutAPlanAndSaysWhetherItWasLost) {
  const auto robot = test::load_robot("toro");
  const Config cfg = Config::load(test::source_dir() + "/config/toro.yaml");
  wbc::WbcComponent wbc(robot, wbc::WbcConfig::load(cfg.section("wbc"), robot));
  balance::PostureReference pref(robot, {});
  pref.start(robot.standing_configuration(), 0.0);
  const balance::TaskReference plan = pref.update(0.0);
  EstimatedState s;
  s.q = robot.standing_configuration();
  s.v = VectorXd::Zero(robot.model.nv);
  wbc::WbcComponent::Outputs out;
  const auto step = [&](std::int64_t k, bool planned) {
    s.tick = k;
    s.time = 0.001 * static_cast<double>(k);
    wbc.step({.state = s, .plan = OptionalRef<balance::TaskReference>::when(planned, plan), .wholebody = {}}, out);
  };
  step(0, false);
  EXPECT_EQ(out.mode, wbc::WbcComponent::Mode::kDampNoState);
  EXPECT_EQ(out.command.mode, JointCommand::Mode::kDamp);
  EXPECT_EQ(out.report.outcome, StepOutcome::kNotReady);
  EXPECT_EQ(out.report.fault("damping").message(), "no balance plan yet (ROBOT_STATE status 0)");
  step(1, true);
  EXPECT_EQ(out.mode, wbc::WbcComponent::Mode::kBalance);
  EXPECT_EQ(out.report.outcome, StepOutcome::kRunning);
  step(2, false);
  EXPECT_EQ(out.mode, wbc::WbcComponent::Mode::kDampNoState);
  EXPECT_EQ(out.command.mode, JointCommand::Mode::kDamp);
  EXPECT_EQ(out.report.outcome, StepOutcome::kDamping) << "a lost plan is no start";
  EXPECT_EQ(out.report.fault("damping").message(), "BALANCE_PLAN stale: no plan to follow");
  step(3, true);
  EXPECT_EQ(out.mode, wbc::WbcComponent::Mode::kBalance);
  EXPECT_TRUE(out.report.fault("damping").change == StepReport::Change::kCleared);
  wbc.reset();
  step(4, false);
  EXPECT_EQ(out.report.outcome, StepOutcome::kNotReady) << "after a reset, waiting for the first plan again";
}

}  // namespace

namespace {

// The impedance caps hold for a configuration built in code as for a loaded one: the controller
// applies them, and a capped free joint's spring-damper meets kp h² ≤ 0.2 I, kd h ≤ 0.5 I at the
// standing posture (I = 1/(M⁻¹)_jj, from an independent CRBA here).
TEST(Wbc, ImpedanceCapsApplyToAConfigurationBuiltInCode) {
  using namespace hpr;
  const auto robot = test::load_robot("toro");
  const model::Model& m = robot.model;
  const int nf = static_cast<int>(robot.free_joints.size());
  wbc::WbcConfig config;  // not loaded
  config.K_free = Eigen::VectorXd::Constant(nf, 1e5);
  config.D_free = Eigen::VectorXd::Constant(nf, 1e4);
  config.K_swing.setConstant(1e7);
  config.D_swing.setConstant(1e6);
  const wbc::WholeBodyController ctl(robot, config);
  model::Data data(m);
  model::crba(m, data, robot.standing_configuration());
  const Eigen::MatrixXd Minv = data.M.inverse();
  const double h = ctl.config().drive_period;
  for (int i = 0; i < nf; ++i) {
    const int j = robot.free_joints[static_cast<size_t>(i)];
    const double I = 1.0 / Minv(6 + j, 6 + j);
    EXPECT_LE(ctl.config().K_free(i) * h * h, 0.2 * I * (1 + 1e-12)) << m.joint_name[static_cast<size_t>(j)];
    EXPECT_LE(ctl.config().D_free(i) * h, 0.5 * I * (1 + 1e-12)) << m.joint_name[static_cast<size_t>(j)];
    EXPECT_LT(ctl.config().K_free(i), 1e5) << "a light joint's stiffness is capped";
  }
  EXPECT_LT(ctl.config().K_swing.maxCoeff(), 1e7);
  // Loaded or built, the same numbers for the same gains.
  const Config cfg = Config::load(test::source_dir() + "/config/toro.yaml");
  const wbc::WbcConfig loaded = wbc::WbcConfig::load(cfg.section("wbc"), robot);
  const wbc::WholeBodyController from_file(robot, loaded);
  EXPECT_EQ(wbc::cap_impedances(loaded, robot).K_free, from_file.config().K_free);
  // Sizes that do not fit the robot are refused.
  wbc::WbcConfig wrong;
  wrong.K_free = Eigen::VectorXd::Constant(nf + 1, 10.0);
  EXPECT_THROW(wbc::WholeBodyController(robot, wrong), std::invalid_argument);
}

}  // namespace
