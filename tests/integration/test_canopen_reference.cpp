// CiA 402 checked against an independent CANopen stack (docs/CAN.md, "Checked against
// python-canopen"): python-canopen's master (RemoteNode, BaseNode402) drives one of the drive
// emulator's CiA 402 drives over cannelloni UDP through tests/canopen/emulator_slave.py, which
// reports each check as a JSON line; this test starts the emulator, runs the script and holds
// every check to its verdict.
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <set>
#include <sstream>
#include <thread>
#include <vector>

#include <humanoid/hal_status_t.hpp>
#include <nlohmann/json.hpp>

#include "hpr/common/config.hpp"
#include "hpr/hal/cia402.hpp"
#include "hpr/hal/hal.hpp"
#include "hpr/model/robot.hpp"
#include "lcm_listener.hpp"
#include "process_group.hpp"
#include "scratch_dir.hpp"
#include "shell.hpp"

#ifndef HPR_PYTHON_CANOPEN_DIR
#define HPR_PYTHON_CANOPEN_DIR ""
#endif

namespace {

namespace fs = std::filesystem;

/// What python-canopen's master must find of the emulator's drive, one check each.
const std::set<std::string> kChecks = {
    "nmt_reset_communication_boots_up",   "sdo_reads_match_the_data_sheet",       "sdo_device_type_is_a_cia402_drive",
    "sdo_supported_modes_csp_and_cst",    "sdo_aborts_name_the_cia301_reason",     "pdo_mapping_written_and_read_back",
    "pdo_mapping_entries_are_index_subindex_bits", "heartbeat_every_0x1017_in_pre_operational", "nmt_start_heartbeat_operational",
    "sync_each_answered_by_tpdo1",        "cia402_switch_on_disabled_to_operation_enabled", "cst_target_torque_reported_as_actual",
    "csp_actual_position_reaches_the_target", "pdo_and_sdo_report_the_same_position", "rpdo_timeout_emcy_and_fault",
    "fault_reset_back_to_operation_enabled", "nmt_stop_heartbeat_stopped"};

/// The checks' JSON lines in `out`, each held to its verdict; returns the checks seen and the
/// other lines' objects (what the script announced).
std::set<std::string> verdicts(const std::string& out, std::vector<nlohmann::json>* announced = nullptr) {
  std::set<std::string> seen;
  std::istringstream lines(out);
  for (std::string line; std::getline(lines, line);) {
    if (line.empty() || line.front() != '{') continue;
    std::cout << line << '\n';  // what python-canopen found, in the test's log
    const auto j = nlohmann::json::parse(line);
    if (j.contains("summary")) {
      EXPECT_EQ(j["summary"]["malformed_datagrams"].get<int>(), 0) << "datagrams python could not decode";
    } else if (j.contains("check")) {
      const std::string name = j["check"].get<std::string>();
      seen.insert(name);
      EXPECT_TRUE(j["ok"].get<bool>()) << name << ": " << j["detail"].get<std::string>();
    } else if (announced != nullptr) {
      announced->push_back(j);
    }
  }
  return seen;
}

/// Each check: skipped without python-canopen (failed without Debian's python3-can); the stack's
/// configuration with the test's overrides (`sets`), its hal section, and the drives' data sheet.
class CanopenReference : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!fs::exists(fs::path(canopen_dir) / "canopen" / "__init__.py")) {
      GTEST_SKIP() << "python-canopen is not at '" << canopen_dir << "' (configure with -DHPR_PYTHON_CANOPEN_DIR)";
    }
    ASSERT_EQ(hpr::test::run_command({"/usr/bin/python3", "-c", "import can"}).exit_code, 0)
        << "Debian's python3-can is missing (tools/install-deps installs it)";
  }
  /// Loads the configuration with `overrides` into `hal`.
  void configure(std::vector<std::string> overrides) {
    sets = std::move(overrides);
    const hpr::Config cfg = hpr::Config::load(cfg_path, sets);
    hal = hpr::hal::HalConfig::load(cfg.section("hal"), hpr::model::RobotSpec::load(cfg.section("robot")));
  }
  /// The process's command line: the configuration and the overrides.
  [[nodiscard]] std::vector<std::string> args() const {
    std::vector<std::string> a = {"--config", cfg_path};
    for (const auto& s : sets) a.insert(a.end(), {"--set", s});
    return a;
  }
  /// The emulated drive's data sheet with its rated torque [N m], as a file; its path.
  [[nodiscard]] std::string write_eds(double rated_torque) const {
    const std::string eds = (dir.path() / "emulated_drive.eds").string();
    std::ofstream(eds) << hpr::hal::Cia402Device::default_eds(static_cast<std::uint32_t>(std::lround(rated_torque * 1e3)));
    return eds;
  }

  const std::string canopen_dir = HPR_PYTHON_CANOPEN_DIR;
  const std::string tests = hpr::test::source_dir() + "/tests/canopen";
  const std::string cfg_path = hpr::test::source_dir() + "/config/toro.yaml";
  const hpr::test::ScratchDir dir{"canopen-reference"};
  std::vector<std::string> sets;
  hpr::hal::HalConfig hal;
};

