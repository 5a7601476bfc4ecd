#pragma once
/// \file
/// The MuJoCo engine under the simulator: the simulated model written as MJCF from the same robot
/// configuration and collision shapes as Bullet's.
#include <array>
#include <memory>

#include "hpr/sim/engine.hpp"

namespace hpr::sim {

/// The MuJoCo engine of `m` with the collision `shapes` of each body (collision_shapes()).
std::unique_ptr<Engine> make_mujoco_engine(const model::Model& m, const SimConfig& config, const Shapes& shapes,
                                           const std::array<int, 2>& foot_body);

}  // namespace hpr::sim
