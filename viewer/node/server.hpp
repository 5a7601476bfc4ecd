#pragma once
/// \file
/// The viewer's HTTP and WebSocket server (websocketpp on standalone Asio, one port): the page and
/// its scripts, the robot's display URDF and meshes, a recorded run's frames, and the Foxglove
/// WebSocket protocol. Everything runs on one I/O thread; publish() may be called from any thread.

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <thread>

#include "hpr/viewer/display_robot.hpp"
#include "hpr/viewer/timeline.hpp"

namespace hpr::viewer {

struct ServerOptions {
  std::string bind = "127.0.0.1";
  int port = 8765;                    ///< 0: any free port (port() tells which)
  std::string web_dir;                ///< viewer/web: index.html, src/, node_modules/
  std::size_t max_client_buffer = 1 << 20;  ///< [bytes] queued for one client before messages to it are dropped
  double playback_rate_hz = 30.0;     ///< log mode: message rate of the WebSocket playback
};

struct ServerStats {
  std::uint64_t clients = 0, sent = 0, dropped = 0, http_requests = 0, bad_client_ops = 0;
};

class Server {
 public:
  /// Opens the port (throws std::runtime_error naming the address when it cannot). `timeline`
  /// (may be null: live mode) must outlive the server.
  Server(ServerOptions options, DisplayRobot robot, const Timeline* timeline);
  ~Server();
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  [[nodiscard]] int port() const { return port_; }
  /// Sends `json` as a message of channel `channel` (index into channels()) to every subscriber,
  /// skipping a client whose queue is over the limit (counted as dropped). Thread-safe.
  void publish(std::size_t channel, std::string json, std::uint64_t timestamp_ns);
  [[nodiscard]] ServerStats stats() const;
  /// Extra JSON merged into /api/status (the node's own counters). Thread-safe.
  void set_status_extra(std::string json);

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
  int port_ = 0;
};

}  // namespace hpr::viewer
