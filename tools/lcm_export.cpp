// lcm_export: an LCM log of the stack to one CSV file per channel (for plots and analysis).
//
//   lcm_export LOG OUTDIR [--channels A,B,...] [--every N]
//
// Columns: the log time of the event [s] (first event = 0), then the message's fields flattened
// (arrays as name_0, name_1, ...; per-joint arrays by joint name). Channels of unknown type are
// counted and skipped; undecodable events are reported with their position in the log.
#include <humanoid/balance_status_t.hpp>
#include <humanoid/cam_reference_t.hpp>
#include <humanoid/joint_command_t.hpp>
#include <humanoid/robot_sensors_t.hpp>
#include <humanoid/robot_state_t.hpp>
#include <humanoid/sim_truth_t.hpp>
#include <humanoid/wholebody_command_t.hpp>
#include <humanoid/balance_plan_t.hpp>

#include <algorithm>
#include <charconv>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <memory>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "hpr/common/args.hpp"
#include "hpr/msg/channels.hpp"
#include "hpr/msg/log_check.hpp"

namespace {

namespace fs = std::filesystem;
namespace channels = hpr::msg::channels;

/// One CSV row: names on the first row written, values after.
class Row {
 public:
  void add(const std::string& name, double v) {
    names_.push_back(name);
    values_.push_back(v);
  }
  template <size_t N>
  void arr(const std::string& name, const double (&a)[N]) {
    for (size_t i = 0; i < N; ++i) add(name + "_" + std::to_string(i), a[i]);
  }
  void vec(const std::string& name, const std::vector<double>& v, const std::vector<std::string>& labels = {}) {
    for (size_t i = 0; i < v.size(); ++i) add(name + "_" + (i < labels.size() ? labels[i] : std::to_string(i)), v[i]);
  }
  void mat(const std::string& name, const std::vector<std::vector<double>>& m, const std::vector<std::string>& labels) {
    for (size_t i = 0; i < m.size(); ++i) vec(name + "_" + (i < labels.size() ? labels[i] : std::to_string(i)), m[i]);
  }
  std::vector<std::string> names_;
  std::vector<double> values_;
};

void fill(Row& r, const humanoid::sim_truth_t& m) {
  r.add("tick", static_cast<double>(m.tick));
  r.add("t", m.sim_time);
  r.arr("p_WB", m.p_WB);
  r.arr("quat_WB", m.quat_WB);
  r.arr("v_WB", m.v_WB);
  r.arr("omega_WB", m.omega_WB);
  r.arr("p_WCom", m.p_WCom);
  r.arr("v_WCom", m.v_WCom);
  r.arr("l_WCom", m.l_WCom);
  r.mat("p_WF", m.p_WF, m.foot_name);
  r.mat("contact_wrench_W", m.contact_wrench_W, m.foot_name);
  r.vec("foot_tilt", m.foot_tilt, m.foot_name);
  r.add("push_active", m.push_active ? 1 : 0);
  r.arr("push_force_W", m.push_force_W);
  r.arr("push_point_W", m.push_point_W);
  r.arr("push_impulse_W", m.push_impulse_W);
  r.add("fallen", m.fallen ? 1 : 0);
}

void fill(Row& r, const humanoid::robot_state_t& m) {
  r.add("tick", static_cast<double>(m.tick));
  r.add("t", static_cast<double>(m.utime) * 1e-6);
  r.arr("p_WB", m.p_WB);
  r.arr("quat_WB", m.quat_WB);
  r.arr("v_WB", m.v_WB);
  r.arr("omega_WB", m.omega_WB);
  r.arr("p_WCom", m.p_WCom);
  r.arr("v_WCom", m.v_WCom);
  r.vec("q", m.q, m.joint_name);
  r.vec("qd", m.qd, m.joint_name);
  r.vec("tau", m.tau, m.joint_name);
  std::vector<double> contact(m.foot_contact.begin(), m.foot_contact.end());
  r.vec("foot_contact", contact, m.foot_name);
  r.vec("foot_force_z", m.foot_force_z, m.foot_name);
  r.arr("l_WCom", m.l_WCom);
  r.arr("ldot_WCom", m.ldot_WCom);
  r.add("status", m.status);
}

void fill(Row& r, const humanoid::balance_status_t& m) {
  r.add("tick", static_cast<double>(m.tick));
  r.add("t", static_cast<double>(m.utime) * 1e-6);
  r.add("support", m.support);
  r.arr("p_WV", m.p_WV);
  r.add("yaw_WV", m.yaw_WV);
  r.arr("tau_ankle_V", m.tau_ankle_V);
  r.arr("tau_hip_V", m.tau_hip_V);
  r.arr("tau_V", m.tau_V);
  r.arr("tau_min_V", m.tau_min_V);
  r.arr("tau_max_V", m.tau_max_V);
  r.arr("cop_V", m.cop_V);
  r.arr("cop_measured_V", m.cop_measured_V);
  r.add("f_vz", m.f_vz);
  r.arr("w_des_WCom", m.w_des_WCom);
  r.arr("w_achieved_WCom", m.w_achieved_WCom);
  r.add("qp_status", m.qp_status);
  r.add("qp_iterations", m.qp_iterations);
  r.add("qp_solve_time_us", m.qp_solve_time_us);
  r.add("qp_fallback", m.qp_fallback ? 1 : 0);
  r.add("compute_time_us", m.compute_time_us);
}

void fill(Row& r, const humanoid::cam_reference_t& m) {
  r.add("tick", static_cast<double>(m.tick));
  r.add("t", static_cast<double>(m.utime) * 1e-6);
  r.arr("l_ref_W", m.l_ref_W);
  r.arr("ldot_ref_W", m.ldot_ref_W);
  r.arr("l_ref_V", m.l_ref_V);
  r.arr("ldot_ref_V", m.ldot_ref_V);
  r.add("yaw_WV", m.yaw_WV);
  for (int k = 0; k < 3; ++k) r.add("phase_" + std::to_string(k), m.phase[k]);
  for (int k = 0; k < 3; ++k) {
    for (int p = 0; p < 3; ++p) r.add("t_phase_start_" + std::to_string(k) + "_" + std::to_string(p + 1), m.t_phase_start[k][p]);
  }
  r.arr("tau_thres_V", m.tau_thres_V);
  r.arr("ldot_max_V", m.ldot_max_V);
  r.add("status", m.status);
}

/// The stepping status, which WHOLEBODY_COMMAND and BALANCE_PLAN carry alike.
template <class M>
void stepping(Row& r, const M& m) {
  r.add("stepping", m.stepping ? 1.0 : 0.0);
  r.arr("xi_W", m.xi_W);
  r.add("xi_excess", m.xi_excess);
  r.add("step_foot", m.step_foot);
  r.arr("step_target_W", m.step_target_W);
  r.add("step_time_left", m.step_time_left);
  r.add("steps_taken", m.steps_taken);
  r.add("follow_steps", m.follow_steps);
}

void fill(Row& r, const humanoid::wholebody_command_t& m) {
  r.add("tick", static_cast<double>(m.tick));
  r.add("t", static_cast<double>(m.utime) * 1e-6);
  r.add("support", m.support);
  r.arr("p_WCom", m.p_WCom);
  r.arr("v_WCom", m.v_WCom);
  r.arr("quat_WB", m.quat_WB);
  r.arr("omega_WB", m.omega_WB);
  r.mat("p_WF", m.p_WF, m.foot_name);
  r.vec("q_free", m.q_free, m.free_joint);
  r.vec("qd_free", m.qd_free, m.free_joint);
  r.arr("l_cmd_W", m.l_cmd_W);
  r.arr("ldot_cmd_W", m.ldot_cmd_W);
  r.arr("l_ref_W", m.l_ref_W);
  r.vec("xa_opt", m.xa_opt, m.adjusted_name);
  r.vec("xad_opt", m.xad_opt, m.adjusted_name);
  r.vec("xa_min", m.xa_min, m.adjusted_name);
  r.vec("xa_max", m.xa_max, m.adjusted_name);
  r.vec("xad_min", m.xad_min, m.adjusted_name);
  r.vec("xad_max", m.xad_max, m.adjusted_name);
  r.mat("segment_l_W", m.segment_l_W, m.segment_name);
  stepping(r, m);
  r.add("posture_error", m.posture_error);
  r.add("qp_status", m.qp_status);
  r.add("qp_iterations", m.qp_iterations);
  r.add("status", m.status);
}

void fill(Row& r, const humanoid::balance_plan_t& m) {
  r.add("tick", static_cast<double>(m.tick));
  r.add("t", static_cast<double>(m.utime) * 1e-6);
  r.add("support", m.support);
  r.add("stage", m.stage);
  r.add("settled", m.settled ? 1.0 : 0.0);
  r.arr("p_WCom", m.p_WCom);
  r.arr("v_WCom", m.v_WCom);
  r.arr("a_WCom", m.a_WCom);
  r.mat("p_WF", m.p_WF, m.foot_name);
  r.vec("foot_load_limit", m.foot_load_limit, m.foot_name);
  r.arr("f_ext_W", m.f_ext_W);
  stepping(r, m);
}

void fill(Row& r, const humanoid::robot_sensors_t& m) {
  r.add("tick", static_cast<double>(m.tick));
  r.add("t", static_cast<double>(m.utime) * 1e-6);
  r.vec("q", m.q, m.joint_name);
  r.vec("qd", m.qd, m.joint_name);
  r.vec("tau", m.tau, m.joint_name);
  for (size_t i = 0; i < m.drive_status.size(); ++i) {
    r.add("drive_status_" + (i < m.joint_name.size() ? m.joint_name[i] : std::to_string(i)), static_cast<double>(m.drive_status[i]));
  }
  r.arr("imu_gyro_B", m.imu_gyro_B);
  r.arr("imu_accel_B", m.imu_accel_B);
  r.mat("ft_wrench_S", m.ft_wrench_S, m.ft_name);
}

void fill(Row& r, const humanoid::joint_command_t& m) {
  r.add("tick", static_cast<double>(m.tick));
  r.add("t", static_cast<double>(m.utime) * 1e-6);
  r.add("mode", m.mode);
  r.vec("tau_ff", m.tau_ff, m.joint_name);
  r.vec("q_des", m.q_des, m.joint_name);
  r.vec("kp", m.kp, m.joint_name);
  r.vec("kd", m.kd, m.joint_name);
}

/// One channel's CSV. The log is read twice: the first pass collects the union of the columns (the
/// layout may change within a run, e.g. the adjusted set when the support changes), the second
/// writes every message with empty cells for the columns it does not have.
class Sink {
 public:
  template <class Msg>
  bool scan(const lcm::LogEvent& ev) {
    Msg m;
    if (m.decode(ev.data, 0, static_cast<int>(ev.datalen)) < 0) return false;
    Row r;
    fill(r, m);
    if (r.names_ == last_names_) return true;  // the layout of the previous message: nothing new
    for (const auto& n : r.names_) {
      if (index_.emplace(n, header_.size()).second) header_.push_back(n);
    }
    last_names_ = std::move(r.names_);
    return true;
  }
  template <class Msg>
  void write(const lcm::LogEvent& ev, int64_t t0_us) {
    Msg m;
    if (m.decode(ev.data, 0, static_cast<int>(ev.datalen)) < 0) return;
    Row r;
    fill(r, m);
    if (!out_.is_open()) return;
    // The column of each of the row's values; looked up again only when the layout changes.
    if (r.names_ != last_names_) {
      column_.resize(r.names_.size());
      for (size_t i = 0; i < r.names_.size(); ++i) column_[i] = index_.at(r.names_[i]);
      last_names_ = std::move(r.names_);
    }
    cells_.assign(header_.size(), nullptr);
    for (size_t i = 0; i < column_.size(); ++i) cells_[column_[i]] = &r.values_[i];
    append_seconds(ev.timestamp - t0_us);
    for (const double* v : cells_) {
      line_ += ',';
      if (v != nullptr) append(*v, 9);  // as "%.9g"
    }
    line_ += '\n';
    if (line_.size() > (1U << 16)) flush();
    ++rows_;
  }
  void open(const fs::path& path) {
    out_.open(path);
    out_ << "log_time";
    for (const auto& n : header_) out_ << "," << n;
    out_ << "\n";
    last_names_.clear();
  }
  void flush() {
    out_.write(line_.data(), static_cast<std::streamsize>(line_.size()));
    line_.clear();
  }
  ~Sink() {
    if (out_.is_open()) flush();
  }
  Sink() = default;
  Sink(const Sink&) = delete;
  Sink& operator=(const Sink&) = delete;
  long rows_ = 0;

