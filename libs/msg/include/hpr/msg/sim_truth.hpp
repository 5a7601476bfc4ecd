#pragma once
/// \file SIM_TRUTH: the simulator's ground truth, and the controller state a test builds from it.

#include <humanoid/sim_truth_t.hpp>
#include <array>
#include <string>

#include "hpr/common/robot_io.hpp"

namespace hpr::msg {

/// `feet` name the two soles (right, left).
void to_message(const SimTruth& t, const std::array<std::string, 2>& feet, humanoid::sim_truth_t& m);
/// Empty when `m` is valid (filled into `t`; SIM_TRUTH carries no joint state, so t.q, t.v and the
/// held joints are left as they were), else the reason.
std::string from_message(const humanoid::sim_truth_t& m, SimTruth& t);

/// The state a controller would get from a perfect estimator: the root link's pose and twist from
/// `truth`, the joints from `sensors` (of the same tick), with tick and time of the sensors; the
/// CoM and the feet as contacts_from_truth.
void state_from_truth(const SimTruth& truth, const SensorSample& sensors, EstimatedState& s);
/// The CoM position and velocity, the feet's contact flags and ground wrenches of `truth` into `s`.
void contacts_from_truth(const SimTruth& truth, EstimatedState& s);

}  // namespace hpr::msg
