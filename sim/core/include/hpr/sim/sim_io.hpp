#pragma once
/// \file PUSH: the push a message asks the simulation for (shared by sim_bullet and the drive
/// emulator). SIM_TRUTH is converted in hpr/msg/sim_truth.hpp.
#include <humanoid/push_t.hpp>

#include <array>
#include <optional>
#include <string>

#include "hpr/sim/simulator.hpp"

namespace hpr::sim {

/// The push a PUSH message asks for, or nullopt (with `why`, naming the field and value) when its
/// link is unknown, or a value is non-finite or outside Push's limits, or its profile is unknown.
std::optional<Push> from_message(const humanoid::push_t& p, const model::Model& m, std::string* why);

}  // namespace hpr::sim
