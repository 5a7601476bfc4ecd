// viewer: the 3D viewer of the stack. Serves a web page (three.js, urdf-loader) and the Foxglove
// WebSocket protocol on one local port, from the live LCM traffic or from a recorded log. It samples
// each channel at the display rate (viewer.rate_hz) and is never on the control path: nothing in the
// stack waits for it, and a slow browser only loses messages (counted).
//
//   viewer --config config/toro.yaml                           live, http://127.0.0.1:8765/
//   viewer --config config/toro.yaml --set viewer.log=run.lcm  a recorded run, with a time slider
#include <lcm/lcm-cpp.hpp>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <map>
#include <mutex>
#include <thread>

#include "hpr/common/log.hpp"
#include "hpr/msg/channels.hpp"
#include "hpr/node/command_line.hpp"
#include "hpr/node/lcm_url.hpp"
#include "hpr/node/runtime.hpp"
#include "hpr/viewer/channels.hpp"
#include "hpr/viewer/display_robot.hpp"
#include "hpr/viewer/timeline.hpp"
#include "server.hpp"

#ifndef HPR_VIEWER_WEB_DIR
#define HPR_VIEWER_WEB_DIR ""
#endif

namespace {

using namespace hpr;
namespace fs = std::filesystem;

/// The viewer's ports: it reads every channel it shows (undecoded, sampled at the display rate)
/// and writes none.
const Ports& viewer_ports() {
  static const std::vector<Read> reads = [] {
    std::vector<Read> r;
    for (const auto& c : viewer::channels()) r.push_back(Read{c.name, 0, false, false, "shown"});
    return r;
  }();
  static const Ports ports{.name = "viewer", .reads = reads, .writes = {}};
  return ports;
}

/// The latest raw message of each shown channel; decoded only when sampled (at the display rate).
class Sampler {
 public:
  Sampler(node::Runtime& rt, viewer::Server& server) : rt_(rt), server_(server) {
    const auto& chans = viewer::channels();
    slots_.resize(chans.size());
    for (std::size_t c = 0; c < chans.size(); ++c) {
      slots_[c].index = c;
      // HEALTH (one per node) and PUSH (rare) are forwarded message by message.
      slots_[c].every_message = chans[c].name == hpr::msg::channels::kHealth.name || chans[c].name == hpr::msg::channels::kPush.name;
      // Room for a display period of messages at 1 kHz (the loop below reads them in batches).
      slots_[c].sampler = this;
      rt.transport().subscribe_bytes(
          chans[c].name, [slot = &slots_[c]](const std::uint8_t* data, std::size_t size) { slot->handle(data, size); }, 1000);
    }
  }

  /// Decodes and sends what changed since the last call.
  void flush() {
    for (auto& s : slots_) {
      if (!s.fresh) continue;
      s.fresh = false;
      send(s, s.data);
    }
  }

  [[nodiscard]] std::int64_t last_tick() const { return last_tick_; }
  [[nodiscard]] std::uint64_t decode_errors() const { return decode_errors_; }

 private:
  struct Slot {
    std::size_t index = 0;
    bool every_message = false;
    bool fresh = false;
    std::vector<std::uint8_t> data;
    Sampler* sampler = nullptr;
    void handle(const std::uint8_t* p, std::size_t size) {
      if (every_message) {
        sampler->send(*this, std::vector<std::uint8_t>(p, p + size));
        return;
      }
      data.assign(p, p + size);
      fresh = true;
    }
  };

  void send(const Slot& s, const std::vector<std::uint8_t>& bytes) {
    const auto& name = viewer::channels()[s.index].name;
    try {
      auto d = viewer::decode(name, bytes.data(), bytes.size());
      if (name == hpr::msg::channels::kRobotState.name) last_tick_ = d.tick;
      const auto ts = static_cast<std::uint64_t>(std::chrono::duration_cast<std::chrono::nanoseconds>(
                                                     std::chrono::system_clock::now().time_since_epoch())
                                                     .count());
      server_.publish(s.index, d.json.dump(), ts);
    } catch (const viewer::DecodeError& e) {
      ++decode_errors_;
      if (reported_[name]++ == 0) log::warn("viewer: skipped: {}", e.what());  // one line per channel
      rt_.set_fault("decode:" + name, e.what(), false, 2.0);
    }
  }

