// QP solver timings on control-loop-like sequences (1 000 slowly varying problems each).
//
//   bench_qp [--benchmark_repetitions=N]
//
// BM_QpHotStartBox16        16 variables, bounds only (motion_opt's (13)-(17)), hot started.
// BM_QpHotStartGeneral12x30 12 variables (two foot wrenches), 30 inequalities: an 8-facet friction
//                           pyramid, CoP in the sole and bounded torsion per foot, and the minimum
//                           normal force, while the desired CoM torque sways so that the CoP runs to
//                           the sole edges and unloads a foot (constraints switch on and off).
// BM_QpCold12x30            the same sequence solved cold.
// Each benchmark iteration solves the whole sequence (alternately forward and backward); every problem is copied into the solver's
// input buffers just before its solve (untimed), as a controller assembles its data every tick.
// Counters: median_us and p99_us per solve, working-set changes per solve, solves not optimal.
#include <benchmark/benchmark.h>

#include <cmath>
#include <chrono>
#include <random>

#include "hpr/common/stats.hpp"
#include "hpr/qp/qp_solver.hpp"
#include "hpr/qp/problems.hpp"

namespace {

using namespace hpr::qp;

void run_sequence(benchmark::State& st, const std::vector<hpr::qp::testing::Problem>& seq, bool hot, int cap) {
  const auto& p0 = seq.front();
  Options opt;
  opt.max_working_set_changes = cap;
  Solver solver(static_cast<int>(p0.g.size()), static_cast<int>(p0.lbA.size()), opt);
  std::vector<double> times;
  times.reserve(seq.size() * 64);
  int changes = 0, non_optimal = 0;
  hpr::qp::testing::Problem p = p0;  // the controller's buffers, refilled every tick
  bool forward = true;
  for (auto _ : st) {
    // The sequence runs forward, then backward, and so on: no jump from its last problem back to
    // its first, which no control loop would see either.
    for (size_t k = 0; k < seq.size(); ++k) {
      const auto& next = seq[forward ? k : seq.size() - 1 - k];
      // Like a control loop, the data of the tick is assembled just before the solve (untimed).
      p.H = next.H;
      p.g = next.g;
      p.A = next.A;
      p.lb = next.lb;
      p.ub = next.ub;
      p.lbA = next.lbA;
      p.ubA = next.ubA;
      const auto t0 = std::chrono::steady_clock::now();
      const Status s = hot ? solver.solve_hot(p.H, p.g, p.A, p.lb, p.ub, p.lbA, p.ubA)
                           : solver.solve_cold(p.H, p.g, p.A, p.lb, p.ub, p.lbA, p.ubA);
      const auto t1 = std::chrono::steady_clock::now();
      benchmark::DoNotOptimize(solver.x().data());
      times.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
      changes += solver.working_set_changes();
      non_optimal += s != Status::kOptimal ? 1 : 0;
    }
    forward = !forward;
  }
  st.counters["median_us"] = hpr::percentile(times, 0.5);
  st.counters["p99_us"] = hpr::percentile(times, 0.99);
  st.counters["changes_per_solve"] = static_cast<double>(changes) / static_cast<double>(times.size());
  st.counters["non_optimal"] = non_optimal;
  st.SetItemsProcessed(static_cast<int64_t>(times.size()));
}

void BM_QpHotStartBox16(benchmark::State& st) {
  static const auto seq = hpr::qp::testing::box_sequence(16, 1000, 3);
  run_sequence(st, seq, true, 10);
}

void BM_QpHotStartGeneral12x30(benchmark::State& st) {
  static const auto seq = hpr::qp::testing::contact_sequence(1000, 5);
  run_sequence(st, seq, true, 10);
}

void BM_QpCold12x30(benchmark::State& st) {
  static const auto seq = hpr::qp::testing::contact_sequence(1000, 5);
  run_sequence(st, seq, false, 1000);
}

}  // namespace

BENCHMARK(BM_QpHotStartBox16)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_QpHotStartGeneral12x30)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_QpCold12x30)->Unit(benchmark::kMillisecond);
BENCHMARK_MAIN();
