// reference_gen: the three-phase CAM reference generator process.
//
// Steps on every ROBOT_STATE (tick k) with the BALANCE_STATUS of tick k-1 (the paper's one-period lag
// between torque computation and reference update) and the posture error of the last
// WHOLEBODY_COMMAND; publishes CAM_REFERENCE for tick k.
#include <humanoid/balance_status_t.hpp>
#include <humanoid/cam_reference_t.hpp>
#include <humanoid/robot_state_t.hpp>
#include <humanoid/wholebody_command_t.hpp>

#include <array>
#include <cmath>

#include "hpr/node/command_line.hpp"
#include "hpr/node/runtime.hpp"
#include "hpr/reference_gen/generator.hpp"

namespace {

using namespace hpr;

std::string check_balance(const humanoid::balance_status_t& m) {
  for (int k = 0; k < 3; ++k) {
    if (!std::isfinite(m.tau_ankle_V[k]) || !std::isfinite(m.tau_min_V[k]) || !std::isfinite(m.tau_max_V[k])) {
      return "non-finite torque or limit";
    }
    if (m.tau_min_V[k] > m.tau_max_V[k]) return "torque limits inverted";
  }
  return std::isfinite(m.yaw_WV) ? "" : "non-finite yaw";
}

/// α and β per axis ("x.alpha") and for all three ("alpha", shown as NaN while the axes differ),
/// the posture tolerance; ranges as the configuration accepts them.
void add_parameters(node::ParameterSet& params, reference_gen::ReferenceGenerator& gen) {
  struct Gain {
    const char* name;
    double reference_gen::AxisParams::*field;
    double good_min, good_max;  // the paper's good range
  };
  static constexpr std::array<Gain, 2> kGains{{{"alpha", &reference_gen::AxisParams::alpha, 0.7, 0.9},
                                               {"beta", &reference_gen::AxisParams::beta, 0.3, 0.5}}};
  static constexpr std::array<const char*, 3> kAxes{"x", "y", "z"};
  for (const Gain& g : kGains) {
    auto set_axis = [&gen, g](int i, double v) {
      auto p = gen.axis(i).params();
      p.*g.field = v;
      gen.set_axis_params(i, p);
      if (v < g.good_min || v > g.good_max) {
        log::warn("reference_gen: {} {} {} is outside the paper's good range [{}, {}]", kAxes[static_cast<size_t>(i)], g.name, v,
                  g.good_min, g.good_max);
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

}  // namespace

int main(int argc, char** argv) {
  return node::run_main(
      argc, argv, "reference_gen", "three-phase CAM reference generator",
      [](const node::CommandLine& cl, const Config& cfg) {
        const Config section = cfg.section("reference_gen");
        reference_gen::ReferenceGenerator gen(reference_gen::GeneratorConfig::load(section));
        const bool wait = section.boolean_or("wait_for_balance", true);
        const double timeout = section.real_or("balance_timeout", 0.5, 0.0, 60.0);
        const double dt = section.real_or("dt", 1e-3, 1e-5, 0.1);
        node::Runtime rt(cl.name, node::lcm_url(cl, cfg), node::runtime_options(cfg, dt));
        auto& state = rt.subscribe<humanoid::robot_state_t>("ROBOT_STATE", [](const humanoid::robot_state_t& m) {
          return m.utime >= 0 ? std::string() : std::string("negative time");
        });
        auto& balance = rt.subscribe<humanoid::balance_status_t>("BALANCE_STATUS", check_balance);
        auto& wholebody = rt.subscribe<humanoid::wholebody_command_t>(
            "WHOLEBODY_COMMAND", [](const humanoid::wholebody_command_t& m) {
              return std::isfinite(m.posture_error) ? std::string() : std::string("non-finite posture error");
            });
        add_parameters(rt.parameters(), gen);
        auto out = rt.advertise<humanoid::cam_reference_t>("CAM_REFERENCE");
        humanoid::cam_reference_t msg{};
        std::vector<node::Sync> sync;
        if (wait) sync.push_back({&balance, -1, {}, true});  // optional: without it, the reference ramps to zero
        rt.on_restart(state, [&] { gen.reset(); });
        rt.on_tick(state, sync, timeout, [&](const node::TickInfo& info) {
          const auto& s = state.latest();
          const double t = static_cast<double>(s.utime) * 1e-6;
          reference_gen::BalanceInput b;
          const bool valid = balance.has_value();
          if (valid) {
            const auto& m = balance.latest();
            b.time = static_cast<double>(m.utime) * 1e-6;
            b.tau_ankle_V = Eigen::Vector3d(m.tau_ankle_V[0], m.tau_ankle_V[1], m.tau_ankle_V[2]);
            b.tau_min_V = Eigen::Vector3d(m.tau_min_V[0], m.tau_min_V[1], m.tau_min_V[2]);
            b.tau_max_V = Eigen::Vector3d(m.tau_max_V[0], m.tau_max_V[1], m.tau_max_V[2]);
            b.yaw_WV = m.yaw_WV;
          }
          const double posture_error = wholebody.has_value() ? wholebody.latest().posture_error : 0.0;
          const auto& o = gen.step(t, dt, b, valid, posture_error);
          if (o.stale && info.tick > 1) {
            rt.set_fault("balance", o.ramping ? "BALANCE_STATUS stale: CAM reference ramped to zero"
                                              : "BALANCE_STATUS stale: CAM reference held");
          } else {
            rt.clear_fault("balance");
          }
          msg.tick = info.tick;
          msg.utime = s.utime;
          msg.yaw_WV = o.yaw_WV;
          for (int k = 0; k < 3; ++k) {
            msg.l_ref_W[k] = o.l_ref_W(k);
            msg.ldot_ref_W[k] = o.ldot_ref_W(k);
            msg.l_ref_V[k] = o.l_ref_V(k);
            msg.ldot_ref_V[k] = o.ldot_ref_V(k);
            msg.phase[k] = static_cast<int8_t>(o.phase[static_cast<size_t>(k)]);
            msg.tau_thres_V[k] = o.tau_thres_V(k);
            msg.ldot_max_V[k] = o.ldot_max_V(k);
            for (int p = 0; p < 3; ++p) msg.t_phase_start[k][p] = o.t_phase_start[static_cast<size_t>(k)][static_cast<size_t>(p)];
          }
          msg.status = (o.stale ? humanoid::cam_reference_t::STATUS_BALANCE_STALE : 0) |
                       (o.ramping ? humanoid::cam_reference_t::STATUS_RAMPING_DOWN : 0);
          msg.balance_tick = balance.tick();
          out.publish(msg);
        });
        return rt.run();
      });
}
