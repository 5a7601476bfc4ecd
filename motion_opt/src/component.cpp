#include "hpr/motion_opt/component.hpp"


#include "hpr/common/robot_io.hpp"

namespace hpr::motion_opt {

MotionOptComponent::MotionOptComponent(const model::RobotSpec& robot, MotionOptConfig config)
    : optimizer_(robot, std::move(config)), dt_(optimizer_.config().dt) {}

void MotionOptComponent::reset() {
  optimizer_.reset();
}

void MotionOptComponent::step(const Inputs& in, Outputs& out) {
  const EstimatedState& s = in.state;
  out.report.begin();
  out.valid = false;
  if (!in.plan) {
    out.report.outcome = StepOutcome::kNotReady;
    return;
  }
  const balance::TaskReference& ref = *in.plan;
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
