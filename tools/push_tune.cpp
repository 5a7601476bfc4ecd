// push_tune: automatic tuning of the CAM strategy's parameters, the paper's future work. A
// derivative-free optimiser (NLopt) searches α, β (reference generator, (23), (27)), Q_l, Q_p and
// K_p (motion optimisation, (13), (16); K_a and the lean budget about y on request) within bounds, maximising
//
//     J = min over the directions of the largest recovered impulse [N s]
//         − w · mean over the directions of the posture return time at that impulse [s]
//
// each largest impulse found by bracketing and bisection (push_sweep's search, from the same start) with the CAM
// strategy through the in-process pipeline, the directions of an evaluation in parallel on this
// machine or as one Slurm job array (--executor, executor.hpp). Every evaluation is
// appended to a results file (JSON lines); --resume answers the optimiser's requests from it, so
// an interrupted run continues where it stopped. The best parameters are written as a YAML overlay
// (tuned.yaml) that push_trial, push_sweep and push_tune take with --overlay.
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <nlohmann/json.hpp>
#include <nlopt.hpp>
#include <sstream>
#include <thread>

#include "hpr/common/args.hpp"
#include "hpr/common/config.hpp"
#include "hpr/common/log.hpp"
#include "hpr/experiments/executor.hpp"
#include "hpr/experiments/version.hpp"

namespace {

using namespace hpr::experiments;
namespace fs = std::filesystem;
using nlohmann::json;

/// A tuned parameter: its configuration key, bounds, and whether the search runs on its logarithm.
struct Param {
  const char* name;
  const char* key;
  double lo, hi;
  bool log_scale;
  const char* what;
  bool off_at_top = false;  ///< the top of the range stands for ∞ (the bound switched off)
};

constexpr Param kParams[] = {
    {"alpha", "reference_gen.alpha", 0.5, 1.0, false, "activation threshold (23)"},
    {"beta", "reference_gen.beta", 0.1, 1.0, false, "reduction rate (27)"},
    {"Q_l", "motion_opt.weights.cam", 0.1, 30.0, true, "CAM weight (14a)"},
    {"Q_p", "motion_opt.weights.posture", 0.01, 5.0, true, "posture weight (14b)"},
    {"K_p", "motion_opt.gains.posture", 0.3, 20.0, true, "posture gain (16) [1/s]"},
    {"K_a", "motion_opt.gains.limits", 1.0, 50.0, true, "limit gain (17) [1/s]"},
    {"lean_y_neg", "reference_gen.y.lean_budget_negative", 0.3, 30.0, true, "lean budget about y, l < 0 [N m s^2]", true},
    {"lean_y_pos", "reference_gen.y.lean_budget_positive", 0.3, 30.0, true, "lean budget about y, l > 0 [N m s^2]", true},
};

const Param& param(const std::string& name) {
  for (const auto& p : kParams) {
    if (name == p.name) return p;
  }
  std::string known;
  for (const auto& p : kParams) known += std::string(known.empty() ? "" : ", ") + p.name;
  throw hpr::UsageError("--params: unknown parameter '" + name + "' (known: " + known + ")");
}

double to_unit(const Param& p, double v) {
  v = std::clamp(v, p.lo, p.hi);
  return p.log_scale ? std::log(v / p.lo) / std::log(p.hi / p.lo) : (v - p.lo) / (p.hi - p.lo);
}
double from_unit(const Param& p, double u) {
  u = std::clamp(u, 0.0, 1.0);
  if (p.off_at_top && u >= 1.0) return std::numeric_limits<double>::infinity();
  return p.log_scale ? p.lo * std::pow(p.hi / p.lo, u) : p.lo + u * (p.hi - p.lo);
}

/// The configured value of a parameter, overrides applied (the first entry of a per-axis list); ∞
/// for a bound that is off unless configured.
double configured(const hpr::Config& cfg, const Param& p) {
  const std::string key = p.key;
  const auto dot = key.find('.');
  const hpr::Config section = cfg.section(key.substr(0, dot));
  const std::string rest = key.substr(dot + 1);
  const auto dot2 = rest.find('.');
  if (dot2 == std::string::npos) return section.real(rest);
  const std::string sub_name = rest.substr(0, dot2), leaf = rest.substr(dot2 + 1);
  const bool set = section.has(sub_name) && section.section(sub_name).has(leaf);
  if (p.off_at_top && !set) return std::numeric_limits<double>::infinity();
  const hpr::Config sub = section.section(sub_name);
  try {
    return sub.real(leaf);
  } catch (const std::exception&) {
    return sub.reals(leaf).at(0);
  }
}

struct Evaluation {
  std::vector<double> values;             ///< the parameters, in --params order
  std::vector<double> impulse;            ///< largest recovered per direction [N s]
  std::vector<double> return_time;        ///< posture return time at it [s]
  double objective = 0.0;
  int trials = 0;
  double wall_s = 0.0;
};

std::string value_text(double v) { return std::isinf(v) ? std::string(".inf") : fmt::format("{:.6g}", v); }
double text_value(const std::string& t) { return t == ".inf" ? std::numeric_limits<double>::infinity() : std::stod(t); }

void usage(std::FILE* out) {
  std::fputs(R"(usage: push_tune [options]

Tunes the CAM strategy (the paper's future work): an NLopt derivative-free search over the
parameters below, maximising the smallest largest-recovered impulse over the directions, less a
posture-return-time penalty; every trial through the in-process pipeline, the directions in
parallel. Writes results.jsonl (one line per evaluation), tuned.yaml (the best parameters as an
overlay for --overlay) and a summary.

  --params LIST          tuned parameters (default alpha,beta,Q_l,Q_p,K_p):
                           alpha  reference_gen.alpha         [0.5, 1]     (23)
                           beta   reference_gen.beta          [0.1, 1]     (27)
                           Q_l    motion_opt.weights.cam      [0.1, 30]    (14a), every axis
                           Q_p    motion_opt.weights.posture  [0.01, 5]    (14b)
                           K_p    motion_opt.gains.posture    [0.3, 20]    (16)
                           K_a    motion_opt.gains.limits     [1, 50]      (17)
                           lean_y_neg, lean_y_pos  reference_gen.y.lean_budget_negative, _positive
                                  [0.3, 30] N m s^2, 30 = off (.inf): the lean budget about y
  --angles LIST          push directions [deg] (default 0,180: from behind and from the front)
  --support S            double | left | right (default double)
  --algorithm A          bobyqa | cobyla | sbplx | crs (default crs: controlled random search,
                         global; the objective is piecewise constant at the resolution)
  --evaluations N        evaluations of the objective (default 60)
  --seed N               the random search's seed (default 1)
  --population N         the random search's population (default 3 (n + 1) for n parameters;
                         NLopt's own 10 (n + 1) spends a short run on its first random draw)
  --start NS             first impulse of every search [N s] (default 15, as push_sweep)
  --resolution NS        bisection resolution [N s] (default 0.5)
  --max-impulse NS       largest impulse tried [N s] (default 80)
  --return-weight W      w of the return-time penalty [N s per s] (default 0.5)
  --out DIR              results folder (default tune-<date>)

With --resume, the evaluations in DIR/results.jsonl (same options) answer the optimiser, and an
evaluation that was cut short runs only the trials it had not finished.

Where the directions run (--jobs defaults to the number of cores):
)",
             out);
  std::fputs(kExecutorOptionsUsage, out);
  std::fputs("\nThe push and the robot (every trial; --in-process is always on):\n", out);
  std::fputs(kPushOptionsUsage, out);
}

}  // namespace

