#pragma once
/// \file
/// The motion optimiser's tick as the stack runs it, whatever carries the data (a process behind
/// LCM, or the in-process pipeline): the posture reference (the paper's high-level planner, holding
/// a posture) started from the first usable estimate, and the optimisation (13) towards the CAM
/// reference of the same tick. No LCM, no allocation per tick once the adjusted set has been seen.

#include "hpr/balance/ports.hpp"
#include "hpr/balance/task_reference.hpp"
#include "hpr/common/robot_io.hpp"
#include "hpr/motion_opt/optimizer.hpp"

namespace hpr::motion_opt {

class MotionOptComponent {
 public:
  struct Inputs {
    const EstimatedState* state = nullptr;       ///< ROBOT_STATE of tick k (required)
    const balance::CamReference* cam = nullptr;  ///< CAM_REFERENCE of tick k; nullptr when missing or stale
  };
  using Outputs = balance::WholebodyCommand;  ///< WHOLEBODY_COMMAND of tick k

  MotionOptComponent(const model::RobotSpec& robot, MotionOptConfig config, balance::PostureReferenceConfig posture);

  /// One tick. False (and `out` untouched) while no usable estimate has started the posture
  /// reference: nothing is published then, and the wbc damps.
  bool step(const Inputs& in, Outputs& out);

  /// A support mode requested by the operator, from time t on.
  void request_support(balance::Support s, double t) { reference_.request_support(s, t); }
  /// Back to the state after construction (keeping the parameters): for a clock that restarted.
  void reset();

  [[nodiscard]] MotionOptimizer& optimizer() { return optimizer_; }
  [[nodiscard]] const MotionOptimizer& optimizer() const { return optimizer_; }
  [[nodiscard]] const balance::PostureReference& posture_reference() const { return reference_; }

 private:
  MotionOptimizer optimizer_;
  balance::PostureReference reference_;
  double dt_;
};

}  // namespace hpr::motion_opt
