#pragma once
/// \file LCM messages of the simulation: SIM_TRUTH from TruthData, Push from PUSH (shared by
/// sim_bullet and the drive emulator).
#include <humanoid/push_t.hpp>
#include <humanoid/sim_truth_t.hpp>

#include <array>
#include <optional>
#include <string>

#include "hpr/sim/simulator.hpp"

namespace hpr::sim {

void to_message(const TruthData& t, const std::array<std::string, 2>& feet, humanoid::sim_truth_t& m);

/// The push a PUSH message asks for, or nullopt (with `why`, naming the field and value) when its
/// link is unknown, or a value is non-finite or outside Push's limits, or its profile is unknown.
std::optional<Push> from_message(const humanoid::push_t& p, const model::Model& m, std::string* why);

}  // namespace hpr::sim
