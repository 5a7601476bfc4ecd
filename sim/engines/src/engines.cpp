#include "hpr/sim/engines.hpp"

#include "hpr/sim/bullet_engine.hpp"
#include "hpr/sim/mujoco_engine.hpp"

namespace hpr::sim {

std::unique_ptr<Engine> make_engine(const model::RobotSpec& robot, const model::Model& m, const SimConfig& config,
                                    const std::array<int, 2>& foot_body) {
  const Shapes shapes = collision_shapes(robot, m, config, foot_body);
  switch (config.engine) {
    case EngineKind::kMujoco:
      return make_mujoco_engine(m, config, shapes, foot_body);
    case EngineKind::kBullet:
      break;
  }
  return make_bullet_engine(m, config, shapes, foot_body);
}

}  // namespace hpr::sim
