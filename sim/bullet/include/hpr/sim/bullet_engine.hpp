#pragma once
/// \file
/// The Bullet engine under the simulator: a btMultiBody of the simulated model (hpr/sim/multibody.hpp).
#include <array>
#include <memory>

#include "hpr/sim/engine.hpp"

namespace hpr::sim {

/// The Bullet engine of `m` with the collision `shapes` of each body (collision_shapes()).
std::unique_ptr<Engine> make_bullet_engine(const model::Model& m, const SimConfig& config, const Shapes& shapes,
                                           const std::array<int, 2>& foot_body);

}  // namespace hpr::sim
