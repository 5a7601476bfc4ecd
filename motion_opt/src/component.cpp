#include "hpr/motion_opt/component.hpp"


#include "hpr/common/robot_io.hpp"

namespace hpr::motion_opt {

MotionOptComponent::MotionOptComponent(const model::RobotSpec& robot, MotionOptConfig config,
                                       balance::PostureReferenceConfig posture)
    : optimizer_(robot, std::move(config)), reference_(robot, posture), dt_(optimizer_.config().dt) {}

void MotionOptComponent::reset() {
  reference_.reset();
  optimizer_.reset();
}

void MotionOptComponent::step(const Inputs& in, Outputs& out) {
  const EstimatedState& s = in.state;
  out.report.begin();
  out.valid = false;
  if (!reference_.started()) {
    if (!s.usable()) {
      out.report.outcome = StepOutcome::kNotReady;
      return;
    }
    reference_.start(s.q, s.time);
  }
  const balance::TaskReference& ref = reference_.update(s.time, s.usable() ? &s : nullptr);
  const bool fresh = in.cam.has_value();
  const Eigen::Vector3d l_ref = fresh ? in.cam->l_ref_W : Eigen::Vector3d::Zero();
  const bool generating = fresh && in.cam->generating();
  out.wholebody = optimizer_.step(s.q, s.v, ref, l_ref, fresh, dt_, generating);
  out.wholebody.tick = s.tick;
  out.valid = true;
  out.report.set("reference", !fresh, "CAM_REFERENCE stale: posture task only");
  if (out.wholebody.qp_failed) {
    out.report.raise("motion_qp", "motion QP failed ({}): posture task within the limits",
                     qp::to_string(static_cast<qp::Status>(out.wholebody.qp_status)));
  } else {
    out.report.clear("motion_qp");
  }
}

}  // namespace hpr::motion_opt
