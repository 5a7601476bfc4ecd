#pragma once
// The supervisor's parts shared by its commands: the options, the status table, the typed
// subscription, and the client commands (status, down, restart, logs, groups) that talk to running
// supervisors over LCM (supervisor_client.cpp); `up` and the running supervisor are in
// supervisor_main.cpp, these helpers in supervisor_common.cpp.
#include <humanoid/supervisor_status_t.hpp>

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <string>
#include <type_traits>
#include <vector>

#include "hpr/common/auth.hpp"
#include "hpr/common/channel.hpp"
#include "hpr/common/log.hpp"
#include "hpr/common/time.hpp"
#include "hpr/launch/groups.hpp"
#include "hpr/node/freshness.hpp"

namespace hpr::supervisor_cli {

namespace fs = std::filesystem;
using Status = humanoid::supervisor_status_t;

/// Set by SIGINT/SIGTERM (on_signal): every loop of the tool ends.
extern std::atomic<bool> g_stop;
void on_signal(int);

struct Options {
  std::string command, target;  // target: group (up) or process (logs, restart)
  std::string groups_file, host, group_filter, run_root, lcm_url;
  std::map<std::string, std::string> vars;
  bool host_given = false, foreground = false, json = false, follow = false;
  double wait_s = 1.2;
  int lines = 100;
};

/// This machine's host name without its domain ("localhost" when it has none).
std::string machine_host();
/// The LCM URL: --lcm-url, else the groups file's, else $LCM_DEFAULT_URL, else LCM's default.
std::string resolve_url(const Options& o, const launch::GroupsFile* f);
/// Local wall-clock time "HH:MM:SS.mmm" for log lines.
std::string now_text();
const char* health_text(int s);
std::string uptime_text(double s);
/// The status table of one or more hosts' supervisors.
std::string render(const std::vector<Status>& hosts);
/// The last `lines` lines of a file.
std::string tail_file(const std::string& path, int lines);

/// A typed LCM subscription calling a std::function (this LCM release has no lambda subscribe).
/// A message that does not decode is counted (errors()) and logged, rate limited, with its
/// channel and size, instead of LCM's own line per message. With a key, a message without its valid
/// authentication code is refused the same way before it is decoded (unauthenticated()). A command
/// (SUPERVISOR_COMMAND) is taken only when fresh (hpr/node/freshness.hpp): a copy is dropped, a
/// stale or replayed one refused and counted (stale()).
template <class Msg>
class Subscription {
 public:
  Subscription(lcm::LCM& lcm, const Channel<Msg>& channel, std::type_identity_t<std::function<void(const Msg&)>> f,
               const auth::Key* key = nullptr)
      : lcm_(lcm), f_(std::move(f)), key_(key) {
    sub_ = lcm_.subscribe(channel.name, &Subscription::on, this);
  }
  ~Subscription() { lcm_.unsubscribe(sub_); }
  Subscription(const Subscription&) = delete;
  Subscription& operator=(const Subscription&) = delete;
  [[nodiscard]] std::int64_t errors() const { return errors_; }
  [[nodiscard]] std::int64_t unauthenticated() const { return unauthenticated_; }
  [[nodiscard]] std::int64_t stale() const { return stale_; }

 private:
  void on(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
    if (key_ != nullptr && !auth::verify(static_cast<const std::uint8_t*>(rbuf->data), rbuf->data_size, channel, *key_)) {
      ++errors_;
      ++unauthenticated_;
      hpr::log::warn("{}: a message of {} bytes refused: no valid authentication code (not signed with {}; {} refused so far)",
                     channel, rbuf->data_size, key_->path, unauthenticated_);
      return;
    }
    if (msg_.decode(rbuf->data, 0, static_cast<int>(rbuf->data_size)) < 0) {
      ++errors_;
      hpr::log::warn("{}: a message of {} bytes is not a valid {} ({} so far)", channel, rbuf->data_size, Msg::getTypeName(), errors_);
      return;
    }
    if constexpr (node::Command<Msg>) {
      std::string why;
      switch (freshness_.check(msg_.source, msg_.utime, wall_us(), why)) {
        case node::CommandFreshness::Verdict::kFresh: break;
        case node::CommandFreshness::Verdict::kCopy: return;
        default:
          ++errors_;
          ++stale_;
          hpr::log::warn("{}: a {} refused: {} ({} refused so far)", channel, Msg::getTypeName(), why, stale_);
          return;
      }
    }
    f_(msg_);
  }
  lcm::LCM& lcm_;
  std::function<void(const Msg&)> f_;
  const auth::Key* key_ = nullptr;
  lcm::Subscription* sub_ = nullptr;
  Msg msg_{};
  std::int64_t errors_ = 0, unauthenticated_ = 0, stale_ = 0;
  node::CommandFreshness freshness_;
};

/// Handles messages for `timeout_s`, and always whatever is already queued.
void handle_for(lcm::LCM& lcm, double timeout_s);
/// The latest status of each (host, group) heard within `wait_s`.
std::vector<Status> collect_status(lcm::LCM& lcm, double wait_s, const std::string& group_filter);
/// The group's inputs that none of its processes writes (the stack's declared data flow).
std::vector<std::string> unmet_inputs(const launch::GroupSpec& g);

int cmd_status(const Options& o, const std::string& url);
int cmd_down(const Options& o, const std::string& url);
int cmd_restart(const Options& o, const std::string& url);
int cmd_logs(const Options& o, const std::string& url);
int cmd_groups(const Options& o);

}  // namespace hpr::supervisor_cli
