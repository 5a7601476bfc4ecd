// What real robot descriptions ship: each rule of the loader against a minimal fixture in
// tests/unit/model/urdf/, and held joints checked against the full model's dynamics.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <filesystem>
#include <fstream>

#include "hpr/mesh/mesh.hpp"
#include "hpr/model/algorithms.hpp"
#include "hpr/model/model.hpp"
#include "model_fixture.hpp"
#include "shell.hpp"

namespace {

using namespace hpr;
using model::Model;
using model::ModelError;
using model::ModelOptions;

std::string fixture(const std::string& name) { return test::source_dir() + "/tests/unit/model/urdf/" + name; }

bool mentions(const std::vector<std::string>& lines, const std::string& a, const std::string& b) {
  for (const auto& l : lines) {
    if (l.find(a) != std::string::npos && l.find(b) != std::string::npos) return true;
  }
  return false;
}

Eigen::Vector3d principal(const Eigen::Matrix3d& I) { return Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(I).eigenvalues(); }

TEST(UrdfRepairs, InertialOfMassZeroIsNoInertia) {
  const auto d = model::load_urdf(fixture("massless_camera.urdf"));
  ASSERT_EQ(d.repairs.size(), 1U);
  EXPECT_TRUE(mentions(d.repairs, "link 'camera'", "mass 0")) << d.repairs.front();
  EXPECT_FALSE(d.find_link("camera")->has_inertial);
  const Model m = Model::build(d);
  EXPECT_NEAR(m.mass, 2.0, 1e-15);
  EXPECT_TRUE(m.has_frame("camera"));
}

TEST(UrdfRepairs, PointMassesAreExactInTheModelAndRegularisedForTheSimulator) {
  const auto d = model::load_urdf(fixture("point_mass_sensor.urdf"));
  EXPECT_TRUE(mentions(d.repairs, "link 'imu'", "point mass"));
  EXPECT_TRUE(mentions(d.repairs, "link 'probe'", "point mass"));
  const model::LinkDesc& imu = *d.find_link("imu");
  EXPECT_TRUE(imu.inertia.isZero(0.0));                       // the file's, untouched
  EXPECT_GT(principal(imu.inertia_physical)(0), 0.0);         // the simulator's: positive definite
  EXPECT_NEAR(imu.inertia_physical.trace() / 3.0, 0.01 * 0.002 * 0.002, 1e-15);  // radius of gyration 2 mm

  const Model m = Model::build(d);
  // The base body keeps the exact inertia: 2 kg box plus a 0.01 kg point at (0, 0.05, 0.1).
  const Eigen::Vector3d c(0, 0.05, 0.1);
  model::Inertia expected = model::Inertia::from_com(2.0, Eigen::Vector3d::Zero(), 0.02 * Eigen::Matrix3d::Identity());
  expected += model::Inertia::from_com(0.01, c, Eigen::Matrix3d::Zero());
  EXPECT_LT((m.inertia[0].I - expected.I).norm(), 1e-15);
  // The probe alone on its joint has no rotational inertia in the file: the model takes the
  // regularised one for that body, and says so.
  EXPECT_TRUE(mentions(m.warnings, "body 'probe'", "regularised"));
  EXPECT_GT(principal(m.inertia[1].inertia_about_com())(0), 0.0);
}

TEST(UrdfRepairs, TriangleInequalityRoundingIsClosedMinimally) {
  const auto d = model::load_urdf(fixture("triangle_rounding.urdf"));
  ASSERT_EQ(d.repairs.size(), 1U);
  EXPECT_TRUE(mentions(d.repairs, "link 'arm'", "triangle inequality")) << d.repairs.front();
  const model::LinkDesc& arm = *d.find_link("arm");
  const Eigen::Vector3d e = principal(arm.inertia_physical);
  EXPECT_NEAR(e(0) + e(1), e(2), 1e-12);              // on the boundary: the smallest change
  const double deficit = 0.205 - 0.2;
  EXPECT_NEAR(e(0), 0.1 + deficit / 3, 1e-12);
  EXPECT_NEAR(e(2), 0.205 - deficit / 3, 1e-12);
  EXPECT_TRUE(model::check_inertia(arm.inertia_physical).empty());
  // The controllers' model keeps the file's values; the simulator's takes the repaired ones.
  const Model exact = Model::build(d);
  ModelOptions physical;
  physical.physical_inertia = true;
  const Model sim = Model::build(d, physical);
  EXPECT_NEAR(principal(exact.inertia[1].inertia_about_com())(2), 0.205, 1e-12);
  EXPECT_NEAR(principal(sim.inertia[1].inertia_about_com())(2), 0.205 - deficit / 3, 1e-12);
}

TEST(UrdfRepairs, TinyNegativeMomentIsRaised) {
  const auto d = model::load_urdf(fixture("tiny_negative_moment.urdf"));
  EXPECT_TRUE(mentions(d.repairs, "link 'rod'", "not all positive"));
  EXPECT_GT(principal(d.find_link("rod")->inertia_physical)(0), 0.0);
  // The file's inertia is not positive definite: the model uses the regularised one for the body.
  const Model m = Model::build(d);
  EXPECT_TRUE(mentions(m.warnings, "body 'rod'", "regularised"));
}

TEST(UrdfRepairs, RegularisationRefusesWhatIsFarFromPhysical) {
  // A negative moment of 10 % of the largest, and a triangle deficit of 20 %.
  auto r = model::regularise_inertia(1.0, Eigen::Vector3d(-0.001, 0.01, 0.01).asDiagonal());
  EXPECT_NE(r.error.find("not positive definite"), std::string::npos);
  r = model::regularise_inertia(1.0, Eigen::Vector3d(0.04, 0.04, 0.1).asDiagonal());
  EXPECT_NE(r.error.find("triangle inequality"), std::string::npos);
  // A consistent inertia is left exactly as it is.
  const Eigen::Matrix3d I = Eigen::Vector3d(0.02, 0.03, 0.04).asDiagonal();
  r = model::regularise_inertia(1.0, I);
  EXPECT_TRUE(r.what.empty());
  EXPECT_TRUE(r.error.empty());
  EXPECT_EQ(r.I_c, I);
}

TEST(UrdfRepairs, MimicJointIsLockedAndSaidSo) {
  const auto d = model::load_urdf(fixture("mimic_gripper.urdf"));
  EXPECT_EQ(d.find_joint("right_finger_joint")->mimic, "left_finger_joint");
  const Model m = Model::build(d);
  EXPECT_EQ(m.nj, 1);
  EXPECT_EQ(m.joint_name.front(), "left_finger_joint");
  EXPECT_TRUE(mentions(m.warnings, "joint 'right_finger_joint'", "locked at 0.1"));
  EXPECT_TRUE(m.held_joint_name.empty());  // locked, not held: no drive holds it
  ASSERT_EQ(m.locked_joint_name.size(), 1U);
  EXPECT_NEAR(m.locked_q[0], 0.1, 1e-15);
  // Held leader: the follower is locked where the leader's held position puts it.
  ModelOptions o;
  o.held["left_finger_joint"] = 0.3;
  const Model held = Model::build(d, o);
  EXPECT_EQ(held.nj, 0);
  ASSERT_EQ(held.held_q.size(), 1U);
  ASSERT_EQ(held.locked_q.size(), 1U);
  EXPECT_NEAR(held.locked_q[0], -0.3 + 0.1, 1e-15);
  // A simulator's model keeps the leader free and locks the follower at the same place.
  model::ModelOptions sim;
  sim.leader_positions = o.held;
  const Model full = Model::build(d, sim);
  EXPECT_EQ(full.nj, 1);
  ASSERT_EQ(full.locked_q.size(), 1U);
  EXPECT_NEAR(full.locked_q[0], -0.3 + 0.1, 1e-15);
  // The follower cannot be held itself.
  model::ModelOptions bad;
  bad.held["right_finger_joint"] = 0.0;
  try {
    (void)Model::build(d, bad);
    FAIL() << "accepted";
  } catch (const ModelError& e) {
    EXPECT_NE(std::string(e.what()).find("hold 'left_finger_joint' instead"), std::string::npos) << e.what();
  }
}

TEST(UrdfRepairs, MeshesResolveFromPackageAndRelativePaths) {
  const auto d = model::load_urdf(fixture("mesh_robot/urdf/mesh_robot.urdf"));
  const auto& base = *d.find_link("base");
  ASSERT_EQ(base.collisions.size(), 1U);
  ASSERT_EQ(base.visuals.size(), 1U);
  namespace fs = std::filesystem;
  EXPECT_TRUE(fs::equivalent(base.collisions[0].mesh, fixture("mesh_robot/meshes/box.stl")));
  EXPECT_TRUE(fs::equivalent(base.visuals[0].mesh, fixture("mesh_robot/meshes/box.obj")));
  EXPECT_EQ(base.collisions[0].mesh_uri, "package://mesh_robot/meshes/box.stl");
  EXPECT_NEAR(base.visuals[0].rgba(2), 0.8, 1e-6);  // the material defined at the top level (float in urdfdom)
  const auto& foot = *d.find_link("foot");
  EXPECT_TRUE(fs::equivalent(foot.collisions[0].mesh, fixture("mesh_robot/meshes/box.stl")));
  ASSERT_EQ(foot.visuals.size(), 1U);
  // STL, OBJ and COLLADA (declared Z_UP: kept in its own axes, as URDF tools read it) give the
  // same box, z the long side; the scale applies per axis.
  for (const auto& g : {base.collisions[0], base.visuals[0], foot.collisions[0], foot.visuals[0]}) {
    const auto mesh = mesh::load(g.mesh, g.mesh_scale);
    Eigen::Vector3d lo = mesh.vertices.front(), hi = lo;
    for (const auto& v : mesh.vertices) {
      lo = lo.cwiseMin(v);
      hi = hi.cwiseMax(v);
    }
    const Eigen::Vector3d size = (hi - lo).cwiseQuotient(g.mesh_scale);
    EXPECT_LT((size - Eigen::Vector3d(0.1, 0.2, 0.3)).norm(), 1e-6) << g.mesh;
    EXPECT_EQ(mesh.triangles.size(), 12U) << g.mesh;
    EXPECT_NEAR(hi.x() - lo.x(), 0.1 * g.mesh_scale.x(), 1e-6);
  }
}

TEST(UrdfRepairs, MissingMeshIsAnErrorNamingIt) {
  try {
    (void)model::load_urdf(fixture("mesh_robot/urdf/missing_mesh.urdf"));
    FAIL() << "no error";
  } catch (const ModelError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("missing_mesh.urdf"), std::string::npos) << msg;
    EXPECT_NE(msg.find("link 'base'"), std::string::npos) << msg;
    EXPECT_NE(msg.find("no_such_file.stl"), std::string::npos) << msg;
  }
}

