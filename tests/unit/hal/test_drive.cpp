// A joint's drive (libs/drive) as the hal and the simulator read it: the simulation process reads
// the hal section's drives through drive::load_joint_drives, the hal through HalConfig::load; both
// must give the same joints, units and ranges, and so refuse the same commands.
#include <gtest/gtest.h>

#include <algorithm>
#include <utility>

#include "hpr/drive/drive.hpp"
#include "hpr/hal/hal.hpp"
#include "process_group.hpp"
#include "shell.hpp"

namespace {

using namespace hpr;

const std::string kKnee = "{joint: r_knee, bus: can1, id: 1}";

/// config/toro.yaml's hal section with `from` replaced by `to`.
Config edited_hal(const std::string& from, const std::string& to) {
  std::string yaml = test::read_file(test::source_dir() + "/config/toro.yaml");
  const auto at = yaml.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) yaml.replace(at, from.size(), to);
  return Config::parse(yaml, "edited.yaml").section("hal");
}

model::RobotSpec toro() { return model::RobotSpec::load(Config::load(test::source_dir() + "/config/toro.yaml").section("robot")); }

void expect_same(const drive::JointDrive& a, const drive::JointDrive& b) {
  EXPECT_EQ(a.joint, b.joint);
  EXPECT_EQ(a.joint_index, b.joint_index) << a.joint;
  EXPECT_EQ(a.sign, b.sign) << a.joint;
  EXPECT_EQ(a.offset, b.offset) << a.joint;
  EXPECT_EQ(a.q_lower, b.q_lower) << a.joint;
  EXPECT_EQ(a.q_upper, b.q_upper) << a.joint;
  EXPECT_EQ(a.held, b.held) << a.joint;
  EXPECT_EQ(a.held_q, b.held_q) << a.joint;
  const drive::DriveLimits &l = a.limits, &m = b.limits;
  for (const auto& [x, y] : {std::pair{l.p_min, m.p_min}, {l.p_max, m.p_max}, {l.v_min, m.v_min}, {l.v_max, m.v_max}, {l.kp_min, m.kp_min},
                             {l.kp_max, m.kp_max}, {l.kd_min, m.kd_min}, {l.kd_max, m.kd_max}, {l.t_min, m.t_min}, {l.t_max, m.t_max}}) {
    EXPECT_EQ(x, y) << a.joint;
  }
}

}  // namespace

TEST(JointDrives, TheSimulatorReadsTheHalSectionsDrivesAsTheHalDoes) {
  const auto robot = toro();
  // A drive turned round and offset, with a gain range of its own.
  const Config hal_section = edited_hal(kKnee, "{joint: r_knee, bus: can1, id: 1, sign: -1, offset: 0.2, limits: {kp: [0, 300]}}");
  const hal::HalConfig hal = hal::HalConfig::load(hal_section, robot);
  const std::vector<drive::JointDrive> drives = drive::load_joint_drives(hal_section, robot);
  ASSERT_EQ(drives.size(), hal.drives.size());
  for (std::size_t i = 0; i < drives.size(); ++i) expect_same(drives[i], hal.drives[i]);
  const auto knee = static_cast<std::size_t>(robot.model.joint_index("r_knee"));
  EXPECT_EQ(drives[knee].sign, -1.0);
  EXPECT_EQ(drives[knee].offset, 0.2);
  EXPECT_EQ(drives[knee].limits.kp_max, 300.0);
  // Its position range from the URDF limits, turned round: p = sign (q - offset).
  const double margin = drive::DriveDefaults{}.position_margin;
  EXPECT_DOUBLE_EQ(drives[knee].limits.p_min, -(robot.model.q_upper[knee] + margin - 0.2));
  EXPECT_DOUBLE_EQ(drives[knee].limits.p_max, -(robot.model.q_lower[knee] - margin - 0.2));

  // Both refuse the same command, for the same reason: the knee's kp beyond its own range.
  const int nj = robot.model.nj;
  JointCommand c;
  c.resize(nj);
  c.mode = JointCommand::Mode::kRun;
  for (int j = 0; j < nj; ++j) {
    const auto ju = static_cast<std::size_t>(j);
    c.q_des(j) = std::clamp(0.0, robot.model.q_lower[ju], robot.model.q_upper[ju]);
  }
  c.kp.setConstant(100.0);
  c.kd.setConstant(1.0);
  EXPECT_EQ(drive::check_command(c, drives, nj), "");
  c.kp(static_cast<Eigen::Index>(knee)) = 400.0;
  const std::string why = drive::check_command(c, drives, nj);
  EXPECT_NE(why.find("kp of joint 'r_knee' = 400"), std::string::npos) << why;
  EXPECT_EQ(why, hal::check_command(c, hal.drives, hal.controlled));
}

TEST(JointDrives, AJointMappedTwiceIsRefusedNamingItByBothReaders) {
  const auto robot = toro();
  const Config hal_section = edited_hal(kKnee, kKnee + "\n    - {joint: r_knee, bus: can2, id: 9}");
  for (int reader = 0; reader < 2; ++reader) {
    try {
      if (reader == 0) {
        (void)drive::load_joint_drives(hal_section, robot);
      } else {
        (void)hal::HalConfig::load(hal_section, robot);
      }
      ADD_FAILURE() << "reader " << reader << " accepted r_knee twice";
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find("joint 'r_knee' is mapped twice"), std::string::npos) << e.what();
    }
  }
}

TEST(JointDrives, WithoutAHalSectionEveryJointHasTheDefaultsFromItsUrdfLimits) {
  const auto robot = toro();
  const std::vector<drive::JointDrive> drives = drive::default_drives(robot);
  ASSERT_EQ(static_cast<int>(drives.size()), robot.model.nj);
  const drive::DriveDefaults d;
  for (int j = 0; j < robot.model.nj; ++j) {
    const auto ju = static_cast<std::size_t>(j);
    EXPECT_EQ(drives[ju].joint, robot.model.joint_name[ju]);
    EXPECT_DOUBLE_EQ(drives[ju].limits.p_max, robot.model.q_upper[ju] + d.position_margin);
    EXPECT_DOUBLE_EQ(drives[ju].limits.t_max, d.torque_scale * robot.model.tau_max[ju]);
    EXPECT_DOUBLE_EQ(drives[ju].limits.kp_max, d.kp_max);
  }
}
