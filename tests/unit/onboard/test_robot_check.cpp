// Onboarding: the feet and soles found in a description equal what the robots' hand-written
// configurations say (TORO-like, H1-2) and what the G1's four contact spheres give.
#include <gtest/gtest.h>

#include "hpr/onboard/robot_check.hpp"
#include "model_fixture.hpp"
#include "shell.hpp"

namespace {

using namespace hpr;

void expect_feet_as_configured(const std::string& name) {
  const auto robot = test::load_robot(name);
  const model::Model full = robot.full_model();
  const auto feet = onboard::find_feet(full, robot.description);
  const Config cfg = Config::load(test::source_dir() + "/config/" + name + ".yaml").section("robot").section("feet");
  for (int k = 0; k < 2; ++k) {
    const auto& f = feet[static_cast<size_t>(k)];
    const Config side = cfg.section(model::kFootNames[static_cast<size_t>(k)]);
    EXPECT_EQ(f.link, side.string("link")) << name;
    EXPECT_EQ(f.leg_joints.size(), 6U) << name;
    const auto size = side.reals("sole_size", 2);
    EXPECT_NEAR(f.sole.length, size[0], 1e-9) << name;
    EXPECT_NEAR(f.sole.width, size[1], 1e-9) << name;
    EXPECT_LT((f.sole.centre - side.vec3("sole_xyz")).norm(), 1e-9) << name;
  }
}

TEST(RobotCheck, FeetAndSolesOfTheConfiguredRobots) {
  expect_feet_as_configured("toro");
  expect_feet_as_configured("h1_2");
}

TEST(RobotCheck, G1SoleFromItsFourContactSpheres) {
  // Spheres of radius 5 mm at x = -0.05 (y = +-0.025) and x = 0.12 (y = +-0.03), z = -0.03: the
  // rectangle over the whole length is 0.17 long and as wide as the heel, 0.05.
  const auto d = model::load_urdf(test::source_dir() + "/models/unitree_g1/g1_29dof_with_hand.urdf");
  const model::Model m = model::Model::build(d);
  const auto feet = onboard::find_feet(m, d);
  EXPECT_EQ(feet[0].link, "right_ankle_roll_link");
  EXPECT_EQ(feet[1].link, "left_ankle_roll_link");
  for (const auto& f : feet) {
    EXPECT_NEAR(f.sole.length, 0.17, 1e-12);
    EXPECT_NEAR(f.sole.width, 0.05, 1e-12);
    EXPECT_LT((f.sole.centre - Eigen::Vector3d(0.035, 0.0, -0.035)).norm(), 1e-12);
    EXPECT_EQ(f.sole.from, "4 spheres");
  }
  const std::string report = onboard::check_report(d, m);
  EXPECT_NE(report.find("43 revolute"), std::string::npos) << report;
  EXPECT_NE(report.find("every one found"), std::string::npos) << report;
}

TEST(RobotCheck, SoleOfAMeshFootIsItsHullsBottomFace) {
  // The fixture's foot: the 0.1 x 0.2 x 0.3 box mesh scaled (2, 1, 0.5), 0.1 below the link origin:
  // bottom face 0.2 x 0.2 at z = -0.1 (the box spans z 0 to 0.3, scaled to 0 to 0.15).
  const auto d = model::load_urdf(test::source_dir() + "/tests/unit/model/urdf/mesh_robot/urdf/mesh_robot.urdf");
  const auto sole = onboard::sole_from_geometry(*d.find_link("foot"));
  EXPECT_NEAR(sole.length, 0.2, 1e-6);
  EXPECT_NEAR(sole.width, 0.2, 1e-6);
  EXPECT_NEAR(sole.centre.z(), -0.1, 1e-6);
  EXPECT_EQ(sole.from, "1 mesh");
}

TEST(RobotCheck, TheImuIsFoundByNameAnywhereOnTheTreeAndTheReportSaysWhy) {
  // The fixture biped's imu_link sits on the torso, one waist joint from the pelvis.
  const auto d = model::load_urdf(test::source_dir() + "/tests/unit/onboard/fixtures/biped-description-main/urdf/biped.urdf");
  const model::Model m = model::Model::build(d);
  const auto imu = onboard::find_imu(m);
  EXPECT_EQ(imu.link, "imu_link");
  EXPECT_NE(imu.why.find("on 'torso', 1 moving joint from the base (waist_yaw_joint)"), std::string::npos) << imu.why;
  const std::string report = onboard::check_report(d, m);
  EXPECT_NE(report.find("IMU: 'imu_link'"), std::string::npos) << report;
  EXPECT_EQ(report.find("warning"), std::string::npos) << report;
  // The G1 has one in the pelvis and one in the torso: the one rigidly on the base.
  const auto g1 = model::load_urdf(test::source_dir() + "/models/unitree_g1/g1_29dof_with_hand.urdf");
  const auto g1_imu = onboard::find_imu(model::Model::build(g1));
  EXPECT_EQ(g1_imu.link, "imu_in_pelvis");
  EXPECT_NE(g1_imu.why.find("rigidly on the base"), std::string::npos) << g1_imu.why;
  // None: the base, and what to do.
  const auto toro = model::Model::build(test::load_robot("toro").description);
  const auto none = onboard::find_imu(toro);
  EXPECT_EQ(none.link, toro.body_name.front());
  EXPECT_NE(none.why.find("set robot.imu.link"), std::string::npos) << none.why;
}

TEST(RobotCheck, AFootMeshOffToTheSideIsWarnedAboutInTheReport) {
  std::string xml = test::read_file(test::source_dir() + "/tests/unit/onboard/fixtures/biped-description-main/urdf/biped.urdf");
  const std::string centred = R"(<origin xyz="0.03 0 -0.06" rpy="0 0 1.5707963267948966"/>)";
  const std::string aside = R"(<origin xyz="0.03 0.042 -0.06" rpy="0 0 1.5707963267948966"/>)";
  for (size_t at = xml.find(centred); at != std::string::npos; at = xml.find(centred)) xml.replace(at, centred.size(), aside);
  const auto d = model::parse_urdf(xml, test::source_dir() + "/tests/unit/onboard/fixtures/biped-description-main/urdf/biped.urdf");
  const std::string report = onboard::check_report(d, model::Model::build(d));
  EXPECT_NE(report.find("warning: the sole of 'l_foot' is centred 4.2 cm to the side"), std::string::npos) << report;
  EXPECT_NE(report.find("warning: the sole of 'r_foot' is centred 4.2 cm to the side"), std::string::npos) << report;
}

}  // namespace