 private:
  std::ofstream out_;
  std::vector<std::string> header_;
  std::map<std::string, size_t> index_;
  std::vector<std::string> last_names_;  // the layout of the last message scanned or written
  std::vector<size_t> column_;           // its values' columns
  std::vector<const double*> cells_;
  std::string line_;  // rows not yet written

  /// `v` as printf's "%.{digits}g" would write it.
  void append(double v, int digits) {
    char buf[32];
    const auto r = std::to_chars(buf, buf + sizeof(buf), v, std::chars_format::general, digits);
    line_.append(buf, r.ptr);
  }
  /// A time of `us` microseconds in seconds, exactly (no trailing zeros).
  void append_seconds(int64_t us) {
    if (us < 0) {
      line_ += '-';
      us = -us;
    }
    char buf[32];
    line_.append(buf, std::to_chars(buf, buf + sizeof(buf), us / 1000000).ptr);
    int64_t frac = us % 1000000;
    if (frac == 0) return;
    int digits = 6;
    while (frac % 10 == 0) {
      frac /= 10;
      --digits;
    }
    const auto end = std::to_chars(buf, buf + sizeof(buf), frac).ptr;
    line_ += '.';
    line_.append(static_cast<size_t>(digits - (end - buf)), '0');
    line_.append(buf, end);
  }
};


}  // namespace