TEST(UrdfRepairs, HullPointsAreBoundedAndTouchTheHull) {
  // 2000 points on a sphere of radius 0.1: 64 support points lose little of the hull.
  std::vector<Eigen::Vector3d> points;
  for (const auto& d : mesh::sphere_directions(2000)) points.push_back(0.1 * d);
  const auto hull = mesh::hull_points(points, 64);
  EXPECT_LE(hull.size(), 64U);
  EXPECT_GE(hull.size(), 48U);
  const double gap = mesh::hull_gap(points, hull);
  EXPECT_GT(gap, 0.0);
  EXPECT_LT(gap, 0.1 * (1.0 - std::cos(0.5)));  // well inside the cap between neighbouring directions
  // A box's 8 corners are all found, and nothing is lost.
  std::vector<Eigen::Vector3d> box;
  for (int k = 0; k < 8; ++k) box.emplace_back(k & 1 ? 0.1 : -0.1, k & 2 ? 0.2 : -0.2, k & 4 ? 0.3 : -0.3);
  for (int k = 0; k < 100; ++k) box.emplace_back(0.05 * std::sin(k), 0.1 * std::cos(k), 0.005 * k - 0.25);
  const auto box_hull = mesh::hull_points(box, 64);
  EXPECT_EQ(box_hull.size(), 8U);
  EXPECT_NEAR(mesh::hull_gap(box, box_hull), 0.0, 1e-15);
}