  node::Runtime& rt_;
  viewer::Server& server_;
  std::vector<Slot> slots_;
  std::map<std::string, long> reported_;
  std::int64_t last_tick_ = -1;
  std::uint64_t decode_errors_ = 0;
};

std::vector<viewer::LogEvent> read_log(const std::string& path) {
  if (fs::is_directory(path)) throw std::runtime_error("viewer.log: '" + path + "' is a directory, not an LCM log");
  lcm::LogFile log(path, "r");
  if (!log.good()) throw std::runtime_error("viewer.log: cannot read the LCM log '" + path + "'");
  std::vector<viewer::LogEvent> events;
  for (const lcm::LogEvent* ev = log.readNextEvent(); ev != nullptr; ev = log.readNextEvent()) {
    if (viewer::channel_index(ev->channel) < 0) continue;
    const auto* p = static_cast<const std::uint8_t*>(ev->data);
    events.push_back({ev->timestamp, ev->channel, std::vector<std::uint8_t>(p, p + ev->datalen)});
  }
  return events;
}

/// A log recorded with another robot cannot be shown: its first ROBOT_STATE must name joints of
/// `robot` (controlled, held or locked).
void check_joints(const viewer::Timeline& timeline, const model::RobotSpec& robot, const std::string& config,
                  const std::string& log_path) {
  const auto frame = timeline.frame(0);
  if (!frame["channels"].contains(hpr::msg::channels::kRobotState.name)) return;
  const auto& m = robot.model;
  std::vector<std::string> unknown;
  for (const auto& name : frame["channels"][hpr::msg::channels::kRobotState.name]["joint_name"]) {
    const auto n = name.get<std::string>();
    auto has = [&n](const std::vector<std::string>& v) { return std::find(v.begin(), v.end(), n) != v.end(); };
    if (!has(m.joint_name) && !has(m.held_joint_name) && !has(m.locked_joint_name)) unknown.push_back(n);
  }
  if (!unknown.empty()) {
    throw std::runtime_error(fmt::format("{}: ROBOT_STATE names {} joint(s) that robot '{}' ({}) does not have ({}{}): view the "
                                         "log with the robot it was recorded with (tools/view LOG --robot NAME)",
                                         log_path, unknown.size(), robot.name, config, unknown.front(),
                                         unknown.size() > 1 ? ", ..." : ""));
  }
}

/// The page's folder: the source tree's when this is the build tree's viewer, else the installed one
/// (prefix/bin/viewer -> prefix/share/hpr/viewer/web).
std::string default_web_dir() {
  std::error_code ec;
  if (fs::exists(HPR_VIEWER_WEB_DIR, ec)) return HPR_VIEWER_WEB_DIR;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec).parent_path();
  return (exe / ".." / "share" / "hpr" / "viewer" / "web").lexically_normal().string();
}

