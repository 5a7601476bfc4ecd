#pragma once
/// \file One search for the largest impulse a case recovers (robot, support, strategy, direction,
/// push shape, configuration): the unit of work push_sweep and push_tune hand to an executor
/// (executor.hpp). Its trials can be kept in a store, one line each as it finishes, so that a
/// search interrupted anywhere (a killed process, a cluster task past its time limit) resumes
/// where it stopped: the search is deterministic, so replaying it against the stored verdicts
/// asks for exactly the trials that are missing.

#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "hpr/experiments/bisection.hpp"
#include "hpr/experiments/trial.hpp"

namespace hpr::experiments {

/// A trial that ends before it can tell is run again, up to this many times in all; one that stays
/// inconclusive counts as not recovered and marks its search.
constexpr int kTrialAttempts = 3;

struct SearchSpec {
  TrialSpec base;  ///< the case; the search chooses the impulse
  double start = 15.0, max_impulse = 80.0, resolution = 0.5;  ///< [N s] largest_recovered's bounds

  /// The spec as JSON text, every double exactly (from_json gives the same spec back).
  [[nodiscard]] std::string to_json() const;
  static SearchSpec from_json(const std::string& json);
  /// A name for the search's results: 16 hex digits hashing the spec, the configuration file's
  /// content and the source commit (results of other code or another configuration never mix).
  [[nodiscard]] std::string key() const;
  /// "double cam 45 deg" (for progress lines).
  [[nodiscard]] std::string label() const;
};

/// TrialSpec as JSON and back (doubles exact; optional fields absent when unset).
std::string trial_spec_to_json(const TrialSpec& spec);
TrialSpec trial_spec_from_json(const std::string& json);

struct TrialOutcome {
  double impulse = 0.0;  ///< [N s]
  TrialResult result;    ///< the last attempt's; an inconclusive one counts as not recovered
  int attempts = 1;
};

struct SearchResult {
  ImpulseBracket bracket;
  std::vector<TrialOutcome> trials;  ///< in the order the search asked for them
  bool inconclusive = false;         ///< a trial stayed inconclusive: the largest impulse may be low
  /// The search did not finish (the task that ran it failed, twice): `bracket` means nothing and
  /// `failure` says which task and why. Never to be read as a fall.
  bool failed = false;
  std::string failure;
  /// The trial at `impulse` (nullptr when not tried).
  [[nodiscard]] const TrialOutcome* find(double impulse) const;
};

/// What a search reports while it runs (each may be empty).
struct SearchEvents {
  /// A trial finished (`stored`: answered from the store, not run).
  std::function<void(const SearchSpec&, const TrialOutcome&, bool stored)> trial;
  /// A trial was inconclusive and runs again.
  std::function<void(const SearchSpec&, double impulse, const std::string& why)> retry;
};

/// Runs one trial of a search (the default: in process through one pre-push checkpoint per search,
/// else run_trial).
using TrialRunner = std::function<TrialResult(const TrialSpec&)>;

/// Trials of searches, one JSON-lines file per search key in a folder: a header line with the
/// search, the commit and the date, then one line per finished trial, appended and flushed as it
/// finishes. One writer per search at a time; readers may read while it writes.
class SearchStore {
 public:
  explicit SearchStore(std::filesystem::path dir);
  [[nodiscard]] const std::filesystem::path& dir() const { return dir_; }
  [[nodiscard]] std::filesystem::path file(const SearchSpec& spec) const;
  /// The trials held for `spec`, by impulse. A last line torn by a writer that was killed is
  /// ignored; a torn line elsewhere, or a file of another search, throws std::runtime_error naming
  /// the file and line.
  [[nodiscard]] std::map<double, TrialOutcome> trials(const SearchSpec& spec) const;
  void append(const SearchSpec& spec, const TrialOutcome& trial) const;

 private:
  std::filesystem::path dir_;
};

/// Runs the search: the trials in `known` are answered from it, the others run through `runner`
/// (empty: the default runner), each up to kTrialAttempts times while inconclusive (an exception
/// counts as inconclusive, its text as the reason), and each new one is appended to `store` when
/// given.
SearchResult run_search(const SearchSpec& spec, const std::map<double, TrialOutcome>& known, const SearchStore* store,
                        const SearchEvents& events = {}, TrialRunner runner = {});

/// The search's result when `known` answers every trial it asks for; nullopt when one is missing.
std::optional<SearchResult> replay_search(const SearchSpec& spec, const std::map<double, TrialOutcome>& known);

}  // namespace hpr::experiments
