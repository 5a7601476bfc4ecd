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
#include "hpr/experiments/tuning.hpp"
#include "hpr/experiments/version.hpp"

namespace {

using namespace hpr::experiments;
namespace fs = std::filesystem;
using nlohmann::json;

struct Evaluation {
  std::vector<double> values;             ///< the parameters, in --params order
  std::vector<double> impulse;            ///< largest recovered per direction [N s]
  std::vector<double> return_time;        ///< posture return time at it [s]
  double objective = 0.0;
  int trials = 0;
  double wall_s = 0.0;
};

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

/// What the command line asks for.
struct TuneOptions {
  TrialSpec base;
  std::vector<std::string> names = {"alpha", "beta", "Q_l", "Q_p", "K_p"};
  std::vector<double> angles = {0.0, 180.0};
  std::string algorithm = "crs", out_dir;
  int evaluations = 60;
  ExecutorOptions executor;
  unsigned seed = 1;
  int population = 0;
  double start = 15.0, resolution = 0.5, max_impulse = 80.0, return_weight = 0.5;
};

/// The options, or the exit status when the command line is refused or asked for help.
std::optional<int> read_options(int argc, char** argv, TuneOptions& o) {
  o.base.config = "toro";
  o.base.stop_when_decided = true;
  o.base.in_process = true;
  o.executor.jobs = static_cast<int>(std::max(1U, std::thread::hardware_concurrency()));
  const auto option = [&](hpr::ArgReader& args) {
    if (args.is("--params")) {
      o.names = args.list();
      for (const auto& n : o.names) (void)tuned_param(n);
      if (o.names.empty()) throw hpr::UsageError("--params: at least one parameter");
    } else if (args.is("--angles")) {
      o.angles.clear();
      for (const auto& a : args.list()) o.angles.push_back(hpr::parse_number(a, "--angles"));
      if (o.angles.empty()) throw hpr::UsageError("--angles: at least one direction");
    } else if (args.is("--support")) {
      o.base.support = args.value();
    } else if (args.is("--algorithm")) {
      o.algorithm = args.value();
      if (o.algorithm != "bobyqa" && o.algorithm != "cobyla" && o.algorithm != "sbplx" && o.algorithm != "crs") {
        throw hpr::UsageError("--algorithm: '" + o.algorithm + "' is not bobyqa, cobyla, sbplx or crs");
      }
    } else if (args.is("--evaluations")) {
      o.evaluations = args.integer();
      if (o.evaluations < 1) throw hpr::UsageError("--evaluations: at least 1");
    } else if (args.is("--population")) {
      o.population = args.integer();
      if (o.population < 2) throw hpr::UsageError("--population: at least 2");
    } else if (args.is("--seed")) {
      o.seed = static_cast<unsigned>(args.integer());
    } else if (args.is("--start")) {
      o.start = args.number();
    } else if (args.is("--resolution")) {
      o.resolution = args.number();
    } else if (args.is("--max-impulse")) {
      o.max_impulse = args.number();
    } else if (args.is("--return-weight")) {
      o.return_weight = args.number();
      if (o.return_weight < 0) throw hpr::UsageError("--return-weight: not negative");
    } else if (args.is("--out")) {
      o.out_dir = args.value();
    } else if (!o.executor.read(args) && !read_push_option(args, o.base)) {
      args.unknown();
    }
  };
  const auto check = [&] {
    o.base.in_process = true;
    o.base.config = find_config(o.base.config);
    if (!(o.resolution > 0) || !(o.start > 0) || !(o.max_impulse > o.start) || !(o.base.peak > 0)) {
      throw hpr::UsageError("need --resolution > 0, 0 < --start < --max-impulse and --peak > 0");
    }
    o.executor.validate();
    if (o.executor.resume && o.out_dir.empty()) throw hpr::UsageError("--resume needs --out DIR");
  };
  return hpr::read_command_line(argc, argv, "push_tune", usage, option, check);
}

/// Why the optimisation stopped early, with the exit status (an interruption, or an evaluation that
/// could not finish): the optimiser turns exceptions into its own, so they are kept here.
struct Stop {
  int status;
  std::string why;
};

/// The objective and its bookkeeping: every evaluation once (a repeated request answered from
/// memory or, with --resume, from the results file), appended to the results file, the best kept.
class Tuning {
 public:
  Tuning(const TuneOptions& o, std::vector<const TunedParam*> params, std::unique_ptr<Executor> executor, int* trials_run)
      : o_(o), params_(std::move(params)), executor_(std::move(executor)), trials_run_(trials_run) {
    best_.objective = -1e9;
  }