int main(int argc, char** argv) {
  std::string log_path, out_dir;
  std::set<std::string> only;
  long every = 1;
  const auto usage = [](std::FILE* out) { std::fputs("usage: lcm_export LOG OUTDIR [--channels A,B,...] [--every N]\n", out); };
  const auto refused = hpr::read_command_line(
      argc, argv, "lcm_export", usage,
      [&](hpr::ArgReader& args) {
        if (args.is("--channels")) {
          for (const auto& c : args.list()) only.insert(c);
        } else if (args.is("--every")) {
          every = std::max(1, args.integer());
        } else if (args.positional() && log_path.empty()) {
          log_path = args.current();
        } else if (args.positional() && out_dir.empty()) {
          out_dir = args.current();
        } else {
          args.unknown();
        }
      },
      [&] {
        if (out_dir.empty()) throw hpr::UsageError("a LOG and an OUTDIR are needed");
      });
  if (refused) return *refused;
  fs::create_directories(out_dir);
  std::map<std::string, Sink> sinks;
  std::map<std::string, long> unknown;
  long events = 0, bad = 0;
  int64_t t0_us = -1;  // the first event's time [µs]
  // Dispatch on the channel's type (channel names may carry a prefix).
  auto visit = [&](const lcm::LogEvent& ev, bool writing) {
    const std::string& ch = ev.channel;
    auto go = [&]<class Msg>() {
      Sink& sink = sinks[ch];
      if (writing) {
        sink.write<Msg>(ev, t0_us);
      } else {
        (void)sink.scan<Msg>(ev);  // an undecodable event is counted below, for every channel
      }
    };
    if (channels::names(ch, channels::kSimTruth.name)) {
      go.template operator()<humanoid::sim_truth_t>();
    } else if (channels::names(ch, channels::kRobotState.name)) {
      go.template operator()<humanoid::robot_state_t>();
    } else if (channels::names(ch, channels::kBalanceStatus.name)) {
      go.template operator()<humanoid::balance_status_t>();
    } else if (channels::names(ch, channels::kCamReference.name)) {
      go.template operator()<humanoid::cam_reference_t>();
    } else if (channels::names(ch, channels::kWholebodyCommand.name)) {
      go.template operator()<humanoid::wholebody_command_t>();
    } else if (channels::names(ch, channels::kBalancePlan.name)) {
      go.template operator()<humanoid::balance_plan_t>();
    } else if (channels::names(ch, channels::kRobotSensors.name)) {
      go.template operator()<humanoid::robot_sensors_t>();
    } else if (channels::names(ch, channels::kJointCommand.name)) {
      go.template operator()<humanoid::joint_command_t>();
    } else if (!writing) {
      ++unknown[ch];
    }
  };
  for (int pass = 0; pass < 2; ++pass) {
    lcm::LogFile log(log_path, "r");
    if (!log.good()) {
      std::fprintf(stderr, "lcm_export: cannot read the LCM log '%s'\n", log_path.c_str());
      return 1;
    }
    if (pass == 1) {
      for (auto& [ch, sink] : sinks) sink.open(fs::path(out_dir) / (ch + ".csv"));
    }
    std::map<std::string, long> seen;
    long offset = std::ftell(log.getFilePtr());
    for (const lcm::LogEvent* ev = log.readNextEvent(); ev != nullptr; ev = log.readNextEvent()) {
      if (pass == 0) {
        ++events;
        // The same judgement as lcm_recorder --check's (hpr::msg::check_message), on every event.
        if (const std::string why = hpr::msg::check_message(ev->channel, ev->data, ev->datalen); !why.empty()) {
          ++bad;
          std::fprintf(stderr, "lcm_export: event %lld at byte %ld on %s: %s; skipped\n", static_cast<long long>(ev->eventnum), offset,
                       ev->channel.c_str(), why.c_str());
        }
      }
      offset = std::ftell(log.getFilePtr());
      if (t0_us < 0) t0_us = ev->timestamp;
      if (!only.empty() && only.count(ev->channel) == 0) continue;
      if ((seen[ev->channel]++ % every) != 0) continue;
      visit(*ev, pass == 1);
    }
  }
  for (auto& [ch, sink] : sinks) sink.flush();
  for (const auto& [ch, s] : sinks) std::printf("%-20s %8ld rows\n", ch.c_str(), s.rows_);
  for (const auto& [ch, n] : unknown) std::printf("%-20s %8ld events not exported\n", ch.c_str(), n);
  std::printf("%ld events read, %ld undecodable; CSV files in %s\n", events, bad, out_dir.c_str());
  return bad > 0 ? 1 : 0;
}