// The reduced model of Pinocchio's kind: with joints held, mass, CoM and the joint-space inertia of
// the remaining joints equal the full model's at the held positions.
TEST(HeldJoints, ReducedModelMatchesTheFullModel) {
  const auto robot = test::load_robot("toro");
  const auto& d = robot.description;
  ModelOptions o;
  o.base_link = robot.model.body_name.front();
  o.held = {{"r_wrist_yaw", 0.4}, {"l_elbow", -0.7}, {"neck_yaw", 0.2}};
  const Model full = Model::build(d, o.base_link);
  const Model reduced = Model::build(d, o);
  EXPECT_EQ(reduced.nj, full.nj - 3);
  EXPECT_NEAR(reduced.mass, full.mass, 1e-12);
  ASSERT_EQ(reduced.held_joint_name.size(), 3U);

  test::RandomState rs(3);
  Eigen::VectorXd q_red = rs.q(reduced);
  Eigen::VectorXd q_full(full.nq);
  q_full.head<7>() = q_red.head<7>();
  std::vector<int> map;
  for (int j = 0; j < reduced.nj; ++j) {
    map.push_back(full.joint_index(reduced.joint_name[static_cast<size_t>(j)]));
    q_full(7 + map.back()) = q_red(7 + j);
  }
  for (const auto& [name, q] : o.held) q_full(7 + full.joint_index(name)) = q;
  model::Data dr(reduced), df(full);
  model::crba(reduced, dr, q_red);
  model::crba(full, df, q_full);
  model::forward_kinematics(reduced, dr, q_red);
  model::forward_kinematics(full, df, q_full);
  model::update_frame_placements(reduced, dr);
  model::update_frame_placements(full, df);
  std::vector<int> idx = {0, 1, 2, 3, 4, 5};
  for (int j : map) idx.push_back(6 + j);
  for (size_t a = 0; a < idx.size(); ++a) {
    for (size_t b = 0; b < idx.size(); ++b) {
      EXPECT_NEAR(dr.M(static_cast<Eigen::Index>(a), static_cast<Eigen::Index>(b)), df.M(idx[a], idx[b]), 1e-12);
    }
  }
  const int hand = reduced.frame_index("r_hand");
  EXPECT_LT((dr.oMf[static_cast<size_t>(hand)].p - df.oMf[static_cast<size_t>(full.frame_index("r_hand"))].p).norm(), 1e-14);
}

