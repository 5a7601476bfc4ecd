// The simulator's configuration (sim section) and scenario files (pushes), validated on load.
#include <fmt/format.h>

#include <cmath>

#include "hpr/sim/simulator.hpp"

namespace hpr::sim {

using Eigen::Vector3d;

Eigen::Vector3d Push::force_at(double t) const {
  if (t < start || t >= start + duration || duration <= 0.0) return Vector3d::Zero();
  if (profile == Profile::kRectangle) return force_W;
  return force_W * std::sin(M_PI * (t - start) / duration);
}

Eigen::Vector3d Push::impulse() const {
  return profile == Profile::kRectangle ? Vector3d(force_W * duration) : Vector3d(force_W * (2.0 * duration / M_PI));
}

SimConfig SimConfig::load(const Config& c) {
  SimConfig s;
  s.engine = c.choice_or("engine", "bullet", {"bullet", "mujoco"}) == "mujoco" ? EngineKind::kMujoco : EngineKind::kBullet;
  if (c.has("mujoco")) {
    const Config mj = c.section("mujoco");
    MujocoConfig& m = s.mujoco;
    m.timeconst = mj.real_or("timeconst", m.timeconst, 1e-4, 1.0);
    m.dampratio = mj.real_or("dampratio", m.dampratio, 0.1, 10.0);
    m.condim = static_cast<int>(mj.integer_or("condim", m.condim, 1, 6));
    if (m.condim != 1 && m.condim != 3 && m.condim != 4 && m.condim != 6) mj.fail("condim", "must be 1, 3, 4 or 6");
    m.elliptic_cone = mj.choice_or("cone", m.elliptic_cone ? "elliptic" : "pyramidal", {"pyramidal", "elliptic"}) == "elliptic";
    m.implicit = mj.choice_or("integrator", "euler", {"euler", "implicit"}) == "implicit";
    m.torsional_friction = mj.real_or("torsional_friction", m.torsional_friction, 0.0, 1.0);
    m.rolling_friction = mj.real_or("rolling_friction", m.rolling_friction, 0.0, 1.0);
    m.impratio = mj.real_or("impratio", m.impratio, 1.0, 1000.0);
    m.noslip_iterations = static_cast<int>(mj.integer_or("noslip_iterations", m.noslip_iterations, 0, 1000));
    m.write_model = mj.string_or("write_model", "");
  }
  s.dt = c.real_or("dt", s.dt, 1e-4, 0.01);
  s.substeps = static_cast<int>(c.integer_or("substeps", s.substeps, 1, 20));
  s.gravity = c.vec3_or("gravity", s.gravity, -100.0, 100.0);
  s.solver_iterations = static_cast<int>(c.integer_or("solver_iterations", s.solver_iterations, 1, 1000));
  if (c.has("ground")) {
    const Config g = c.section("ground");
    s.ground_friction = g.real_or("friction", s.ground_friction, 0.0, 5.0);
    s.ground_restitution = g.real_or("restitution", s.ground_restitution, 0.0, 1.0);
    s.ground_multipoint = g.boolean_or("multipoint", s.ground_multipoint);
    s.contact_stiffness = g.real_or("contact_stiffness", s.contact_stiffness, 0.0, 1e9);
    s.contact_damping = g.real_or("contact_damping", s.contact_damping, 0.0, 1e7);
    s.contact_erp = g.real_or("contact_erp", s.contact_erp, 0.0, 1.0);
    s.contact_cfm = g.real_or("contact_cfm", s.contact_cfm, 0.0, 1.0);
  }
  s.joint_limits = c.boolean_or("joint_limits", s.joint_limits);
  s.feet_only_collisions = c.choice_or("collisions", s.feet_only_collisions ? "feet" : "all", {"feet", "all"}) == "feet";
  s.friction_directions = static_cast<int>(c.integer_or("friction_directions", s.friction_directions, 1, 2));
  if (c.has("joint_friction")) {
    const Config j = c.section("joint_friction");
    s.joint_friction_coulomb = j.real_or("coulomb", s.joint_friction_coulomb, 0.0, 100.0);
    s.joint_friction_viscous = j.real_or("viscous", s.joint_friction_viscous, 0.0, 100.0);
  }
  s.actuation_delay_ticks = static_cast<int>(c.integer_or("actuation_delay_ticks", s.actuation_delay_ticks, 0, 10));
  if (c.has("model_error")) {
    for (const Config& e : c.items("model_error")) {
      BodyError b;
      b.body = e.string("body");
      b.mass_scale = e.real_or("mass_scale", b.mass_scale, 0.1, 10.0);
      b.com_offset = e.vec3_or("com_offset", b.com_offset, -0.5, 0.5);
      s.model_error.push_back(b);
    }
  }
  s.command_timeout = c.real_or("command_timeout", s.command_timeout, 1e-3, 10.0);
  s.damping_kd = c.real_or("damping_kd", s.damping_kd, 0.0, 1e3);
  if (c.has("start")) {
    const Config st = c.section("start");
    s.settle_time = st.real_or("settle_time", s.settle_time, 0.0, 10.0);
    s.settle_kp = st.real_or("kp", s.settle_kp, 0.0, 1e5);
    s.settle_kd = st.real_or("kd", s.settle_kd, 0.0, 1e4);
  }
  if (c.has("held_joints")) {
    const Config h = c.section("held_joints");
    s.held_kp = h.real_or("kp", s.held_kp, 0.0, 1e5);
    s.held_kd = h.real_or("kd", s.held_kd, 0.0, 1e4);
    s.held_rigid = h.boolean_or("rigid", s.held_rigid);
  }
  if (c.has("fallen")) {
    const Config f = c.section("fallen");
    s.fallen_base_height = f.real_or("base_height", s.fallen_base_height, 0.0, 3.0);
    s.fallen_tilt_deg = f.real_or("tilt_deg", s.fallen_tilt_deg, 1.0, 180.0);
  }
  if (c.has("noise")) {
    const Config n = c.section("noise");
    NoiseConfig& nc = s.noise;
    nc.enabled = n.boolean_or("enabled", nc.enabled);
    nc.seed = static_cast<unsigned>(n.integer_or("seed", nc.seed, 0, 1L << 31));
    nc.gyro_noise_density = n.real_or("gyro_noise_density", nc.gyro_noise_density, 0.0, 1.0);
    nc.gyro_bias_random_walk = n.real_or("gyro_bias_random_walk", nc.gyro_bias_random_walk, 0.0, 1.0);
    nc.gyro_bias_initial = n.real_or("gyro_bias_initial", nc.gyro_bias_initial, 0.0, 1.0);
    nc.accel_noise_density = n.real_or("accel_noise_density", nc.accel_noise_density, 0.0, 10.0);
    nc.encoder_bits = static_cast<int>(n.integer_or("encoder_bits", nc.encoder_bits, 0, 32));
    nc.joint_torque_noise = n.real_or("joint_torque_noise", nc.joint_torque_noise, 0.0, 100.0);
    nc.ft_force_noise = n.real_or("ft_force_noise", nc.ft_force_noise, 0.0, 100.0);
    nc.ft_torque_noise = n.real_or("ft_torque_noise", nc.ft_torque_noise, 0.0, 10.0);
  }
  if (s.engine == EngineKind::kMujoco && s.mujoco.timeconst < 2.0 * s.dt / s.substeps - 1e-12) {
    const std::string what = fmt::format("mujoco.timeconst {} s is below two physics steps, 2 dt / substeps = {} s", s.mujoco.timeconst,
                                         2.0 * s.dt / s.substeps);
    if (c.has("mujoco")) c.section("mujoco").fail("timeconst", what);
    c.fail("engine", what);
  }
  return s;
}

std::vector<Push> load_scenario(const std::string& path) {
  const Config cfg = Config::load(path);
  std::vector<Push> out;
  std::int64_t id = 1;
  for (const Config& p : cfg.items("pushes")) {
    Push push;
    push.id = id++;
    push.link = p.string("link");
    push.point_L = p.vec3_or("point", Vector3d::Zero(), -Push::kMaxPoint, Push::kMaxPoint);
    push.force_W = p.vec3("force", -Push::kMaxForce, Push::kMaxForce);
    push.start = p.real("start", 0.0, Push::kMaxStart);
    push.duration = p.real("duration", Push::kMinDuration, Push::kMaxDuration);
    push.profile = p.choice_or("profile", "half_sine", {"half_sine", "rectangle"}) == "rectangle"
                       ? Push::Profile::kRectangle
                       : Push::Profile::kHalfSine;
    out.push_back(push);
  }
  return out;
}

}  // namespace hpr::sim
