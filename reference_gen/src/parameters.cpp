#include <array>
#include <cmath>

#include "hpr/common/log.hpp"
#include "hpr/reference_gen/generator.hpp"

namespace hpr::reference_gen {

void add_parameters(ParameterSet& params, ReferenceGenerator& gen) {
  // α and β per axis ("x.alpha") and for all three ("alpha", NaN while the axes differ), the
  // posture tolerance.
  struct Gain {
    const char* name;
    double AxisParams::*field;
    double good_min, good_max;  // the paper's good range
  };
  static constexpr std::array<Gain, 2> kGains{{{"alpha", &AxisParams::alpha, 0.7, 0.9}, {"beta", &AxisParams::beta, 0.3, 0.5}}};
  static constexpr std::array<const char*, 3> kAxes{"x", "y", "z"};
  for (const Gain& g : kGains) {
    auto set_axis = [&gen, g](int i, double v) {
      auto p = gen.axis(i).params();
      p.*g.field = v;
      gen.set_axis_params(i, p);
      if (v < g.good_min || v > g.good_max) {
        log::warn("reference_gen: {} {} {} is outside the paper's good range [{}, {}]", kAxes[static_cast<size_t>(i)], g.name,
                  v, g.good_min, g.good_max);
      }
      return std::string();
    };
    params.add({g.name, "", 1e-3, 1.0,
                [&gen, g] {
                  const double x = gen.axis(0).params().*g.field;
                  for (int i = 1; i < 3; ++i) {
                    if (gen.axis(i).params().*g.field != x) return std::nan("");
                  }
                  return x;
                },
                [set_axis](double v) {
                  for (int i = 0; i < 3; ++i) set_axis(i, v);
                  return std::string();
                }});
    for (int i = 0; i < 3; ++i) {
      params.add({std::string(kAxes[static_cast<size_t>(i)]) + "." + g.name, "", 1e-3, 1.0,
                  [&gen, g, i] { return gen.axis(i).params().*g.field; }, [set_axis, i](double v) { return set_axis(i, v); }});
    }
  }
  params.add({"posture_tolerance", "rad", 1e-4, 1.0, [&gen] { return gen.config().posture_tolerance; },
              [&gen](double v) {
                gen.set_posture_tolerance(v);
                return std::string();
              }});
}

}  // namespace hpr::reference_gen
