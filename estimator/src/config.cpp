// The estimator's configuration section (estimator.*), validated on load: every key known, every
// number in its range, errors naming the file, key and value.
#include <fmt/format.h>

#include "hpr/estimator/estimator.hpp"

namespace hpr::estimator {

EstimatorConfig EstimatorConfig::load(const Config& c) {
  c.reject_unknown({"sensor_timeout", "joint_accel_noise", "encoder_noise", "filter_joints", "gyro_noise", "gyro_bias_walk",
                    "gyro_bias_initial", "angular_accel_noise", "kinematic_orientation_noise", "kinematic_rate_noise",
                    "accel_orientation_noise", "level_ground", "accel_noise", "foot_contact_noise", "foot_swing_noise",
                    "kinematic_position_noise", "kinematic_velocity_noise", "contact_on", "contact_off", "cop_edge_margin", "anchor_max_rate", "edge_velocity_noise", "edge_min_load", "settle_after_roll", "settle_at_start", "anchor_velocity_gate", "contact_max_height",
                    "cam_observer_gain", "initialisation_time", "max_position_std", "max_accel", "max_gyro",
                    "max_ft_force", "joint_limit_margin"});
  EstimatorConfig e;
  e.joint_accel_noise = c.real_or("joint_accel_noise", e.joint_accel_noise, 1e-3, 1e6);
  e.encoder_noise = c.real_or("encoder_noise", e.encoder_noise, 1e-9, 0.1);
  e.filter_joints = c.boolean_or("filter_joints", e.filter_joints);
  e.gyro_noise = c.real_or("gyro_noise", e.gyro_noise, 1e-6, 1.0);
  e.gyro_bias_walk = c.real_or("gyro_bias_walk", e.gyro_bias_walk, 0.0, 1.0);
  e.gyro_bias_initial = c.real_or("gyro_bias_initial", e.gyro_bias_initial, 1e-6, 1.0);
  e.angular_accel_noise = c.real_or("angular_accel_noise", e.angular_accel_noise, 1e-3, 1e5);
  e.kinematic_orientation_noise = c.real_or("kinematic_orientation_noise", e.kinematic_orientation_noise, 1e-6, 1.0);
  e.kinematic_rate_noise = c.real_or("kinematic_rate_noise", e.kinematic_rate_noise, 1e-6, 10.0);
  e.accel_orientation_noise = c.real_or("accel_orientation_noise", e.accel_orientation_noise, 1e-4, 10.0);
  e.level_ground = c.boolean_or("level_ground", e.level_ground);
  e.accel_noise = c.real_or("accel_noise", e.accel_noise, 1e-6, 100.0);
  e.foot_contact_noise = c.real_or("foot_contact_noise", e.foot_contact_noise, 1e-8, 1.0);
  e.foot_swing_noise = c.real_or("foot_swing_noise", e.foot_swing_noise, 1e-4, 100.0);
  e.kinematic_position_noise = c.real_or("kinematic_position_noise", e.kinematic_position_noise, 1e-6, 1.0);
  e.kinematic_velocity_noise = c.real_or("kinematic_velocity_noise", e.kinematic_velocity_noise, 1e-6, 10.0);
  e.contact_on = c.real_or("contact_on", e.contact_on, 0.0, 1e4);
  e.contact_off = c.real_or("contact_off", e.contact_off, 0.0, 1e4);
  if (e.contact_off > e.contact_on) {
    c.fail("contact_off", fmt::format("must not exceed contact_on ({} N)", e.contact_on));
  }
  e.cop_edge_margin = c.real_or("cop_edge_margin", e.cop_edge_margin, 0.0, 0.5);
  e.anchor_max_rate = c.real_or("anchor_max_rate", e.anchor_max_rate, 0.0, 100.0);
  e.edge_velocity_noise = c.real_or("edge_velocity_noise", e.edge_velocity_noise, 0.0, 10.0);
  e.edge_min_load = c.real_or("edge_min_load", e.edge_min_load, 0.0, 2.0);
  e.settle_after_roll = c.boolean_or("settle_after_roll", e.settle_after_roll);
  e.settle_at_start = c.boolean_or("settle_at_start", e.settle_at_start);
  e.anchor_velocity_gate = c.real_or("anchor_velocity_gate", e.anchor_velocity_gate, 0.0, 100.0);
  e.contact_max_height = c.real_or("contact_max_height", e.contact_max_height, 0.0, 1.0);
  e.cam_observer_gain = c.real_or("cam_observer_gain", e.cam_observer_gain, 0.1, 1e4);
  e.initialisation_time = c.real_or("initialisation_time", e.initialisation_time, 0.0, 60.0);
  e.max_position_std = c.real_or("max_position_std", e.max_position_std, 1e-4, 100.0);
  e.max_accel = c.real_or("max_accel", e.max_accel, 1.0, 1e4);
  e.max_gyro = c.real_or("max_gyro", e.max_gyro, 0.1, 1e4);
  e.max_ft_force = c.real_or("max_ft_force", e.max_ft_force, 1.0, 1e6);
  e.joint_limit_margin = c.real_or("joint_limit_margin", e.joint_limit_margin, 0.0, 10.0);
  return e;
}

}  // namespace hpr::estimator
