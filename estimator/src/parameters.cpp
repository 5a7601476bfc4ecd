#include <fmt/format.h>

#include "hpr/estimator/estimator.hpp"

namespace hpr::estimator {

void add_parameters(ParameterSet& params, EstimatorConfig& c) {
  // The contact hysteresis (on above off, as on load) and the CoP edge margin.
  params.add({"contact_on", "N", 0.0, 1e4, [&c] { return c.contact_on; },
              [&c](double v) {
                if (v < c.contact_off) return fmt::format("below contact_off ({} N)", c.contact_off);
                c.contact_on = v;
                return std::string();
              }});
  params.add({"contact_off", "N", 0.0, 1e4, [&c] { return c.contact_off; },
              [&c](double v) {
                if (v > c.contact_on) return fmt::format("above contact_on ({} N)", c.contact_on);
                c.contact_off = v;
                return std::string();
              }});
  params.add("cop_edge_margin", c.cop_edge_margin, 0.0, 0.5, "m");
  params.add("anchor_max_rate", c.anchor_max_rate, 0.0, 100.0, "rad/s");
  params.add("anchor_velocity_gate", c.anchor_velocity_gate, 0.0, 100.0, "m/s");
}

}  // namespace hpr::estimator
