#include <cmath>

#include "hpr/motion_opt/optimizer.hpp"

namespace hpr::motion_opt {

void add_parameters(ParameterSet& params, MotionOptConfig& c) {
  // The weights and gains of (14), (16), (17); "weights.cam" sets the three axes (NaN while they differ).
  params.add({"weights.cam", "", 0.0, 1e6,
              [&c] { return c.Q_l.minCoeff() == c.Q_l.maxCoeff() ? c.Q_l(0) : std::nan(""); },
              [&c](double v) {
                c.Q_l.setConstant(v);
                return std::string();
              }});
  params.add_xyz("weights.cam", c.Q_l.data(), 0.0, 1e6, "");
  params.add("weights.posture", c.Q_p, 1e-9, 1e6, "");
  params.add("weights.cam_idle_fraction", c.cam_idle_fraction, 0.0, 1.0, "");
  params.add("weights.cam_release_time", c.cam_release_time, 0.0, 10.0, "s");
  params.add("gains.posture", c.K_p, 0.0, 1e3, "1/s");
  params.add("gains.limits", c.K_a, 0.0, 1e4, "1/s");
}

}  // namespace hpr::motion_opt
