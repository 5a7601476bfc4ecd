#include "server.hpp"


#include <websocketpp/config/asio_no_tls.hpp>
#include <websocketpp/server.hpp>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <set>
#include <sstream>

#include <fmt/format.h>

#include "hpr/common/log.hpp"
#include "hpr/viewer/channels.hpp"
#include "hpr/viewer/foxglove.hpp"

namespace hpr::viewer {
namespace {

namespace fs = std::filesystem;
using WsServer = websocketpp::server<websocketpp::config::asio>;
using Hdl = websocketpp::connection_hdl;

std::string content_type(const fs::path& p) {
  static const std::map<std::string, std::string> types{
      {".html", "text/html; charset=utf-8"}, {".js", "text/javascript; charset=utf-8"},
      {".mjs", "text/javascript; charset=utf-8"}, {".css", "text/css; charset=utf-8"},
      {".json", "application/json"}, {".urdf", "application/xml"}, {".png", "image/png"},
      {".stl", "model/stl"}, {".dae", "model/vnd.collada+xml"}, {".obj", "model/obj"}, {".svg", "image/svg+xml"}};
  std::string ext = p.extension().string();
  for (auto& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  const auto it = types.find(ext);
  return it == types.end() ? "application/octet-stream" : it->second;
}

bool read_file(const fs::path& p, std::string& out) {
  std::ifstream in(p, std::ios::binary);
  if (!in) return false;
  std::ostringstream s;
  s << in.rdbuf();
  out = s.str();
  return true;
}

/// `rel` under `base`, or empty when it would leave `base` (.., symlinks out) or does not exist.
fs::path contained(const fs::path& base, const std::string& rel) {
  std::error_code ec;
  const fs::path b = fs::canonical(base, ec);
  if (ec) return {};
  const fs::path p = fs::canonical(b / rel, ec);
  if (ec || !fs::is_regular_file(p, ec)) return {};
  const auto [mb, mp] = std::mismatch(b.begin(), b.end(), p.begin(), p.end());
  return mb == b.end() ? p : fs::path();
}

struct Client {
  foxglove::Subscriptions subs;
};

}  // namespace

struct Server::Impl {
  ServerOptions options;
  DisplayRobot robot;
  const Timeline* timeline;
  WsServer ws;
  std::thread io;
  std::map<Hdl, Client, std::owner_less<Hdl>> clients;
  std::atomic<std::uint64_t> sent{0}, dropped{0}, http_requests{0}, bad_ops{0}, client_count{0};
  std::mutex extra_mutex;
  std::string extra = "{}";
  std::string advertise = foxglove::advertise(channels());
  // Log mode: the WebSocket plays the run in a loop on the robot clock.
  std::unique_ptr<asio::steady_timer> playback;
  int playback_frame = 0;
  std::vector<long> playback_last;
  std::chrono::steady_clock::time_point playback_start;

  void send_to_subscribers(std::size_t channel, const std::string& json, std::uint64_t ts) {
    const auto id = static_cast<std::uint32_t>(channel + 1);
    for (auto& [hdl, c] : clients) {
      const auto subs = c.subs.of_channel(id);
      if (subs.empty()) continue;
      websocketpp::lib::error_code ec;
      auto con = ws.get_con_from_hdl(hdl, ec);
      if (ec || !con) continue;
      for (auto sub : subs) {
        if (con->get_buffered_amount() > options.max_client_buffer) {
          ++dropped;  // a slow client loses messages; the viewer and the stack never wait for it
          continue;
        }
        if (!con->send(foxglove::message_data(sub, ts, json), websocketpp::frame::opcode::binary)) ++sent;
      }
    }
  }

  void on_open(Hdl hdl) {
    clients[hdl];
    client_count = clients.size();
    websocketpp::lib::error_code ec;
    ws.send(hdl,
            foxglove::server_info("hpr viewer", {{"robot", robot.info["name"].get<std::string>()},
                                                 {"mode", timeline ? "log" : "live"}},
                                  fmt::format("{}", std::chrono::system_clock::now().time_since_epoch().count())),
            websocketpp::frame::opcode::text, ec);
    ws.send(hdl, advertise, websocketpp::frame::opcode::text, ec);
  }

  void on_close(Hdl hdl) {
    clients.erase(hdl);
    client_count = clients.size();
  }

  void on_message(Hdl hdl, WsServer::message_ptr msg) {
    auto it = clients.find(hdl);
    if (it == clients.end()) return;
    std::string why;
    if (msg->get_opcode() != websocketpp::frame::opcode::text) {
      why = "binary client operations are not supported";
    } else {
      why = it->second.subs.apply(msg->get_payload(), channels().size());
    }
    if (!why.empty()) {
      ++bad_ops;
      websocketpp::lib::error_code ec;
      ws.send(hdl, foxglove::status(foxglove::Level::kWarning, why), websocketpp::frame::opcode::text, ec);
    }
  }

