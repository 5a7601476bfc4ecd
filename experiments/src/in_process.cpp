// A push trial through the in-process pipeline: the same plan (configuration, overrides, push) as
// run_trial, the same evaluation from the same messages, the stack's libraries stepping in one
// thread instead of processes over LCM.
#include <fmt/format.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstring>
#include <stdexcept>

#include "hpr/experiments/trial.hpp"
#include "hpr/msg/robot_io.hpp"
#include "hpr/msg/sim_truth.hpp"
#include "hpr/graph/closed_loop.hpp"

namespace hpr::experiments {

namespace {

graph::ClosedLoopOptions loop_options(const TrialSpec& spec) {
  graph::ClosedLoopOptions options;
  options.cam = spec.strategy == Strategy::kCam;
  // The controllers see the estimator's state, or (truth_state) the simulator's truth.
  options.estimator_in_loop = !spec.truth_state;
  return options;
}

}  // namespace

/// A trial's closed loop and evaluation, ticked as sim_bullet in lockstep; the push is added by
/// the caller (a push adds no force before its start, so the run before it is the same without).
struct InProcessRun {
  explicit InProcessRun(const TrialSpec& spec)
      : plan(plan_trial(spec)),
        loop(plan.config, plan.overrides, loop_options(spec)),
        eval(loop.spec, spec.support, plan.push.start, plan.push.start + plan.push.duration) {
    eval.allow_steps(steps_enabled(spec));
    names.joints = loop.spec.model.joint_name;
  }

  /// One tick: the plant's messages (ROBOT_SENSORS, then SIM_TRUTH) to the evaluator, then, unless
  /// the watch stops the run (false), the controllers' step and the commanded CAM.
  bool tick(TrialWatch& watch) {
    msg::to_message(loop.sim.sensors(), names, sensors);
    eval.on_sensors(sensors);
    msg::to_message(loop.sim.truth(), names.feet, truth);
    eval.on_truth(truth);
    if (watch.stop()) return false;
    const double t = loop.sim.time();
    loop.step();
    if (loop.have_wholebody()) {
      // The evaluator reads the commanded CAM of WHOLEBODY_COMMAND (stamped with the state's time).
      wholebody.utime = static_cast<std::int64_t>(std::llround(t * 1e6));
      const Eigen::Vector3d& l_cmd = loop.wholebody().l_cmd;
      for (int k = 0; k < 3; ++k) wholebody.l_cmd_W[k] = l_cmd(k);
      wholebody.steps_taken = loop.wholebody().command.stepping.steps_taken;
      wholebody.follow_steps = loop.wholebody().command.stepping.follow_steps;
      eval.on_wholebody(wholebody);
    }
    return true;
  }

  /// Ticks until the end of `plan_of_push`'s run or until the watch stops it.
  TrialResult finish(const TrialSpec& spec, const TrialPlan& plan_of_push,
                     const std::function<void(const std::string&)>& progress, std::chrono::steady_clock::time_point wall0) {
    const double t_push = plan_of_push.push.start, t_end = t_push + plan_of_push.push.duration;
    if (!spec.standing()) loop.sim.add_push(plan_of_push.push);
    eval.set_push_end(t_end);
    TrialWatch watch(spec, eval, t_push, t_end, progress, wall0);
    while (loop.sim.time() < plan_of_push.sim_duration && tick(watch)) {
    }
    return watch.result();
  }

  TrialPlan plan;
  graph::ClosedLoop loop;
  TrialEvaluator eval;
  msg::RobotNames names;
  humanoid::sim_truth_t truth{};
  humanoid::robot_sensors_t sensors{};
  humanoid::wholebody_command_t wholebody{};
  bool stopped_before_push = false;
};

TrialResult run_trial_in_process(const TrialSpec& spec, const std::function<void(const std::string&)>& progress) {
  if (!spec.log_file.empty()) throw std::invalid_argument("an in-process trial writes no log: run it through the processes (run_trial)");
  const auto wall0 = std::chrono::steady_clock::now();
  InProcessRun run(spec);
  return run.finish(spec, run.plan, progress, wall0);
}

namespace {

constexpr double kForkBeforePush = 0.1;  ///< [s]

/// Writes all of `text` to `fd` (the child's end of the pipe).
void write_all(int fd, const std::string& text) {
  size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return;
    done += static_cast<size_t>(n);
  }
}

}  // namespace