void announce(int port, const std::string& bind, const std::string& what) {
  std::printf("viewer: %s at http://%s:%d/\n", what.c_str(), bind.c_str(), port);
  std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) {
  return node::run_main(argc, argv, "viewer", "3D viewer: web page and Foxglove WebSocket server", [](const node::CommandLine& cl,
                                                                                                         const Config& cfg) {
    const Config section = cfg.has("viewer") ? cfg.section("viewer") : Config::parse("{}", cfg.file() + " (viewer)");
    section.reject_unknown({"port", "bind", "rate_hz", "log", "log_fps", "web_dir", "max_client_buffer_kb", "mesh_max_triangles",
                            "mesh_max_error"});
    viewer::ServerOptions opt;
    opt.port = static_cast<int>(section.integer_or("port", 8765, 0, 65535));
    opt.bind = section.string_or("bind", "127.0.0.1");
    const double rate = section.real_or("rate_hz", 30.0, 1.0, 120.0);
    opt.playback_rate_hz = rate;
    opt.max_client_buffer = static_cast<std::size_t>(section.integer_or("max_client_buffer_kb", 1024, 16, 1 << 20)) * 1024;
    opt.web_dir = section.has("web_dir") ? section.file_path("web_dir") : default_web_dir();
    if (!fs::exists(fs::path(opt.web_dir) / "node_modules" / "three" / "build" / "three.module.js")) {
      section.fail("web_dir", fmt::format("'{}' lacks node_modules/three: install the page's packages with "
                                          "`tools/install-web-packages {}` (tools/install-deps does)", opt.web_dir, opt.web_dir));
    }
    const auto robot = model::RobotSpec::load(cfg.section("robot"));
    viewer::DisplayOptions display_options;
    display_options.mesh_max_triangles = static_cast<std::size_t>(section.integer_or("mesh_max_triangles", 1500, 0, 10'000'000));
    display_options.mesh_max_error = section.real_or("mesh_max_error", 0.002, 0.0, 0.1);
    auto display = viewer::display_robot(robot, display_options);
    if (display.triangles_in > 0) {
      log::info("viewer: {} meshes, {} triangles shown of {} (viewer.mesh_max_triangles {} per mesh, mesh_max_error {} m)",
                display.mesh_files.size(), display.triangles_out, display.triangles_in, display_options.mesh_max_triangles,
                display_options.mesh_max_error);
    }

    if (section.has("log")) {
      const std::string path = section.string("log");
      viewer::Timeline timeline(read_log(path), section.real_or("log_fps", 60.0, 1.0, 1000.0));
      for (const auto& why : timeline.skip_reasons()) log::warn("viewer: skipped: {}", why);
      log::info("viewer: {}: {} messages shown, {:.2f} s, {} frames at {} Hz{}", path, timeline.num_events(),
                timeline.duration(), timeline.num_frames(), timeline.fps(),
                timeline.skipped() ? fmt::format(", {} malformed skipped", timeline.skipped()) : "");
      check_joints(timeline, robot, cfg.file(), path);
      viewer::Server server(opt, std::move(display), &timeline);
      announce(server.port(), opt.bind, "playing " + path);
      sigset_t set;
      sigemptyset(&set);
      sigaddset(&set, SIGINT);
      sigaddset(&set, SIGTERM);
      pthread_sigmask(SIG_BLOCK, &set, nullptr);
      int sig = 0;
      sigwait(&set, &sig);
      log::info("viewer: stopping ({})", sig == SIGINT ? "SIGINT" : "SIGTERM");
      return 0;
    }

    node::RuntimeOptions ro = node::runtime_options(cfg, 1.0 / rate);
    node::Runtime rt(viewer_ports(), cl.name, node::lcm_url(cl, cfg), ro);
    viewer::Server server(opt, std::move(display), nullptr);
    Sampler sampler(rt, server);
    rt.every(1.0 / rate, [&] {
      const auto t0 = std::chrono::steady_clock::now();
      sampler.flush();
      rt.record_step(sampler.last_tick(),
                     std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    });
    rt.every(1.0, [&] {
      const auto s = server.stats();
      server.set_status_extra(nlohmann::json{{"decode_errors", sampler.decode_errors()}, {"last_tick", sampler.last_tick()}}.dump());
      if (s.dropped > 0) rt.set_fault("clients", fmt::format("{} messages dropped for slow clients", s.dropped), false, 5.0);
    });
    announce(server.port(), opt.bind, "live");
    // Messages are read in batches at the display rate rather than one wake-up per message: the
    // viewer keeps only the latest of each channel, and a 1 kHz stack would otherwise wake it
    // thousands of times a second.
    const auto period = std::chrono::duration<double>(1.0 / rate);
    auto next = std::chrono::steady_clock::now();
    while (!rt.stop_requested()) {
      next += std::chrono::duration_cast<std::chrono::steady_clock::duration>(period);
      const auto now = std::chrono::steady_clock::now();
      if (next < now) next = now;
      std::this_thread::sleep_until(next);
      rt.spin_once(0.0);
    }
    return 0;
  });
}
