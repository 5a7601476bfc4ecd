#include <fmt/format.h>

#include <Eigen/Geometry>
#include <cmath>
#include <nlohmann/json.hpp>

#include "hpr/experiments/trial.hpp"

namespace hpr::experiments {

using Eigen::Vector3d;

namespace {

Eigen::Quaterniond quat(const double (&wxyz)[4]) { return {wxyz[0], wxyz[1], wxyz[2], wxyz[3]}; }
Eigen::Quaterniond quat(const std::vector<double>& wxyz) { return {wxyz[0], wxyz[1], wxyz[2], wxyz[3]}; }

}  // namespace

const char* to_string(Strategy s) { return s == Strategy::kCam ? "cam" : "ankle"; }

Strategy strategy_from_string(const std::string& s) {
  if (s == "cam") return Strategy::kCam;
  if (s == "ankle") return Strategy::kAnkle;
  throw std::invalid_argument("strategy '" + s + "': expected cam or ankle");
}

Variant variant_from_string(const std::string& s) {
  constexpr std::string_view kStanding = "-standing";
  if (s.ends_with(kStanding)) {
    const std::string strategy = s.substr(0, s.size() - kStanding.size());
    if (strategy == "cam" || strategy == "ankle") return {strategy_from_string(strategy), true};
  } else if (s == "cam" || s == "ankle") {
    return {strategy_from_string(s), false};
  }
  throw std::invalid_argument("strategy '" + s + "': expected cam, ankle, cam-standing or ankle-standing");
}

void apply(const Variant& v, TrialSpec& spec) {
  spec.strategy = v.strategy;
  if (v.standing) spec.overrides.push_back("balance.stepping.enabled=false");
}

std::string variant_name(const TrialSpec& spec) {
  return std::string(to_string(spec.strategy)) + (overrides_enable_steps(spec.overrides, true) ? "" : "-standing");
}

TrialEvaluator::TrialEvaluator(const model::RobotSpec& robot, const std::string& support, double push_start, double push_end)
    : robot_(&robot), push_start_(push_start), push_end_(push_end) {
  if (support == "double") {
    stance_ = {model::kRight, model::kLeft};
  } else if (support == "right") {
    stance_ = {model::kRight};
  } else if (support == "left") {
    stance_ = {model::kLeft};
  } else {
    throw std::invalid_argument("support '" + support + "': expected double, left or right");
  }
  r_.push_start = push_start;
  r_.push_end = push_end;
  r_.min_cop_margin = 1e9;
  const auto nf = static_cast<Eigen::Index>(robot.free_joints.size());
  joints_ref_ = joints_now_ = Eigen::VectorXd::Zero(nf);
}

void TrialEvaluator::on_sensors(const humanoid::robot_sensors_t& s) {
  if (s.num_joints != robot_->model.nj) return;
  const double t = static_cast<double>(s.utime) * 1e-6;
  for (size_t f = 0; f < robot_->free_joints.size(); ++f) {
    joints_now_(static_cast<Eigen::Index>(f)) = s.q[static_cast<size_t>(robot_->free_joints[f])];
  }
  have_joints_ = true;
  if (t >= push_start_ - 0.2 && t < push_start_) {
    joints_ref_ += joints_now_;
    ++n_joint_ref_;
  }
}

void TrialEvaluator::on_wholebody(const humanoid::wholebody_command_t& w) {
  const double t = static_cast<double>(w.utime) * 1e-6;
  if (t < push_start_) return;
  r_.steps_started = w.steps_taken;
  r_.follow_steps = w.follow_steps;
  for (int i = 0; i < 3; ++i) r_.peak_cam_cmd(i) = std::max(r_.peak_cam_cmd(i), std::abs(w.l_cmd_W[i]));
}

void TrialEvaluator::on_truth(const humanoid::sim_truth_t& t) {
  const double time = t.sim_time;
  last_time_ = time;
  r_.sim_time = time;
  r_.fallen = r_.fallen || t.fallen;
  if (t.push_id >= 0) r_.impulse_W = Vector3d(t.push_impulse_W[0], t.push_impulse_W[1], t.push_impulse_W[2]);
  const Vector3d com(t.p_WCom[0], t.p_WCom[1], t.p_WCom[2]);
  if (time >= push_start_ - 0.2 && time < push_start_) {
    com_ref_ += com;
    const Eigen::Quaterniond q = quat(t.quat_WB);
    Eigen::Vector4d c(q.w(), q.x(), q.y(), q.z());
    if (n_ref_ > 0 && c.dot(quat_ref_) < 0) c = -c;
    quat_ref_ += c;
    ++n_ref_;
  }
  if (time < push_start_ || n_ref_ == 0) return;
  if (!have_sole0_) {
    for (int k : stance_) {
      const auto& p = t.p_WF[static_cast<size_t>(k)];
      sole0_[static_cast<size_t>(k)] = Vector3d(p[0], p[1], p[2]);
    }
    have_sole0_ = true;
  }
  const double weight = robot_->model.mass * robot_->model.gravity.norm();
  for (int k : stance_) {
    const auto ku = static_cast<size_t>(k);
    const double tilt = t.foot_tilt[ku] * 180.0 / M_PI;
    const Vector3d p(t.p_WF[ku][0], t.p_WF[ku][1], t.p_WF[ku][2]);
    const double slip = (p - sole0_[ku]).head<2>().norm();
    final_tilt_deg_[ku] = tilt;
    if (steps_allowed_) {
      if (!stepped_) pending_[ku].push_back({time, tilt, slip});
      // A step: the balance planner has started one, and the sole leaves the ground, then lands
      // again after a real flight (a sole that bounces as the robot falls is none). The first one
      // ends the standing judgement: what the soles did from just before its lift-off is the step's.
      if (!t.foot_contact[ku] && lift_time_[ku] < 0.0) lift_time_[ku] = time;
      if (t.foot_contact[ku] && lift_time_[ku] >= 0.0) {
        if (time - lift_time_[ku] >= kMinFlightTime && r_.steps_started > 0) {
          ++r_.steps;
          if (!stepped_) {
            judge_until(lift_time_[ku] - kLiftWindow);
            for (auto& q : pending_) q.clear();
            stepped_ = true;
          }
        }
        lift_time_[ku] = -1.0;
      }
    }
    r_.max_tilt_deg = std::max(r_.max_tilt_deg, tilt);
    r_.max_slip = std::max(r_.max_slip, slip);
    // Centre of pressure in the sole frame, for a foot that carries load.
    const Eigen::Matrix3d R = quat(t.quat_WF[ku]).normalized().toRotationMatrix();
    const auto& w = t.contact_wrench_W[ku];
    const Vector3d f = R.transpose() * Vector3d(w[0], w[1], w[2]);
    const Vector3d tau = R.transpose() * Vector3d(w[3], w[4], w[5]);
    if (f.z() > 0.05 * weight) {
      const double cx = -tau.y() / f.z(), cy = tau.x() / f.z();
      const auto& foot = robot_->feet[ku];
      const double margin = std::min(0.5 * foot.length - std::abs(cx), 0.5 * foot.width - std::abs(cy));
      r_.min_cop_margin = std::min(r_.min_cop_margin, margin);
    }
  }
  if (steps_allowed_ && !stepped_) {
    // Judged once older than the lift window, and never past a lift-off under way.
    double horizon = time - kLiftWindow;
    for (int k : stance_) {
      const double lift = lift_time_[static_cast<size_t>(k)];
      if (lift >= 0.0) horizon = std::min(horizon, lift - kLiftWindow);
    }
    judge_until(horizon);
  }
  for (int i = 0; i < 3; ++i) r_.peak_cam(i) = std::max(r_.peak_cam(i), std::abs(t.l_WCom[i]));
  const Vector3d com0 = com_ref_ / n_ref_;
  const double dev = (com - com0).norm();
  r_.max_com_deviation = std::max(r_.max_com_deviation, dev);
  // Posture band: CoM, base orientation and the free joints.
  const Eigen::Vector4d qr = quat_ref_.normalized();
  const Eigen::Quaterniond q0(qr(0), qr(1), qr(2), qr(3));
  const double angle = quat(t.quat_WB).normalized().angularDistance(q0) * 180.0 / M_PI;
  double joints = 0.0;
  if (have_joints_ && n_joint_ref_ > 0) {
    Eigen::Index worst = 0;
    joints = (joints_now_ - joints_ref_ / n_joint_ref_).cwiseAbs().maxCoeff(&worst) * 180.0 / M_PI;
    r_.final_joint = robot_->model.joint_name[static_cast<size_t>(robot_->free_joints[static_cast<size_t>(worst)])];
  }
  r_.final_com_deviation = dev;
  r_.final_base_angle_deg = angle;
  r_.final_joint_deg = joints;
  bool in_band = dev < kPostureDistance && angle < kPostureAngleDeg && joints < kPostureAngleDeg;
  if (stepped_) {
    // After steps the CoM rests over the new support: at rest, soles flat and down, posture back.
    const double speed = Vector3d(t.v_WCom[0], t.v_WCom[1], t.v_WCom[2]).norm();
    bool flat = true;
    for (int k : stance_) {
      const auto ku = static_cast<size_t>(k);
      flat = flat && t.foot_contact[ku] && final_tilt_deg_[ku] < kTiltLimitDeg;
    }
    in_band = speed < kRestSpeed && flat && angle < kStepBaseAngleDeg;
  }
  if (!in_band) last_out_of_posture_ = time;
  evaluated_after_push_ = true;
}

void TrialEvaluator::judge_until(double horizon) {
  for (auto& q : pending_) {
    while (!q.empty() && q.front().time < horizon) {
      judged_tilt_deg_ = std::max(judged_tilt_deg_, q.front().tilt_deg);
      judged_slip_ = std::max(judged_slip_, q.front().slip);
      q.pop_front();
    }
  }
}

TrialResult TrialEvaluator::result() const {
  TrialResult r = r_;
  r.stepping = steps_allowed_;
  if (steps_allowed_) {
    // What is judged: before the first step (all of the run when there was none).
    r.max_tilt_deg = judged_tilt_deg_;
    r.max_slip = judged_slip_;
    for (const auto& q : pending_) {
      for (const SoleSample& x : q) {
        r.max_tilt_deg = std::max(r.max_tilt_deg, x.tilt_deg);
        r.max_slip = std::max(r.max_slip, x.slip);
      }
    }
  }
  if (r.min_cop_margin > 1e8) r.min_cop_margin = 0.0;
  r.completed = evaluated_after_push_ && last_time_ >= push_end_ + kSettleTime - 1e-3;
  if (last_out_of_posture_ < 0) {
    r.return_time = 0.0;
  } else if (last_out_of_posture_ < last_time_) {
    r.return_time = std::max(0.0, last_out_of_posture_ - push_end_);
  }
  std::vector<std::string> why;
  const bool standing = push_end_ <= push_start_;
  if (r.fallen) why.emplace_back("fell");
  const bool decided = failed();
  r.inconclusive = !r.completed && !decided;
  if (r.inconclusive) why.emplace_back(fmt::format("run ended at t = {:.2f} s, before 5 s after the push", last_time_));
  const char* before = stepped_ ? " before the first step" : "";
  if (r.max_tilt_deg >= kTiltLimitDeg) why.emplace_back(fmt::format("sole tilt {:.1f} deg{}", r.max_tilt_deg, before));
  if (r.max_slip >= kSlipLimit) why.emplace_back(fmt::format("sole slip {:.1f} mm{}", r.max_slip * 1e3, before));
  if (!decided && (!r.return_time || *r.return_time > kSettleTime)) {
    why.emplace_back(stepped_ ? "not at rest on flat soles with the base within 5 deg"
                              : "posture not back within 1 cm and 1 deg");
  }
  r.recovered = why.empty();
  for (size_t i = 0; i < why.size(); ++i) r.failure += (i > 0 ? "; " : "") + why[i];
  if (r.recovered) {
    r.outcome = standing ? "stood" : "recovered";
  } else if (r.fallen) {
    r.outcome = "fell";
  } else if (r.inconclusive) {
    r.outcome = "inconclusive";
  } else if (r.max_tilt_deg >= kTiltLimitDeg) {
    r.outcome = "tilted";
  } else if (r.max_slip >= kSlipLimit) {
    r.outcome = "slipped";
  } else {
    r.outcome = "unsettled";
  }
  return r;
}

std::string TrialResult::to_json(const TrialSpec& spec) const {
  nlohmann::ordered_json j;
  j["robot"] = spec.config;
  j["support"] = spec.support;
  j["strategy"] = to_string(spec.strategy);
  j["stepping"] = stepping;
  j["direction_deg"] = spec.direction_deg;
  j["pipeline"] = spec.in_process ? "in-process" : "processes";
  j["peak_force_N"] = spec.peak;
  j["duration_s"] = spec.push_duration();
  j["recovered"] = recovered;
  j["fallen"] = fallen;
  j["completed"] = completed;
  j["outcome"] = outcome;
  j["failure"] = failure;
  j["inconclusive"] = inconclusive;
  j["applied_impulse_Ns"] = impulse_W.norm();
  j["applied_impulse_W_Ns"] = {impulse_W.x(), impulse_W.y(), impulse_W.z()};
  j["max_foot_tilt_deg"] = max_tilt_deg;
  j["max_sole_slip_m"] = max_slip;
  j["steps"] = steps;
  j["steps_started"] = steps_started;
  j["follow_steps"] = follow_steps;
  j["peak_cam_Nms"] = {peak_cam.x(), peak_cam.y(), peak_cam.z()};
  j["peak_cam_commanded_Nms"] = {peak_cam_cmd.x(), peak_cam_cmd.y(), peak_cam_cmd.z()};
  j["min_cop_margin_m"] = min_cop_margin;
  j["max_com_deviation_m"] = max_com_deviation;
  j["return_time_s"] = return_time ? nlohmann::ordered_json(*return_time) : nlohmann::ordered_json(nullptr);
  j["final_com_deviation_m"] = final_com_deviation;
  j["final_base_angle_deg"] = final_base_angle_deg;
  j["final_joint_deviation_deg"] = final_joint_deg;
  j["final_joint"] = final_joint;
  j["push_start_s"] = push_start;
  j["push_end_s"] = push_end;
  j["simulated_s"] = sim_time;
  j["wall_s"] = wall_time;
  if (spec.alpha) j["alpha"] = *spec.alpha;
  if (spec.beta) j["beta"] = *spec.beta;
  if (!log_file.empty()) j["log"] = log_file;
  return j.dump();
}

TrialResult TrialResult::from_json(const std::string& json) {
  const nlohmann::json j = nlohmann::json::parse(json);
  const auto vec = [&](const char* key) {
    const auto& a = j.at(key);
    return Vector3d(a.at(0).get<double>(), a.at(1).get<double>(), a.at(2).get<double>());
  };
  TrialResult r;
  r.recovered = j.at("recovered").get<bool>();
  r.fallen = j.at("fallen").get<bool>();
  r.completed = j.at("completed").get<bool>();
  r.inconclusive = j.at("inconclusive").get<bool>();
  r.failure = j.at("failure").get<std::string>();
  r.outcome = j.contains("outcome") ? j.at("outcome").get<std::string>() : (r.recovered ? "recovered" : r.fallen ? "fell" : "not recovered");
  r.impulse_W = vec("applied_impulse_W_Ns");
  r.max_tilt_deg = j.at("max_foot_tilt_deg").get<double>();
  r.max_slip = j.at("max_sole_slip_m").get<double>();
  r.stepping = j.value("stepping", false);  // absent from results files written before it
  r.steps = j.at("steps").get<int>();
  r.steps_started = j.value("steps_started", 0);  // absent from results files written before these counts
  r.follow_steps = j.value("follow_steps", 0);
  r.peak_cam = vec("peak_cam_Nms");
  r.peak_cam_cmd = vec("peak_cam_commanded_Nms");
  r.min_cop_margin = j.at("min_cop_margin_m").get<double>();
  r.max_com_deviation = j.at("max_com_deviation_m").get<double>();
  if (!j.at("return_time_s").is_null()) r.return_time = j.at("return_time_s").get<double>();
  r.final_com_deviation = j.at("final_com_deviation_m").get<double>();
  r.final_base_angle_deg = j.at("final_base_angle_deg").get<double>();
  r.final_joint_deg = j.at("final_joint_deviation_deg").get<double>();
  r.final_joint = j.at("final_joint").get<std::string>();
  r.push_start = j.at("push_start_s").get<double>();
  r.push_end = j.at("push_end_s").get<double>();
  r.sim_time = j.at("simulated_s").get<double>();
  r.wall_time = j.at("wall_s").get<double>();
  if (j.contains("log")) r.log_file = j.at("log").get<std::string>();
  return r;
}

}  // namespace hpr::experiments
