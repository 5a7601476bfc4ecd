// The Slurm executor: a round of searches as one job array. The searches go to a file in the
// shared folder; array task i runs searches [i K, (i + 1) K) with push_task, which appends every
// trial to the store there as it finishes. This side follows the store (progress, and which
// searches are complete: a search is complete when the stored verdicts answer every trial it asks
// for) and squeue (the array's state) until the array has left the queue; then it submits the
// tasks whose searches are incomplete once more, and reports those still incomplete as failed.
#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <thread>

#include "hpr/experiments/executor.hpp"
#include "hpr/experiments/version.hpp"
#include "hpr/launch/process_group.hpp"

extern char** environ;

namespace hpr::experiments {

namespace fs = std::filesystem;

namespace {

struct Captured {
  int exit_code = -1;  ///< -1: could not be started, or ended by a signal
  std::string out;     ///< standard output
  std::string err;     ///< standard error (or why it could not be started)
};

/// Runs `argv` (looked up on PATH, no shell) and collects its output; standard error goes through
/// `err_file`.
Captured capture(const std::vector<std::string>& argv, const fs::path& err_file) {
  Captured c;
  int out_pipe[2];
  if (::pipe2(out_pipe, O_CLOEXEC) != 0) {
    c.err = std::strerror(errno);
    return c;
  }
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, out_pipe[1], STDOUT_FILENO);
  posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, err_file.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
  std::vector<char*> args;
  for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  pid_t pid = 0;
  const int rc = ::posix_spawnp(&pid, args[0], &actions, nullptr, args.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  ::close(out_pipe[1]);
  if (rc != 0) {
    ::close(out_pipe[0]);
    c.err = fmt::format("cannot run {}: {}", argv[0], std::strerror(rc));
    return c;
  }
  char buf[4096];
  for (ssize_t n = 0; (n = ::read(out_pipe[0], buf, sizeof buf)) != 0;) {
    if (n < 0) {
      if (errno == EINTR) continue;
      break;
    }
    c.out.append(buf, static_cast<size_t>(n));
  }
  ::close(out_pipe[0]);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  c.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  std::ifstream in(err_file);
  std::ostringstream s;
  s << in.rdbuf();
  c.err = s.str();
  while (!c.err.empty() && (c.err.back() == '\n' || c.err.back() == ' ')) c.err.pop_back();
  return c;
}

std::string shell_quote(const std::string& s) {
  std::string out = "'";
  for (const char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

/// "0-7" or "1,4,5" (Slurm's --array syntax) for ascending indices.
std::string array_list(const std::vector<int>& tasks) {
  const bool contiguous = tasks.back() - tasks.front() + 1 == static_cast<int>(tasks.size());
  if (contiguous) return tasks.size() == 1 ? std::to_string(tasks[0]) : fmt::format("{}-{}", tasks.front(), tasks.back());
  return fmt::format("{}", fmt::join(tasks, ","));
}

/// Ctrl-C (and SIGTERM) while an array runs: noted here, acted on by the polling loop.
std::atomic<bool> g_interrupted{false};
extern "C" void note_interrupt(int) { g_interrupted = true; }

class InterruptGuard {
 public:
  InterruptGuard() {
    g_interrupted = false;
    struct sigaction sa {};
    sa.sa_handler = note_interrupt;
    sigemptyset(&sa.sa_mask);
    ::sigaction(SIGINT, &sa, &old_int_);
    ::sigaction(SIGTERM, &sa, &old_term_);
  }
  ~InterruptGuard() {
    ::sigaction(SIGINT, &old_int_, nullptr);
    ::sigaction(SIGTERM, &old_term_, nullptr);
  }
  InterruptGuard(const InterruptGuard&) = delete;
  InterruptGuard& operator=(const InterruptGuard&) = delete;

 private:
  struct sigaction old_int_ {}, old_term_ {};
};

/// "KEY=VALUE KEY=VALUE ..." (scontrol -o) as a map.
std::map<std::string, std::string> fields(const std::string& line) {
  std::map<std::string, std::string> out;
  std::istringstream in(line);
  for (std::string word; in >> word;) {
    const auto eq = word.find('=');
    if (eq != std::string::npos) out[word.substr(0, eq)] = word.substr(eq + 1);
  }
  return out;
}

class SlurmExecutor final : public Executor {
 public:
  SlurmExecutor(SlurmOptions options, bool resume, ExecutorEvents events)
      : o_(std::move(options)), resume_(resume), events_(std::move(events)), store_(fs::path(o_.shared_dir) / "trials") {
    if (o_.task_exe.empty()) o_.task_exe = (fs::path(launch::executable_dir()) / "push_task").string();
    if (!fs::exists(o_.task_exe)) throw std::runtime_error("the task program " + o_.task_exe + " does not exist (--task-exe)");
    o_.task_exe = fs::absolute(o_.task_exe).string();
  }

  std::vector<SearchResult> run(const std::vector<SearchSpec>& searches) override;

  [[nodiscard]] std::string describe() const override {
    std::string d = "slurm";
    if (!o_.partition.empty()) d += ", partition " + o_.partition;
    d += fmt::format(", {} search{} per task, {} CPU{} per task, shared folder {}", o_.searches_per_task,
                     o_.searches_per_task == 1 ? "" : "es", o_.cpus_per_task, o_.cpus_per_task == 1 ? "" : "s", o_.shared_dir);
    return d;
  }

 private:
  /// One round's bookkeeping.
  struct Round {
    fs::path dir;
    std::vector<size_t> pending;            ///< indices into the round's searches, in file order
    int per_task = 1;
    std::vector<SearchResult>* results = nullptr;
    std::vector<bool> done;                 ///< per search of the round
    std::vector<std::set<double>> reported; ///< trials already reported, per search
    std::vector<fs::path> file;             ///< each pending search's store file (its key hashed once)
    std::vector<std::uintmax_t> size_read;  ///< the file's size when last read: unchanged, not read again
  };

  void note(const std::string& line) const {
    if (events_.note) events_.note(line);
  }
  [[nodiscard]] int task_of(const Round& r, size_t pending_pos) const {
    return static_cast<int>(pending_pos) / r.per_task;
  }
  /// The searches the store answers already (--resume), reported; the others pending in `r`.
  void answer_from_store(const std::vector<SearchSpec>& searches, Round& r) const;
  /// The round's folder, its searches.jsonl and task.sh; the number of array tasks.
  int write_round(const std::vector<SearchSpec>& searches, Round& r) const;
  /// Each search whose array task failed twice, marked failed with the trials it finished.
  void mark_failed(const std::string& job, const Round& r, const std::vector<SearchSpec>& searches) const;
  std::string submit(const Round& r, const std::vector<int>& tasks) const;
  void follow(const std::string& job, Round& r, const std::vector<SearchSpec>& searches) const;
  void poll_store(Round& r, const std::vector<SearchSpec>& searches) const;
  [[nodiscard]] std::map<int, std::string> task_states(const std::string& job, const Round& r) const;

  SlurmOptions o_;
  bool resume_;
  ExecutorEvents events_;
  SearchStore store_;
};

void SlurmExecutor::answer_from_store(const std::vector<SearchSpec>& searches, Round& r) const {
  std::vector<SearchResult>& results = *r.results;
  for (size_t i = 0; i < searches.size(); ++i) {
    if (!resume_) {
      fs::remove(store_.file(searches[i]));
      r.pending.push_back(i);
      continue;
    }
    const auto known = store_.trials(searches[i]);
    if (auto replay = replay_search(searches[i], known)) {
      for (const auto& t : replay->trials) {
        if (events_.trial) events_.trial(searches[i], t, true);
      }
      results[i] = *replay;
      r.done[i] = true;
      if (events_.search) events_.search(searches[i], results[i]);
    } else {
      for (const auto& [impulse, t] : known) {
        r.reported[i].insert(impulse);
        if (events_.trial) events_.trial(searches[i], t, true);
      }
      r.pending.push_back(i);
    }
  }
}

int SlurmExecutor::write_round(const std::vector<SearchSpec>& searches, Round& r) const {
  const fs::path rounds = fs::path(o_.shared_dir) / "rounds";
  fs::create_directories(rounds);
  for (int n = 1;; ++n) {
    r.dir = rounds / fmt::format("{:04d}", n);
    if (fs::create_directory(r.dir)) break;
  }
  {
    std::ofstream list(r.dir / "searches.jsonl");
    for (const size_t i : r.pending) list << searches[i].to_json() << "\n";
    if (!list) throw std::runtime_error("cannot write " + (r.dir / "searches.jsonl").string());
  }
  // Slurm's default MaxArraySize is 1001: more searches share tasks.
  constexpr int kMaxArray = 1000;
  r.per_task = std::max(o_.searches_per_task, static_cast<int>((r.pending.size() + kMaxArray - 1) / kMaxArray));
  if (r.per_task != o_.searches_per_task) {
    note(fmt::format("{} searches: {} per array task (Slurm's array size)", r.pending.size(), r.per_task));
  }
  {
    std::ofstream script(r.dir / "task.sh");
    script << "#!/bin/sh\n"
           << "# One array task of the searches in searches.jsonl (written by push_sweep or push_tune):\n"
           << "# task i runs searches i*" << r.per_task << " to i*" << r.per_task << "+" << r.per_task - 1
           << " and appends each trial to the store as it finishes.\n"
           << "exec " << shell_quote(o_.task_exe) << " --searches " << shell_quote((r.dir / "searches.jsonl").string())
           << " --task \"$SLURM_ARRAY_TASK_ID\" --per-task " << r.per_task << " --store " << shell_quote(store_.dir().string())
           << " --jobs \"${SLURM_CPUS_PER_TASK:-1}\" --commit " << shell_quote(source_commit()) << "\n";
  }
  fs::permissions(r.dir / "task.sh", fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec | fs::perms::others_read |
                                         fs::perms::others_exec);
  return task_of(r, r.pending.size() - 1) + 1;
}

void SlurmExecutor::mark_failed(const std::string& job, const Round& r, const std::vector<SearchSpec>& searches) const {
  const std::map<int, std::string> states = task_states(job, r);
  for (size_t p = 0; p < r.pending.size(); ++p) {
    const size_t i = r.pending[p];
    if (r.done[i]) continue;
    const int t = task_of(r, p);
    SearchResult& res = (*r.results)[i];
    res = SearchResult{};
    res.failed = true;
    res.failure = fmt::format("array task {} failed twice (job {}_{}: {}; log {}), the search is incomplete", t, job, t,
                              states.at(t), (r.dir / fmt::format("task-{}.log", t)).string());
    // The trials it did finish, in the order the search asked for them.
    const auto known = store_.trials(searches[i]);
    for (const auto& [impulse, trial] : known) res.trials.push_back(trial);
    if (events_.search) events_.search(searches[i], res);
  }
}

std::vector<SearchResult> SlurmExecutor::run(const std::vector<SearchSpec>& searches) {
  std::vector<SearchResult> results(searches.size());
  Round r;
  r.results = &results;
  r.done.assign(searches.size(), false);
  r.reported.resize(searches.size());
  r.file.resize(searches.size());
  r.size_read.assign(searches.size(), 0);
  answer_from_store(searches, r);
  if (r.pending.empty()) return results;
  for (const size_t i : r.pending) r.file[i] = store_.file(searches[i]);
  const int n_tasks = write_round(searches, r);
  std::vector<int> all(static_cast<size_t>(n_tasks));
  for (int t = 0; t < n_tasks; ++t) all[static_cast<size_t>(t)] = t;

  const InterruptGuard guard;
  std::string job = submit(r, all);
  note(fmt::format("slurm: job array {} of {} task{} ({} search{}), files in {}", job, n_tasks, n_tasks == 1 ? "" : "s",
                   r.pending.size(), r.pending.size() == 1 ? "" : "es", r.dir.string()));
  follow(job, r, searches);
  // A task whose searches are incomplete is submitted once more; twice, they are failed.
  for (int attempt = 1;; ++attempt) {
    std::vector<int> failed_tasks;
    for (size_t p = 0; p < r.pending.size(); ++p) {
      if (!r.done[r.pending[p]]) {
        const int t = task_of(r, p);
        if (failed_tasks.empty() || failed_tasks.back() != t) failed_tasks.push_back(t);
      }
    }
    if (failed_tasks.empty()) break;
    if (attempt == 2) {
      mark_failed(job, r, searches);
      break;
    }
    const std::map<int, std::string> states = task_states(job, r);
    for (const int t : failed_tasks) {
      note(fmt::format("slurm: array task {} (job {}_{}) ended with its searches incomplete: {}; submitting it again (log {})", t, job, t,
                       states.at(t), (r.dir / fmt::format("task-{}.log", t)).string()));
    }
    job = submit(r, failed_tasks);
    note(fmt::format("slurm: job array {} of {} task{} (resubmitted)", job, failed_tasks.size(), failed_tasks.size() == 1 ? "" : "s"));
    follow(job, r, searches);
  }
  return results;
}

std::string SlurmExecutor::submit(const Round& r, const std::vector<int>& tasks) const {
  std::vector<std::string> argv = {"sbatch",
                                   "--parsable",
                                   "--array=" + array_list(tasks),
                                   "--job-name=" + o_.job_name,
                                   "--output=" + (r.dir / "task-%a.log").string(),
                                   "--open-mode=append",
                                   fmt::format("--cpus-per-task={}", o_.cpus_per_task)};
  if (!o_.partition.empty()) argv.push_back("--partition=" + o_.partition);
  if (!o_.account.empty()) argv.push_back("--account=" + o_.account);
  if (!o_.time_limit.empty()) argv.push_back("--time=" + o_.time_limit);
  argv.insert(argv.end(), o_.sbatch_args.begin(), o_.sbatch_args.end());
  argv.push_back((r.dir / "task.sh").string());
  const Captured c = capture(argv, r.dir / "sbatch.err");
  // --parsable prints "jobid" or "jobid;cluster".
  std::string id = c.out.substr(0, c.out.find_first_of(";\n"));
  const bool numeric = !id.empty() && id.find_first_not_of("0123456789") == std::string::npos;
  if (c.exit_code != 0 || !numeric) {
    std::string cmd;
    for (const auto& a : argv) cmd += (cmd.empty() ? "" : " ") + a;
    throw std::runtime_error(fmt::format("sbatch refused the array ({}): {}", cmd, c.err.empty() ? c.out : c.err));
  }
  return id;
}

void SlurmExecutor::poll_store(Round& r, const std::vector<SearchSpec>& searches) const {
  for (const size_t i : r.pending) {
    if (r.done[i]) continue;
    // Read again only once the task has appended to it (and a bad file is said once).
    std::error_code ec;
    const std::uintmax_t size = fs::file_size(r.file[i], ec);
    if (ec || size == r.size_read[i]) continue;
    r.size_read[i] = size;
    std::map<double, TrialOutcome> known;
    try {
      known = store_.trials(searches[i]);
    } catch (const std::exception& e) {
      note(std::string("slurm: ") + e.what());
      continue;
    }
    // New trials, in the order the search asked for them (a replay of what is known).
    const std::optional<SearchResult> replay = replay_search(searches[i], known);
    std::vector<const TrialOutcome*> order;
    if (replay) {
      for (const auto& t : replay->trials) order.push_back(&t);
    } else {
      for (const auto& [impulse, t] : known) order.push_back(&t);
    }
    for (const TrialOutcome* t : order) {
      if (r.reported[i].insert(t->impulse).second && events_.trial) events_.trial(searches[i], *t, false);
    }
    if (replay) {
      (*r.results)[i] = *replay;
      r.done[i] = true;
      if (events_.search) events_.search(searches[i], *replay);
    }
  }
}

void SlurmExecutor::follow(const std::string& job, Round& r, const std::vector<SearchSpec>& searches) const {
  using Clock = std::chrono::steady_clock;
  std::string last_state;
  auto next_squeue = Clock::now();
  bool told_unreachable = false;
  for (;;) {
    if (g_interrupted) {
      const Captured c = capture({"scancel", job}, r.dir / "scancel.err");
      throw Interrupted(fmt::format("interrupted: job array {} cancelled{}; the finished trials are kept in {} (run again with --resume)",
                                    job, c.exit_code == 0 ? "" : " (scancel: " + c.err + ")", store_.dir().string()));
    }
    poll_store(r, searches);
    // Every search complete: the results are in, whatever the tasks still do on their way out.
    if (std::all_of(r.pending.begin(), r.pending.end(), [&](size_t i) { return r.done[i]; })) return;
    if (Clock::now() >= next_squeue) {
      next_squeue = Clock::now() + std::max<std::chrono::milliseconds>(o_.poll, std::chrono::seconds(2));
      const Captured c = capture({"squeue", "--noheader", "--array", "--jobs=" + job, "--format=%i %T"}, r.dir / "squeue.err");
      const bool gone = c.exit_code != 0 && c.err.find("Invalid job id") != std::string::npos;
      if (c.exit_code != 0 && !gone) {
        if (!told_unreachable) note("slurm: squeue failed (" + c.err + "); still waiting for job " + job);
        told_unreachable = true;
      } else {
        told_unreachable = false;
        std::map<std::string, int> by_state;
        std::istringstream in(c.out);
        for (std::string id, state; in >> id >> state;) ++by_state[state];
        if (by_state.empty()) {
          poll_store(r, searches);  // what the last tasks wrote before they left the queue
          return;
        }
        std::string state;
        for (const auto& [s, n] : by_state) state += fmt::format("{}{} {}", state.empty() ? "" : ", ", n, s);
        if (state != last_state) note(fmt::format("slurm: job {}: {}", job, state));
        last_state = state;
      }
    }
    std::this_thread::sleep_for(o_.poll);
  }
}

std::map<int, std::string> SlurmExecutor::task_states(const std::string& job, const Round& r) const {
  std::map<int, std::string> out;
  const int n_tasks = task_of(r, r.pending.size() - 1) + 1;
  for (int t = 0; t < n_tasks; ++t) out[t] = "state unknown (no longer in slurmctld's memory)";
  const Captured c = capture({"scontrol", "--oneliner", "show", "job", job}, r.dir / "scontrol.err");
  std::istringstream in(c.out);
  for (std::string line; std::getline(in, line);) {
    const auto f = fields(line);
    if (!f.contains("ArrayTaskId")) continue;
    try {
      const int t = std::stoi(f.at("ArrayTaskId"));
      std::string s = f.contains("JobState") ? f.at("JobState") : "?";
      if (f.contains("ExitCode")) s += ", exit code " + f.at("ExitCode");
      if (f.contains("Reason") && f.at("Reason") != "None") s += ", " + f.at("Reason");
      out[t] = s;
    } catch (const std::exception&) {
      // A range of pending tasks ("ArrayTaskId=3-7"): none is left once the array is done.
    }
  }
  return out;
}

}  // namespace

std::unique_ptr<Executor> make_slurm_executor(SlurmOptions options, bool resume, ExecutorEvents events) {
  return std::make_unique<SlurmExecutor>(std::move(options), resume, std::move(events));
}

}  // namespace hpr::experiments
