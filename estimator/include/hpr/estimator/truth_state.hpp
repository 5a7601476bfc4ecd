#pragma once
/// \file
/// The simulator's true state in the estimator's place (README.md, "The processes"): for simulated
/// groups only (sim-truth-lockstep), a controller tested against the state a perfect estimator
/// would give. From ROBOT_SENSORS of tick k and the SIM_TRUTH of the same tick: the root link's
/// pose and twist, the CoM and the feet's contacts from the truth, the joints from the sensors. A
/// tick without its SIM_TRUTH gives no state (fault "truth"): the wbc, without its state, damps.
/// No LCM, no allocation per tick once sized.

#include <array>
#include <string_view>

#include "hpr/common/component.hpp"
#include "hpr/common/ports.hpp"
#include "hpr/common/robot_io.hpp"

namespace hpr::estimator {

/// The state a controller would get from a perfect estimator: the root link's pose and twist from
/// `truth`, the joints from `sensors` (of the same tick), with tick and time of the sensors; the
/// CoM and the feet as contacts_from_truth.
void state_from_truth(const SimTruth& truth, const SensorSample& sensors, EstimatedState& s);
/// The CoM position and velocity, the feet's contact flags and ground wrenches of `truth` into `s`.
void contacts_from_truth(const SimTruth& truth, EstimatedState& s);

class TruthState {
 public:
  static constexpr std::array<std::string_view, 1> kFaultKeys{"truth"};
  /// The truth_state process's ports.
  static constexpr Read kReads[] = {
      {channel::kRobotSensors, 0, true, false, "the joints and the tick"},
      {channel::kSimTruth, 0, false, false, "the simulator's base, CoM and contacts of the same tick"}};
  static constexpr std::string_view kWrites[] = {channel::kRobotState};
  static constexpr Ports kPorts{"truth_state", kReads, kWrites};
  struct Inputs {
    const SensorSample& sensors;    ///< ROBOT_SENSORS of tick k
    OptionalRef<SimTruth> truth;    ///< SIM_TRUTH of tick k; empty when it did not come
  };
  struct Outputs {
    EstimatedState state;  ///< ROBOT_STATE of tick k (when `valid`)
    bool valid = false;
    StepReport report{kFaultKeys};
  };

  void step(const Inputs& in, Outputs& out);
  void reset() {}
};

static_assert(Component<TruthState>);

}  // namespace hpr::estimator
