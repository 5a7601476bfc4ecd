// The QP solver: KKT conditions on random problems (degenerate, redundant, infeasible), agreement
// with exhaustive active-set enumeration and with cvxopt, hot start against cold start on
// control-loop sequences, every status, the working-set cap, and no allocation in a solve.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <atomic>
#include <cstdlib>
#include <fstream>
#include <random>
#include <sstream>

#include "hpr/qp/qp_solver.hpp"
#include "process_group.hpp"
#include "hpr/qp/problems.hpp"

#include "allocation_counter.hpp"

namespace {

using namespace hpr::qp;
using hpr::qp::testing::kInf;
using hpr::qp::testing::Problem;
using Eigen::MatrixXd;
using Eigen::VectorXd;

Status solve(Solver& s, const Problem& p, bool hot = false) {
  return hot ? s.solve_hot(p.H, p.g, p.A, p.lb, p.ub, p.lbA, p.ubA)
             : s.solve_cold(p.H, p.g, p.A, p.lb, p.ub, p.lbA, p.ubA);
}

// A random problem of n variables and m rows around a feasible point, with some equalities, rows
// duplicated or scaled (redundant), and bounds chosen so that many constraints pass through the
// feasible point (degenerate).
Problem random_problem(std::mt19937& gen, int n, int m, bool degenerate) {
  std::normal_distribution<double> nd;
  std::uniform_real_distribution<double> ud(0, 1);
  Problem p;
  MatrixXd Mh(n, n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) Mh(i, j) = nd(gen);
  p.H = Mh.transpose() * Mh / n + 0.1 * MatrixXd::Identity(n, n);
  p.g.resize(n);
  for (int i = 0; i < n; ++i) p.g(i) = 3 * nd(gen);
  VectorXd xf(n);
  for (int i = 0; i < n; ++i) xf(i) = nd(gen);
  p.A.resize(m, n);
  for (int r = 0; r < m; ++r)
    for (int j = 0; j < n; ++j) p.A(r, j) = nd(gen);
  // Redundancy: some rows are copies or multiples of earlier ones.
  for (int r = 1; r < m; ++r) {
    if (ud(gen) < 0.1) p.A.row(r) = p.A.row(static_cast<int>(ud(gen) * r)) * (ud(gen) < 0.5 ? 1.0 : 2.5);
  }
  const VectorXd Ax = p.A * xf;
  p.lbA.resize(m);
  p.ubA.resize(m);
  for (int r = 0; r < m; ++r) {
    const double u = ud(gen);
    const double gap = degenerate && ud(gen) < 0.5 ? 0.0 : ud(gen);
    if (u < 0.05) {
      p.lbA(r) = p.ubA(r) = Ax(r);  // equality through the feasible point
    } else if (u < 0.4) {
      p.lbA(r) = Ax(r) - gap;
      p.ubA(r) = kInf;
    } else if (u < 0.75) {
      p.lbA(r) = -kInf;
      p.ubA(r) = Ax(r) + gap;
    } else {
      p.lbA(r) = Ax(r) - gap;
      p.ubA(r) = Ax(r) + ud(gen);
    }
  }
  p.lb.resize(n);
  p.ub.resize(n);
  for (int i = 0; i < n; ++i) {
    const double u = ud(gen);
    p.lb(i) = u < 0.3 ? -kInf : xf(i) - (degenerate && u < 0.5 ? 0.0 : ud(gen));
    p.ub(i) = u > 0.7 ? kInf : xf(i) + ud(gen);
  }
  return p;
}

void expect_kkt(const Solver& s, double tol, const std::string& what) {
  EXPECT_EQ(s.status(), Status::kOptimal) << what << ": " << to_string(s.status());
  EXPECT_LT(s.kkt().stationarity, tol) << what;
  EXPECT_LT(s.kkt().primal, tol) << what;
  EXPECT_LT(s.kkt().dual, tol) << what;
  EXPECT_LT(s.kkt().complementarity, tol) << what;
}

TEST(Qp, RandomProblemsSatisfyKkt) {
  std::mt19937 gen(1);
  int solved = 0;
  for (int n : {1, 2, 3, 5, 8, 12, 20, 35, 60}) {
    for (int m : {0, 1, 4, 10, 30, 80, 150}) {
      for (int rep = 0; rep < 6; ++rep) {
        const Problem p = random_problem(gen, n, m, rep % 2 == 1);
        Solver s(n, m);
        solve(s, p);
        expect_kkt(s, 1e-9, "n=" + std::to_string(n) + " m=" + std::to_string(m) + " rep=" + std::to_string(rep));
        ++solved;
      }
    }
  }
  EXPECT_EQ(solved, 9 * 7 * 6);
}

// Independent reference for small problems: try every assignment of {inactive, lower, upper} to
// the bounds and rows, solve the equality-constrained QP with a dense KKT system, and keep the
// feasible assignment whose multipliers have the right signs (unique for H positive definite).
VectorXd enumerate(const Problem& p) {
  const int n = static_cast<int>(p.g.size()), m = static_cast<int>(p.lbA.size());
  const int total = n + m;
  MatrixXd N(total, n);
  N << MatrixXd::Identity(n, n), p.A;
  VectorXd lo(total), hi(total);
  lo << p.lb, p.lbA;
  hi << p.ub, p.ubA;
  long combos = 1;
  for (int i = 0; i < total; ++i) combos *= 3;
  VectorXd best;
  double best_obj = kInf;
  for (long code = 0; code < combos; ++code) {
    std::vector<int> idx;
    std::vector<double> rhs;
    long c = code;
    bool ok = true;
    for (int i = 0; i < total; ++i) {
      const int st = static_cast<int>(c % 3);
      c /= 3;
      if (st == 1) {
        if (lo(i) == -kInf) ok = false;
        idx.push_back(i);
        rhs.push_back(lo(i));
      } else if (st == 2) {
        if (hi(i) == kInf || lo(i) == hi(i)) ok = false;
        idx.push_back(i);
        rhs.push_back(hi(i));
      }
    }
    if (!ok || static_cast<int>(idx.size()) > n) continue;
    const int q = static_cast<int>(idx.size());
    MatrixXd K = MatrixXd::Zero(n + q, n + q);
    VectorXd b(n + q);
    K.topLeftCorner(n, n) = p.H;
    b.head(n) = -p.g;
    for (int k = 0; k < q; ++k) {
      K.block(0, n + k, n, 1) = N.row(idx[static_cast<size_t>(k)]).transpose();
      K.block(n + k, 0, 1, n) = N.row(idx[static_cast<size_t>(k)]);
      b(n + k) = rhs[static_cast<size_t>(k)];
    }
    Eigen::FullPivLU<MatrixXd> lu(K);
    if (lu.rank() < n + q) continue;
    const VectorXd sol = lu.solve(b);
    const VectorXd x = sol.head(n);
    const VectorXd Nx = N * x;
    bool feasible = true;
    for (int i = 0; i < total; ++i) feasible = feasible && Nx(i) >= lo(i) - 1e-9 && Nx(i) <= hi(i) + 1e-9;
    if (!feasible) continue;
    // K x = b with the multipliers λ of +N rows: H x + g + Σ λ N = 0; lower needs λ ≤ 0, upper λ ≥ 0.
    bool signs = true;
    for (int k = 0; k < q; ++k) {
      const int i = idx[static_cast<size_t>(k)];
      const double lam = sol(n + k);
      if (lo(i) == hi(i)) continue;
      const bool lower = rhs[static_cast<size_t>(k)] == lo(i);
      signs = signs && (lower ? lam <= 1e-9 : lam >= -1e-9);
    }
    if (!signs) continue;
    const double obj = 0.5 * x.dot(p.H * x) + p.g.dot(x);
    if (obj < best_obj) {
      best_obj = obj;
      best = x;
    }
  }
  return best;
}

TEST(Qp, AgreesWithExhaustiveEnumeration) {
  std::mt19937 gen(2);
  int compared = 0;
  for (int rep = 0; rep < 300; ++rep) {
    const int n = 1 + rep % 4, m = rep % 5;
    const Problem p = random_problem(gen, n, m, rep % 3 == 0);
    const VectorXd ref = enumerate(p);
    ASSERT_GT(ref.size(), 0) << "reference found no optimum, rep " << rep;
    Solver s(n, m);
    solve(s, p);
    ASSERT_EQ(s.status(), Status::kOptimal) << "rep " << rep;
    EXPECT_LT((s.x() - ref).norm(), 1e-9 * (1 + ref.norm())) << "rep " << rep;
    ++compared;
  }
  EXPECT_EQ(compared, 300);
}

// cvxopt (Debian's python3-cvxopt), an interior-point solver, as an independent reference.
TEST(Qp, AgreesWithCvxopt) {
  if (std::system("/usr/bin/python3 -c 'import cvxopt' 2>/dev/null") != 0) {
    GTEST_SKIP() << "python3-cvxopt is not installed (tools/install-deps installs it)";
  }
  std::mt19937 gen(3);
  const std::string dir = hpr::test::temp_dir("cvxopt");
  std::ofstream f(dir + "/problems.txt");
  f.precision(17);
  std::vector<Problem> probs;
  for (int rep = 0; rep < 40; ++rep) {
    const int n = 2 + rep % 15, m = (rep * 7) % 40;
    probs.push_back(random_problem(gen, n, m, rep % 2 == 0));
    const Problem& p = probs.back();
    f << n << " " << m << "\n" << p.H.reshaped().transpose() << "\n" << p.g.transpose() << "\n";
    if (m > 0) f << p.A.reshaped<Eigen::RowMajor>().transpose();
    f << "\n";
    f << p.lb.transpose() << "\n" << p.ub.transpose() << "\n" << p.lbA.transpose() << "\n" << p.ubA.transpose() << "\n";
  }
  f.close();
  const std::string cmd = "/usr/bin/python3 " + hpr::test::source_dir() + "/tests/unit/qp/cvxopt_reference.py " + dir +
                          "/problems.txt " + dir + "/solutions.txt";
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  std::ifstream sol(dir + "/solutions.txt");
  for (size_t k = 0; k < probs.size(); ++k) {
    const Problem& p = probs[k];
    const int n = static_cast<int>(p.g.size());
    std::string status;
    sol >> status;
    VectorXd ref(n);
    for (int i = 0; i < n; ++i) sol >> ref(i);
    ASSERT_EQ(status, "optimal") << "cvxopt, problem " << k;
    Solver s(n, static_cast<int>(p.lbA.size()));
    solve(s, p);
    ASSERT_EQ(s.status(), Status::kOptimal) << "problem " << k;
    EXPECT_LT((s.x() - ref).norm(), 1e-6 * (1 + ref.norm())) << "problem " << k;
  }
}

TEST(Qp, InfeasibleSetsAreDetected) {
  std::mt19937 gen(4);
  for (int rep = 0; rep < 50; ++rep) {
    const int n = 2 + rep % 10, m = 3 + rep % 20;
    Problem p = random_problem(gen, n, m, false);
    // Row 0 and a copy of it with disjoint ranges.
    p.A.row(1) = p.A.row(0) * (1.0 + rep % 3);
    p.lbA(0) = 1.0;
    p.ubA(0) = 2.0;
    p.lbA(1) = -5.0 * (1.0 + rep % 3);
    p.ubA(1) = 0.5 * (1.0 + rep % 3);
    Solver s(n, m);
    EXPECT_EQ(solve(s, p), Status::kInfeasible) << "rep " << rep;
  }
  // A bound and a row that contradict each other.
  Problem p;
  p.H = MatrixXd::Identity(2, 2);
  p.g = VectorXd::Zero(2);
  p.A = (MatrixXd(1, 2) << 1, 1).finished();
  p.lb = VectorXd::Constant(2, -1);
  p.ub = VectorXd::Constant(2, 1);
  p.lbA = VectorXd::Constant(1, 3);
  p.ubA = VectorXd::Constant(1, kInf);
  Solver s(2, 1);
  EXPECT_EQ(solve(s, p), Status::kInfeasible);
}

TEST(Qp, BadInputGetsItsStatus) {
  Problem p;
  p.H = MatrixXd::Identity(3, 3);
  p.g = VectorXd::Ones(3);
  p.A = MatrixXd::Ones(2, 3);
  p.lb = VectorXd::Constant(3, -1);
  p.ub = VectorXd::Constant(3, 1);
  p.lbA = VectorXd::Constant(2, -1);
  p.ubA = VectorXd::Constant(2, 1);
  Solver s(3, 2);
  ASSERT_EQ(solve(s, p), Status::kOptimal);
  Problem q = p;
  q.H(1, 1) = std::nan("");
  EXPECT_EQ(solve(s, q), Status::kNonFinite);
  q = p;
  q.A(0, 0) = kInf;
  EXPECT_EQ(solve(s, q), Status::kNonFinite);
  q = p;
  q.lbA(1) = std::nan("");
  EXPECT_EQ(solve(s, q), Status::kNonFinite);
  q = p;
  q.lb(2) = 2.0;
  EXPECT_EQ(solve(s, q), Status::kInconsistentBounds);
  q = p;
  q.lbA(0) = 2.0;
  EXPECT_EQ(solve(s, q), Status::kInconsistentBounds);
  q = p;
  q.H(2, 2) = -1.0;
  EXPECT_EQ(solve(s, q), Status::kNotPositiveDefinite);
  q = p;
  q.H(0, 1) = 0.5;  // not symmetric
  EXPECT_EQ(solve(s, q), Status::kNotPositiveDefinite);
  q = p;
  q.g = VectorXd::Ones(4);
  EXPECT_EQ(solve(s, q), Status::kInvalidDimensions);
  EXPECT_FALSE(s.primal_feasible());
  // And it recovers on the next good problem.
  EXPECT_EQ(solve(s, p, true), Status::kOptimal);
}

// Hot start over control-loop sequences gives the cold-start solutions.
TEST(Qp, HotStartMatchesColdStartOnSequences) {
  for (int which = 0; which < 3; ++which) {
    const auto seq = which == 0   ? hpr::qp::testing::contact_sequence(1000, 7)
                     : which == 1 ? hpr::qp::testing::box_sequence(16, 1000, 8)
                                  : hpr::qp::testing::box_sequence(40, 1000, 9);
    const int n = static_cast<int>(seq[0].g.size()), m = static_cast<int>(seq[0].lbA.size());
    Solver hot(n, m), cold(n, m);
    int changes = 0;
    for (size_t k = 0; k < seq.size(); ++k) {
      ASSERT_EQ(solve(hot, seq[k], true), Status::kOptimal) << "hot, step " << k;
      ASSERT_EQ(solve(cold, seq[k], false), Status::kOptimal) << "cold, step " << k;
      EXPECT_LT((hot.x() - cold.x()).norm(), 1e-9 * (1 + cold.x().norm())) << "step " << k;
      // Residuals relative to the data's scale (contact forces are hundreds of newtons).
      EXPECT_LT(hot.kkt().max(), 1e-9 * (1 + seq[k].g.cwiseAbs().maxCoeff())) << "step " << k;
      changes += hot.working_set_changes();
    }
    // Hot starts need few working-set changes on slowly varying data.
    EXPECT_LT(changes, static_cast<int>(seq.size())) << "sequence " << which;
  }
}

TEST(Qp, WorkingSetCapReturnsTheBestFeasiblePoint) {
  std::mt19937 gen(5);
  int capped = 0;
  for (int rep = 0; rep < 50; ++rep) {
    const Problem p = random_problem(gen, 20, 60, false);
    Solver full(20, 60);
    ASSERT_EQ(solve(full, p), Status::kOptimal);
    if (full.working_set_changes() < 4) continue;
    Options opt;
    opt.max_working_set_changes = 2;
    Solver s(20, 60, opt);
    // Warm it up on the problem with its bounds relaxed, then hot start with the cap.
    Problem relaxed = p;
    relaxed.lb.array() -= 10;
    relaxed.ub.array() += 10;
    relaxed.lbA.array() -= 10;
    relaxed.ubA.array() += 10;
    s.options().max_working_set_changes = 1000;
    ASSERT_EQ(solve(s, relaxed), Status::kOptimal);
    s.options().max_working_set_changes = 2;
    const Status st = solve(s, p, true);
    EXPECT_LE(s.working_set_changes(), 2);
    if (st == Status::kIterationLimit) {
      ++capped;
      if (s.primal_feasible()) {
        EXPECT_LT(s.kkt().primal, 1e-9);
        EXPECT_GE(s.objective(), full.objective() - 1e-9);
      }
    }
  }
  EXPECT_GT(capped, 5);
}

TEST(Qp, NoAllocationInASolve) {
  const auto seq = hpr::qp::testing::contact_sequence(200, 11);
  Solver s(12, 30);
  solve(s, seq[0], true);
  const long before = hpr::test::allocations();
  for (const auto& p : seq) solve(s, p, true);
  EXPECT_EQ(hpr::test::allocations() - before, 0);
}

}  // namespace
