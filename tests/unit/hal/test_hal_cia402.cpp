// CiA 402 drives in the hal, against the drive emulator's CiA 402 devices in one process: start-up,
// the closed loop against MIT mode's, an EMCY, missed TPDOs and a fault reset on request, and the
// configuration's checks (EDS, sensor bus, timing).
#include <gtest/gtest.h>

#include <fstream>

#include "hal_rig.hpp"
#include "hpr/hal/cia402.hpp"
#include "process_group.hpp"
#include "shell.hpp"

namespace {

using namespace hpr;
using hal::SafetyState;
using test::Rig;

// ---------------------------------------------------------------------------------------------
// CiA 402 drives: the same hal and emulator, every bus speaking CANopen.
// ---------------------------------------------------------------------------------------------

/// Ticks until every drive runs cyclically; returns the ticks taken (or -1).
int start_up(Rig& r, int limit = 500) {
  for (int k = 0; k < limit; ++k) {
    if (r.h->starting_drives().empty()) return k;
    r.tick_once();
  }
  return -1;
}

TEST(HalCia402, DrivesStartUpEnableAndCloseTheLoopWithSensorsMatchingTheSimulation) {
  Rig r({"hal.protocol=cia402"});
  EXPECT_NE(r.h->operator_command(hal::kOperatorEnable, r.now, "test", test::issued()).find("starting up"), std::string::npos)
      << "no enable before the drives are configured";
  const int ticks = start_up(r);
  ASSERT_GE(ticks, 0) << r.h->starting_drives() << " / " << r.h->fault_conditions();
  EXPECT_LT(ticks, 100) << "reset, 26 SDO transfers, NMT start and a heartbeat per drive, the drives in parallel";
  EXPECT_EQ(r.h->fault_conditions(), "");
  EXPECT_FALSE(r.emu->released());
  for (std::size_t i = 0; i < r.config.drives.size(); ++i) {
    ASSERT_NE(r.emu->cia402(i), nullptr);
    EXPECT_EQ(r.emu->cia402(i)->object(hpr::hal::canopen::kModesOfOperation, 0), 10u) << r.config.drives[i].joint;
  }
  EXPECT_EQ(r.h->operator_command(hal::kOperatorEnable, r.now, "test", test::issued()), "enabled by test");
  SensorSample measured;
  for (int k = 0; k < 1000; ++k) {
    ASSERT_EQ(r.h->set_command(r.hold(), r.now), "");
    measured = r.sim.sensors();
    r.tick_once();
    ASSERT_EQ(r.h->fault_conditions(), "") << k;
  }
  EXPECT_EQ(r.h->safety().state(), SafetyState::kEnabled);
  EXPECT_TRUE(r.emu->released());
  EXPECT_TRUE(r.h->replies_complete());
  const SensorSample& s = r.h->sensors();
  for (int j = 0; j < r.robot.model.nj; ++j) {
    const auto& d = r.config.drives[static_cast<std::size_t>(j)];
    const std::string name = r.robot.model.joint_name[static_cast<std::size_t>(j)];
    EXPECT_TRUE(r.emu->motor_mode(static_cast<std::size_t>(j))) << name;
    EXPECT_NEAR(s.q(j), measured.q(j), 0.5 * d.cia402.rad_per_count() + 1e-12) << name;
    EXPECT_NEAR(s.qd(j), measured.qd(j), 0.5 * d.cia402.rad_s_per_unit() + 1e-12) << name;
    EXPECT_NEAR(s.tau(j), measured.tau(j), 0.5 * d.cia402.nm_per_permille() + 1e-9) << name;
  }
  // The joint impedance closes in the hal on the drives' torque interface, one sample late: the
  // robot moves as it does with MIT-mode drives that close it themselves.
  Rig mit;
  (void)mit.h->operator_command(hal::kOperatorEnable, mit.now, "test", test::issued());
  for (int k = 0; k < 1000; ++k) {
    ASSERT_EQ(mit.h->set_command(mit.hold(), mit.now), "");
    mit.tick_once();
  }
  const Eigen::VectorXd dq = r.sim.sensors().q - mit.sim.sensors().q;
  EXPECT_LT(dq.cwiseAbs().maxCoeff(), 5e-3) << dq.transpose();
  EXPECT_NEAR(r.sim.truth().q(2), mit.sim.truth().q(2), 2e-3) << "base height";
}

TEST(HalCia402, AnEmergencyFaultsTheHalTheDriveBrakesAndTheResetNeedsTheOperator) {
  Rig r({"hal.protocol=cia402", "emulator.fault_joint=r_knee", "emulator.fault_code=8976", "emulator.fault_at=0.2"});
  ASSERT_GE(start_up(r), 0);
  ASSERT_EQ(r.h->operator_command(hal::kOperatorEnable, r.now, "test", test::issued()), "enabled by test");
  for (int k = 0; k < 400 && r.h->safety().state() != SafetyState::kFault; ++k) {
    (void)r.h->set_command(r.hold(), r.now);
    r.tick_once();
  }
  EXPECT_EQ(r.h->safety().state(), SafetyState::kFault);
  const std::string faults = r.h->fault_conditions();
  EXPECT_NE(faults.find("r_knee: node 1: EMCY 0x2310"), std::string::npos) << faults;
  EXPECT_NE(faults.find("current"), std::string::npos) << faults;
  const auto knee = static_cast<std::size_t>(r.robot.model.joint_index("r_knee"));
  EXPECT_EQ(r.h->drives()[knee].state, hal::kDriveFault);
  EXPECT_TRUE(r.emu->cia402(knee)->fault_reaction()) << "the drive brakes by itself";
  r.tick_once();
  // The other drives damp (the hal's damping, as torque).
  for (std::size_t i = 0; i < r.config.drives.size(); ++i) {
    if (i == knee) continue;
    EXPECT_EQ(r.h->sent()[i].kp, 0.0);
    EXPECT_GT(r.h->sent()[i].kd, 0.0);
  }
  // The operator's enable asks for the reset and is refused; the injected fault is still present,
  // so the drive faults again and the next enable is refused too.
  EXPECT_NE(r.h->operator_command(hal::kOperatorEnable, r.now, "test", test::issued()).find("fault reset requested"), std::string::npos);
  for (int k = 0; k < 20; ++k) r.tick_once();
  EXPECT_NE(r.h->fault_conditions().find("EMCY 0x2310"), std::string::npos) << "the fault persists: " << r.h->fault_conditions();
}

TEST(HalCia402, AFaultResetOnRequestBringsTheDriveBack) {
  Rig r({"hal.protocol=cia402"});
  ASSERT_GE(start_up(r), 0);
  ASSERT_EQ(r.h->operator_command(hal::kOperatorEnable, r.now, "test", test::issued()), "enabled by test");
  for (int k = 0; k < 50; ++k) {
    (void)r.h->set_command(r.hold(), r.now);
    r.tick_once();
  }
  // The drives stop hearing the hal for longer than their RPDO timeout: each faults (EMCY 0x8250)
  // and brakes, and the hal counts missed replies meanwhile.
  r.drives_answer = false;
  for (int k = 0; k < 5; ++k) r.tick_once();
  EXPECT_EQ(r.h->safety().state(), SafetyState::kFault) << "missed TPDOs are missed replies, as in MIT mode";
  EXPECT_NE(r.h->fault_conditions().find("missed 5 replies"), std::string::npos) << r.h->fault_conditions();
  for (int k = 0; k < 35; ++k) r.tick_once();  // the emulator's own periodic: RPDO timeout
  r.drives_answer = true;
  for (int k = 0; k < 5; ++k) r.tick_once();
  EXPECT_NE(r.h->fault_conditions().find("EMCY 0x8250"), std::string::npos) << r.h->fault_conditions();
  EXPECT_NE(r.h->operator_command(hal::kOperatorEnable, r.now, "test", test::issued()).find("fault reset requested"), std::string::npos);
  for (int k = 0; k < 10; ++k) r.tick_once();
  EXPECT_EQ(r.h->fault_conditions(), "");
  EXPECT_EQ(r.h->operator_command(hal::kOperatorEnable, r.now, "test", test::issued()), "enabled by test");
  for (int k = 0; k < 20; ++k) {
    (void)r.h->set_command(r.hold(), r.now);
    r.tick_once();
  }
  EXPECT_EQ(r.h->safety().state(), SafetyState::kEnabled) << r.h->fault_conditions();
  for (std::size_t i = 0; i < r.config.drives.size(); ++i) EXPECT_TRUE(r.emu->motor_mode(i)) << r.config.drives[i].joint;
}

TEST(HalConfig, Cia402DrivesAreCheckedAgainstTheirDataSheetAndTheSensorBus) {
  const std::string dir = test::temp_dir("cia402cfg");
  const std::string base = test::source_dir() + "/config/toro.yaml";
  auto load = [&](const std::vector<std::string>& overrides) {
    const Config c = Config::load(base, overrides);
    const auto robot = model::RobotSpec::load(c.section("robot"));
    return hal::HalConfig::load(c.section("hal"), robot);
  };
  auto error = [&](const std::vector<std::string>& overrides) -> std::string {
    try {
      (void)load(overrides);
    } catch (const ConfigError& e) {
      return e.what();
    }
    return "";
  };
  // The scaling: defaults, the hal.canopen section, a drive's EDS.
  std::string eds = hal::Cia402Device::default_eds(1200);
  std::ofstream(dir + "/drive.eds") << eds;
  const auto c = load({"hal.protocol=cia402", "hal.canopen={gear_ratio: 9, eds: " + dir + "/drive.eds}"});
  EXPECT_EQ(c.drives[0].protocol, hal::DriveProtocol::kCia402);
  EXPECT_DOUBLE_EQ(c.drives[0].cia402.gear_ratio, 9.0);
  EXPECT_DOUBLE_EQ(c.drives[0].cia402.rated_torque, 1.2) << "0x6076 of the EDS, in mN m";
  const auto mixed = load({"hal.buses=[{name: can0, protocol: cia402}, {name: can1}, {name: can2}, {name: can3}, {name: can4}, "
                           "{name: can5}, {name: can6}, {name: can7}, {name: can8}, {name: can9}]"});
  for (const auto& d : mixed.drives) {
    EXPECT_EQ(d.protocol, d.bus == 0 ? hal::DriveProtocol::kCia402 : hal::DriveProtocol::kMit) << d.joint << " on bus " << d.bus;
  }
  // An EDS of a drive without cyclic synchronous torque.
  const auto modes = eds.find("0x00000280");
  ASSERT_NE(modes, std::string::npos);
  eds.replace(modes, 10, "0x00000080");
  std::ofstream(dir + "/csp_only.eds") << eds;
  std::string e = error({"hal.protocol=cia402", "hal.canopen={eds: " + dir + "/csp_only.eds}"});
  EXPECT_NE(e.find("csp_only.eds:"), std::string::npos) << e;
  EXPECT_NE(e.find("[6502]"), std::string::npos) << e;
  EXPECT_NE(e.find("cyclic synchronous torque"), std::string::npos) << e;
  // A CiA 402 node whose TPDO1 would be an IMU frame on the sensor bus.
  e = error({"hal.buses=[{name: can0}, {name: can1}, {name: can2}, {name: can3}, {name: can4}, {name: can5}, {name: can6}, {name: can7}, "
             "{name: can8, protocol: cia402}, {name: can9}]",
             "hal.sensors={bus: can8}"});
  EXPECT_NE(e.find("sensor bus"), std::string::npos) << e;
  EXPECT_NE(e.find("hal.drives[24].id"), std::string::npos) << e;
  e = error({"hal.protocol=cia402", "hal.canopen={eds: " + dir + "/missing.eds}"});
  EXPECT_NE(e.find("hal.canopen.eds"), std::string::npos) << e;
  EXPECT_NE(e.find("missing.eds"), std::string::npos) << e;
  e = error({"hal.canopen={heartbeat_ms: 100, heartbeat_timeout: 0.05}"});
  EXPECT_NE(e.find("hal.canopen.heartbeat_timeout"), std::string::npos) << e;
}

}  // namespace