int main(int argc, char** argv) {
  TrialSpec base;
  base.config = "toro";
  base.stop_when_decided = true;
  base.in_process = true;
  std::vector<std::string> names = {"alpha", "beta", "Q_l", "Q_p", "K_p"};
  std::vector<double> angles = {0.0, 180.0};
  std::string algorithm = "crs", out_dir;
  int evaluations = 60;
  ExecutorOptions executor;
  executor.jobs = static_cast<int>(std::max(1U, std::thread::hardware_concurrency()));
  unsigned seed = 1;
  int population = 0;
  double start = 15.0, resolution = 0.5, max_impulse = 80.0, return_weight = 0.5;
  const auto option = [&](hpr::ArgReader& args) {
    if (args.is("--params")) {
      names = args.list();
      for (const auto& n : names) (void)param(n);
      if (names.empty()) throw hpr::UsageError("--params: at least one parameter");
    } else if (args.is("--angles")) {
      angles.clear();
      for (const auto& a : args.list()) angles.push_back(hpr::parse_number(a, "--angles"));
      if (angles.empty()) throw hpr::UsageError("--angles: at least one direction");
    } else if (args.is("--support")) {
      base.support = args.value();
    } else if (args.is("--algorithm")) {
      algorithm = args.value();
      if (algorithm != "bobyqa" && algorithm != "cobyla" && algorithm != "sbplx" && algorithm != "crs") {
        throw hpr::UsageError("--algorithm: '" + algorithm + "' is not bobyqa, cobyla, sbplx or crs");
      }
    } else if (args.is("--evaluations")) {
      evaluations = args.integer();
      if (evaluations < 1) throw hpr::UsageError("--evaluations: at least 1");
    } else if (args.is("--population")) {
      population = args.integer();
      if (population < 2) throw hpr::UsageError("--population: at least 2");
    } else if (args.is("--seed")) {
      seed = static_cast<unsigned>(args.integer());
    } else if (args.is("--start")) {
      start = args.number();
    } else if (args.is("--resolution")) {
      resolution = args.number();
    } else if (args.is("--max-impulse")) {
      max_impulse = args.number();
    } else if (args.is("--return-weight")) {
      return_weight = args.number();
      if (return_weight < 0) throw hpr::UsageError("--return-weight: not negative");
    } else if (args.is("--out")) {
      out_dir = args.value();
    } else if (!executor.read(args) && !read_push_option(args, base)) {
      args.unknown();
    }
  };
  const auto check = [&] {
    base.in_process = true;
    base.config = find_config(base.config);
    if (!(resolution > 0) || !(start > 0) || !(max_impulse > start) || !(base.peak > 0)) {
      throw hpr::UsageError("need --resolution > 0, 0 < --start < --max-impulse and --peak > 0");
    }
    executor.validate();
    if (executor.resume && out_dir.empty()) throw hpr::UsageError("--resume needs --out DIR");
  };
  if (const auto status = hpr::read_command_line(argc, argv, "push_tune", usage, option, check)) return *status;
  if (out_dir.empty()) out_dir = dated_name("tune");
  fs::create_directories(out_dir);
  // The candidates' configurations load once per trial: their warnings (an α outside the paper's
  // range, say) would bury the progress lines.
  hpr::log::init("push_tune", hpr::log::Level::kError);
  const std::string results_path = out_dir + "/results.jsonl";

  std::vector<const Param*> params;
  for (const auto& n : names) params.push_back(&param(n));
  std::vector<double> x0;
  try {
    const hpr::Config cfg = hpr::Config::load(base.config, base.overrides);
    for (const Param* p : params) x0.push_back(to_unit(*p, configured(cfg, *p)));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "push_tune: %s\n", e.what());
    return 2;
  }

  // What a set of values is called in the results file and the cache: its overrides.
  const auto overrides_of = [&](const std::vector<double>& values) {
    std::vector<std::string> o;
    for (size_t i = 0; i < params.size(); ++i) o.push_back(std::string(params[i]->key) + "=" + value_text(values[i]));
    return o;
  };
  const auto cache_key = [&](const std::vector<double>& values) {
    std::string k;
    for (const auto& o : overrides_of(values)) k += o + ";";
    return k;
  };
  std::map<std::string, Evaluation> cache;
  const bool resume = executor.resume;
  if (resume && fs::exists(results_path)) {
    std::ifstream in(results_path);
    int line_no = 0;
    for (std::string line; std::getline(in, line);) {
      ++line_no;
      if (line.empty()) continue;
      try {
        const json j = json::parse(line);
        Evaluation e;
        for (const Param* p : params) {
          const json& v = j.at("params").at(p->name);
          e.values.push_back(v.is_string() ? text_value(v.get<std::string>()) : v.get<double>());
        }
        e.impulse = j.at("impulse_Ns").get<std::vector<double>>();
        e.return_time = j.at("return_time_s").get<std::vector<double>>();
        e.objective = j.at("objective").get<double>();
        e.trials = j.at("trials").get<int>();
        if (e.impulse.size() != angles.size()) throw std::runtime_error("made with other --angles");
        cache[cache_key(e.values)] = e;
      } catch (const std::exception& err) {
        std::fprintf(stderr, "push_tune: %s:%d: %s\n", results_path.c_str(), line_no, err.what());
        return 2;
      }
    }
    std::fprintf(stderr, "push_tune: %zu evaluations from %s\n", cache.size(), results_path.c_str());
  }
  std::ofstream results(results_path, resume ? std::ios::app : std::ios::trunc);

  const auto t0 = std::chrono::steady_clock::now();
  int n_eval = 0, total_trials = 0;
  Evaluation best;
  best.objective = -1e9;
  Evaluation initial;

  // The directions of an evaluation are one round of searches for the executor.
  int trials_run = 0;
  ExecutorEvents events;
  events.trial = [&](const SearchSpec&, const TrialOutcome&, bool stored) { trials_run += stored ? 0 : 1; };
  events.note = [](const std::string& line) { std::fprintf(stderr, "%s\n", line.c_str()); };
  std::unique_ptr<Executor> run_round;
  try {
    run_round = make_executor(executor, out_dir, events);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "push_tune: %s\n", e.what());
    return 1;
  }
  const auto evaluate = [&](const std::vector<double>& values) -> Evaluation {
    Evaluation e;
    e.values = values;
    const auto t_eval = std::chrono::steady_clock::now();
    std::vector<SearchSpec> searches;
    for (const double angle : angles) {
      SearchSpec search;
      search.base = base;
      search.base.strategy = Strategy::kCam;
      search.base.direction_deg = angle;
      const std::vector<std::string> tuned = overrides_of(values);
      search.base.overrides.insert(search.base.overrides.end(), tuned.begin(), tuned.end());
      // Every search starts where push_sweep's does: recovery is not monotonic in the impulse
      // near the limit, so a search from elsewhere may end half a step off, and the objective
      // would depend on the order of the evaluations.
      search.start = start;
      search.max_impulse = max_impulse;
      search.resolution = resolution;
      searches.push_back(search);
    }
    const int before = trials_run;
    const std::vector<SearchResult> found = run_round->run(searches);
    for (const SearchResult& r : found) {
      if (r.failed) throw std::runtime_error(r.failure);
      e.impulse.push_back(r.bracket.max_recovered);
      const TrialOutcome* at = r.find(r.bracket.max_recovered);
      e.return_time.push_back(at != nullptr && at->result.return_time ? *at->result.return_time : 5.0);
    }
    e.trials = trials_run - before;
    double mean_return = 0.0;
    for (double r : e.return_time) mean_return += r / static_cast<double>(angles.size());
    e.objective = *std::min_element(e.impulse.begin(), e.impulse.end()) - return_weight * mean_return;
    e.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_eval).count();
    return e;
  };

  // Why the optimisation stopped early, and the exit status (an interruption, or an evaluation
  // that could not finish): the optimiser turns exceptions into its own, so they are kept here.
  std::optional<std::pair<int, std::string>> stopped;
  const auto objective = [&](const std::vector<double>& u) {
    std::vector<double> values;
    for (size_t i = 0; i < params.size(); ++i) values.push_back(from_unit(*params[i], u[i]));
    // The results are keyed by the values as written (6 digits): the same request, the same answer.
    for (auto& v : values) v = text_value(value_text(v));
    const std::string key = cache_key(values);
    Evaluation e;
    bool cached = false;
    if (const auto it = cache.find(key); it != cache.end()) {
      e = it->second;
      cached = true;
    } else {
      try {
        e = evaluate(values);
      } catch (const Interrupted& err) {
        stopped = {130, err.what()};
        throw nlopt::forced_stop();
      } catch (const std::exception& err) {
        // A search that could not finish (a cluster task failed twice): no objective to report.
        stopped = {4, err.what()};
        throw nlopt::forced_stop();
      }
      cache[key] = e;
      json j;
      j["evaluation"] = n_eval + 1;
      for (size_t i = 0; i < params.size(); ++i) {
        j["params"][params[i]->name] = std::isinf(values[i]) ? json(value_text(values[i])) : json(values[i]);  // JSON has no ∞
      }
      j["angles_deg"] = angles;
      j["impulse_Ns"] = e.impulse;
      j["return_time_s"] = e.return_time;
      j["objective"] = e.objective;
      j["trials"] = e.trials;
      j["wall_s"] = e.wall_s;
      j["commit"] = source_commit();
      results << j.dump() << std::endl;
    }
    ++n_eval;
    total_trials += cached ? 0 : e.trials;
    if (e.objective > best.objective) best = e;
    std::string line = fmt::format("[{:3d}/{}, {:5.0f} s]", n_eval, evaluations,
                                   std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    for (size_t i = 0; i < params.size(); ++i) line += fmt::format(" {} {}", params[i]->name, value_text(values[i]));
    line += " ->";
    for (size_t a = 0; a < angles.size(); ++a) line += fmt::format(" {:.0f} deg {:.2f} N s;", angles[a], e.impulse[a]);
    line += fmt::format(" J {:.2f} (best {:.2f}){}", e.objective, best.objective, cached ? " [from the results file]" : "");
    std::fprintf(stderr, "%s\n", line.c_str());
    return e.objective;
  };

  nlopt::algorithm alg = nlopt::GN_CRS2_LM;
  if (algorithm == "bobyqa") alg = nlopt::LN_BOBYQA;
  if (algorithm == "cobyla") alg = nlopt::LN_COBYLA;
  if (algorithm == "sbplx") alg = nlopt::LN_SBPLX;
  nlopt::srand(seed);
  nlopt::opt opt(alg, static_cast<unsigned>(params.size()));
  opt.set_lower_bounds(std::vector<double>(params.size(), 0.0));
  opt.set_upper_bounds(std::vector<double>(params.size(), 1.0));
  opt.set_max_objective(
      [](const std::vector<double>& u, std::vector<double>&, void* data) {
        return (*static_cast<decltype(objective)*>(data))(u);
      },
      const_cast<void*>(static_cast<const void*>(&objective)));
  opt.set_maxeval(evaluations);
  if (alg == nlopt::GN_CRS2_LM) {
    opt.set_population(static_cast<unsigned>(population > 0 ? population : 3 * (static_cast<int>(params.size()) + 1)));
  }
  opt.set_initial_step(std::vector<double>(params.size(), 0.15));
  std::fprintf(stderr, "push_tune: %s, %s over %s; %d evaluations, %zu directions, %s; results in %s\n", base.config.c_str(),
               algorithm.c_str(), fmt::format("{}", fmt::join(names, ",")).c_str(), evaluations, angles.size(),
               run_round->describe().c_str(), results_path.c_str());
  // The optimiser starts at the configured parameters: the baseline (evaluated last if it did not).
  std::vector<double> u = x0;
  double f = 0.0;
  try {
    opt.optimize(u, f);
  } catch (const nlopt::roundoff_limited&) {
    // The best point so far stands.
  } catch (const std::exception& e) {
    if (!stopped) std::fprintf(stderr, "push_tune: the optimiser stopped: %s (the best point so far stands)\n", e.what());
  }
  if (stopped) {
    std::fprintf(stderr, "push_tune: %s\n%s", stopped->second.c_str(),
                 stopped->first == 130 ? "" : "push_tune: the evaluation could not finish; run again with --resume to go on\n");
    return stopped->first;
  }
  std::vector<double> configured_values;
  for (size_t i = 0; i < params.size(); ++i) configured_values.push_back(text_value(value_text(from_unit(*params[i], x0[i]))));
  if (!cache.contains(cache_key(configured_values))) (void)objective(x0);
  initial = cache.at(cache_key(configured_values));

  // The overlay: the best values in the configuration's layout.
  std::ostringstream yaml;
  yaml << "# push_tune: " << algorithm << ", " << n_eval << " evaluations, directions";
  for (double a : angles) yaml << " " << a;
  yaml << " deg, " << base.support << " support, " << base.peak << " N peak; " << base.config << " at " << source_commit() << "\n";
  yaml << "# objective " << fmt::format("{:.2f}", best.objective) << " (configured: " << fmt::format("{:.2f}", initial.objective)
       << "); use with --overlay, or merge into the robot's configuration\n";
  std::map<std::string, std::map<std::string, std::string>> sections;
  for (size_t i = 0; i < params.size(); ++i) {
    const std::string key = params[i]->key;
    const auto dot = key.find('.');
    sections[key.substr(0, dot)][key.substr(dot + 1)] = value_text(best.values[i]);
  }
  for (const auto& [section, keys] : sections) {
    yaml << section << ":\n";
    // Nested keys ("weights.cam") as nested mappings.
    std::map<std::string, std::map<std::string, std::string>> nested;
    for (const auto& [k, v] : keys) {
      const auto dot = k.find('.');
      if (dot == std::string::npos) {
        yaml << "  " << k << ": " << v << "\n";
      } else {
        nested[k.substr(0, dot)][k.substr(dot + 1)] = v;
      }
    }
    for (const auto& [k, leaves] : nested) {
      yaml << "  " << k << ":\n";
      for (const auto& [leaf, v] : leaves) yaml << "    " << leaf << ": " << v << "\n";
    }
  }
  std::ofstream(out_dir + "/tuned.yaml") << yaml.str();

  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("push_tune: %d evaluations, %d trials in %.0f s\n", n_eval, total_trials, wall);
  std::printf("%-10s %12s %12s\n", "", "configured", "tuned");
  for (size_t i = 0; i < params.size(); ++i) {
    std::printf("%-10s %12s %12s\n", params[i]->name, value_text(initial.values[i]).c_str(), value_text(best.values[i]).c_str());
  }
  for (size_t a = 0; a < angles.size(); ++a) {
    std::printf("%3.0f deg    %10.2f N s %10.2f N s\n", angles[a], initial.impulse[a], best.impulse[a]);
  }
  std::printf("objective  %12.2f %12.2f\n", initial.objective, best.objective);
  std::printf("overlay: %s/tuned.yaml (push_sweep --overlay %s/tuned.yaml ...)\n", out_dir.c_str(), out_dir.c_str());
  return 0;
}