  /// What a set of values is called in the results file and the cache: its overrides.
  std::vector<std::string> overrides_of(const std::vector<double>& values) const {
    std::vector<std::string> out;
    for (size_t i = 0; i < params_.size(); ++i) out.push_back(std::string(params_[i]->key) + "=" + value_text(values[i]));
    return out;
  }
  std::string key(const std::vector<double>& values) const {
    std::string k;
    for (const auto& ov : overrides_of(values)) k += ov + ";";
    return k;
  }

  /// The evaluations of an earlier run (--resume); an error names the file and line.
  void read_results(const std::string& path) {
    std::ifstream in(path);
    int line_no = 0;
    for (std::string line; std::getline(in, line);) {
      ++line_no;
      if (line.empty()) continue;
      try {
        const json j = json::parse(line);
        Evaluation e;
        for (const TunedParam* p : params_) {
          const json& v = j.at("params").at(p->name);
          e.values.push_back(v.is_string() ? text_value(v.get<std::string>()) : v.get<double>());
        }
        e.impulse = j.at("impulse_Ns").get<std::vector<double>>();
        e.return_time = j.at("return_time_s").get<std::vector<double>>();
        e.objective = j.at("objective").get<double>();
        e.trials = j.at("trials").get<int>();
        if (e.impulse.size() != o_.angles.size()) throw std::runtime_error("made with other --angles");
        cache_[key(e.values)] = e;
      } catch (const std::exception& err) {
        throw std::runtime_error(fmt::format("{}:{}: {}", path, line_no, err.what()));
      }
    }
    std::fprintf(stderr, "push_tune: %zu evaluations from %s\n", cache_.size(), path.c_str());
  }
  void append_results_to(const std::string& path, bool resume) { results_.open(path, resume ? std::ios::app : std::ios::trunc); }

  /// The parameters at the point `u` of the unit cube, as written (6 digits): the results are keyed
  /// by them, so the same request gets the same answer.
  std::vector<double> values_at(const std::vector<double>& u) const {
    std::vector<double> values;
    for (size_t i = 0; i < params_.size(); ++i) values.push_back(text_value(value_text(from_unit(*params_[i], u[i]))));
    return values;
  }

  /// The objective at the point `u` of the unit cube (the optimiser's coordinates).
  double objective(const std::vector<double>& u) {
    const std::vector<double> values = values_at(u);
    Evaluation e;
    const auto it = cache_.find(key(values));
    const bool cached = it != cache_.end();
    if (cached) {
      e = it->second;
    } else {
      try {
        e = evaluate(values);
      } catch (const Interrupted& err) {
        stopped_ = Stop{130, err.what()};
        throw nlopt::forced_stop();
      } catch (const std::exception& err) {
        // A search that could not finish (a cluster task failed twice): no objective to report.
        stopped_ = Stop{4, err.what()};
        throw nlopt::forced_stop();
      }
      cache_[key(values)] = e;
      record(e);
    }
    ++n_eval_;
    total_trials_ += cached ? 0 : e.trials;
    if (e.objective > best_.objective) best_ = e;
    report(e, cached);
    return e.objective;
  }

  /// The evaluation of the configured values, run now if the optimiser never asked for them.
  const Evaluation& configured(const std::vector<double>& u0) {
    const std::vector<double> values = values_at(u0);
    if (!cache_.contains(key(values))) (void)objective(u0);
    return cache_.at(key(values));
  }

  const std::optional<Stop>& stopped() const { return stopped_; }
  const Evaluation& best() const { return best_; }
  int evaluations() const { return n_eval_; }
  int trials() const { return total_trials_; }
  double seconds() const { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count(); }

 private:
  /// The largest recovered impulse in every direction with `values`: one round of searches.
  Evaluation evaluate(const std::vector<double>& values) {
    Evaluation e;
    e.values = values;
    const auto t_eval = std::chrono::steady_clock::now();
    std::vector<SearchSpec> searches;
    for (const double angle : o_.angles) {
      SearchSpec search;
      search.base = o_.base;
      search.base.strategy = Strategy::kCam;
      search.base.direction_deg = angle;
      const std::vector<std::string> tuned = overrides_of(values);
      search.base.overrides.insert(search.base.overrides.end(), tuned.begin(), tuned.end());
      // Every search starts where push_sweep's does: recovery is not monotonic in the impulse
      // near the limit, so a search from elsewhere may end half a step off, and the objective
      // would depend on the order of the evaluations.
      search.start = o_.start;
      search.max_impulse = o_.max_impulse;
      search.resolution = o_.resolution;
      searches.push_back(search);
    }
    const int before = *trials_run_;
    for (const SearchResult& r : executor_->run(searches)) {
      if (r.failed) throw std::runtime_error(r.failure);
      e.impulse.push_back(r.bracket.max_recovered);
      const TrialOutcome* at = r.find(r.bracket.max_recovered);
      e.return_time.push_back(at != nullptr && at->result.return_time ? *at->result.return_time : 5.0);
    }
    e.trials = *trials_run_ - before;
    double mean_return = 0.0;
    for (double r : e.return_time) mean_return += r / static_cast<double>(o_.angles.size());
    e.objective = *std::min_element(e.impulse.begin(), e.impulse.end()) - o_.return_weight * mean_return;
    e.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_eval).count();
    return e;
  }

