#pragma once
/// \file Where the searches of a sweep or a tune run: on this machine (threads, `--jobs`) or on a
/// Slurm cluster (job arrays; docs/CLUSTER.md). Both run the same searches through the same code
/// (run_search) and give the same results; push_sweep and push_tune choose with `--executor`.
///
/// A round is a set of independent searches: push_sweep's whole sweep, or one push_tune
/// evaluation's directions. With a store, every finished trial is kept, so a round interrupted
/// anywhere and run again (push_sweep and push_tune --resume) runs only what is missing.

#include <chrono>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "hpr/experiments/search.hpp"

namespace hpr {
class ArgReader;
}

namespace hpr::experiments {

/// What an executor reports while a round runs; called from one thread at a time.
struct ExecutorEvents {
  /// A trial finished: run now, or answered from the store (`stored`).
  std::function<void(const SearchSpec&, const TrialOutcome&, bool stored)> trial;
  /// A search finished (its result as run() will return it).
  std::function<void(const SearchSpec&, const SearchResult&)> search;
  /// Anything else worth a line: retries, the cluster's state, resubmissions.
  std::function<void(const std::string&)> note;
};

/// Thrown by run() when the user interrupted the round (Ctrl-C); what finished is in the store.
class Interrupted : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class Executor {
 public:
  virtual ~Executor() = default;
  /// Runs every search of one round; the results in the order of `searches`.
  virtual std::vector<SearchResult> run(const std::vector<SearchSpec>& searches) = 0;
  /// "local, 2 jobs" / "slurm, partition debug, 1 search per task".
  [[nodiscard]] virtual std::string describe() const = 0;
};

/// The options of `--executor slurm`.
struct SlurmOptions {
  std::string shared_dir;       ///< task files, logs and the trial store; must be visible on the nodes
  std::string partition;        ///< sbatch --partition (empty: the cluster's default)
  std::string account;          ///< sbatch --account
  std::string time_limit;       ///< sbatch --time of one array task (empty: the partition's)
  int cpus_per_task = 1;        ///< sbatch --cpus-per-task; a task runs that many searches at once
  int searches_per_task = 1;    ///< searches one array task runs
  std::vector<std::string> sbatch_args;  ///< more arguments for sbatch, as given
  std::string task_exe;         ///< the program each task runs (default: push_task beside this one)
  std::string job_name = "hpr";
  std::chrono::milliseconds poll{500};   ///< how often the store and squeue are looked at
};

/// The executor options every tool shares: --executor, --jobs and the Slurm ones.
struct ExecutorOptions {
  std::string kind = "local";   ///< local | slurm
  int jobs = 1;                 ///< local: searches at the same time
  bool resume = false;          ///< --resume: the store's trials are not run again
  std::optional<std::string> shared_dir;  ///< slurm: default <out>/slurm
  SlurmOptions slurm;
  /// Reads the current option into the fields and returns true, or returns false when the
  /// current argument is none of them.
  bool read(ArgReader& args);
  /// Checks the combination (throws hpr::UsageError).
  void validate() const;
};
/// The lines of those options for a usage text.
extern const char* const kExecutorOptionsUsage;

/// Searches on this machine, `jobs` at a time, in the order given. Every trial is kept in
/// `store_dir`; with `resume` the trials it already holds are not run again, without it a
/// search's stored trials are dropped before it runs.
std::unique_ptr<Executor> make_local_executor(int jobs, std::string store_dir, bool resume, ExecutorEvents events);

/// Searches as Slurm job arrays (sbatch --array): the searches of a round are written to a file in
/// the shared folder, each array task runs `searches_per_task` of them with `task_exe` (push_task)
/// and appends every trial to the store there as it finishes; run() follows the store (progress)
/// and squeue until the array has left the queue. A task that failed or ran out of time is
/// submitted again once (its finished trials are kept), then its searches are reported as failed,
/// never as falls. Ctrl-C cancels the array (scancel) and throws Interrupted. Throws
/// std::runtime_error when sbatch refuses the array (its message included). `resume` as for the
/// local executor; the store is `<shared_dir>/trials`.
std::unique_ptr<Executor> make_slurm_executor(SlurmOptions options, bool resume, ExecutorEvents events);

/// The executor the options ask for (resuming when `options.resume`): the store is `<out_dir>/trials` locally, `<shared>/trials` on
/// Slurm (the shared folder defaulting to `<out_dir>/slurm`).
std::unique_ptr<Executor> make_executor(const ExecutorOptions& options, const std::string& out_dir, ExecutorEvents events);

}  // namespace hpr::experiments
