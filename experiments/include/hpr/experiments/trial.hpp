#pragma once
/// \file
/// One push-recovery experiment with every process of the stack in lockstep against the simulator
/// (estimator in the loop), and its evaluation from the messages of the run.
///
/// "Recovered" means: not fallen 5 s after the push ends, the stance soles flat (tilt below 2°) and
/// sliding less than 1 cm from the push on, and the posture back within 1 cm and 1° of the
/// pre-push posture within 5 s of the push end (CoM position; base orientation and every free
/// joint within 1°). A trial without a push (impulse and duration 0) is a standing trial judged
/// alike from the time the push would have come; its success is "stood". kOutcomeLegend says every
/// outcome in words.

#include <humanoid/robot_sensors_t.hpp>
#include <humanoid/sim_truth_t.hpp>
#include <humanoid/wholebody_command_t.hpp>

#include <Eigen/Core>
#include <chrono>
#include <deque>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "hpr/model/robot.hpp"
#include "hpr/sim/simulator.hpp"

namespace hpr {
class ArgReader;
}

namespace hpr::experiments {

/// The outcomes of a trial in words, one line each, as every tool prints them under its results.
extern const char* const kOutcomeLegend;

enum class Strategy { kCam, kAnkle };
const char* to_string(Strategy s);
Strategy strategy_from_string(const std::string& s);

/// The configuration file of a robot: a path, or a name looked up in $HPR_CONFIG_DIR, the source
/// tree next to the build and the installed share directory. Throws std::runtime_error with the
/// places searched when not found.
std::string find_config(const std::string& robot_or_path);
/// Whether stepping is on after `overrides` (the last balance.stepping.enabled=... wins) when the
/// configuration says `configured`.
bool overrides_enable_steps(const std::vector<std::string>& overrides, bool configured = false);

/// A file of the configuration folder ($HPR_CONFIG_DIR, the source tree next to the build, the
/// installed share directory), e.g. "templates/robot.yaml". Throws std::runtime_error naming the
/// places searched.
std::string find_in_config_dirs(const std::string& relative);

struct TrialSpec {
  std::string config;                 ///< configuration file (find_config)
  std::string support = "double";     ///< double | left | right
  Strategy strategy = Strategy::kCam; ///< cam: reference_gen + motion_opt + wbc; ankle: wbc holding the posture
  double direction_deg = 0.0;         ///< push direction: 0 = pushed forward from behind (+x), 90 = towards +y
  double impulse = 18.0;              ///< [N s] of the half-sine (0: from peak and duration; both 0: no push)
  double peak = 65.0;                 ///< peak force [N]
  double duration = 0.0;              ///< [s] (0: from impulse and peak, I = 2 F T / π)
  std::string link;                   ///< link pushed (default: the base link)
  std::optional<double> height;       ///< height of the push point above the ground at the start [m] (default: the link origin)
  std::optional<double> alpha, beta;  ///< reference_gen overrides for every axis
  double push_time = 0.0;             ///< [s] simulation time of the push (0: when the support is settled)
  double after = 5.0;                 ///< [s] simulated after the push ends
  std::vector<std::string> overrides; ///< more --set key=value for every process (later ones win)
  size_t overlay_keys = 0;            ///< of `overrides`, the first this many came from --overlay files, in their order:
                                      ///<   a later overlay wins over an earlier one, every --set over both
  std::string log_file;               ///< LCM log of the run (lcm_recorder), empty: none
  std::string work_dir;               ///< folder for the processes' output (default: a temporary one)
  std::string lcm_url;                ///< the processes' LCM URL (default: one no other run uses)
  double timeout = 600.0;             ///< [s] wall clock for the whole run
  bool stop_when_decided = false;     ///< end the run as soon as it cannot count as recovered (sweeps)
  bool in_process = false;            ///< through the in-process pipeline, not the processes (no log)
  bool truth_state = false;           ///< in process: the controllers see the simulator's truth, no estimator

