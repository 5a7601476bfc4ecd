// reference_gen: the three-phase CAM reference generator process.
//
// Steps on every ROBOT_STATE (tick k) with the BALANCE_STATUS of tick k-1 (the paper's one-period lag
// between torque computation and reference update) and the posture error of the last
// WHOLEBODY_COMMAND; publishes CAM_REFERENCE for tick k.
#include <humanoid/balance_status_t.hpp>
#include <humanoid/cam_reference_t.hpp>
#include <humanoid/robot_state_t.hpp>
#include <humanoid/wholebody_command_t.hpp>

#include "hpr/msg/balance.hpp"
#include "hpr/msg/channels.hpp"
#include "hpr/msg/state.hpp"
#include "hpr/node/command_line.hpp"
#include "hpr/node/runtime.hpp"
#include "hpr/reference_gen/generator.hpp"

int main(int argc, char** argv) {
  using namespace hpr;
  return node::run_main(
      argc, argv, "reference_gen", "three-phase CAM reference generator",
      [](const node::CommandLine& cl, const Config& cfg) {
        const Config section = cfg.section("reference_gen");
        reference_gen::ReferenceGenerator gen(reference_gen::GeneratorConfig::load(section));
        const bool wait = section.boolean_or("wait_for_balance", true);
        const double timeout = section.real_or("balance_timeout", 0.5, 0.0, 60.0);
        node::Runtime rt(reference_gen::ReferenceGenerator::kPorts, cl.name, node::lcm_url(cl, cfg), node::runtime_options(cfg, gen.config().dt));
        EstimatedState state;  // only tick and time are read: the header of ROBOT_STATE
        balance::BalanceStatus balance_status;
        balance::WholebodyCommand wholebody;
        auto& state_in = rt.subscribe(msg::channels::kRobotState, [&](const humanoid::robot_state_t& m) {
          if (m.utime < 0) return std::string("negative time");
          state.tick = m.tick;
          state.time = static_cast<double>(m.utime) * 1e-6;
          return std::string();
        });
        auto& balance_in = rt.subscribe(msg::channels::kBalanceStatus,
            [&](const humanoid::balance_status_t& m) { return msg::from_message(m, balance_status); });
        auto& wholebody_in = rt.subscribe(msg::channels::kWholebodyCommand,
            [&](const humanoid::wholebody_command_t& m) { return msg::from_message(m, {}, wholebody); });
        reference_gen::add_parameters(rt.parameters(), gen);
        auto out = rt.advertise(msg::channels::kCamReference);
        reference_gen::ReferenceGenerator::Outputs reference;
        humanoid::cam_reference_t msg{};
        std::vector<node::Sync> sync;
        // BALANCE_STATUS of the previous tick, optional: without it, the reference ramps to zero.
        const Read& b = reference_gen::ReferenceGenerator::kPorts.at(channel::kBalanceStatus);
        if (wait) sync.push_back({&balance_in, b.tick_offset, {}, b.optional});
        rt.on_restart(state_in, [&] { gen.reset(); });
        rt.on_tick(state_in, sync, timeout, [&](const node::TickInfo& info) {
          gen.step({.tick = info.tick,
                    .time = state.time,
                    .balance = OptionalRef<balance::BalanceStatus>::when(balance_in.has_value(), balance_status),
                    .posture_error = wholebody_in.has_value() ? wholebody.posture_error : 0.0},
                   reference);
          rt.report(reference.report);
          msg::to_message(reference.reference, msg);
          out.publish(msg);
        });
        return rt.run();
      });
}