PrePushCheckpoint::PrePushCheckpoint(const TrialSpec& base) : base_(base) {
  if (!base.log_file.empty()) throw std::invalid_argument("an in-process trial writes no log: run it through the processes (run_trial)");
  run_ = std::make_unique<InProcessRun>(base);
  TrialWatch watch(base, run_->eval, run_->plan.push.start, run_->plan.push.start + run_->plan.push.duration, {},
                   std::chrono::steady_clock::now());
  const double t_fork = run_->plan.push.start - kForkBeforePush;
  while (run_->loop.sim.time() < t_fork) {
    if (!run_->tick(watch)) {
      // It fell (or ran out of time) before any push: each trial runs afresh and says so.
      run_->stopped_before_push = true;
      break;
    }
  }
}

PrePushCheckpoint::~PrePushCheckpoint() = default;

std::unique_ptr<PrePushCheckpoint> PrePushCheckpoint::for_case(const TrialSpec& base) {
  if (!base.in_process) return nullptr;
  try {
    return std::make_unique<PrePushCheckpoint>(base);
  } catch (const std::exception&) {
    return nullptr;
  }
}

TrialResult PrePushCheckpoint::run(const TrialSpec& spec) const {
  const TrialPlan plan = plan_trial(spec);
  const auto differs = [](const char* what) {
    throw std::invalid_argument(fmt::format("a trial from a pre-push checkpoint may change only the push: its {} differs", what));
  };
  if (plan.config != run_->plan.config) differs("configuration");
  if (plan.overrides != run_->plan.overrides) differs("overrides (support, --set, alpha, beta)");
  if (spec.strategy != base_.strategy) differs("strategy");
  if (spec.truth_state != base_.truth_state) differs("state source (--truth-state)");
  if (plan.push.start != run_->plan.push.start) differs("push time");
  if (!spec.log_file.empty()) differs("log (an in-process trial writes none)");
  if (run_->stopped_before_push) return run_trial_in_process(spec);

  int fds[2];
  if (::pipe(fds) != 0) throw std::runtime_error(fmt::format("pipe: {}", std::strerror(errno)));
  const auto wall0 = std::chrono::steady_clock::now();
  const pid_t parent = ::getpid();
  const pid_t pid = ::fork();
  if (pid < 0) {
    ::close(fds[0]);
    ::close(fds[1]);
    throw std::runtime_error(fmt::format("fork: {}", std::strerror(errno)));
  }
  if (pid == 0) {
    // The copy: continue with this push, hand the result over, and leave without running the
    // parent's exit handlers or flushing its buffers. It keeps no other descriptor: a pipe another
    // thread of the parent opened for its own copy must see its end of file when that copy ends.
    // It ends with the sweep or tune that forked it (interrupted, killed), not seconds later.
    ::prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (::getppid() != parent) ::_exit(1);
    const auto fd = static_cast<unsigned>(fds[1]);
    if (fd > 3) ::close_range(3, fd - 1, 0);
    ::close_range(fd + 1, ~0U, 0);
    int status = 0;
    try {
      write_all(fds[1], run_->finish(spec, plan, {}, wall0).to_json(spec));
    } catch (const std::exception& e) {
      write_all(fds[1], std::string("error: ") + e.what());
      status = 1;
    }
    ::_exit(status);
  }
  ::close(fds[1]);
  std::string text;
  char buf[4096];
  for (;;) {
    const ssize_t n = ::read(fds[0], buf, sizeof(buf));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    text.append(buf, static_cast<size_t>(n));
  }
  ::close(fds[0]);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (WIFSIGNALED(status)) {
    throw std::runtime_error(fmt::format("the trial's process (from the pre-push checkpoint) ended by signal {}", WTERMSIG(status)));
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    throw std::runtime_error("the trial's process (from the pre-push checkpoint) failed: " + text);
  }
  return TrialResult::from_json(text);
}

}  // namespace hpr::experiments
