#include "hpr/motion_opt/component.hpp"

#include <stdexcept>

#include "hpr/common/robot_io.hpp"

namespace hpr::motion_opt {

MotionOptComponent::MotionOptComponent(const model::RobotSpec& robot, MotionOptConfig config,
                                       balance::PostureReferenceConfig posture)
    : optimizer_(robot, std::move(config)), reference_(robot, posture), dt_(optimizer_.config().dt) {}

void MotionOptComponent::reset() {
  reference_.reset();
  optimizer_.reset();
}

bool MotionOptComponent::step(const Inputs& in, Outputs& out) {
  if (in.state == nullptr) throw std::invalid_argument("MotionOptComponent::step: no state");
  const EstimatedState& s = *in.state;
  if (!reference_.started()) {
    if (!s.usable()) return false;
    reference_.start(s.q, s.time);
  }
  const balance::TaskReference& ref = reference_.update(s.time, s.usable() ? &s : nullptr);
  const bool fresh = in.cam != nullptr;
  const Eigen::Vector3d l_ref = fresh ? in.cam->l_ref_W : Eigen::Vector3d::Zero();
  const bool generating = fresh && in.cam->generating();
  out = optimizer_.step(s.q, s.v, ref, l_ref, fresh, dt_, generating);
  out.tick = s.tick;
  return true;
}

}  // namespace hpr::motion_opt
