#include "wbc_node.hpp"

#include <cmath>

#include "hpr/common/log.hpp"

namespace hpr::wbc {

WbcNodeOptions WbcNodeOptions::load(const Config& c) {
  WbcNodeOptions o;
  o.use_sim_truth = c.choice_or("state_source", "estimator", {"estimator", "sim_truth"}) == "sim_truth";
  o.wait_for_wholebody = c.boolean_or("wait_for_wholebody", o.wait_for_wholebody);
  o.wholebody_timeout = c.real_or("wholebody_timeout", o.wholebody_timeout, 0.0, 60.0);
  o.wholebody_stale_ticks = static_cast<int>(c.integer_or("wholebody_stale_ticks", o.wholebody_stale_ticks, 1, 100000));
  o.state_timeout = c.real_or("state_timeout", o.state_timeout, 0.0, 60.0);
  o.bad_state_ticks = static_cast<int>(c.integer_or("bad_state_ticks", o.bad_state_ticks, 1, 100000));
  return o;
}

/// The CoM and base impedance (6), the extra joint damping and μ; ranges as the configuration accepts.
void WbcNode::add_parameters() {
  node::ParameterSet& params = rt_.parameters();
  WbcConfig& c = wbc_.tunable_config();
  params.add_xyz("com.stiffness", c.K_com.data(), 0.0, 1e6, "N/m");
  params.add_xyz("com.damping", c.D_com.data(), 0.0, 1e5, "N s/m");
  params.add_xyz("base.stiffness", c.K_base.data(), 0.0, 1e5, "N m/rad");
  params.add_xyz("base.damping", c.D_base.data(), 0.0, 1e4, "N m s/rad");
  params.add("joint_damping", c.joint_damping, 0.0, 100.0, "N m s/rad");
  params.add({"contact.friction", "", 0.05, 2.0, [this] { return wbc_.config().contact.friction; },
              [this](double mu) {
                wbc_.set_contact_friction(mu);
                return std::string();
              }});
}

WbcNode::WbcNode(node::Runtime& rt, const model::RobotSpec& robot, WholeBodyController& wbc,
                 balance::PostureReference& reference, WbcNodeOptions options)
    : rt_(rt), robot_(robot), wbc_(wbc), reference_(reference), options_(options) {
  names_.joints = robot.model.joint_name;
  for (int j : robot.free_joints) free_names_.push_back(robot.model.joint_name[static_cast<size_t>(j)]);
  command_out_ = rt.advertise<humanoid::joint_command_t>("JOINT_COMMAND");
  status_out_ = rt.advertise<humanoid::balance_status_t>("BALANCE_STATUS");
  wholebody_in_ = &rt.subscribe<humanoid::wholebody_command_t>(
      "WHOLEBODY_COMMAND", [this](const humanoid::wholebody_command_t& m) { return msg::from_message(m, free_names_, wholebody_); },
      [this](const humanoid::wholebody_command_t&) { have_wholebody_ = true; });
  rt.subscribe<humanoid::operator_t>("OPERATOR", msg::check_operator, [this](const humanoid::operator_t& m) {
    if (m.command == humanoid::operator_t::COMMAND_DAMP || m.command == humanoid::operator_t::COMMAND_STOP) {
      if (!damping_) log::warn("OPERATOR {} from {}: damping ({})", m.command == humanoid::operator_t::COMMAND_STOP ? "stop" : "damp", m.source, m.reason);
      damping_ = true;
    } else if (m.command == humanoid::operator_t::COMMAND_ENABLE) {
      if (damping_) log::info("OPERATOR enable from {}", m.source);
      damping_ = false;
    } else if (m.command == humanoid::operator_t::COMMAND_SET_SUPPORT && m.support >= 0 && m.support <= 2) {
      const auto s = static_cast<balance::Support>(m.support);
      log::info("OPERATOR: support {} requested", balance::to_string(s));
      reference_.request_support(s, state_.time);
    }
  });
  add_parameters();
  std::vector<node::Sync> sync;
  if (options_.use_sim_truth) {
    log::warn("state from SIM_TRUTH: for tests only, a real robot has no such channel");
    truth_in_ = &rt.subscribe<humanoid::sim_truth_t>("SIM_TRUTH");
    sensors_in_ = &rt.subscribe<humanoid::robot_sensors_t>(
        "ROBOT_SENSORS", [this](const humanoid::robot_sensors_t& m) { return msg::from_message(m, names_, sensors_); });
    sync.push_back({truth_in_, 0, {}});
  } else {
    state_in_ = &rt.subscribe<humanoid::robot_state_t>(
        "ROBOT_STATE", [this](const humanoid::robot_state_t& m) { return msg::from_message(m, names_, state_); });
  }
  // The motion optimiser's command of the tick, unless this tick only damps (operator damp, or an
  // estimate nothing may act on: motion_opt then publishes nothing).
  if (options_.wait_for_wholebody) {
    // Optional: with the motion optimiser gone, the wbc runs its own posture reference (the ankle
    // strategy) at full rate.
    sync.push_back({wholebody_in_, 0,
                    [this] { return !damping_ && (options_.use_sim_truth || (state_.status & msg::kStateUnusable) == 0); },
                    true});
  }
  node::InputBase& primary = options_.use_sim_truth ? static_cast<node::InputBase&>(*sensors_in_) : *state_in_;
  rt.on_restart(primary, [this] {
    // The posture reference starts again from the next usable estimate; an operator damp stays.
    reference_.reset();
    bad_state_count_ = 0;
    have_wholebody_ = false;
  });
  rt.on_tick(primary, sync, options_.wait_for_wholebody ? options_.wholebody_timeout : options_.state_timeout,
             [this](const node::TickInfo& info) {
               if (options_.use_sim_truth) {
                 const humanoid::sim_truth_t& t = truth_in_->latest();
                 if (truth_in_->tick() != info.tick) {
                   publish_damp(info.tick, "no SIM_TRUTH for this tick");
                   return;
                 }
                 const int n = robot_.model.nj;
                 state_.tick = info.tick;
                 state_.time = sensors_.time;
                 state_.q.resize(7 + n);
                 state_.v.resize(6 + n);
                 const Eigen::Quaterniond qb(t.quat_WB[0], t.quat_WB[1], t.quat_WB[2], t.quat_WB[3]);
                 const Eigen::Matrix3d Rt = qb.toRotationMatrix().transpose();
                 state_.q.head<3>() = Eigen::Vector3d(t.p_WB[0], t.p_WB[1], t.p_WB[2]);
                 state_.q.segment<4>(3) = qb.coeffs();  // (x, y, z, w)
                 state_.q.tail(n) = sensors_.q;
                 state_.v.head<3>() = Rt * Eigen::Vector3d(t.v_WB[0], t.v_WB[1], t.v_WB[2]);
                 state_.v.segment<3>(3) = Rt * Eigen::Vector3d(t.omega_WB[0], t.omega_WB[1], t.omega_WB[2]);
                 state_.v.tail(n) = sensors_.qd;
               }
               const bool fresh = have_wholebody_ && wholebody_in_->tick() >= info.tick - options_.wholebody_stale_ticks;
               if (info.timed_out) rt_.count_stale();
               step(info.tick, state_, fresh);
             });
}

void WbcNode::publish_damp(std::int64_t tick, const std::string& why) {
  JointCommand c;
  c.resize(robot_.model.nj);
  c.tick = tick;
  c.mode = JointCommand::Mode::kDamp;
  c.kd.setConstant(5.0);
  msg::to_message(c, names_, command_msg_);
  command_out_.publish(command_msg_);
  rt_.set_fault("damping", why);
}

void WbcNode::step(std::int64_t tick, const EstimatedState& state, bool wholebody_fresh) {
  // The held posture starts from the first usable estimate (a robot whose drives have not all
  // answered yet has none): until then the joints only damp.
  if (!reference_.started()) {
    if ((state.status & msg::kStateUnusable) != 0) {
      publish_damp(tick, "no usable ROBOT_STATE yet (status " + std::to_string(state.status) + ")");
      return;
    }
    reference_.start(state.q, state.time);
  }
  const balance::TaskReference& own = reference_.update(state.time);
  if (damping_) {
    publish_damp(tick, "operator damp");
    return;
  }
  // A state the estimator flags as stale, implausible or diverged is tolerated for a few ticks (one
  // refused sample keeps the previous estimate), then the robot goes limp.
  bad_state_count_ = (state.status & msg::kStateUnusable) != 0 ? bad_state_count_ + 1 : 0;
  if (bad_state_count_ >= options_.bad_state_ticks) {
    publish_damp(tick, "ROBOT_STATE flagged (status " + std::to_string(state.status) + ") for " +
                           std::to_string(bad_state_count_) + " ticks");
    return;
  }
  rt_.clear_fault("damping");
  const balance::TaskReference& cmd = wholebody_fresh ? wholebody_ : own;
  if (!wholebody_fresh && have_wholebody_) rt_.set_fault("wholebody", "WHOLEBODY_COMMAND stale: holding the reference posture");
  if (wholebody_fresh) rt_.clear_fault("wholebody");
  RobotState rs;
  rs.tick = tick;
  rs.time = state.time;
  rs.q = state.q;
  rs.v = state.v;
  const double t0 = monotonic_s();
  const JointCommand& c = wbc_.step(rs, cmd);
  const double compute_us = (monotonic_s() - t0) * 1e6;
  msg::to_message(c, names_, command_msg_);
  command_out_.publish(command_msg_);
  // BALANCE_STATUS.
  const BalanceStatus& s = wbc_.status();
  humanoid::balance_status_t& m = status_msg_;
  m.tick = tick;
  m.utime = static_cast<int64_t>(std::llround(state.time * 1e6));
  m.support = static_cast<int8_t>(s.support);
  m.yaw_WV = s.yaw_WV;
  for (int k = 0; k < 3; ++k) {
    m.p_WV[k] = s.p_WV(k);
    m.tau_ankle_V[k] = s.tau_ankle_V(k);
    m.tau_hip_V[k] = s.tau_hip_V(k);
    m.tau_V[k] = s.tau_V(k);
    m.tau_min_V[k] = s.tau_min_V(k);
    m.tau_max_V[k] = s.tau_max_V(k);
  }
  for (int k = 0; k < 2; ++k) {
    m.cop_V[k] = s.cop_V(k);
    m.cop_measured_V[k] = s.cop_measured_V(k);
  }
  m.f_vz = s.f_vz;
  for (int k = 0; k < 6; ++k) {
    m.w_des_WCom[k] = s.w_des(k);
    m.w_achieved_WCom[k] = s.w_achieved(k);
  }
  m.num_contacts = 2;
  m.contact_name = {names_.feet[0], names_.feet[1]};
  m.contact_wrench_W.resize(2);
  for (size_t f = 0; f < 2; ++f) m.contact_wrench_W[f].assign(s.contact_wrench[f].data(), s.contact_wrench[f].data() + 6);
  m.qp_status = s.qp_status;
  m.qp_iterations = s.qp_iterations;
  m.qp_solve_time_us = s.qp_solve_time_us;
  m.qp_fallback = s.qp_fallback;
  m.compute_time_us = compute_us;
  status_out_.publish(m);
  if (s.qp_fallback) {
    rt_.set_fault("qp", "contact QP failed: last valid wrenches kept");
  } else {
    rt_.clear_fault("qp");
  }
  if (s.singular) {
    rt_.set_fault("singular", "task Jacobian singular (stretched knee): last valid inverse kept");
  } else {
    rt_.clear_fault("singular");
  }
}

}  // namespace hpr::wbc