  /// The push's duration from impulse and peak when not given (0 for a standing trial).
  [[nodiscard]] double push_duration() const;
  /// No push (impulse and duration 0): the robot stands `after` seconds from the time the push
  /// would have come, judged as after a push.
  [[nodiscard]] bool standing() const { return impulse == 0.0 && duration == 0.0; }
};

/// A strategy as the tools name it: "cam" or "ankle" as configured (stepping when the configuration
/// steps), "cam-standing" or "ankle-standing" with stepping off.
struct Variant {
  Strategy strategy = Strategy::kCam;
  bool standing = false;
};
/// Throws std::invalid_argument naming the accepted words.
Variant variant_from_string(const std::string& s);
/// Sets the spec's strategy and, standing, appends balance.stepping.enabled=false to its overrides.
void apply(const Variant& v, TrialSpec& spec);
/// The spec's name: its strategy, "-standing" when its overrides turn stepping off.
std::string variant_name(const TrialSpec& spec);

/// Whether the trial's robot may step: balance.stepping.enabled of its configuration with its
/// overrides, read as the processes read it (Config: a non-boolean throws ConfigError naming the
/// file, line, key and value).
bool steps_enabled(const TrialSpec& spec);

struct TrialResult {
  bool recovered = false, fallen = false, completed = false;
  /// The run says nothing about the robot: it ended (or timed out) before the evaluation window
  /// closed with nothing decided yet (no fall, tilt or slip). A sweep runs such a trial again.
  bool inconclusive = false;
  std::string failure;                 ///< why not recovered ("" when recovered)
  /// One word of kOutcomeLegend: recovered, stood, fell, tilted, slipped, unsettled, inconclusive.
  std::string outcome;
  Eigen::Vector3d impulse_W = Eigen::Vector3d::Zero();  ///< applied impulse [N s]
  double max_tilt_deg = 0.0;           ///< stance soles, from the push on
  double max_slip = 0.0;               ///< [m] stance soles, horizontal, from the push on
  Eigen::Vector3d peak_cam = Eigen::Vector3d::Zero();   ///< max |l_c| per axis (truth) [N m s]
  Eigen::Vector3d peak_cam_cmd = Eigen::Vector3d::Zero();  ///< max |commanded CAM| per axis
  double min_cop_margin = 0.0;         ///< [m] smallest distance of a stance sole's CoP to its edge
  double max_com_deviation = 0.0;      ///< [m] from the pre-push CoM
  std::optional<double> return_time;   ///< [s] after the push end until the posture stays within 1 cm and 1°
  double final_com_deviation = 0.0;    ///< [m] at the end of the run, from the pre-push posture
  double final_base_angle_deg = 0.0;   ///< base orientation
  double final_joint_deg = 0.0;        ///< largest free-joint deviation
  std::string final_joint;             ///< and its joint
  double push_start = 0.0, push_end = 0.0, sim_time = 0.0, wall_time = 0.0;
  /// Judged as a robot that may step (balance.stepping.enabled): at rest anywhere, not back in place.
  bool stepping = false;
  /// With stepping on (balance.stepping.enabled): touchdowns of a sole after at least 20 ms in the
  /// air, from the push on.
  int steps = 0;
  /// The controller's count of the steps it started (WHOLEBODY_COMMAND steps_taken) and, of them,
  /// a trailing foot closing up because it carried almost nothing (follow_steps): the steps the
  /// capture point asked for are the difference.
  int steps_started = 0, follow_steps = 0;
  std::string log_file;

