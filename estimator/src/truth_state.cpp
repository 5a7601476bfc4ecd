#include "hpr/estimator/truth_state.hpp"

#include <Eigen/Geometry>

namespace hpr::estimator {

void state_from_truth(const SimTruth& truth, const SensorSample& sensors, EstimatedState& s) {
  const auto n = sensors.q.size();
  s.tick = sensors.tick;
  s.time = sensors.time;
  s.q.resize(7 + n);
  s.v.resize(6 + n);
  const Eigen::Quaterniond qb(truth.quat_WB(0), truth.quat_WB(1), truth.quat_WB(2), truth.quat_WB(3));
  const Eigen::Matrix3d Rt = qb.toRotationMatrix().transpose();
  s.q.head<3>() = truth.p_WB;
  s.q.segment<4>(3) = qb.coeffs();  // (x, y, z, w)
  s.q.tail(n) = sensors.q;
  s.v.head<3>() = Rt * truth.v_WB;
  s.v.segment<3>(3) = Rt * truth.omega_WB;
  s.v.tail(n) = sensors.qd;
  contacts_from_truth(truth, s);
}

void contacts_from_truth(const SimTruth& truth, EstimatedState& s) {
  s.p_com = truth.p_WCom;
  s.v_com = truth.v_WCom;
  for (size_t k = 0; k < 2; ++k) {
    s.contact[k] = truth.foot_contact[k];
    s.foot_wrench_W[k] = truth.contact_wrench_W[k];
    s.foot_force_z[k] = truth.contact_wrench_W[k](2);
  }
}

void TruthState::step(const Inputs& in, Outputs& out) {
  out.report.begin();
  out.valid = in.truth.has_value();
  if (!out.valid) {
    out.report.raise("truth", "no SIM_TRUTH for this tick: no state published");
    out.report.outcome = StepOutcome::kNotReady;
    return;
  }
  out.report.clear("truth");
  state_from_truth(*in.truth, in.sensors, out.state);
}

}  // namespace hpr::estimator
