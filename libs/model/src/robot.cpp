#include "hpr/model/robot.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <filesystem>

#include "hpr/model/algorithms.hpp"

namespace hpr::model {

namespace {
SE3 pose_from(const Config& c, const std::string& xyz_key, const std::string& rpy_key) {
  SE3 X;
  X.p = c.vec3_or(xyz_key, Vector3d::Zero());
  const Vector3d rpy = c.vec3_or(rpy_key, Vector3d::Zero());
  X.R = (Eigen::AngleAxisd(rpy.z(), Vector3d::UnitZ()) * Eigen::AngleAxisd(rpy.y(), Vector3d::UnitY()) *
         Eigen::AngleAxisd(rpy.x(), Vector3d::UnitX()))
            .toRotationMatrix();
  return X;
}
}  // namespace

std::vector<int> RobotSpec::joints(const std::vector<std::string>& names, const Config& where,
                                   const std::string& key) const {
  std::vector<int> out;
  for (const auto& n : names) {
    bool found = false;
    for (int j = 0; j < model.nj; ++j) {
      if (model.joint_name[static_cast<size_t>(j)] == n) {
        out.push_back(j);
        found = true;
      }
    }
    if (!found && held.count(n) != 0) {
      where.fail(key, fmt::format("'{}' is held (robot.held_joints): it is not a joint of the controllers' model", n));
    }
    if (!found) where.fail(key, fmt::format("'{}' is not a joint of {}", n, model.source));
  }
  return out;
}

namespace {

/// A controlled joint needs its limits: the controllers bound torques and velocities by them and the
/// drives' scaling comes from them (an effort of 0 would silently leave a joint without a motor).
void check_joint_limits(const RobotSpec& r, const Config& c, const std::string& urdf) {
  for (int j = 0; j < r.model.nj; ++j) {
    const auto ju = static_cast<size_t>(j);
    const model::JointDesc& jd = *r.description.find_joint(r.model.joint_name[ju]);
    std::string why;
    if (!jd.has_limits) {
      why = "has no <limit>";
    } else if (!(jd.effort > 0.0)) {
      why = fmt::format("has <limit effort=\"{}\">: a controlled joint needs a positive effort", jd.effort);
    } else if (!(jd.velocity > 0.0)) {
      why = fmt::format("has <limit velocity=\"{}\">: a controlled joint needs a positive velocity", jd.velocity);
    }
    if (!why.empty()) {
      c.fail("urdf", fmt::format("{}: joint '{}' {} (hold it with robot.held_joints if the balance controller does not "
                                 "use it)", urdf, jd.name, why));
    }
  }
}

/// A frame added to the model (a sole, an F/T sensor, the IMU), kept for the models built later.
int add_frame(RobotSpec& r, const std::string& frame_name, const std::string& link, const SE3& X_LF) {
  r.added_frames.push_back(AddedFrame{frame_name, link, X_LF});
  return r.model.add_frame(frame_name, link, X_LF);
}

/// The feet (`feet.right`, `feet.left`): link, sole, F/T sensor and the six joints of each leg; the
/// joints that are not the legs' are the free ones.
void load_feet(RobotSpec& r, const Config& c, const std::string& urdf) {
  const Config feet = c.section("feet");
  for (int k = 0; k < 2; ++k) {
    const std::string side = kFootNames[static_cast<size_t>(k)];
    const Config f = feet.section(side);
    FootSpec& fs = r.feet[static_cast<size_t>(k)];
    fs.link = f.string("link");
    if (!r.model.has_frame(fs.link)) f.fail("link", fmt::format("no such link in {}", urdf));
    fs.sole_frame = add_frame(r, side + "_sole", fs.link, pose_from(f, "sole_xyz", "sole_rpy"));
    const auto size = f.reals("sole_size", 2, 0.01, 1.0);
    fs.length = size[0];
    fs.width = size[1];
    fs.ft_link = f.string_or("ft_link", fs.link);
    if (!r.model.has_frame(fs.ft_link)) f.fail("ft_link", fmt::format("no such link in {}", urdf));
    fs.ft_frame = add_frame(r, side + "_ft", fs.ft_link, pose_from(f, "ft_xyz", "ft_rpy"));
    fs.leg_joints = r.model.support[static_cast<size_t>(r.model.frames[static_cast<size_t>(fs.sole_frame)].body)];
    if (fs.leg_joints.size() != 6) {
      f.fail("link", fmt::format("the {} leg has {} joints between the base and the foot; the task Jacobian (2) "
                                 "needs 6 per leg", side, fs.leg_joints.size()));
    }
  }
  r.leg_joints = r.feet[kRight].leg_joints;
  r.leg_joints.insert(r.leg_joints.end(), r.feet[kLeft].leg_joints.begin(), r.feet[kLeft].leg_joints.end());
  for (int j = 0; j < r.model.nj; ++j) {
    if (std::find(r.leg_joints.begin(), r.leg_joints.end(), j) == r.leg_joints.end()) r.free_joints.push_back(j);
  }
}

/// `standing_posture` (within the joints' limits) and `segments` (a held joint moves nothing: it
/// leaves its segment).
void load_posture_and_segments(RobotSpec& r, const Config& c) {
  r.q_joints_stand = Eigen::VectorXd::Zero(r.model.nj);
  if (c.has("standing_posture")) {
    const Config s = c.section("standing_posture");
    for (const auto& key : s.keys()) {
      const int j = r.joints({key}, s, key).front();
      const double v = s.real(key);
      const auto ju = static_cast<size_t>(j);
      if (v < r.model.q_lower[ju] || v > r.model.q_upper[ju]) {
        s.fail(key, fmt::format("outside the joint limits [{}, {}]", r.model.q_lower[ju], r.model.q_upper[ju]));
      }
      r.q_joints_stand(j) = v;
    }
  }
  if (c.has("segments")) {
    const Config s = c.section("segments");
    for (const auto& key : s.keys()) {
      std::vector<std::string> names;
      for (const auto& n : s.strings(key)) {
        if (r.held.count(n) == 0) names.push_back(n);
      }
      r.segments[key] = r.joints(names, s, key);
    }
  }
}

}  // namespace

RobotSpec RobotSpec::load(const Config& c) {
  RobotSpec r;
  r.name = c.string("name");
  const std::string urdf = c.file_path("urdf");
  UrdfOptions urdf_options;
  if (c.has("mesh_search_paths")) {
    for (const auto& p : c.strings("mesh_search_paths")) {
      std::filesystem::path path(p);
      if (path.is_relative()) path = std::filesystem::path(c.file()).parent_path() / path;
      urdf_options.mesh_search_paths.push_back(path.string());
    }
  }
  ModelOptions model_options;
  model_options.base_link = c.string_or("base_link", "");
  if (c.has("held_joints")) {
    const Config h = c.section("held_joints");
    for (const auto& key : h.keys()) model_options.held[key] = h.real(key);
  }
  r.held = model_options.held;
  r.mesh_collision = c.choice_or("collision_meshes", "convex_hull", {"convex_hull", "box"}) == "box"
                         ? MeshCollision::kBox
                         : MeshCollision::kConvexHull;
  r.mesh_hull_points = static_cast<int>(c.integer_or("mesh_hull_points", r.mesh_hull_points, 8, 1000));
  try {
    r.description = load_urdf(urdf, urdf_options);
  } catch (const ModelError& e) {
    c.fail("urdf", e.what());
  }
  if (c.has("held_joints")) {
    const Config h = c.section("held_joints");
    for (const auto& [name, q] : model_options.held) {
      if (const std::string why = check_held_joint(r.description, name, q); !why.empty()) {
        h.fail(name, fmt::format("{} ({})", why, urdf));
      }
    }
  }
  try {
    r.model = Model::build(r.description, model_options);
  } catch (const ModelError& e) {
    c.fail("urdf", e.what());
  }
  check_joint_limits(r, c, urdf);
  load_feet(r, c, urdf);
  const Config imu = c.section("imu");
  const std::string imu_link = imu.string("link");
  if (!r.model.has_frame(imu_link)) imu.fail("link", fmt::format("no such link in {}", urdf));
  r.imu_frame = add_frame(r, "imu", imu_link, pose_from(imu, "xyz", "rpy"));
  load_posture_and_segments(r, c);
  return r;
}

Model RobotSpec::full_model(bool held_rigid) const {
  ModelOptions options;
  options.base_link = model.body_name.front();
  options.physical_inertia = true;
  if (held_rigid) {
    options.held = held;
  } else {
    options.leader_positions = held;
  }
  Model full = Model::build(description, options);
  for (const auto& f : added_frames) full.add_frame(f.name, f.link, f.X_LF);
  return full;
}

Eigen::VectorXd RobotSpec::standing_configuration() const {
  Eigen::VectorXd q = model.neutral();
  q.tail(model.nj) = q_joints_stand;
  Data data(model);
  forward_kinematics(model, data, q);
  update_frame_placements(model, data);
  const SE3& r = data.oMf[static_cast<size_t>(feet[kRight].sole_frame)];
  const SE3& l = data.oMf[static_cast<size_t>(feet[kLeft].sole_frame)];
  // Level the base so that the mean sole orientation is flat, then put the soles on z = 0, centred.
  const Vector3d tilt = log3(r.R) * 0.5 + log3(l.R) * 0.5;
  const Matrix3d Rb = exp3(Vector3d(-tilt.x(), -tilt.y(), 0.0));
  Eigen::Quaterniond qb(Rb);
  q(3) = qb.x();
  q(4) = qb.y();
  q(5) = qb.z();
  q(6) = qb.w();
  forward_kinematics(model, data, q);
  update_frame_placements(model, data);
  const Vector3d mid = 0.5 * (data.oMf[static_cast<size_t>(feet[kRight].sole_frame)].p +
                              data.oMf[static_cast<size_t>(feet[kLeft].sole_frame)].p);
  q.head<3>() -= mid;
  return q;
}

}  // namespace hpr::model
