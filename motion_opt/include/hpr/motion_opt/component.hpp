#pragma once
/// \file
/// The motion optimiser's tick as the stack runs it, whatever carries the data (a process behind
/// LCM, or the in-process pipeline): the optimisation (13) around the balance planner's plan of the
/// tick (the paper's high-level planner, holding a posture) towards the CAM reference of the same
/// tick. No LCM, no allocation per tick once the adjusted set has been seen.

#include <array>
#include <string_view>

#include "hpr/balance/ports.hpp"
#include "hpr/balance/task_reference.hpp"
#include "hpr/common/ports.hpp"
#include "hpr/common/component.hpp"
#include "hpr/common/robot_io.hpp"
#include "hpr/motion_opt/optimizer.hpp"

namespace hpr::motion_opt {

class MotionOptComponent {
 public:
  /// The component's tick (hpr/common/component.hpp). Faults: "reference" (no CAM_REFERENCE for
  /// the tick: the posture task only) and "motion_qp" (the QP failed: the posture task within the
  /// limits); not ready, with nothing to publish, while there is no plan (the wbc damps meanwhile).
  static constexpr std::array<std::string_view, 2> kFaultKeys{"reference", "motion_qp"};
  /// The motion_opt process's ports.
  static constexpr Read kReads[] = {
      {channel::kRobotState, 0, true, false, "the state it optimises from"},
      {channel::kBalancePlan, 0, false, false, "the task-space reference it optimises around"},
      {channel::kCamReference, 0, false, true, "l_c^ref (without it: the posture task only)"}};
  static constexpr std::string_view kWrites[] = {channel::kWholebodyCommand};
  static constexpr Ports kPorts{"motion_opt", kReads, kWrites};
  struct Inputs {
    const EstimatedState& state;               ///< ROBOT_STATE of tick k
    OptionalRef<balance::TaskReference> plan;  ///< BALANCE_PLAN of tick k; empty: none yet, or stale
    OptionalRef<balance::CamReference> cam;    ///< CAM_REFERENCE of tick k; empty when missing or stale
  };
  struct Outputs {
    balance::WholebodyCommand wholebody;  ///< WHOLEBODY_COMMAND of tick k (when `valid`)
    bool valid = false;                   ///< this tick made one (else the last one is kept)
    StepReport report{kFaultKeys};
  };

  MotionOptComponent(const model::RobotSpec& robot, MotionOptConfig config);

  void step(const Inputs& in, Outputs& out);

  /// Back to the state after construction (keeping the parameters): for a clock that restarted.
  void reset();

  [[nodiscard]] MotionOptimizer& optimizer() { return optimizer_; }
  [[nodiscard]] const MotionOptimizer& optimizer() const { return optimizer_; }

 private:
  MotionOptimizer optimizer_;
  double dt_;
};

}  // namespace hpr::motion_opt