  bool on_validate(Hdl hdl) {
    auto con = ws.get_con_from_hdl(hdl);
    for (const auto& p : con->get_requested_subprotocols()) {
      if (p == foxglove::kSubprotocol) {
        con->select_subprotocol(p);
        return true;
      }
    }
    con->set_status(websocketpp::http::status_code::bad_request);
    con->set_body(fmt::format("this server speaks the {} WebSocket subprotocol only\n", foxglove::kSubprotocol));
    return false;
  }

  void reply(WsServer::connection_ptr con, websocketpp::http::status_code::value code, const std::string& type,
             std::string body) {
    con->set_status(code);
    con->append_header("Content-Type", type);
    con->append_header("Cache-Control", "no-cache");
    con->set_body(std::move(body));
  }

  void on_http(Hdl hdl) {
    ++http_requests;
    auto con = ws.get_con_from_hdl(hdl);
    std::string path = con->get_resource();
    std::string query;
    if (const auto q = path.find('?'); q != std::string::npos) {
      query = path.substr(q + 1);
      path.resize(q);
    }
    using websocketpp::http::status_code::not_found;
    using websocketpp::http::status_code::ok;
    const fs::path web(options.web_dir);
    auto serve = [&](const fs::path& base, const std::string& rel) {
      const fs::path p = contained(base, rel);
      std::string body;
      if (p.empty() || !read_file(p, body)) {
        reply(con, not_found, "text/plain", "not found: " + path + "\n");
      } else {
        reply(con, ok, content_type(p), std::move(body));
      }
    };
    auto starts = [&path](const char* prefix) { return path.rfind(prefix, 0) == 0; };
    if (path == "/" || path == "/index.html") {
      serve(web, "index.html");
    } else if (starts("/app/")) {
      serve(web / "src", path.substr(5));
    } else if (starts("/vendor/three/")) {
      serve(web / "node_modules" / "three", path.substr(14));
    } else if (starts("/vendor/urdf-loader/")) {
      serve(web / "node_modules" / "urdf-loader" / "src", path.substr(20));
    } else if (path == "/robot/robot.urdf") {
      reply(con, ok, "application/xml", robot.urdf);
    } else if (path == "/robot/info.json") {
      reply(con, ok, "application/json", robot.info.dump());
    } else if (starts("/robot/mesh/")) {
      const std::string name = path.substr(12);
      for (std::size_t i = 0; i < robot.mesh_urls.size(); ++i) {
        if (robot.mesh_urls[i] == path) {
          reply(con, ok, content_type(path), robot.mesh_data[i]);
          return;
        }
      }
      reply(con, not_found, "text/plain", "no mesh " + name + "\n");
    } else if (path == "/api/mode") {
      reply(con, ok, "application/json",
            nlohmann::json{{"mode", timeline ? "log" : "live"}, {"subprotocol", foxglove::kSubprotocol}}.dump());
    } else if (path == "/api/status") {
      nlohmann::json s = {{"clients", client_count.load()}, {"sent", sent.load()}, {"dropped", dropped.load()},
                          {"http_requests", http_requests.load()}, {"bad_client_ops", bad_ops.load()}};
      {
        std::lock_guard<std::mutex> lock(extra_mutex);
        s.update(nlohmann::json::parse(extra, nullptr, false));
      }
      reply(con, ok, "application/json", s.dump());
    } else if (timeline && path == "/api/log") {
      reply(con, ok, "application/json", summary_text());
    } else if (timeline && starts("/api/frames/")) {
      // /api/frames/<first>/<count>: up to 120 consecutive frames in one reply (playback prefetch).
      int first = -1, count = 0;
      if (std::sscanf(path.c_str() + 12, "%d/%d", &first, &count) != 2 || first < 0 || first >= timeline->num_frames() ||
          count < 1 || count > 120) {
        reply(con, not_found, "text/plain", fmt::format("expected /api/frames/<first 0 to {}>/<count 1 to 120>\n", timeline->num_frames() - 1));
      } else {
        nlohmann::json frames = nlohmann::json::array();
        for (int i = first; i < std::min(first + count, timeline->num_frames()); ++i) frames.push_back(timeline->frame(i));
        reply(con, ok, "application/json", frames.dump());
      }
    } else if (timeline && starts("/api/frame/")) {
      int i = -1;
      try {
        i = std::stoi(path.substr(11));
      } catch (const std::exception&) {
      }
      if (i < 0 || i >= timeline->num_frames()) {
        reply(con, not_found, "text/plain", fmt::format("frame index must be 0 to {}\n", timeline->num_frames() - 1));
      } else {
        reply(con, ok, "application/json", timeline->frame(i).dump());
      }
    } else {
      reply(con, not_found, "text/plain", "not found: " + path + "\n");
    }
  }

