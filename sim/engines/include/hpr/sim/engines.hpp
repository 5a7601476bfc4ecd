#pragma once
/// \file
/// The one factory of the simulator's physics engines: Bullet or MuJoCo, as `sim.engine` says.
#include <array>
#include <memory>

#include "hpr/sim/engine.hpp"
#include "hpr/sim/simulator.hpp"

namespace hpr::sim {

/// The engine `config.engine` names for the simulated model `m` of `robot` (an EngineFactory), its
/// bodies' collision shapes from the robot description (collision_shapes()).
std::unique_ptr<Engine> make_engine(const model::RobotSpec& robot, const model::Model& m, const SimConfig& config,
                                    const std::array<int, 2>& foot_body);

}  // namespace hpr::sim
