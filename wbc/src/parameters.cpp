#include "hpr/wbc/controller.hpp"

namespace hpr::wbc {

void add_parameters(ParameterSet& params, WholeBodyController& wbc) {
  // The CoM and base impedance (6), the extra joint damping and μ.
  WbcConfig& c = wbc.tunable_config();
  params.add_xyz("com.stiffness", c.K_com.data(), 0.0, 1e6, "N/m");
  params.add_xyz("com.damping", c.D_com.data(), 0.0, 1e5, "N s/m");
  params.add_xyz("base.stiffness", c.K_base.data(), 0.0, 1e5, "N m/rad");
  params.add_xyz("base.damping", c.D_base.data(), 0.0, 1e4, "N m s/rad");
  params.add("joint_damping", c.joint_damping, 0.0, 100.0, "N m s/rad");
  params.add({"contact.friction", "", 0.05, 2.0, [&wbc] { return wbc.config().contact.friction; },
              [&wbc](double mu) {
                wbc.set_contact_friction(mu);
                return std::string();
              }});
}

}  // namespace hpr::wbc
