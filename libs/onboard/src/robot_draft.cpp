#include "hpr/onboard/robot_draft.hpp"

#include <fmt/format.h>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <map>
#include <set>

#include "hpr/balance/trajectories.hpp"
#include "hpr/model/algorithms.hpp"
#include "hpr/model/robot.hpp"
#include "text.hpp"

namespace hpr::onboard {

using detail::lower;

using Eigen::Vector3d;
using Eigen::VectorXd;
using model::Model;
using model::SE3;

namespace {

// Closed-loop gains of the CoM and base impedance, per unit of mass or inertia: ω = 4.5 rad/s and
// damping ratio 0.6 horizontally (TORO-like: 1604 N/m, 428 N s/m), twice as stiff vertically;
// the base orientation at ω = 7.5 rad/s, damping ratio 0.6 about the composite inertia.
constexpr double kComOmega = 4.5, kComZeta = 0.6, kComZetaZ = 0.55, kBaseOmega = 7.5, kBaseZeta = 0.6;
// Free-joint impedance of the configured robots (72 kg): 300 N m/rad, 30 N m s/rad, scaled by mass.
constexpr double kFreeStiffnessPerKg = 300.0 / 72.0, kFreeDampingPerKg = 30.0 / 72.0;
// The CoM's shift onto one foot: its quintic's peak acceleration asks the stance sole's CoP for at
// most this fraction of its reach beyond the CoM (the rest is for tracking and the other foot's
// least load); never quicker than the configured robots' 1.2 s. The reach is the sole's half
// width less the template's wbc.contact.cop_margin.
constexpr double kShiftFraction = 0.6, kMinShiftTime = 1.2, kCopMargin = 0.005;

double clamp_to_limits(const Model& m, int j, double q) {
  const auto ju = static_cast<size_t>(j);
  return std::clamp(q, m.q_lower[ju], m.q_upper[ju]);
}

// 0, or the middle of the range when 0 is outside it.
double rest_position(const model::JointDesc& j) {
  if (!j.has_limits || j.type == model::JointType::kContinuous) return 0.0;
  return (j.lower > 0.0 || j.upper < 0.0) ? 0.5 * (j.lower + j.upper) : 0.0;
}

std::string round4(double v) { return fmt::format("{:.4f}", std::abs(v) < 5e-5 ? 0.0 : v); }

/// Arms relaxed in `q`: shoulder roll joints 0.15 rad away from the body, elbows bent 0.4 rad
/// towards their larger range (joints of the legs left alone).
void relax_arms(const Model& m, const std::set<std::string>& leg, model::Data& data, VectorXd& q) {
  for (int j = 0; j < m.nj; ++j) {
    const std::string name = lower(m.joint_name[static_cast<size_t>(j)]);
    if (leg.count(m.joint_name[static_cast<size_t>(j)]) != 0) continue;
    const double lo = m.q_lower[static_cast<size_t>(j)], hi = m.q_upper[static_cast<size_t>(j)];
    if (name.find("elbow") != std::string::npos) {
      q(7 + j) = clamp_to_limits(m, j, hi > -lo ? 0.4 : -0.4);
    } else if (name.find("shoulder_roll") != std::string::npos || name.find("shoulder_r") != std::string::npos) {
      // The sign that moves the arm's end away from the body (its |y| up).
      int end = j + 1;
      for (int b = j + 2; b < m.nb; ++b) {
        const auto& sup = m.support[static_cast<size_t>(b)];
        if (std::find(sup.begin(), sup.end(), j) != sup.end()) end = b;
      }
      double best = 0.0, best_y = -1.0;
      for (double s : {0.15, -0.15}) {
        VectorXd qt = q;
        qt(7 + j) = clamp_to_limits(m, j, s);
        model::forward_kinematics(m, data, qt);
        const double y = std::abs(data.oMi[static_cast<size_t>(end)].p.y());
        if (y > best_y) {
          best_y = y;
          best = qt(7 + j);
        }
      }
      q(7 + j) = best;
    }
  }
}

/// The standing posture: from `q` (knees seeded), the legs' joints by damped least squares until
/// each sole frame reaches its target flat and level, the targets moved until the CoM is over the
/// middle of the soles. Throws ModelError naming `source` when it does not converge.
void stand(const Model& m, const std::array<int, 2>& sole, const std::array<std::vector<int>, 2>& legs,
           std::array<Vector3d, 2>& target, const std::string& source, model::Data& data, VectorXd& q) {
  Eigen::Matrix<double, 6, Eigen::Dynamic> J(6, m.nv);
  double residual = 0.0;
  for (int outer = 0; outer < 20; ++outer) {
    for (int it = 0; it < 200; ++it) {
      model::forward_kinematics(m, data, q);
      model::update_frame_placements(m, data);
      residual = 0.0;
      for (int k = 0; k < 2; ++k) {
        const auto ku = static_cast<size_t>(k);
        const SE3& X = data.oMf[static_cast<size_t>(sole[ku])];
        model::Vector6d e;
        e.head<3>() = target[ku] - X.p;
        e.tail<3>() = -model::log3(X.R);  // log3(R* R^T) with R* = I, world axes
        residual = std::max(residual, e.norm());
        J.setZero();
        model::frame_jacobian(m, data, sole[ku], model::ReferenceFrame::kLocalWorldAligned, J);
        Eigen::MatrixXd Jl(6, static_cast<Eigen::Index>(legs[ku].size()));
        for (size_t c = 0; c < legs[ku].size(); ++c) Jl.col(static_cast<Eigen::Index>(c)) = J.col(6 + legs[ku][c]);
        const Eigen::MatrixXd A = Jl * Jl.transpose() + 1e-6 * Eigen::MatrixXd::Identity(6, 6);
        const VectorXd dq = Jl.transpose() * A.ldlt().solve(e);
        for (size_t c = 0; c < legs[ku].size(); ++c) {
          const int j = legs[ku][c];
          q(7 + j) = clamp_to_limits(m, j, q(7 + j) + dq(static_cast<Eigen::Index>(c)));
        }
      }
      if (residual < 1e-10) break;
    }
    // Move both soles so that the middle of the support is under the CoM.
    const Vector3d c = model::center_of_mass(m, data, q);
    model::update_frame_placements(m, data);
    const Vector3d mid = 0.5 * (data.oMf[static_cast<size_t>(sole[0])].p + data.oMf[static_cast<size_t>(sole[1])].p);
    const double dx = c.x() - mid.x();
    for (auto& t : target) t.x() += dx;
    if (std::abs(dx) < 1e-6 && residual < 1e-9) break;
  }
  if (residual > 1e-6) {
    throw model::ModelError(fmt::format("{}: the standing posture's inverse kinematics did not converge (sole error "
                                        "{:.3g}); try another --leg-height",
                                        source, residual));
  }
}

/// The segments (the legs; the joints shared by the chains to two or more leaves of the rest, the
/// torso; each remaining chain named by where its end is) and the motion optimiser's adjusted
/// coordinates (base rotation, the torso, the first four joints of each arm), into `r`.
void segments_and_adjusted(const Model& m, const model::Data& data, const std::set<std::string>& leg, RobotDraft& r) {
  std::vector<std::vector<int>> chains;
  std::vector<int> ends;
  for (int b = 1; b < m.nb; ++b) {
    bool leaf = true;
    for (int c2 = 1; c2 < m.nb; ++c2) leaf = leaf && m.parent[static_cast<size_t>(c2)] != b;
    if (!leaf) continue;
    std::vector<int> chain;
    for (int j : m.support[static_cast<size_t>(b)]) {
      if (leg.count(m.joint_name[static_cast<size_t>(j)]) == 0) chain.push_back(j);
    }
    if (!chain.empty()) {
      chains.push_back(chain);
      ends.push_back(b);
    }
  }
  std::map<int, int> uses;
  for (const auto& ch : chains) {
    for (int j : ch) ++uses[j];
  }
  std::vector<std::string> torso;
  for (const auto& [j, n] : uses) {
    if (n >= 2) torso.push_back(m.joint_name[static_cast<size_t>(j)]);
  }
  if (!torso.empty()) r.segments.emplace_back("torso", torso);
  std::map<std::string, int> seen;
  std::vector<std::string> right_arm, left_arm;
  for (size_t i = 0; i < chains.size(); ++i) {
    std::vector<std::string> names;
    for (int j : chains[i]) {
      if (uses[j] < 2) names.push_back(m.joint_name[static_cast<size_t>(j)]);
    }
    if (names.empty()) continue;
    const double y = data.oMi[static_cast<size_t>(ends[i])].p.y();
    std::string seg = y < -0.05 ? "right_arm" : y > 0.05 ? "left_arm" : "head";
    if (seen[seg]++ > 0) seg += fmt::format("_{}", seen[seg]);
    if (seg == "right_arm") right_arm = names;
    if (seg == "left_arm") left_arm = names;
    r.segments.emplace_back(seg, names);
  }
  r.segments.emplace_back("right_leg", r.feet[0].leg_joints);
  r.segments.emplace_back("left_leg", r.feet[1].leg_joints);

  // The motion optimiser's adjusted coordinates, as in the paper: base rotation, the torso and the
  // first four joints of each arm.
  r.adjusted_double = {"base_rotation"};
  r.adjusted_double.insert(r.adjusted_double.end(), torso.begin(), torso.end());
  for (const auto* arm : {&right_arm, &left_arm}) {
    for (size_t k = 0; k < arm->size() && k < 4; ++k) r.adjusted_double.push_back((*arm)[k]);
  }
  r.adjusted_single = r.adjusted_double;
  r.adjusted_single.push_back("swing_foot");

}

/// Gains from the mass and the composite inertia at the standing posture `q`, and the physics
/// sub-steps the lightest body needs, into `r`.
void gains(const Model& m, model::Data& data, const VectorXd& q, RobotDraft& r) {
  r.mass = m.mass;
  const VectorXd v = VectorXd::Zero(m.nv);
  model::ccrba(m, data, q, v);
  r.I_com = data.Ic;
  const double w2 = kComOmega * kComOmega;
  r.com_stiffness = Vector3d(r.mass * w2, r.mass * w2, 2.0 * r.mass * w2);
  r.com_damping = Vector3d(2 * kComZeta * r.mass * kComOmega, 2 * kComZeta * r.mass * kComOmega,
                           2 * kComZetaZ * std::sqrt(r.com_stiffness.z() * r.mass));
  for (int a = 0; a < 3; ++a) {
    // About z half as stiff (the configured robots: 300 against 600 N m/rad).
    const double I = r.I_com(a, a);
    const double K = I * kBaseOmega * kBaseOmega * (a == 2 ? 0.5 : 1.0);
    r.base_stiffness(a) = K;
    r.base_damping(a) = 2 * kBaseZeta * std::sqrt(K * I);
  }
  r.free_stiffness = kFreeStiffnessPerKg * r.mass;
  r.free_damping = kFreeDampingPerKg * r.mass;
  r.lightest_body = std::numeric_limits<double>::infinity();
  for (int b = 1; b < m.nb; ++b) r.lightest_body = std::min(r.lightest_body, m.inertia[static_cast<size_t>(b)].m);
  // One 1 ms step is not enough even for a robot without light links: the TORO-like robot's sagittal
  // limits moved by up to 10 N s from 1 to 2 sub-steps, and by 1.4 N s more up to 8 (docs/results/paper-configuration.md, "The physics step").
  r.substeps = r.lightest_body >= 0.3 ? 2 : 4;
  r.notes.push_back(fmt::format("mass {:.2f} kg, composite inertia about the CoM diag({:.3f}, {:.3f}, {:.3f}) kg m^2; "
                                "lightest moving body {:.3f} kg: {} physics steps per ms",
                                r.mass, r.I_com(0, 0), r.I_com(1, 1), r.I_com(2, 2), r.lightest_body, r.substeps));
}

/// The CoM shift's duration onto one foot (balance.shift_time) into `r`: from the soles' centres
/// standing (right, left), the CoM height and the narrower sole (after the gains' mass).
void shift_time(const Vector3d& p_right, const Vector3d& p_left, RobotDraft& r) {
  const double travel = 0.5 * (p_left - p_right).head<2>().norm();
  const double reach = 0.5 * std::min(r.feet[0].sole.width, r.feet[1].sole.width) - kCopMargin;
  const double T = balance::quintic_shift_time(travel, r.com_height, std::max(reach, 1e-3), kShiftFraction);
  r.shift_time = std::max(kMinShiftTime, std::ceil(T * 10.0 - 1e-9) / 10.0);
  r.notes.push_back(fmt::format("CoM shift onto one foot over {:.1f} s: {:.3f} m at a peak acceleration of {:.0f} % of what "
                                "the sole's CoP reaches beyond the CoM ({:.3f} m)",
                                r.shift_time, travel, 100 * kShiftFraction * T * T / (r.shift_time * r.shift_time), reach));
}

}  // namespace

RobotDraft draft_robot(const model::RobotDescription& d, const DraftOptions& o) {
  RobotDraft r;
  r.name = o.name.empty() ? d.name : o.name;
  // Feet on the full model.
  model::ModelOptions full_options;
  full_options.base_link = o.base_link;
  const Model full = Model::build(d, full_options);
  r.base_link = full.body_name.front();
  r.feet = find_feet(full, d);
  for (const auto& f : r.feet) {
    for (const auto& w : f.sole.warnings) r.notes.push_back("warning: " + w);
  }
  std::set<std::string> leg;
  for (const auto& f : r.feet) leg.insert(f.leg_joints.begin(), f.leg_joints.end());

  // Held joints.
  model::ModelOptions options = full_options;
  for (int j = 0; j < full.nj; ++j) {
    const std::string& name = full.joint_name[static_cast<size_t>(j)];
    if (leg.count(name) != 0 || std::find(o.keep.begin(), o.keep.end(), name) != o.keep.end()) continue;
    bool hold = std::find(o.hold.begin(), o.hold.end(), name) != o.hold.end();
    for (const auto& p : o.hold_patterns) hold = hold || lower(name).find(lower(p)) != std::string::npos;
    if (!hold) continue;
    const double q = rest_position(*d.find_joint(name));
    options.held[name] = q;
    r.held.emplace_back(name, q);
  }
  Model m = Model::build(d, options);
  std::array<int, 2> sole{};
  for (int k = 0; k < 2; ++k) {
    SE3 X;
    X.p = r.feet[static_cast<size_t>(k)].sole.centre;
    X.R = Eigen::AngleAxisd(r.feet[static_cast<size_t>(k)].sole.yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    sole[static_cast<size_t>(k)] = m.add_frame(std::string(model::kFootNames[static_cast<size_t>(k)]) + "_sole",
                                               r.feet[static_cast<size_t>(k)].link, X);
  }
  const ImuChoice imu = find_imu(m);
  r.imu_link = imu.link;
  r.notes.push_back(fmt::format("IMU at link '{}' ({})", imu.link, imu.why));

  // Standing posture: knees bent until each hip stands leg_height_fraction of the straight leg above
  // its sole, soles flat and level, the CoM over the middle of the support; arms relaxed.
  model::Data data(m);
  VectorXd q = m.neutral();
  std::array<std::vector<int>, 2> legs;
  std::array<Vector3d, 2> target{};
  model::forward_kinematics(m, data, q);
  model::update_frame_placements(m, data);
  for (int k = 0; k < 2; ++k) {
    const auto ku = static_cast<size_t>(k);
    for (const auto& n : r.feet[ku].leg_joints) legs[ku].push_back(m.joint_index(n));
    const Vector3d hip = data.oMi[static_cast<size_t>(legs[ku].front() + 1)].p;
    const Vector3d p0 = data.oMf[static_cast<size_t>(sole[ku])].p;
    const double length = (hip - p0).norm();
    target[ku] = Vector3d(p0.x(), p0.y(), hip.z() - o.leg_height_fraction * length);
    // Seed the knee: the leg's pitch joint with one limit near zero, bent towards the other.
    for (int j : legs[ku]) {
      const Vector3d axis_W = data.oMi[static_cast<size_t>(j + 1)].R * m.axis[static_cast<size_t>(j + 1)];
      const double lo = m.q_lower[static_cast<size_t>(j)], hi = m.q_upper[static_cast<size_t>(j)];
      if (std::abs(axis_W.y()) > 0.9 && std::min(std::abs(lo), std::abs(hi)) < 0.2 && j != legs[ku].front()) {
        q(7 + j) = clamp_to_limits(m, j, hi > -lo ? 0.5 : -0.5);
      }
    }
  }
  relax_arms(m, leg, data, q);
  stand(m, sole, legs, target, d.source, data, q);
  model::forward_kinematics(m, data, q);
  model::update_frame_placements(m, data);
  const Vector3d c = model::center_of_mass(m, data, q);
  const double sole_z = data.oMf[static_cast<size_t>(sole[0])].p.z();
  r.base_height = -sole_z;
  r.com_height = c.z() - sole_z;
  for (int j = 0; j < m.nj; ++j) {
    if (std::abs(q(7 + j)) >= 5e-5) r.posture.emplace_back(m.joint_name[static_cast<size_t>(j)], q(7 + j));
  }
  r.notes.push_back(fmt::format("standing: hips at {:.0f} % of the straight leg above the soles, base {:.3f} m and CoM "
                                "{:.3f} m above the ground, CoM over the middle of the soles",
                                100 * o.leg_height_fraction, r.base_height, r.com_height));
  shift_time(data.oMf[static_cast<size_t>(sole[0])].p, data.oMf[static_cast<size_t>(sole[1])].p, r);

  segments_and_adjusted(m, data, leg, r);
  gains(m, data, q, r);
  r.notes.push_back(fmt::format("{} joints held, {} controlled", r.held.size(), m.nj));
  return r;
}

namespace {

std::string vec(const Vector3d& v, int decimals = 0) {
  return fmt::format("[{:.{}f}, {:.{}f}, {:.{}f}]", v.x(), decimals, v.y(), decimals, v.z(), decimals);
}

std::string list(const std::vector<std::string>& names, const std::string& indent) {
  std::string out = "[";
  size_t col = indent.size() + 1;
  for (size_t i = 0; i < names.size(); ++i) {
    const std::string item = names[i] + (i + 1 < names.size() ? ", " : "");
    if (col + item.size() > 110 && i > 0) {
      if (out.ends_with(' ')) out.pop_back();
      out += "\n" + indent + " ";
      col = indent.size() + 1;
    }
    out += item;
    col += item.size();
  }
  return out + "]";
}

void replace_all(std::string& s, const std::string& key, const std::string& value) {
  for (size_t p = s.find(key); p != std::string::npos; p = s.find(key, p + value.size())) s.replace(p, key.size(), value);
}

}  // namespace

std::string write_config(const RobotDraft& r, const std::string& text, const std::string& urdf_in_config,
                         const std::string& command, const std::vector<std::string>& mesh_paths_in_config) {
  std::string robot;
  auto line = [&robot](const std::string& s) { robot += s + "\n"; };
  line(fmt::format("  name: {}", r.name));
  line(fmt::format("  urdf: {}", urdf_in_config));
  if (!mesh_paths_in_config.empty()) {
    line(fmt::format("  mesh_search_paths: [{}]   # where the meshes were found (init --mesh-path), relative to this file",
                     fmt::join(mesh_paths_in_config, ", ")));
  }
  line(fmt::format("  base_link: {}", r.base_link));
  line("  feet:                      # the lowest links at the end of the leg chains; soles from their collision geometry");
  for (int k = 0; k < 2; ++k) {
    const auto& f = r.feet[static_cast<size_t>(k)];
    line(fmt::format("    {}:", model::kFootNames[static_cast<size_t>(k)]));
    line(fmt::format("      link: {}", f.link));
    line(fmt::format("      sole_xyz: [{:.4f}, {:.4f}, {:.4f}]   # centre of the sole in the link frame [m] ({})",
                     f.sole.centre.x(), f.sole.centre.y(), f.sole.centre.z(), f.sole.from));
    if (f.sole.yaw != 0.0) {
      line(fmt::format("      sole_rpy: [0.0, 0.0, {:.4f}]   # the sole's length {:.1f} deg from the link's x [rad]", f.sole.yaw,
                       f.sole.yaw * 180.0 / M_PI));
    }
    line(fmt::format("      sole_size: [{:.4f}, {:.4f}]          # length (x), width (y) [m]", f.sole.length, f.sole.width));
    line(fmt::format("      ft_link: {}   # ankle force/torque sensor frame", f.link));
  }
  line("  imu:");
  line(fmt::format("    link: {}", r.imu_link));
  line("    xyz: [0.0, 0.0, 0.0]");
  line("    rpy: [0.0, 0.0, 0.0]");
  if (!r.held.empty()) {
    line("  held_joints:               # not used for balance: held at these positions [rad], outside the controllers' model");
    for (const auto& [n, v] : r.held) line(fmt::format("    {}: {}", n, round4(v)));
  }
  line("  standing_posture:          # joint positions [rad] from inverse kinematics; joints not listed stand at 0");
  for (const auto& [n, v] : r.posture) line(fmt::format("    {}: {}", n, round4(v)));
  line("  segments:                  # joint groups, for each segment's share of the CAM (Fig. 7d)");
  for (const auto& [n, joints] : r.segments) line(fmt::format("    {}: {}", n, list(joints, std::string(6 + n.size(), ' '))));
  if (!robot.empty()) robot.pop_back();

  std::string out = text;
  replace_all(out, "{{title}}", fmt::format("{}: configuration of the push-recovery stack", r.name));
  replace_all(out, "{{urdf_arg}}", command);
  replace_all(out, "{{robot_section}}", robot);
  replace_all(out, "{{com_stiffness}}", vec(r.com_stiffness));
  replace_all(out, "{{com_damping}}", vec(r.com_damping));
  replace_all(out, "{{com_note}}", fmt::format("{:.1f} kg at {:.1f} rad/s", r.mass, kComOmega));
  replace_all(out, "{{base_stiffness}}", vec(r.base_stiffness, 1));
  replace_all(out, "{{base_damping}}", vec(r.base_damping, 1));
  replace_all(out, "{{base_note}}", fmt::format("composite inertia diag({:.2f}, {:.2f}, {:.2f}) kg m^2 at {:.1f} rad/s",
                                                r.I_com(0, 0), r.I_com(1, 1), r.I_com(2, 2), kBaseOmega));
  replace_all(out, "{{free_stiffness}}", fmt::format("{:.0f}", r.free_stiffness));
  replace_all(out, "{{free_damping}}", fmt::format("{:.1f}", r.free_damping));
  replace_all(out, "{{adjusted_double}}", list(r.adjusted_double, "            "));
  replace_all(out, "{{adjusted_single}}", list(r.adjusted_single, "            "));
  replace_all(out, "{{substeps}}", std::to_string(r.substeps));
  replace_all(out, "{{shift_time}}", fmt::format("{:.1f}", r.shift_time));
  replace_all(out, "{{substeps_note}}", fmt::format("the lightest moving body is {:.3f} kg", r.lightest_body));
  replace_all(out, "{{fallen_height}}", fmt::format("{:.2f}", 0.6 * r.base_height));
  return out;
}

}  // namespace hpr::onboard
