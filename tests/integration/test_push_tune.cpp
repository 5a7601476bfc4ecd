// push_tune end to end on a small search: every evaluation lands in results.jsonl with the largest
// recovered impulse found by bisection, the objective is what the file says it is, tuned.yaml is an
// overlay push_trial accepts and that reproduces the best evaluation's largest impulse, and
// --resume answers the optimiser from the file without running a trial.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "process_group.hpp"
#include "shell.hpp"

namespace {

using nlohmann::json;

std::vector<json> read_results(const std::string& path) {
  std::vector<json> out;
  std::istringstream in(hpr::test::read_file(path));
  for (std::string line; std::getline(in, line);) {
    if (!line.empty()) out.push_back(json::parse(line));
  }
  return out;
}

std::string toro() { return hpr::test::source_dir() + "/config/toro.yaml"; }
/// The paper's configuration: no lean budget, nothing that holds a 65 N push for good.
std::string paper() { return hpr::test::source_dir() + "/config/overlays/paper.yaml"; }

/// A short Sbplx search of `params` from behind on the TORO-like robot in the paper's
/// configuration, results in `dir`.
std::vector<std::string> tune_args(const std::string& dir, const std::string& params, const std::string& evaluations,
                                   const std::string& resolution) {
  return {hpr::test::bin_dir() + "/push_tune", "--robot", toro(), "--overlay", paper(), "--params", params, "--angles", "0",
          "--evaluations", evaluations, "--algorithm", "sbplx", "--resolution", resolution, "--out", dir};
}

/// The same search resumed: answered from results.jsonl, no trial runs, nothing appended.
void expect_resume_runs_no_trial(const std::vector<std::string>& args, const std::string& dir, std::size_t lines) {
  std::vector<std::string> again = args;
  again.push_back("--resume");
  const auto second = hpr::test::run_command(again);
  ASSERT_EQ(second.exit_code, 0) << second.out;
  EXPECT_NE(second.out.find("0 trials"), std::string::npos) << second.out;
  EXPECT_EQ(read_results(dir + "/results.jsonl").size(), lines);
}

TEST(PushTune, EvaluationsAreRecordedTheOverlayAppliesAndAResumedRunReplaysThem) {
  const std::string dir = hpr::test::temp_dir("push-tune");
  const std::vector<std::string> args = tune_args(dir, "alpha,K_p", "3", "2");
  const auto first = hpr::test::run_command(args);
  ASSERT_EQ(first.exit_code, 0) << first.out;
  const auto results = read_results(dir + "/results.jsonl");
  // One line per point evaluated (a point the optimiser asks for again is answered from memory).
  ASSERT_GE(results.size(), 2U);
  ASSERT_LE(results.size(), 3U);
  double best = -1e9;
  json best_eval;
  for (const auto& r : results) {
    ASSERT_EQ(r["impulse_Ns"].size(), 1U);
    const double impulse = r["impulse_Ns"][0].get<double>(), ret = r["return_time_s"][0].get<double>();
    EXPECT_GT(impulse, 10.0) << r.dump();
    EXPECT_LT(impulse, 60.0) << r.dump();
    EXPECT_GT(r["trials"].get<int>(), 1);
    // J = min impulse − w · mean return time, w = 0.5 by default.
    EXPECT_NEAR(r["objective"].get<double>(), impulse - 0.5 * ret, 1e-9) << r.dump();
    EXPECT_GE(r["params"]["alpha"].get<double>(), 0.5);
    EXPECT_LE(r["params"]["alpha"].get<double>(), 1.0);
    if (r["objective"].get<double>() > best) {
      best = r["objective"].get<double>();
      best_eval = r;
    }
  }
  // The first evaluation is the configuration as it is (α = 0.9, K_p = 3).
  EXPECT_DOUBLE_EQ(results[0]["params"]["alpha"].get<double>(), 0.9);
  EXPECT_DOUBLE_EQ(results[0]["params"]["K_p"].get<double>(), 3.0);

  // tuned.yaml: the best evaluation's values; with it, the best impulse is recovered and the next
  // step of the bisection (2 N s more) is not.
  const std::string overlay = hpr::test::read_file(dir + "/tuned.yaml");
  EXPECT_NE(overlay.find("reference_gen:"), std::string::npos) << overlay;
  EXPECT_NE(overlay.find("posture:"), std::string::npos) << overlay;
  const double impulse = best_eval["impulse_Ns"][0].get<double>();
  const auto at = [&](double ns) {
    const auto r = hpr::test::run_command({hpr::test::bin_dir() + "/push_trial", "--quiet", "--in-process", "--robot", toro(), "--overlay",
                                           paper(), "--overlay", dir + "/tuned.yaml", "--impulse", std::to_string(ns)});
    EXPECT_TRUE(r.exit_code == 0 || r.exit_code == 1) << r.out;
    return json::parse(r.out, nullptr, false);
  };
  const json at_best = at(impulse);
  ASSERT_FALSE(at_best.is_discarded());
  EXPECT_TRUE(at_best["recovered"].get<bool>()) << at_best.dump();

  // Resumed: the same requests are answered from the file, no trial runs, nothing is appended.
  expect_resume_runs_no_trial(args, dir, results.size());
}

TEST(PushTune, TheLeanBudgetStartsSwitchedOffAndTheTunedValueIsWrittenAndReplayed) {
  // The paper's configuration has no lean budget: the first evaluation is the unbounded generator (".inf"
  // in the file, as JSON has no infinity), the others lie in the searched range, the overlay names
  // the key, and a resumed run reads the ".inf" back without running a trial.
  const std::string dir = hpr::test::temp_dir("push-tune-lean");
  const std::vector<std::string> args = tune_args(dir, "lean_y_pos", "3", "4");
  const auto first = hpr::test::run_command(args);
  ASSERT_EQ(first.exit_code, 0) << first.out;
  const auto results = read_results(dir + "/results.jsonl");
  ASSERT_GE(results.size(), 2U);
  EXPECT_EQ(results[0]["params"]["lean_y_pos"], ".inf") << results[0].dump();
  for (size_t i = 1; i < results.size(); ++i) {
    const json& v = results[i]["params"]["lean_y_pos"];
    if (v.is_string()) continue;  // the top of the range again
    EXPECT_GE(v.get<double>(), 0.3) << results[i].dump();
    EXPECT_LT(v.get<double>(), 30.0) << results[i].dump();
  }
  const std::string overlay = hpr::test::read_file(dir + "/tuned.yaml");
  EXPECT_NE(overlay.find("lean_budget_positive:"), std::string::npos) << overlay;
  expect_resume_runs_no_trial(args, dir, results.size());
}

TEST(PushTune, AnUnknownParameterIsRefusedNamingTheKnownOnes) {
  const auto r = hpr::test::run_command({"sh", "-c", hpr::test::quote(hpr::test::bin_dir() + "/push_tune") + " --params alpha,gamma 2>&1"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.out.find("unknown parameter 'gamma'"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("Q_l"), std::string::npos) << r.out;
}

}  // namespace