  /// One JSON object (the fields above, units in the names).
  [[nodiscard]] std::string to_json(const TrialSpec& spec) const;
  /// The result to_json wrote, every field as it was (doubles round-trip exactly).
  static TrialResult from_json(const std::string& json);
};

/// Computes the result from the run's messages (fed in order). Independent of how they were produced.
class TrialEvaluator {
 public:
  TrialEvaluator(const model::RobotSpec& robot, const std::string& support, double push_start, double push_end);
  void on_truth(const humanoid::sim_truth_t& t);
  void on_sensors(const humanoid::robot_sensors_t& s);
  void on_wholebody(const humanoid::wholebody_command_t& w);
  /// A push that ends at `push_end` (a run continued from before the push with another push).
  void set_push_end(double push_end) { push_end_ = r_.push_end = push_end; }
  /// The result once the run is over (`sim_time` reached).
  [[nodiscard]] TrialResult result() const;
  [[nodiscard]] double last_time() const { return last_time_; }
  [[nodiscard]] bool fallen() const { return r_.fallen; }
  /// True once the run can no longer count as recovered (fallen, a sole tilted or slid too far
  /// before any step).
  [[nodiscard]] bool failed() const {
    return r_.fallen || (steps_allowed_ ? (judged_tilt_deg_ >= kTiltLimitDeg || judged_slip_ >= kSlipLimit)
                                        : (r_.max_tilt_deg >= kTiltLimitDeg || r_.max_slip >= kSlipLimit));
  }
  /// The robot may step (the third strategy). Until its first step (once the planner has started
  /// one, a sole that lands again after a flight of kMinFlightTime) it is judged as a robot that may not: its soles flat and sliding less
  /// than kSlipLimit, its posture back in the band; a run without steps is judged exactly so. From
  /// kLiftWindow before that step's lift-off on, a sole that lifts, tilts or moves is no failure, and
  /// the robot counts as recovered once its CoM is at rest (wherever the steps took it) with both
  /// soles flat on the ground and the base within 5° of its orientation before the push.
  void allow_steps(bool allowed) { steps_allowed_ = allowed; }

  static constexpr double kTiltLimitDeg = 2.0, kSlipLimit = 0.01, kPostureDistance = 0.01, kPostureAngleDeg = 1.0,
                          kSettleTime = 5.0, kRestSpeed = 0.01, kMinFlightTime = 0.02,
                          kStepBaseAngleDeg = 5.0, kLiftWindow = 0.05;

 private:
  const model::RobotSpec* robot_;
  std::vector<int> stance_;
  double push_start_, push_end_;
  TrialResult r_;
  double last_time_ = 0.0;
  // Pre-push posture, averaged over the 0.2 s before the push.
  Eigen::Vector3d com_ref_ = Eigen::Vector3d::Zero();
  Eigen::Vector4d quat_ref_ = Eigen::Vector4d::Zero();
  Eigen::VectorXd joints_ref_, joints_now_;
  int n_ref_ = 0, n_joint_ref_ = 0;
  bool have_joints_ = false;
  std::array<Eigen::Vector3d, 2> sole0_{};
  bool have_sole0_ = false;
  double last_out_of_posture_ = -1.0;  ///< last time (after the push start) the posture was outside the band
  bool steps_allowed_ = false;
  std::array<double, 2> lift_time_{-1.0, -1.0};  ///< when each sole left the ground (−1: on it)
  /// May steps: each sole's tilt [deg] and slip [m] at each tick, until judged (once older than
  /// kLiftWindow and before every lift-off under way) or dropped (at the first step).
  struct SoleSample {
    double time, tilt_deg, slip;
  };
  std::array<std::deque<SoleSample>, 2> pending_;
  double judged_tilt_deg_ = 0.0, judged_slip_ = 0.0;  ///< may step: the largest judged
  bool stepped_ = false;                               ///< may step: the first step has landed
  void judge_until(double horizon);
  std::array<double, 2> final_tilt_deg_{};
  bool evaluated_after_push_ = false;
};

/// What both ways of running a trial check while it runs: a progress line per simulated second,
/// and whether to stop (a fall; a run that can no longer count as recovered, when the spec stops on
/// that; the spec's wall-clock limit).
class TrialWatch {
 public:
  /// `start`: when the run began (its wall time and time limit count from there).
  TrialWatch(const TrialSpec& spec, const TrialEvaluator& eval, double push_start, double push_end,
             std::function<void(const std::string&)> progress, std::chrono::steady_clock::time_point start);
  /// After the evaluation has taken in the messages at hand: true when the run should stop.
  bool stop();
  [[nodiscard]] bool timed_out() const { return timed_out_; }
  /// The result, with the time limit named when it ended the run.
  [[nodiscard]] TrialResult result() const;

