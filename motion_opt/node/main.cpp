// motion_opt: the CAM-based whole-body motion optimisation process.
//
// Steps on every ROBOT_STATE (tick k) with the CAM_REFERENCE of the same tick, and publishes the
// WHOLEBODY_COMMAND of tick k: the reference posture with the optimised adjusted DoF.
#include <humanoid/cam_reference_t.hpp>
#include <humanoid/operator_t.hpp>
#include <humanoid/robot_state_t.hpp>
#include <humanoid/wholebody_command_t.hpp>

#include <cmath>

#include "hpr/motion_opt/optimizer.hpp"
#include "hpr/msg/commands.hpp"
#include "hpr/msg/state.hpp"
#include "hpr/node/command_line.hpp"
#include "hpr/node/runtime.hpp"

namespace {

/// The weights and gains of (14), (16), (17); ranges as the configuration accepts them.
void add_parameters(hpr::node::ParameterSet& params, hpr::motion_opt::MotionOptConfig& c) {
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

}  // namespace

int main(int argc, char** argv) {
  using namespace hpr;
  return node::run_main(
      argc, argv, "motion_opt", "CAM-based whole-body motion optimisation",
      [](const node::CommandLine& cl, const Config& cfg) {
        const auto robot = model::RobotSpec::load(cfg.section("robot"));
        const Config section = cfg.section("motion_opt");
        motion_opt::MotionOptimizer opt(robot, motion_opt::MotionOptConfig::load(section, robot));
        balance::PostureReference reference(robot, balance::PostureReferenceConfig::load(cfg.section("balance")));
        const bool wait = section.boolean_or("wait_for_reference", true);
        const double timeout = section.real_or("reference_timeout", 0.5, 0.0, 60.0);
        const long stale_ticks = section.integer_or("reference_stale_ticks", 20, 1, 100000);
        const double dt = section.real_or("dt", 1e-3, 1e-5, 0.1);
        node::Runtime rt(cl.name, node::lcm_url(cl, cfg), node::runtime_options(cfg, dt));
        msg::RobotNames names;
        names.joints = robot.model.joint_name;
        std::vector<std::string> free_names;
        for (int j : robot.free_joints) free_names.push_back(robot.model.joint_name[static_cast<size_t>(j)]);
        EstimatedState state;
        auto& state_in = rt.subscribe<humanoid::robot_state_t>(
            "ROBOT_STATE", [&](const humanoid::robot_state_t& m) { return msg::from_message(m, names, state); });
        auto& cam_in = rt.subscribe<humanoid::cam_reference_t>("CAM_REFERENCE", [](const humanoid::cam_reference_t& m) {
          for (int k = 0; k < 3; ++k) {
            if (!std::isfinite(m.l_ref_W[k]) || !std::isfinite(m.ldot_ref_W[k])) return std::string("non-finite CAM reference");
          }
          return std::string();
        });
        rt.subscribe<humanoid::operator_t>("OPERATOR", msg::check_operator, [&](const humanoid::operator_t& m) {
          if (m.command == humanoid::operator_t::COMMAND_SET_SUPPORT && m.support >= 0 && m.support <= 2) {
            reference.request_support(static_cast<balance::Support>(m.support), state.time);
          }
        });
        add_parameters(rt.parameters(), opt.tunable_config());
        auto out = rt.advertise<humanoid::wholebody_command_t>("WHOLEBODY_COMMAND");
        humanoid::wholebody_command_t msg{};
        std::vector<node::Sync> sync;
        if (wait) sync.push_back({&cam_in, 0, {}, true});  // optional: without it, the posture task only
        rt.on_restart(state_in, [&] {
          reference.reset();
          opt.reset();
        });
        rt.on_tick(state_in, sync, timeout, [&](const node::TickInfo& info) {
          if (!reference.started()) {
            // The posture reference starts from the first usable estimate; nothing goes out before it
            // (the wbc damps meanwhile).
            if ((state.status & msg::kStateUnusable) != 0) return;
            reference.start(state.q, state.time);
          }
          const auto& ref = reference.update(state.time);
          const bool fresh = cam_in.has_value() && cam_in.tick() >= info.tick - stale_ticks;
          Eigen::Vector3d l_ref = Eigen::Vector3d::Zero();
          bool generating = false;
          if (fresh) {
            const auto& c = cam_in.latest();
            l_ref = Eigen::Vector3d(c.l_ref_W[0], c.l_ref_W[1], c.l_ref_W[2]);
            for (int k = 0; k < 3; ++k) {
              generating = generating || c.phase[k] == humanoid::cam_reference_t::PHASE_GENERATE ||
                           c.phase[k] == humanoid::cam_reference_t::PHASE_REDUCE;
            }
          }
          const auto& o = opt.step(state.q, state.v, ref, l_ref, fresh, dt, generating);
          if (!fresh) {
            rt.set_fault("reference", "CAM_REFERENCE stale: posture task only");
          } else {
            rt.clear_fault("reference");
          }
          if (o.qp_failed) {
            rt.set_fault("qp", std::string("QP failed (") + std::string(qp::to_string(static_cast<qp::Status>(o.qp_status))) +
                                   "): posture task within the limits");
          } else {
            rt.clear_fault("qp");
          }
          msg::to_message(o.command, free_names, names, msg);
          msg.tick = info.tick;
          for (int k = 0; k < 3; ++k) {
            msg.l_cmd_W[k] = o.l_cmd(k);
            msg.ldot_cmd_W[k] = o.ldot_cmd(k);
            msg.l_ref_W[k] = o.l_ref(k);
          }
          const int na = static_cast<int>(o.adjusted.size());
          msg.num_adjusted = na;
          msg.adjusted_name.resize(static_cast<size_t>(na));
          for (int a = 0; a < na; ++a) {
            msg.adjusted_name[static_cast<size_t>(a)] = opt.coordinates()[static_cast<size_t>(o.adjusted[static_cast<size_t>(a)])].name;
          }
          auto put = [na](const Eigen::VectorXd& v, std::vector<double>& dst) { dst.assign(v.data(), v.data() + na); };
          put(o.xa_opt, msg.xa_opt);
          put(o.xad_opt, msg.xad_opt);
          put(o.xa_min, msg.xa_min);
          put(o.xa_max, msg.xa_max);
          put(o.xad_min, msg.xad_min);
          put(o.xad_max, msg.xad_max);
          msg.num_segments = static_cast<int32_t>(o.segment_names.size());
          msg.segment_name = o.segment_names;
          msg.segment_l_W.resize(o.segment_names.size());
          for (size_t s = 0; s < o.segment_names.size(); ++s) msg.segment_l_W[s].assign(o.segment_l[s].data(), o.segment_l[s].data() + 3);
          msg.posture_error = o.posture_error;
          msg.qp_status = o.qp_status;
          msg.qp_iterations = o.qp_iterations;
          msg.qp_solve_time_us = o.qp_solve_time_us;
          msg.status = (o.reference_stale ? humanoid::wholebody_command_t::STATUS_REFERENCE_STALE : 0) |
                       (o.qp_failed ? humanoid::wholebody_command_t::STATUS_QP_FAILED : 0) |
                       (o.singular ? humanoid::wholebody_command_t::STATUS_SINGULAR : 0);
          out.publish(msg);
        });
        return rt.run();
      });
}