  /// One line of the results file.
  void record(const Evaluation& e) {
    json j;
    j["evaluation"] = n_eval_ + 1;
    for (size_t i = 0; i < params_.size(); ++i) {
      j["params"][params_[i]->name] = std::isinf(e.values[i]) ? json(value_text(e.values[i])) : json(e.values[i]);  // JSON has no ∞
    }
    j["angles_deg"] = o_.angles;
    j["impulse_Ns"] = e.impulse;
    j["return_time_s"] = e.return_time;
    j["objective"] = e.objective;
    j["trials"] = e.trials;
    j["wall_s"] = e.wall_s;
    j["commit"] = source_commit();
    results_ << j.dump() << std::endl;
  }

  /// The progress line of an evaluation.
  void report(const Evaluation& e, bool cached) const {
    std::string line = fmt::format("[{:3d}/{}, {:5.0f} s]", n_eval_, o_.evaluations, seconds());
    for (size_t i = 0; i < params_.size(); ++i) line += fmt::format(" {} {}", params_[i]->name, value_text(e.values[i]));
    line += " ->";
    for (size_t a = 0; a < o_.angles.size(); ++a) line += fmt::format(" {:.0f} deg {:.2f} N s;", o_.angles[a], e.impulse[a]);
    line += fmt::format(" J {:.2f} (best {:.2f}){}", e.objective, best_.objective, cached ? " [from the results file]" : "");
    std::fprintf(stderr, "%s\n", line.c_str());
  }

  const TuneOptions& o_;
  std::vector<const TunedParam*> params_;
  std::unique_ptr<Executor> executor_;
  int* trials_run_;  ///< trials the executor ran (not answered from its store)
  std::map<std::string, Evaluation> cache_;
  std::ofstream results_;
  std::optional<Stop> stopped_;
  Evaluation best_;
  int n_eval_ = 0, total_trials_ = 0;
  std::chrono::steady_clock::time_point t0_ = std::chrono::steady_clock::now();
};

/// NLopt's optimiser for `o.algorithm` over the unit cube, maximising `tuning`'s objective.
nlopt::opt make_optimiser(const TuneOptions& o, size_t n, Tuning& tuning) {
  nlopt::algorithm alg = nlopt::GN_CRS2_LM;
  if (o.algorithm == "bobyqa") alg = nlopt::LN_BOBYQA;
  if (o.algorithm == "cobyla") alg = nlopt::LN_COBYLA;
  if (o.algorithm == "sbplx") alg = nlopt::LN_SBPLX;
  nlopt::srand(o.seed);
  nlopt::opt opt(alg, static_cast<unsigned>(n));
  opt.set_lower_bounds(std::vector<double>(n, 0.0));
  opt.set_upper_bounds(std::vector<double>(n, 1.0));
  opt.set_max_objective(
      [](const std::vector<double>& u, std::vector<double>&, void* data) { return static_cast<Tuning*>(data)->objective(u); }, &tuning);
  opt.set_maxeval(o.evaluations);
  if (alg == nlopt::GN_CRS2_LM) {
    opt.set_population(static_cast<unsigned>(o.population > 0 ? o.population : 3 * (static_cast<int>(n) + 1)));
  }
  opt.set_initial_step(std::vector<double>(n, 0.15));
  return opt;
}

/// tuned.yaml: the best values in the configuration's layout (nested keys as nested mappings).
std::string overlay_yaml(const TuneOptions& o, const std::vector<const TunedParam*>& params, const Tuning& tuning, const Evaluation& initial) {
  const Evaluation& best = tuning.best();
  std::ostringstream yaml;
  yaml << "# push_tune: " << o.algorithm << ", " << tuning.evaluations() << " evaluations, directions";
  for (double a : o.angles) yaml << " " << a;
  yaml << " deg, " << o.base.support << " support, " << o.base.peak << " N peak; " << o.base.config << " at " << source_commit() << "\n";
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
  return yaml.str();
}

