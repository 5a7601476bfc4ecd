// lcm_latency on a log whose receive times it did not make: each hop's delay and the total are the
// ones written, a tick missing a channel is left out, and a log of the ankle strategy (no CAM
// channels) is measured from ROBOT_STATE to JOINT_COMMAND.
#include <gtest/gtest.h>

#include <humanoid/cam_reference_t.hpp>
#include <humanoid/joint_command_t.hpp>
#include <humanoid/robot_sensors_t.hpp>
#include <humanoid/robot_state_t.hpp>
#include <humanoid/wholebody_command_t.hpp>

#include <lcm/lcm-cpp.hpp>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "process_group.hpp"
#include "shell.hpp"

namespace {

template <class M>
void write(lcm::LogFile& log, const std::string& channel, std::int64_t tick, std::int64_t t_us) {
  M m{};
  m.tick = tick;
  std::vector<uint8_t> buf(static_cast<size_t>(m.getEncodedSize()));
  ASSERT_EQ(m.encode(buf.data(), 0, static_cast<int>(buf.size())), static_cast<int>(buf.size()));
  lcm::LogEvent e{};
  e.timestamp = t_us;
  e.channel = channel;
  e.datalen = static_cast<int32_t>(buf.size());
  e.data = buf.data();
  ASSERT_EQ(log.writeEvent(&e), 0);
}

nlohmann::json measure(const std::string& path) {
  const auto r = hpr::test::run_command({hpr::test::bin_dir() + "/lcm_latency", path, "--json", path + ".json"});
  EXPECT_EQ(r.exit_code, 0) << r.out;
  return nlohmann::json::parse(hpr::test::read_file(path + ".json"));
}

TEST(LcmLatency, HopsAndTotalAreTheRecordedDelays) {
  const std::string dir = hpr::test::temp_dir("lcm-latency");
  {
    lcm::LogFile log(dir + "/cam.lcm", "w");
    ASSERT_TRUE(log.good());
    for (std::int64_t k = 0; k < 100; ++k) {
      const std::int64_t t = 1'000'000 + 1000 * k;
      const std::int64_t slow = k == 50 ? 400 : 0;  // one slow wbc tick: the max, not the median
      write<humanoid::robot_sensors_t>(log, "ROBOT_SENSORS", k, t);
      write<humanoid::robot_state_t>(log, "ROBOT_STATE", k, t + 50);
      write<humanoid::cam_reference_t>(log, "CAM_REFERENCE", k, t + 60);
      if (k != 7) write<humanoid::wholebody_command_t>(log, "WHOLEBODY_COMMAND", k, t + 80);  // tick 7 lacks it
      write<humanoid::joint_command_t>(log, "JOINT_COMMAND", k, t + 110 + slow);
    }
  }
  const auto j = measure(dir + "/cam.lcm");
  EXPECT_EQ(j["ticks"].get<int>(), 99);
  EXPECT_DOUBLE_EQ(j["estimator"]["median_us"].get<double>(), 50.0);
  EXPECT_DOUBLE_EQ(j["reference_gen"]["median_us"].get<double>(), 10.0);
  EXPECT_DOUBLE_EQ(j["motion_opt"]["median_us"].get<double>(), 20.0);
  EXPECT_DOUBLE_EQ(j["wbc"]["median_us"].get<double>(), 30.0);
  EXPECT_DOUBLE_EQ(j["wbc"]["max_us"].get<double>(), 430.0);
  EXPECT_DOUBLE_EQ(j["total"]["median_us"].get<double>(), 110.0);
  EXPECT_DOUBLE_EQ(j["total"]["max_us"].get<double>(), 510.0);

  {
    lcm::LogFile log(dir + "/ankle.lcm", "w");
    ASSERT_TRUE(log.good());
    for (std::int64_t k = 0; k < 10; ++k) {
      write<humanoid::robot_sensors_t>(log, "ROBOT_SENSORS", k, 1000 * k);
      write<humanoid::robot_state_t>(log, "ROBOT_STATE", k, 1000 * k + 40);
      write<humanoid::joint_command_t>(log, "JOINT_COMMAND", k, 1000 * k + 65);
    }
  }
  const auto a = measure(dir + "/ankle.lcm");
  EXPECT_EQ(a["ticks"].get<int>(), 10);
  EXPECT_DOUBLE_EQ(a["wbc"]["median_us"].get<double>(), 25.0);
  EXPECT_FALSE(a.contains("motion_opt"));
  EXPECT_DOUBLE_EQ(a["total"]["median_us"].get<double>(), 65.0);
  EXPECT_FALSE(a["one_process"].get<bool>());

  // The composed controllers: JOINT_COMMAND out first, the other channels of the tick after it.
  {
    lcm::LogFile log(dir + "/composed.lcm", "w");
    ASSERT_TRUE(log.good());
    for (std::int64_t k = 0; k < 10; ++k) {
      write<humanoid::robot_sensors_t>(log, "ROBOT_SENSORS", k, 1000 * k);
      write<humanoid::joint_command_t>(log, "JOINT_COMMAND", k, 1000 * k + 70);
      write<humanoid::robot_state_t>(log, "ROBOT_STATE", k, 1000 * k + 80);
      write<humanoid::cam_reference_t>(log, "CAM_REFERENCE", k, 1000 * k + 90);
      write<humanoid::wholebody_command_t>(log, "WHOLEBODY_COMMAND", k, 1000 * k + 100);
    }
  }
  const auto c = measure(dir + "/composed.lcm");
  EXPECT_TRUE(c["one_process"].get<bool>());
  EXPECT_FALSE(c.contains("wbc")) << "no hops for one process";
  EXPECT_DOUBLE_EQ(c["total"]["median_us"].get<double>(), 70.0);
}

}  // namespace
