#include "sim_node.hpp"

#include <time.h>

#include <cmath>

#include "hpr/common/log.hpp"

namespace hpr::sim {

SimNodeOptions SimNodeOptions::load(const Config& c) {
  SimNodeOptions o;
  o.lockstep = c.choice_or("mode", "lockstep", {"lockstep", "realtime"}) == "lockstep";
  o.lockstep_timeout = c.real_or("lockstep_timeout", o.lockstep_timeout, 1e-3, 600.0);
  o.startup_timeout = c.real_or("startup_timeout", o.startup_timeout, 0.0, 600.0);
  o.duration = c.real_or("duration", o.duration, 0.0, 1e7);
  o.publish_truth = c.boolean_or("publish_truth", o.publish_truth);
  if (c.has("scenario") && !c.string("scenario").empty()) o.scenario = c.file_path("scenario");
  return o;
}

SimNode::SimNode(node::Runtime& rt, Simulator& sim, SimNodeOptions options)
    : rt_(rt), sim_(sim), options_(std::move(options)) {
  const model::Model& m = sim.robot().model;
  names_.joints = m.joint_name;
  command_in_ = &rt.subscribe<humanoid::joint_command_t>(
      "JOINT_COMMAND", [this](const humanoid::joint_command_t& msg) {
        JointCommand c;
        const std::string why = msg::from_message(msg, names_, c);
        if (!why.empty()) return why;
        std::string refused;
        if (!sim_.set_command(c, &refused)) return refused;
        return std::string();
      });
  rt.subscribe<humanoid::push_t>("PUSH", {}, [this](const humanoid::push_t& p) {
    Push push;
    push.id = p.id;
    push.link = p.link;
    push.point_L = Eigen::Vector3d(p.point_L[0], p.point_L[1], p.point_L[2]);
    push.force_W = Eigen::Vector3d(p.force_W[0], p.force_W[1], p.force_W[2]);
    push.start = p.start_time;
    push.duration = p.duration;
    push.profile = p.profile == humanoid::push_t::PROFILE_RECTANGLE ? Push::Profile::kRectangle : Push::Profile::kHalfSine;
    if (!sim_.robot().model.has_frame(push.link) || !push.force_W.allFinite() || !(push.duration > 0)) {
      log::warn("PUSH {} refused: link '{}' unknown, or force or duration invalid", p.id, p.link);
      return;
    }
    log::info("push {} on '{}': {:.1f} N peak for {:.3f} s at t = {:.3f} s", p.id, p.link, push.force_W.norm(),
              push.duration, push.start < 0 ? sim_.time() : push.start);
    sim_.add_push(push);
  });
  sensors_out_ = rt.advertise<humanoid::robot_sensors_t>("ROBOT_SENSORS");
  truth_out_ = rt.advertise<humanoid::sim_truth_t>("SIM_TRUTH");
  if (!options_.scenario.empty()) {
    for (auto& p : load_scenario(options_.scenario)) {
      log::info("scenario push {} on '{}': {:.1f} N peak, {:.3f} s from t = {:.3f} s", p.id, p.link, p.force_W.norm(),
                p.duration, p.start);
      sim_.add_push(p);
    }
  }
}

void SimNode::publish() {
  msg::to_message(sim_.sensors(), names_, sensors_msg_);
  sensors_out_.publish(sensors_msg_);
  if (!options_.publish_truth) return;
  const TruthData& t = sim_.truth();
  humanoid::sim_truth_t& m = truth_msg_;
  m.tick = t.tick;
  m.utime = static_cast<int64_t>(std::llround(t.time * 1e6));
  for (int k = 0; k < 3; ++k) {
    m.p_WB[k] = t.p_WB(k);
    m.v_WB[k] = t.v_WB(k);
    m.omega_WB[k] = t.omega_WB(k);
    m.p_WCom[k] = t.p_WCom(k);
    m.v_WCom[k] = t.v_WCom(k);
    m.h_lin_W[k] = t.h_lin_W(k);
    m.l_WCom[k] = t.l_WCom(k);
    m.push_force_W[k] = t.push_force_W(k);
    m.push_impulse_W[k] = t.push_impulse_W(k);
  }
  for (int k = 0; k < 4; ++k) m.quat_WB[k] = t.quat_WB(k);
  m.num_feet = 2;
  m.foot_name = {names_.feet[0], names_.feet[1]};
  m.p_WF.resize(2);
  m.quat_WF.resize(2);
  m.contact_wrench_W.resize(2);
  m.foot_contact.resize(2);
  m.foot_tilt.resize(2);
  for (size_t f = 0; f < 2; ++f) {
    m.p_WF[f].assign(t.p_WF[f].data(), t.p_WF[f].data() + 3);
    m.quat_WF[f].assign(t.quat_WF[f].data(), t.quat_WF[f].data() + 4);
    m.contact_wrench_W[f].assign(t.contact_wrench_W[f].data(), t.contact_wrench_W[f].data() + 6);
    m.foot_contact[f] = t.foot_contact[f] ? 1 : 0;
    m.foot_tilt[f] = t.foot_tilt[f];
  }
  m.push_id = t.push_id;
  m.push_active = t.push_active;
  m.fallen = t.fallen;
  m.sim_time = t.time;
  truth_out_.publish(m);
}

int SimNode::run() {
  log::info("simulating {} ({} joints) in {} mode, dt {} ms", sim_.robot().name, sim_.robot().model.nj,
            options_.lockstep ? "lockstep" : "realtime", sim_.config().dt * 1e3);
  const int rc = options_.lockstep ? run_lockstep() : run_realtime();
  log::info("stopped at t = {:.3f} s (tick {}); commands rejected {}, ticks without a command {}, late steps {}",
            sim_.time(), sim_.tick(), sim_.rejected_commands(), missed_, late_);
  return rc;
}

int SimNode::run_lockstep() {
  bool fallen_reported = false;
  while (!rt_.stop_requested()) {
    if (options_.duration > 0 && sim_.time() >= options_.duration - 1e-9) break;
    publish();
    const std::int64_t k = sim_.tick();
    const double timeout = command_in_->count() == 0 ? options_.startup_timeout : options_.lockstep_timeout;
    const bool got = rt_.spin_until([&] { return command_in_->tick() >= k; }, timeout);
    if (rt_.stop_requested()) break;
    if (!got) {
      ++missed_;
      rt_.set_fault("command", "no JOINT_COMMAND for tick " + std::to_string(k));
    } else {
      rt_.clear_fault("command");
    }
    const double t0 = monotonic_s();
    sim_.step();
    rt_.record_step(k, monotonic_s() - t0);
    if (sim_.truth().fallen && !fallen_reported) {
      fallen_reported = true;
      log::warn("the robot fell at t = {:.3f} s", sim_.time());
    }
  }
  return node::kExitOk;
}

int SimNode::run_realtime() {
  timespec next{};
  clock_gettime(CLOCK_MONOTONIC, &next);
  const long period = static_cast<long>(std::llround(sim_.config().dt * 1e9));
  while (!rt_.stop_requested()) {
    if (options_.duration > 0 && sim_.time() >= options_.duration - 1e-9) break;
    const double t0 = monotonic_s();
    sim_.step();
    publish();
    rt_.record_step(sim_.tick(), monotonic_s() - t0);
    next.tv_nsec += period;
    while (next.tv_nsec >= 1000000000L) {
      next.tv_nsec -= 1000000000L;
      ++next.tv_sec;
    }
    timespec now{};
    clock_gettime(CLOCK_MONOTONIC, &now);
    const double slack = static_cast<double>(next.tv_sec - now.tv_sec) + 1e-9 * static_cast<double>(next.tv_nsec - now.tv_nsec);
    if (slack < 0) {
      ++late_;
      if (slack < -0.1) next = now;  // far behind: restart the clock rather than burst
    }
    // Handle messages until the next period starts.
    while (!rt_.stop_requested()) {
      clock_gettime(CLOCK_MONOTONIC, &now);
      const double left = static_cast<double>(next.tv_sec - now.tv_sec) + 1e-9 * static_cast<double>(next.tv_nsec - now.tv_nsec);
      if (left <= 0) break;
      rt_.spin_once(left);
    }
  }
  return node::kExitOk;
}

}  // namespace hpr::sim