 private:
  const TrialSpec& spec_;
  const TrialEvaluator& eval_;
  double push_start_, push_end_, next_report_ = 1.0;
  std::function<void(const std::string&)> progress_;
  std::chrono::steady_clock::time_point start_, deadline_;
  bool timed_out_ = false;
};

/// A new folder name for a tool's output: "<prefix>-YYYYmmdd-HHMMSS" (local time).
std::string dated_name(const std::string& prefix);

/// What a spec asks of the stack, the same however the trial runs.
struct TrialPlan {
  std::string config;                   ///< the configuration file
  std::vector<std::string> overrides;   ///< every process's: the support, the spec's, α and β
  std::shared_ptr<const model::RobotSpec> robot;  ///< the robot as the configuration gives it
  sim::Push push;                       ///< the push, its numbers as the simulator receives them
  double sim_duration = 0.0;            ///< [s] simulated in all
  std::string sim_process = "sim_bullet";  ///< the simulation process of the configured engine (sim.engine)
};
TrialPlan plan_trial(const TrialSpec& spec);

/// Runs the experiment: starts the processes on a private LCM URL, logs when asked, evaluates,
/// stops everything (or, with `spec.in_process`, runs run_trial_in_process). `progress` receives a
/// line per simulated second (may be empty).
TrialResult run_trial(const TrialSpec& spec, const std::function<void(const std::string&)>& progress = {});

/// The same experiment through the in-process pipeline (hpr::graph: the simulator, estimator,
/// reference generator, motion optimiser and wbc libraries stepping in one thread, no LCM, no
/// log), evaluated from the same messages. Many times faster than run_trial, for sweeps and
/// tuning; run_trial stays the end-to-end check of the processes. `spec.log_file` must be empty.
TrialResult run_trial_in_process(const TrialSpec& spec, const std::function<void(const std::string&)>& progress = {});

/// In-process trials that share their run up to the push. The robot, support, strategy and
/// configuration of `base` are simulated once, to 0.1 s before the push; each run() continues a
/// copy of that process (fork) with its own push and returns what run_trial_in_process returns
/// for the same spec, bit for bit (nothing before the push depends on it; test
/// InProcess.ACheckpointBeforeThePushGivesTheFreshRunsResultBitForBit). The 2 s before a push are a
/// quarter of a recovered trial and most of a lost one: a sweep or a tune runs one per case.
/// `wall_time` counts from the fork. Not for a process that must not fork (the copy holds every
/// thread's memory but runs only the caller's).
struct InProcessRun;

class PrePushCheckpoint {
 public:
  explicit PrePushCheckpoint(const TrialSpec& base);
  ~PrePushCheckpoint();
  /// A checkpoint for a sweep's or a tune's case: none (nullptr) when `base` is not in process or
  /// its run cannot be built; its trials then run afresh (run_trial) and report what stops them.
  static std::unique_ptr<PrePushCheckpoint> for_case(const TrialSpec& base);
  PrePushCheckpoint(const PrePushCheckpoint&) = delete;
  PrePushCheckpoint& operator=(const PrePushCheckpoint&) = delete;
  /// `spec` may differ from `base` only in the push (impulse, peak, duration, direction, link,
  /// height) and the time after it; anything else throws std::invalid_argument.
  [[nodiscard]] TrialResult run(const TrialSpec& spec) const;

 private:
  std::unique_ptr<InProcessRun> run_;
  TrialSpec base_;
};

/// The options that shape the push and the robot, shared by push_trial and push_sweep: --robot,
/// --peak, --link, --height, --alpha, --beta, --push-time, --after, --set, --in-process. Reads the current one
/// into `spec` and returns true, or returns false when the current argument is none of them.
bool read_push_option(ArgReader& args, TrialSpec& spec);
/// Their lines for a usage text.
extern const char* const kPushOptionsUsage;

/// The leaves of a configuration overlay (a YAML file in the configuration's layout, such as
/// push_tune's tuned.yaml) as overrides "section.key=value", lists in flow style. Throws
/// std::runtime_error naming the file (and line) when it cannot be read or is not a mapping.
std::vector<std::string> overlay_overrides(const std::string& path);

}  // namespace hpr::experiments