TEST_F(CanopenReference, PythonCanopenMasterDrivesTheEmulatorsCia402Drive) {
  // Ports beside the hil tests' (22000 + 40 k, 20 of them for ten buses).
  const int port = 22020 + 40 * (::getpid() % 250);
  configure({"hal.udp_base_port=" + std::to_string(port), "hal.clock=realtime", "hal.protocol=cia402", "emulator.drive_timeout=1.0"});
  // The drive the master talks to: node 3 on the first bus (a hip's yaw joint, which gravity
  // hardly loads), its data sheet and its position units as the emulator has them.
  const auto drive = std::find_if(hal.drives.begin(), hal.drives.end(), [](const auto& d) { return d.bus == 0 && d.id == 3; });
  ASSERT_NE(drive, hal.drives.end());
  const std::string eds = write_eds(drive->cia402.rated_torque);

  hpr::test::ProcessGroup group;
  group.start("drive_emulator", args());
  const auto r = hpr::test::run_command({"env", "PYTHONPATH=" + canopen_dir + ":" + tests, "/usr/bin/python3", tests + "/emulator_slave.py",
                                         "--port", std::to_string(port), "--node", "3", "--eds", eds, "--counts-per-rad",
                                         std::to_string(1.0 / drive->cia402.rad_per_count()), "--rpdo-timeout", "1.0"});
  const auto seen = verdicts(r.out);
  for (const auto& c : kChecks) EXPECT_TRUE(seen.count(c)) << "python-canopen did not get as far as " << c << "\n" << r.out;
  EXPECT_EQ(r.exit_code, 0) << r.out;
}

// The hal as master: python-canopen LocalNodes (CiA 301: SDO server, NMT slave, heartbeat
// producer) built from the same data sheet stand for the first bus's three drives; the other
// buses keep MIT mode. The hal must start them as docs/CAN.md says and notice a heartbeat that stops.
TEST_F(CanopenReference, TheHalStartsPythonCanopenSlavesAsDocumented) {
  // Below the hil tests' ports and the supervisor's 21000, so both checks may run at once.
  const int port = 12000 + 40 * (::getpid() % 250);
  std::string buses = "hal.buses=[{name: can0, protocol: cia402}";
  for (int b = 1; b < 10; ++b) buses += ", {name: can" + std::to_string(b) + "}";
  buses += "]";
  configure({"hal.udp_base_port=" + std::to_string(port), "hal.clock=realtime", buses});
  std::vector<int> nodes;
  double rated = 0.0;
  for (const auto& d : hal.drives) {
    if (d.bus != 0) continue;
    ASSERT_EQ(d.protocol, hpr::hal::DriveProtocol::kCia402);
    nodes.push_back(d.id);
    rated = d.cia402.rated_torque;
  }
  ASSERT_EQ(nodes.size(), 3U);
  const std::string eds = write_eds(rated);
  std::string node_list;
  for (int n : nodes) node_list += (node_list.empty() ? "" : ",") + std::to_string(n);

  hpr::test::ProcessGroup group;
  hpr::test::LcmListener lcm{group.lcm_url()};
  const auto status = lcm.collect<humanoid::hal_status_t>("HAL_STATUS");
  const std::string slave_log = (dir.path() / "slaves.log").string(), hal_log = (dir.path() / "hal.log").string();
  hpr::launch::StartOptions py;
  py.env["PYTHONPATH"] = canopen_dir + ":" + tests;
  py.log_file = slave_log;
  const pid_t slaves = group.start("/usr/bin/python3",
                                   {tests + "/hal_master.py", "--port", std::to_string(port), "--buses", std::to_string(hal.buses.size()),
                                    "--nodes", node_list, "--eds", eds, "--heartbeat-ms", std::to_string(hal.canopen.heartbeat_ms)},
                                   py);
  const auto wait_for_text = [](const std::string& path, const std::string& text, std::chrono::seconds timeout) {
    const auto end = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < end) {
      if (hpr::test::read_file(path).find(text) != std::string::npos) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return false;
  };
  ASSERT_TRUE(wait_for_text(slave_log, "\"ready\"", std::chrono::seconds(20))) << hpr::test::read_file(slave_log);
  hpr::launch::StartOptions h;
  h.log_file = hal_log;
  group.start("hal", args(), h);
  const auto done = group.wait(slaves, std::chrono::seconds(60));
  std::vector<nlohmann::json> announced;
  const auto seen = verdicts(hpr::test::read_file(slave_log), &announced);
  EXPECT_EQ(done.exit_code, 0) << hpr::test::read_file(slave_log);
  for (int n : nodes) {
    for (const char* c : {"_nmt_reset_communication_then_start", "_sdo_reads_identity_first", "_sdo_requests_counted",
                          "_sdo_configuration_as_documented", "_pdo_mapping_in_cia301_order"}) {
      EXPECT_TRUE(seen.count("node" + std::to_string(n) + c)) << "node " << n << ": no verdict " << c << "\n" << hpr::test::read_file(slave_log);
    }
  }
  EXPECT_TRUE(seen.count("nmt_started_every_drive"));
  // The hal's side: every drive started, then the silent heartbeat noticed, naming the drive (in
  // HAL_STATUS's reason: the MIT-mode buses, which nothing answers here, hold the hal in fault).
  const std::string log = hpr::test::read_file(hal_log);
  EXPECT_NE(log.find("CiA 402 drives started in"), std::string::npos) << log;
  const auto stopped = std::find_if(announced.begin(), announced.end(), [](const auto& j) { return j.contains("heartbeat_stopped"); });
  ASSERT_NE(stopped, announced.end());
  const std::string silent = "node " + std::to_string((*stopped)["heartbeat_stopped"].get<int>()) + ": no heartbeat for";
  const auto reason = [&] { return status->empty() ? std::string() : status->back().state_reason; };
  EXPECT_TRUE(lcm.wait_for([&] { return reason().find(silent) != std::string::npos; }, std::chrono::seconds(5)))
      << "the hal did not report '" << silent << "': " << reason();
  for (int n : nodes) {
    if (n == (*stopped)["heartbeat_stopped"].get<int>()) continue;
    EXPECT_EQ(reason().find("node " + std::to_string(n) + ":"), std::string::npos) << "a drive still heartbeating is at fault: " << reason();
  }
}

}  // namespace