/// The summary table: configured against tuned.
void print_summary(const TuneOptions& o, const std::vector<const TunedParam*>& params, const Tuning& tuning, const Evaluation& initial) {
  const Evaluation& best = tuning.best();
  std::printf("push_tune: %d evaluations, %d trials in %.0f s\n", tuning.evaluations(), tuning.trials(), tuning.seconds());
  std::printf("%-10s %12s %12s\n", "", "configured", "tuned");
  for (size_t i = 0; i < params.size(); ++i) {
    std::printf("%-10s %12s %12s\n", params[i]->name, value_text(initial.values[i]).c_str(), value_text(best.values[i]).c_str());
  }
  for (size_t a = 0; a < o.angles.size(); ++a) {
    std::printf("%3.0f deg    %10.2f N s %10.2f N s\n", o.angles[a], initial.impulse[a], best.impulse[a]);
  }
  std::printf("objective  %12.2f %12.2f\n", initial.objective, best.objective);
  std::printf("overlay: %s/tuned.yaml (push_sweep --overlay %s/tuned.yaml ...)\n", o.out_dir.c_str(), o.out_dir.c_str());
}

}  // namespace

int main(int argc, char** argv) {
  TuneOptions o;
  if (const auto status = read_options(argc, argv, o)) return *status;
  if (o.out_dir.empty()) o.out_dir = dated_name("tune");
  fs::create_directories(o.out_dir);
  // The candidates' configurations load once per trial: their warnings (an α outside the paper's
  // range, say) would bury the progress lines.
  hpr::log::init("push_tune", hpr::log::Level::kError);
  const std::string results_path = o.out_dir + "/results.jsonl";

  std::vector<const TunedParam*> params;
  for (const auto& n : o.names) params.push_back(&tuned_param(n));
  // The optimiser starts at the configured parameters: the baseline (evaluated last if it did not).
  std::vector<double> u0;
  try {
    const hpr::Config cfg = hpr::Config::load(o.base.config, o.base.overrides);
    for (const TunedParam* p : params) u0.push_back(to_unit(*p, configured_value(cfg, *p)));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "push_tune: %s\n", e.what());
    return 2;
  }

  // The directions of an evaluation are one round of searches for the executor.
  int trials_run = 0;
  ExecutorEvents events;
  events.trial = [&](const SearchSpec&, const TrialOutcome&, bool stored) { trials_run += stored ? 0 : 1; };
  events.note = [](const std::string& line) { std::fprintf(stderr, "%s\n", line.c_str()); };
  std::unique_ptr<Executor> executor;
  try {
    executor = make_executor(o.executor, o.out_dir, events);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "push_tune: %s\n", e.what());
    return 1;
  }
  const std::string where = executor->describe();
  Tuning tuning(o, params, std::move(executor), &trials_run);
  if (o.executor.resume && fs::exists(results_path)) {
    try {
      tuning.read_results(results_path);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "push_tune: %s\n", e.what());
      return 2;
    }
  }
  tuning.append_results_to(results_path, o.executor.resume);

  nlopt::opt opt = make_optimiser(o, params.size(), tuning);
  std::fprintf(stderr, "push_tune: %s, %s over %s; %d evaluations, %zu directions, %s; results in %s\n", o.base.config.c_str(),
               o.algorithm.c_str(), fmt::format("{}", fmt::join(o.names, ",")).c_str(), o.evaluations, o.angles.size(), where.c_str(),
               results_path.c_str());
  std::vector<double> u = u0;
  double f = 0.0;
  try {
    opt.optimize(u, f);
  } catch (const nlopt::roundoff_limited&) {
    // The best point so far stands.
  } catch (const std::exception& e) {
    if (!tuning.stopped()) std::fprintf(stderr, "push_tune: the optimiser stopped: %s (the best point so far stands)\n", e.what());
  }
  if (const auto& stop = tuning.stopped()) {
    std::fprintf(stderr, "push_tune: %s\n%s", stop->why.c_str(),
                 stop->status == 130 ? "" : "push_tune: the evaluation could not finish; run again with --resume to go on\n");
    return stop->status;
  }
  const Evaluation initial = tuning.configured(u0);
  std::ofstream(o.out_dir + "/tuned.yaml") << overlay_yaml(o, params, tuning, initial);
  print_summary(o, params, tuning, initial);
  return 0;
}
