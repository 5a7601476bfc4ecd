#include "sim_node.hpp"

#include <cmath>
#include <stdexcept>

#include "hpr/common/log.hpp"
#include "hpr/msg/channels.hpp"
#include "hpr/common/time.hpp"
#include "hpr/msg/sim_truth.hpp"
#include "hpr/sim/sim_io.hpp"

namespace hpr::sim {

SimNodeOptions SimNodeOptions::load(const Config& c) {
  SimNodeOptions o;
  o.lockstep = c.choice_or("mode", "lockstep", {"lockstep", "realtime"}) == "lockstep";
  o.lockstep_timeout = c.real_or("lockstep_timeout", o.lockstep_timeout, 1e-3, 600.0);
  o.startup_timeout = c.real_or("startup_timeout", o.startup_timeout, 0.0, 600.0);
  o.duration = c.real_or("duration", o.duration, 0.0, 1e7);
  o.publish_truth = c.boolean_or("publish_truth", o.publish_truth);
  o.push_input = c.boolean_or("push_input", o.push_input);
  if (c.has("scenario") && !c.string("scenario").empty()) o.scenario = c.file_path("scenario");
  return o;
}

SimNode::SimNode(node::Runtime& rt, Simulator& sim, SimNodeOptions options, std::vector<drive::JointDrive> drives)
    : rt_(rt), sim_(sim), options_(std::move(options)), drives_(std::move(drives)) {
  const model::Model& m = sim.robot().model;
  names_.joints = m.joint_name;
  if (static_cast<int>(drives_.size()) < m.nj) throw std::invalid_argument("sim_bullet: fewer drive ranges than joints");
  command_in_ = &rt.subscribe(msg::channels::kJointCommand, [this, nj = m.nj](const humanoid::joint_command_t& msg) {
        JointCommand c;
        std::string why = msg::from_message(msg, names_, c);
        if (why.empty()) why = drive::check_command(c, drives_, nj);  // what the hal refuses
        if (!why.empty()) {
          ++refused_;
          return why;
        }
        std::string refused;
        if (!sim_.set_command(c, &refused)) return refused;
        return std::string();
      });
  command_in_->follow_ticks();  // a forged or corrupted tick is held back, never applied
  rt.subscribe(msg::channels::kPush, {}, [this](const humanoid::push_t& p) {
    if (!options_.push_input) {
      log::warn("PUSH {} refused: sim.push_input is off", p.id);
      return;
    }
    std::string why;
    const auto push = from_message(p, sim_.robot().model, &why);
    if (!push) {
      log::warn("PUSH {} refused: {}", p.id, why);
      return;
    }
    log::info("push {} on '{}': {:.1f} N peak for {:.3f} s at t = {:.3f} s", p.id, push->link, push->force_W.norm(),
              push->duration, push->start < 0 ? sim_.time() : push->start);
    sim_.add_push(*push);
  });
  sensors_out_ = rt.advertise(msg::channels::kRobotSensors);
  truth_out_ = rt.advertise(msg::channels::kSimTruth);
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
  msg::to_message(sim_.truth(), names_.feet, truth_msg_);
  truth_out_.publish(truth_msg_);
}

int SimNode::run() {
  log::info("simulating {} ({} joints) in {} mode, dt {} ms", sim_.robot().name, sim_.robot().model.nj,
            options_.lockstep ? "lockstep" : "realtime", sim_.config().dt * 1e3);
  const int rc = options_.lockstep ? run_lockstep() : run_realtime();
  log::info("stopped at t = {:.3f} s (tick {}); commands rejected {}, ticks without a command {}, late steps {}",
            sim_.time(), sim_.tick(), refused_ + sim_.rejected_commands(), missed_, late_);
  return rc;
}

void SimNode::report_fall() {
  if (!sim_.truth().fallen || fallen_reported_) return;
  fallen_reported_ = true;
  log::warn("the robot fell at t = {:.3f} s", sim_.time());
  rt_.set_fault("fallen", fmt::format("the robot fell at t = {:.3f} s", sim_.time()));
}

int SimNode::run_lockstep() {
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
    report_fall();
  }
  return node::kExitOk;
}

int SimNode::run_realtime() {
  PeriodicClock clock(sim_.config().dt);
  while (!rt_.stop_requested()) {
    if (options_.duration > 0 && sim_.time() >= options_.duration - 1e-9) break;
    const double t0 = monotonic_s();
    sim_.step();
    publish();
    rt_.record_step(sim_.tick(), monotonic_s() - t0);
    report_fall();
    clock.next();  // far behind (0.1 s): the clock restarts rather than bursting
    if (clock.left() < 0) ++late_;  // the step overran into the next period
    // Handle messages until the next period starts.
    while (!rt_.stop_requested()) {
      const double left = clock.left();
      if (left <= 0) break;
      rt_.spin_once(left);
    }
  }
  return node::kExitOk;
}

}  // namespace hpr::sim