  const std::string& summary_text() {
    if (summary.empty()) summary = timeline->summary().dump();
    return summary;
  }
  std::string summary;

  void playback_tick() {
    const auto now = std::chrono::steady_clock::now();
    const double elapsed = std::chrono::duration<double>(now - playback_start).count();
    const int n = timeline->num_frames();
    const int frame = static_cast<int>(elapsed * timeline->fps()) % std::max(n, 1);
    if (frame < playback_frame) std::fill(playback_last.begin(), playback_last.end(), -1);  // looped
    playback_frame = frame;
    const auto at = timeline->events_at(frame);
    for (std::size_t c = 0; c < at.size(); ++c) {
      if (at[c] < 0 || at[c] == playback_last[c]) continue;
      playback_last[c] = at[c];
      if (clients.empty()) continue;
      const auto ts = static_cast<std::uint64_t>(timeline->event_time(c, at[c]) * 1e9);
      send_to_subscribers(c, timeline->event_json(c, at[c]).dump(), ts);
    }
    playback->expires_after(std::chrono::microseconds(static_cast<long>(1e6 / options.playback_rate_hz)));
    playback->async_wait([this](const asio::error_code& ec) {
      if (!ec) playback_tick();
    });
  }
};

Server::Server(ServerOptions options, DisplayRobot robot, const Timeline* timeline) : impl_(std::make_unique<Impl>()) {
  auto& d = *impl_;
  d.options = std::move(options);
  d.robot = std::move(robot);
  d.timeline = timeline;
  d.ws.clear_access_channels(websocketpp::log::alevel::all);
  d.ws.clear_error_channels(websocketpp::log::elevel::all);
  d.ws.init_asio();
  d.ws.set_reuse_addr(true);
  d.ws.set_open_handler([&d](Hdl h) { d.on_open(h); });
  d.ws.set_close_handler([&d](Hdl h) { d.on_close(h); });
  d.ws.set_fail_handler([](Hdl) {});
  d.ws.set_message_handler([&d](Hdl h, WsServer::message_ptr m) { d.on_message(h, m); });
  d.ws.set_validate_handler([&d](Hdl h) { return d.on_validate(h); });
  d.ws.set_http_handler([&d](Hdl h) { d.on_http(h); });
  asio::error_code ec;
  const auto address = asio::ip::make_address(d.options.bind, ec);
  if (ec) throw std::runtime_error(fmt::format("viewer.bind: '{}' is not an IP address", d.options.bind));
  d.ws.listen(asio::ip::tcp::endpoint(address, static_cast<unsigned short>(d.options.port)), ec);
  if (ec) throw std::runtime_error(fmt::format("cannot listen on {}:{}: {}", d.options.bind, d.options.port, ec.message()));
  const auto local = d.ws.get_local_endpoint(ec);
  port_ = ec ? d.options.port : local.port();
  d.ws.start_accept();
  if (timeline) {
    d.playback = std::make_unique<asio::steady_timer>(d.ws.get_io_service());
    d.playback_last.assign(channels().size(), -1);
    d.playback_start = std::chrono::steady_clock::now();
    asio::post(d.ws.get_io_service(), [&d] { d.playback_tick(); });
  }
  d.io = std::thread([&d] {
    try {
      d.ws.run();
    } catch (const std::exception& e) {
      log::error("viewer: server thread: {}", e.what());
    }
  });
}

Server::~Server() {
  auto& d = *impl_;
  asio::post(d.ws.get_io_service(), [&d] {
    if (d.playback) d.playback->cancel();
    websocketpp::lib::error_code ec;
    d.ws.stop_listening(ec);
    for (auto& [hdl, c] : d.clients) d.ws.close(hdl, websocketpp::close::status::going_away, "viewer stopping", ec);
  });
  // Give the close frames a moment, then stop the loop.
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  d.ws.stop();
  if (d.io.joinable()) d.io.join();
}

void Server::publish(std::size_t channel, std::string json, std::uint64_t timestamp_ns) {
  auto& d = *impl_;
  if (d.client_count.load() == 0) return;
  asio::post(d.ws.get_io_service(),
             [&d, channel, j = std::move(json), timestamp_ns] { d.send_to_subscribers(channel, j, timestamp_ns); });
}

ServerStats Server::stats() const {
  const auto& d = *impl_;
  return {d.client_count.load(), d.sent.load(), d.dropped.load(), d.http_requests.load(), d.bad_ops.load()};
}

void Server::set_status_extra(std::string json) {
  std::lock_guard<std::mutex> lock(impl_->extra_mutex);
  impl_->extra = std::move(json);
}

}  // namespace hpr::viewer
