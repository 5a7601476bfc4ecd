// hpr_robot init's draft: a configuration every process loads, whose standing posture has the soles
// flat and level, the CoM over their middle and the hips at the asked height.
#include <gtest/gtest.h>

#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>

#include "hpr/model/algorithms.hpp"
#include "hpr/onboard/robot_draft.hpp"
#include "model_fixture.hpp"
#include "scratch_dir.hpp"
#include "shell.hpp"

namespace {

using namespace hpr;

// Writes the draft's configuration next to the source config folder's files (so that relative
// paths resolve as for a user's file) and loads it as the processes do.
model::RobotSpec write_and_load(const onboard::RobotDraft& draft, const std::string& urdf, const std::string& file) {
  namespace fs = std::filesystem;
  static const hpr::test::ScratchDir scratch("draft");
  const fs::path& dir = scratch.path();
  const fs::path out = dir / file;
  const std::string text = onboard::write_config(draft, test::read_file(test::source_dir() + "/config/templates/robot.yaml"),
                                                 fs::relative(urdf, dir).string(), "test");
  std::ofstream(out) << text;
  const Config cfg = Config::load(out.string());
  // Every section the processes read is there.
  for (const char* s : {"robot", "balance", "estimator", "wbc", "reference_gen", "motion_opt", "sim"}) {
    EXPECT_TRUE(cfg.has(s)) << s;
  }
  EXPECT_EQ(text.find("{{"), std::string::npos);
  return model::RobotSpec::load(cfg.section("robot"));
}

void expect_standing_posture(const model::RobotSpec& spec, double fraction) {
  const Eigen::VectorXd q = spec.standing_configuration();
  model::Data data(spec.model);
  model::forward_kinematics(spec.model, data, q);
  model::update_frame_placements(spec.model, data);
  const Eigen::Vector3d c = model::center_of_mass(spec.model, data, q);
  Eigen::Vector3d mid = Eigen::Vector3d::Zero();
  for (const auto& f : spec.feet) {
    const model::SE3& X = data.oMf[static_cast<size_t>(f.sole_frame)];
    EXPECT_LT((X.R - Eigen::Matrix3d::Identity()).norm(), 1e-6);  // flat and level
    EXPECT_NEAR(X.p.z(), 0.0, 1e-9);
    mid += 0.5 * X.p;
    // The hip (first leg joint) at `fraction` of the straight leg's length above the sole.
    const int hip_body = f.leg_joints.front() + 1;
    const double height = data.oMi[static_cast<size_t>(hip_body)].p.z() - X.p.z();
    Eigen::VectorXd q0 = spec.model.neutral();
    model::Data d0(spec.model);
    model::forward_kinematics(spec.model, d0, q0);
    model::update_frame_placements(spec.model, d0);
    const double length = (d0.oMi[static_cast<size_t>(hip_body)].p - d0.oMf[static_cast<size_t>(f.sole_frame)].p).norm();
    EXPECT_NEAR(height / length, fraction, 2e-3);  // posture written with 4 decimals
  }
  EXPECT_NEAR(c.x(), mid.x(), 2e-3);
}

TEST(RobotDraft, ToroLikeFromItsUrdf) {
  const auto robot = test::load_robot("toro");
  onboard::DraftOptions o;
  o.leg_height_fraction = 0.93;
  const auto draft = onboard::draft_robot(robot.description, o);
  EXPECT_EQ(draft.feet[0].link, "r_foot");
  EXPECT_EQ(draft.feet[1].link, "l_foot");
  EXPECT_NEAR(draft.com_stiffness.x(), robot.model.mass * 4.5 * 4.5, 1e-9);
  const auto spec = write_and_load(draft, robot.description.source, "toro_draft.yaml");
  expect_standing_posture(spec, 0.93);
}

TEST(RobotDraft, G1HoldsItsFingersAndAdjustsTorsoAndArms) {
  const std::string urdf = test::source_dir() + "/models/unitree_g1/g1_29dof_with_hand.urdf";
  const auto draft = onboard::draft_robot(model::load_urdf(urdf));
  ASSERT_EQ(draft.held.size(), 14U);
  for (const auto& [name, q] : draft.held) {
    EXPECT_NE(name.find("_hand_"), std::string::npos) << name;
    EXPECT_EQ(q, 0.0) << name;
  }
  EXPECT_EQ(draft.imu_link, "imu_in_pelvis");
  const std::vector<std::string> adjusted = {"base_rotation", "waist_yaw_joint", "waist_roll_joint", "waist_pitch_joint",
                                             "right_shoulder_pitch_joint", "right_shoulder_roll_joint",
                                             "right_shoulder_yaw_joint", "right_elbow_joint", "left_shoulder_pitch_joint",
                                             "left_shoulder_roll_joint", "left_shoulder_yaw_joint", "left_elbow_joint"};
  EXPECT_EQ(draft.adjusted_double, adjusted);
  EXPECT_EQ(draft.adjusted_single.back(), "swing_foot");
  EXPECT_EQ(draft.substeps, 4);  // ankle pitch links of 0.074 kg
  const auto spec = write_and_load(draft, urdf, "g1_draft.yaml");
  EXPECT_EQ(spec.model.nj, 29);
  EXPECT_EQ(spec.segments.at("torso").size(), 3U);
  EXPECT_EQ(spec.segments.at("right_arm").size(), 7U);
  expect_standing_posture(spec, 0.90);
  // Shoulders out, away from the body, within the joint limits.
  const int r = spec.model.joint_index("right_shoulder_roll_joint"), l = spec.model.joint_index("left_shoulder_roll_joint");
  EXPECT_NEAR(spec.q_joints_stand(r), -0.15, 1e-12);
  EXPECT_NEAR(spec.q_joints_stand(l), 0.15, 1e-12);
}

// The G1's URDF alone in one folder, its meshes in the repository (init --mesh-path): the file
// written names the mesh folder relative to itself, so it loads where it is and wherever the two
// folders move together; without it the load fails naming the option.
TEST(RobotDraft, TheMeshFolderGivenToInitIsWrittenRelativeToTheFileAndMovesWithIt) {
  namespace fs = std::filesystem;
  const fs::path root = fs::temp_directory_path() / ("hpr_mesh_path_" + std::to_string(::getpid()));
  fs::remove_all(root);
  const fs::path urdf = root / "robot/description/g1.urdf", meshes = root / "robot/assets", out = root / "robot/config/g1.yaml";
  fs::create_directories(urdf.parent_path());
  fs::create_directories(out.parent_path());
  fs::create_directories(meshes);
  fs::copy_file(test::source_dir() + "/models/unitree_g1/g1_29dof_with_hand.urdf", urdf);
  fs::copy(test::source_dir() + "/models/unitree_g1/meshes", meshes / "meshes", fs::copy_options::recursive);
  model::UrdfOptions urdf_options;
  urdf_options.mesh_search_paths = {meshes.string()};
  const auto draft = onboard::draft_robot(model::load_urdf(urdf.string(), urdf_options));
  const std::string template_text = test::read_file(test::source_dir() + "/config/templates/robot.yaml");
  const auto rel = [&](const fs::path& p) { return fs::relative(p, out.parent_path()).string(); };
  std::ofstream(out) << onboard::write_config(draft, template_text, rel(urdf), "test", {rel(meshes)});
  EXPECT_NE(test::read_file(out.string()).find("mesh_search_paths: [../assets]"), std::string::npos);
  EXPECT_EQ(model::RobotSpec::load(Config::load(out.string()).section("robot")).model.nj, 29);
  const fs::path moved = root / "elsewhere";
  fs::rename(root / "robot", moved);
  EXPECT_EQ(model::RobotSpec::load(Config::load((moved / "config/g1.yaml").string()).section("robot")).model.nj, 29);
  std::ofstream(moved / "config/g1.yaml") << onboard::write_config(draft, template_text, rel(urdf), "test");
  try {
    (void)model::RobotSpec::load(Config::load((moved / "config/g1.yaml").string()).section("robot"));
    ADD_FAILURE() << "loaded without its mesh folder";
  } catch (const ConfigError& e) {  // naming the file and key, then the mesh and the fix
    const std::string msg = e.what();
    EXPECT_NE(msg.find("config/g1.yaml:"), std::string::npos) << msg;
    EXPECT_NE(msg.find("robot.urdf = ../description/g1.urdf"), std::string::npos) << msg;
    EXPECT_NE(msg.find("--mesh-path DIR"), std::string::npos) << msg;
  }
  fs::remove_all(root);
}

// A biped as robot repositories publish it (tests/unit/onboard/fixtures/make_biped.py): the package
// in a folder of another name, feet a mesh turned 90 deg in the link, the IMU on the torso one
// waist joint from the pelvis. init's draft loads with no hand edit: soles 0.19 x 0.08 m along the
// link's x and centred, the IMU at imu_link, the standing posture as asked.
TEST(RobotDraft, ABipedAsPublishedWithYawedFootMeshesAndItsImuOnTheTorso) {
  const std::string urdf = test::source_dir() + "/tests/unit/onboard/fixtures/biped-description-main/urdf/biped.urdf";
  const auto draft = onboard::draft_robot(model::load_urdf(urdf));
  for (const auto& f : draft.feet) {
    EXPECT_NEAR(f.sole.length, 0.19, 1e-6) << f.link;
    EXPECT_NEAR(f.sole.width, 0.08, 1e-6) << f.link;
    EXPECT_EQ(f.sole.yaw, 0.0) << f.link;
    EXPECT_LT((f.sole.centre - Eigen::Vector3d(0.03, 0.0, -0.06)).norm(), 1e-6) << f.link;
    EXPECT_TRUE(f.sole.warnings.empty()) << f.sole.warnings.front();
  }
  EXPECT_EQ(draft.imu_link, "imu_link");
  const auto note = std::find_if(draft.notes.begin(), draft.notes.end(), [](const std::string& n) { return n.rfind("IMU", 0) == 0; });
  ASSERT_NE(note, draft.notes.end());
  EXPECT_NE(note->find("1 moving joint from the base (waist_yaw_joint)"), std::string::npos) << *note;
  const model::RobotSpec spec = write_and_load(draft, urdf, "biped.yaml");
  EXPECT_EQ(spec.model.frames[static_cast<size_t>(spec.imu_frame)].body, spec.model.frames[static_cast<size_t>(spec.model.frame_index("torso"))].body);
  expect_standing_posture(spec, onboard::DraftOptions{}.leg_height_fraction);
}

// The same biped with inertias only (no geometry anywhere): the feet are the ends of the leg chains,
// their soles a guess from the leg's length that init writes with a warning saying what to measure,
// and the file loads.
TEST(RobotDraft, ARobotWithInertiasOnlyGetsGuessedSolesAndAWarning) {
  const std::string urdf = test::source_dir() + "/tests/unit/onboard/fixtures/inertias_only.urdf";
  const auto draft = onboard::draft_robot(model::load_urdf(urdf));
  const double leg = std::hypot(0.06 + 0.35 + 0.35, 0.0);  // hip yaw joint to the ankle: 0.06 + 2 x 0.35 m
  EXPECT_EQ(draft.feet[0].link, "r_foot");
  EXPECT_EQ(draft.feet[1].link, "l_foot");
  for (const auto& f : draft.feet) {
    EXPECT_NEAR(f.sole.length, 0.3 * leg, 1e-9);
    EXPECT_NEAR(f.sole.width, 0.12 * leg, 1e-9);
    ASSERT_EQ(f.sole.warnings.size(), 1U);
    EXPECT_NE(f.sole.warnings[0].find("no collision geometry: its sole is a guess"), std::string::npos) << f.sole.warnings[0];
  }
  EXPECT_EQ(std::count_if(draft.notes.begin(), draft.notes.end(), [](const std::string& n) { return n.rfind("warning: ", 0) == 0; }), 2);
  const model::RobotSpec spec = write_and_load(draft, urdf, "inertias_only.yaml");
  expect_standing_posture(spec, onboard::DraftOptions{}.leg_height_fraction);
}

// A foot whose sole is yawed in its link (a box turned 0.3 rad): init writes sole_rpy, and the sole
// frame of the loaded configuration lies along the robot's x, flat, in the standing posture.
TEST(RobotDraft, ASoleYawedInItsLinkIsWrittenAsSoleRpy) {
  std::string xml = test::read_file(test::source_dir() + "/tests/unit/onboard/fixtures/biped-description-main/urdf/biped.urdf");
  const std::string mesh = R"(<origin xyz="0.03 0 -0.06" rpy="0 0 1.5707963267948966"/><geometry><mesh filename="package://biped_description/meshes/chamfered_foot.stl"/></geometry>)";
  const std::string box = R"(<origin xyz="0.03 0 -0.06" rpy="0 0 0.3"/><geometry><box size="0.2 0.08 0.04"/></geometry>)";
  for (size_t at = xml.find(mesh); at != std::string::npos; at = xml.find(mesh)) xml.replace(at, mesh.size(), box);
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("hpr_yawed_sole_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string urdf = (dir / "biped_box_feet.urdf").string();
  std::ofstream(urdf) << xml;
  const auto draft = onboard::draft_robot(model::load_urdf(urdf));
  for (const auto& f : draft.feet) {
    EXPECT_NEAR(f.sole.yaw, 0.3, 1e-9);
    EXPECT_NEAR(f.sole.length, 0.2, 1e-9);
    EXPECT_NEAR(f.sole.width, 0.08, 1e-9);
  }
  const std::string text = onboard::write_config(draft, test::read_file(test::source_dir() + "/config/templates/robot.yaml"), urdf, "test");
  EXPECT_NE(text.find("sole_rpy: [0.0, 0.0, 0.3000]"), std::string::npos) << text.substr(0, 2000);
  const model::RobotSpec spec = write_and_load(draft, urdf, "biped_box_feet.yaml");
  expect_standing_posture(spec, onboard::DraftOptions{}.leg_height_fraction);
  fs::remove_all(dir);
}

// The part of a configuration's text from the line `name:` to the next top-level key.
std::string top_level_section(const std::string& text, const std::string& name) {
  const size_t begin = text.find("\n" + name + ":\n");
  if (begin == std::string::npos) return {};
  size_t end = begin + 1;
  do {
    end = text.find('\n', end + 1);
  } while (end != std::string::npos && end + 1 < text.size() && !std::isalpha(static_cast<unsigned char>(text[end + 1])));
  return text.substr(begin + 1, end == std::string::npos ? std::string::npos : end - begin);
}

// config/g1.yaml is init's output for the published G1 with the controller set to the best this
// stack measures on it (docs/RESULTS.md, "The default controller (G1)"): its robot section is the
// draft written today from the URDF and the template byte for byte, and every other key is the
// draft's but for the four the G1's controller sets (a change to the template or the draft shows
// here, and the file is written again with the command in its header, those four set again).
TEST(RobotDraft, TheShippedG1ConfigurationIsInitsOutputWithItsControllerSet) {
  const std::string urdf = test::source_dir() + "/models/unitree_g1/g1_29dof_with_hand.urdf";
  onboard::DraftOptions o;
  o.name = "g1";
  const auto draft = onboard::draft_robot(model::load_urdf(urdf), o);
  const std::string text = onboard::write_config(draft, test::read_file(test::source_dir() + "/config/templates/robot.yaml"),
                                                 "../models/unitree_g1/g1_29dof_with_hand.urdf",
                                                 "models/unitree_g1/g1_29dof_with_hand.urdf --name g1 --out config/g1.yaml");
  const std::string shipped = test::read_file(test::source_dir() + "/config/g1.yaml");
  ASSERT_FALSE(top_level_section(text, "robot").empty());
  EXPECT_EQ(top_level_section(text, "robot"), top_level_section(shipped, "robot"));

  const YAML::Node written = YAML::Load(text);
  YAML::Node set = YAML::Load(shipped);
  EXPECT_FALSE(written["balance"]["push_compensation"]) << "the template now writes push compensation: this test's list is out of date";
  EXPECT_FALSE(written["balance"]["stepping"]);
  EXPECT_FALSE(written["reference_gen"]["x"]);
  EXPECT_FALSE(written["wbc"]["contact"]["sole_torsion"]);
  ASSERT_TRUE(set["balance"]["stepping"]["enabled"].as<bool>());
  ASSERT_TRUE(set["balance"]["push_compensation"]["enabled"].as<bool>());
  ASSERT_FALSE(set["reference_gen"]["x"]["enabled"].as<bool>());
  ASSERT_TRUE(set["wbc"]["contact"]["sole_torsion"].as<bool>());
  set["balance"].remove("push_compensation");
  set["balance"].remove("stepping");
  set["reference_gen"].remove("x");
  set["wbc"]["contact"].remove("sole_torsion");
  EXPECT_EQ(YAML::Dump(written), YAML::Dump(set));
}

}  // namespace