TEST(HeldJoints, ConfigurationNamesTheKeyOfAnUnknownOrOutOfRangeJoint) {
  const std::string cfg = test::source_dir() + "/config/toro.yaml";
  for (const auto& [set, expect] : {std::pair{"robot.held_joints={no_such_joint: 0.0}", "no_such_joint"},
                                    std::pair{"robot.held_joints={r_wrist_yaw: 9.0}", "outside its limits"},
                                    std::pair{"robot.held_joints={r_elbow: 0.0}", "is held"}}) {
    try {
      (void)model::RobotSpec::load(Config::load(cfg, {set}).section("robot"));
      FAIL() << set;
    } catch (const ConfigError& e) {
      const std::string msg = e.what();
      // An unknown or out-of-range held joint names its key under robot.held_joints; a held joint that the
      // standing posture still lists names robot.standing_posture.r_elbow.
      const std::string key = std::string(expect) == "is held"       ? "robot.standing_posture.r_elbow"
                              : std::string(expect) == "no_such_joint" ? "robot.held_joints.no_such_joint"
                                                                       : "robot.held_joints.r_wrist_yaw";
      EXPECT_NE(msg.find(key), std::string::npos) << msg;
      EXPECT_NE(msg.find(expect), std::string::npos) << msg;
    }
  }
}

TEST(RobotConfiguration, NamesWhatTheUrdfLacksOrCannotDrive) {
  const std::string cfg = test::source_dir() + "/config/toro.yaml";
  auto error_of = [&](const std::vector<std::string>& overrides) -> std::string {
    try {
      (void)model::RobotSpec::load(Config::load(cfg, overrides).section("robot"));
    } catch (const ConfigError& e) {
      return e.what();
    }
    return "";
  };
  // A link the URDF lacks: the key, the value and the URDF.
  std::string msg = error_of({"robot.feet.left.link=no_such_foot"});
  EXPECT_NE(msg.find("robot.feet.left.link"), std::string::npos) << msg;
  EXPECT_NE(msg.find("no_such_foot"), std::string::npos) << msg;
  EXPECT_NE(msg.find("toro.urdf"), std::string::npos) << msg;
  // A joint the URDF lacks.
  msg = error_of({"robot.segments.torso=[waist_yaw, no_such_joint]"});
  EXPECT_NE(msg.find("robot.segments.torso"), std::string::npos) << msg;
  EXPECT_NE(msg.find("no_such_joint"), std::string::npos) << msg;
  EXPECT_NE(msg.find("toro.urdf"), std::string::npos) << msg;
}

TEST(RobotConfiguration, AControlledJointWithoutEffortIsRefused) {
  // The TORO-like URDF with effort="0" on the right elbow, next to the original.
  const std::string dir = test::temp_dir("effort0");
  std::string urdf = test::read_file(test::source_dir() + "/models/toro/toro.urdf");
  const auto j = urdf.find("<joint name=\"r_elbow\"");
  ASSERT_NE(j, std::string::npos);
  const auto e = urdf.find("effort=\"", j) + 8;
  urdf = urdf.substr(0, e) + "0" + urdf.substr(urdf.find('"', e));
  std::ofstream(dir + "/toro.urdf") << urdf;
  const std::string cfg = test::source_dir() + "/config/toro.yaml";
  try {
    (void)model::RobotSpec::load(Config::load(cfg, {"robot.urdf=" + dir + "/toro.urdf"}).section("robot"));
    FAIL() << "accepted";
  } catch (const ConfigError& ex) {
    const std::string msg = ex.what();
    EXPECT_NE(msg.find("r_elbow"), std::string::npos) << msg;
    EXPECT_NE(msg.find("effort=\"0\""), std::string::npos) << msg;
  }
  // Held, the same joint is fine.
  const auto spec = model::RobotSpec::load(
      Config::load(cfg, {"robot.urdf=" + dir + "/toro.urdf", "robot.held_joints={r_elbow: -0.4}",
                         "robot.standing_posture={r_hip_pitch: -0.25, r_knee: 0.5, r_ankle_pitch: -0.25, l_hip_pitch: -0.25, "
                         "l_knee: 0.5, l_ankle_pitch: -0.25}"})
          .section("robot"));
  EXPECT_EQ(spec.model.nj, 26);
}

}  // namespace
