#pragma once
/// \file SIM_TRUTH: the simulator's ground truth (the state a perfect estimator would give from it:
/// hpr/estimator/truth_state.hpp).

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

}  // namespace hpr::msg
