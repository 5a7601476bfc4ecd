#include "hpr/experiments/executor.hpp"

#include <fmt/format.h>

#include <atomic>
#include <filesystem>
#include <future>
#include <mutex>

#include "hpr/common/args.hpp"

namespace hpr::experiments {

namespace fs = std::filesystem;

const char* const kExecutorOptionsUsage =
    R"(  --executor E          local | slurm: where the searches run (default local)
  --jobs J              local: searches run at the same time
  --resume              go on from an interrupted run with the same --out: the trials it finished
                        (kept in <out>/trials, or <shared-dir>/trials with slurm) are not run again
 Slurm (--executor slurm; docs/CLUSTER.md):
  --shared-dir DIR      task files, logs and trial results, visible on the nodes (default <out>/slurm)
  --partition P         sbatch --partition
  --account A           sbatch --account
  --time-limit T        sbatch --time of one array task (e.g. 30:00)
  --cpus-per-task N     sbatch --cpus-per-task; a task runs N searches at once (default 1)
  --searches-per-task N searches one array task runs (default 1)
  --sbatch-arg ARG      one more argument for sbatch (repeatable), e.g. --sbatch-arg=--qos=long
  --task-exe PATH       the program the tasks run (default: push_task beside this program)
)";

bool ExecutorOptions::read(ArgReader& args) {
  if (args.is("--executor")) {
    kind = args.value();
  } else if (args.is("--jobs")) {
    jobs = args.integer();
    if (jobs < 1) throw UsageError("--jobs: at least 1");
  } else if (args.is("--resume")) {
    resume = true;
  } else if (args.is("--shared-dir")) {
    shared_dir = args.value();
  } else if (args.is("--partition")) {
    slurm.partition = args.value();
  } else if (args.is("--account")) {
    slurm.account = args.value();
  } else if (args.is("--time-limit")) {
    slurm.time_limit = args.value();
  } else if (args.is("--cpus-per-task")) {
    slurm.cpus_per_task = args.integer();
    if (slurm.cpus_per_task < 1) throw UsageError("--cpus-per-task: at least 1");
  } else if (args.is("--searches-per-task")) {
    slurm.searches_per_task = args.integer();
    if (slurm.searches_per_task < 1) throw UsageError("--searches-per-task: at least 1");
  } else if (args.is("--sbatch-arg")) {
    slurm.sbatch_args.push_back(args.value());
  } else if (args.is("--task-exe")) {
    slurm.task_exe = args.value();
  } else {
    return false;
  }
  return true;
}

void ExecutorOptions::validate() const {
  if (kind != "local" && kind != "slurm") throw UsageError("--executor: '" + kind + "' is not local or slurm");
  if (kind == "local") {
    const bool slurm_set = shared_dir || !slurm.partition.empty() || !slurm.account.empty() || !slurm.time_limit.empty() ||
                           slurm.cpus_per_task != 1 || slurm.searches_per_task != 1 || !slurm.sbatch_args.empty() ||
                           !slurm.task_exe.empty();
    if (slurm_set) throw UsageError("the Slurm options need --executor slurm");
  }
}

namespace {

class LocalExecutor final : public Executor {
 public:
  LocalExecutor(int jobs, std::string store_dir, bool resume, ExecutorEvents events)
      : jobs_(jobs), store_(std::move(store_dir)), resume_(resume), events_(std::move(events)) {}

  std::vector<SearchResult> run(const std::vector<SearchSpec>& searches) override {
    std::vector<SearchResult> results(searches.size());
    std::mutex mutex;
    SearchEvents ev;
    ev.trial = [&](const SearchSpec& s, const TrialOutcome& t, bool stored) {
      const std::lock_guard<std::mutex> lock(mutex);
      if (events_.trial) events_.trial(s, t, stored);
    };
    ev.retry = [&](const SearchSpec& s, double impulse, const std::string& why) {
      const std::lock_guard<std::mutex> lock(mutex);
      if (events_.note) {
        events_.note(fmt::format("  {} {:.2f} N s: inconclusive ({}), running it again", s.label(), impulse, why));
      }
    };
    std::atomic<size_t> next{0};
    const auto work = [&] {
      for (size_t i = next++; i < searches.size(); i = next++) {
        const SearchSpec& s = searches[i];
        if (!resume_) fs::remove(store_.file(s));
        results[i] = run_search(s, store_.trials(s), &store_, ev);
        const std::lock_guard<std::mutex> lock(mutex);
        if (events_.search) events_.search(s, results[i]);
      }
    };
    std::vector<std::future<void>> workers;
    for (int w = 0; w < std::min<int>(jobs_, static_cast<int>(searches.size())); ++w) {
      workers.push_back(std::async(std::launch::async, work));
    }
    for (auto& w : workers) w.get();
    return results;
  }

  [[nodiscard]] std::string describe() const override { return fmt::format("local, {} job{}", jobs_, jobs_ == 1 ? "" : "s"); }

 private:
  int jobs_;
  SearchStore store_;
  bool resume_;
  ExecutorEvents events_;
};

}  // namespace

std::unique_ptr<Executor> make_local_executor(int jobs, std::string store_dir, bool resume, ExecutorEvents events) {
  return std::make_unique<LocalExecutor>(std::max(1, jobs), std::move(store_dir), resume, std::move(events));
}

std::unique_ptr<Executor> make_executor(const ExecutorOptions& options, const std::string& out_dir, ExecutorEvents events) {
  if (options.kind == "slurm") {
    SlurmOptions s = options.slurm;
    s.shared_dir = fs::absolute(options.shared_dir ? *options.shared_dir : out_dir + "/slurm").lexically_normal().string();
    return make_slurm_executor(std::move(s), options.resume, std::move(events));
  }
  return make_local_executor(options.jobs, (fs::path(out_dir) / "trials").string(), options.resume, std::move(events));
}

}  // namespace hpr::experiments
