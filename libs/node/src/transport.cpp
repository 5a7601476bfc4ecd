// A process's view of LCM, held to its declaration (hpr/node/transport.hpp).
#include "hpr/node/transport.hpp"

#include <poll.h>

#include <algorithm>
#include <limits>
#include <random>
#include <stdexcept>

#include <fmt/format.h>

#include "hpr/common/log.hpp"
#include "hpr/common/time.hpp"
#include "hpr/node/lcm_url.hpp"

namespace hpr::node {
namespace {

/// Datagrams the own socket is drained of at a time: a few ticks' worth, so that timers (HEALTH)
/// and steps run between batches of a backlog.
constexpr std::size_t kDirectDrainBatch = 256;

/// The largest message the own socket takes on a channel the node reads [bytes]: one datagram's
/// worth. The stack's messages are a few kB (2.4 kB for WHOLEBODY_COMMAND with 27 joints, about 80
/// bytes more per joint), so a fragmented one is never the stack's; a forged first fragment that
/// declares more is refused without an allocation (hpr/node/udpm.hpp).
constexpr std::size_t kMaxReadMessageBytes = 65'536;
/// What the unfinished fragmented messages of all senders may hold together [bytes].
constexpr std::size_t kDirectPartialBudget = 1u << 20;

}  // namespace

Transport::Transport(const Ports& declared, std::string node, const std::string& lcm_url, TransportOptions options,
                     InputEvents& events, const StreamRules& rules, std::function<bool()> stop)
    : declared_(declared), node_(std::move(node)), options_(std::move(options)), events_(events), rules_(rules), stop_(std::move(stop)) {
  lcm_ = open_lcm(lcm_url);
  if (options_.receive_direct && is_udpm_url(lcm_url)) {
    const auto limit = [this](std::string_view channel) -> std::size_t {
      return by_channel_.find(channel) == by_channel_.end() ? 0 : kMaxReadMessageBytes;
    };
    receiver_ = std::make_unique<UdpmReceiver>(parse_udpm_url(with_receive_buffer(lcm_url, kDirectReceiveBufferBytes)), limit,
                                               kDirectPartialBudget);
    deliver_ = [this](std::string_view channel, const std::uint8_t* payload, std::size_t size, std::int64_t /*utime*/) {
      const auto it = by_channel_.find(channel);
      if (it == by_channel_.end()) return;
      // By index: a callback may subscribe (a vector that grows moves, a map node does not).
      for (std::size_t i = 0; i < it->second.size(); ++i) it->second[i]->deliver(payload, size);
    };
  }
  std::random_device entropy;
  while (source_id_ == 0) source_id_ = static_cast<std::int64_t>(std::uint64_t{entropy()} << 32);
}

Transport::~Transport() = default;

void Transport::check_declared(std::string_view ch, bool write) const {
  if (write ? declared_.writes_to(ch) : declared_.read(ch) != nullptr) return;
  throw std::logic_error(
      fmt::format("{} {} {}, which its declared ports ({}) do not list", node_, write ? "publishes" : "reads", ch, declared_.name));
}

const auth::Key* Transport::deployment_key() {
  if (!options_.authenticate) {
    if (!warned_unauthenticated_) {
      log::warn("lcm.authentication is off: commands (OPERATOR, JOINT_COMMAND, SUPERVISOR_COMMAND) and the control chain's "
                "samples are accepted from anyone on the LCM network, and sent unsigned");
      warned_unauthenticated_ = true;
    }
    return nullptr;
  }
  if (!key_) key_ = std::make_unique<auth::Key>(auth::load_key(auth::key_path()));
  return key_.get();
}

void Transport::subscribe_bytes(std::string_view name, BytesHandler handler, int queue_capacity) {
  check_declared(name, false);
  bytes_.push_back(std::make_unique<BytesSubscription>(BytesSubscription{std::move(handler)}));
  lcm_->subscribe(channel(name), &BytesSubscription::on_lcm, bytes_.back().get())->setQueueCapacity(queue_capacity);
  bytes_subscribed_ = true;
}

void Transport::publish_bytes(std::string_view name, const void* data, std::size_t size) {
  check_declared(name, true);
  lcm_->publish(channel(name), data, static_cast<unsigned>(size));
}

int Transport::receive_fd() const { return receiver_ ? receiver_->fd() : lcm_->getFileno(); }

int Transport::extra_fd() const { return receiver_ && bytes_subscribed_ ? lcm_->getFileno() : -1; }

void Transport::handle_lcm() {
  lcm_->handle();
  // Drain whatever else is already queued, without blocking.
  pollfd more{lcm_->getFileno(), POLLIN, 0};
  while (!stop_() && ::poll(&more, 1, 0) > 0 && (more.revents & POLLIN) != 0) lcm_->handle();
}

void Transport::receive(bool typed, bool extra) {
  if (typed) {
    if (receiver_) {
      receive_direct();
    } else {
      handle_lcm();
    }
  }
  if (extra && extra_fd() >= 0) handle_lcm();
}

void Transport::receive_direct() {
  receiver_->drain(deliver_, kDirectDrainBatch);
  if (receiver_->refused() != refused_reported_) {
    const double now = monotonic_s();
    if (now - last_refusal_log_ > 1.0) {
      last_refusal_log_ = now;
      log::warn("LCM: refused {} ({} datagrams refused so far)", receiver_->last_refusal(), receiver_->refused());
      refused_reported_ = receiver_->refused();
    }
  }
}

void Transport::follow_quiet_streams(double now) {
  for (auto& in : inputs_) in->follow_if_quiet(now);
}

double Transport::next_follow_time() const {
  double next = std::numeric_limits<double>::infinity();
  for (const auto& in : inputs_) next = std::min(next, in->follow_time());
  return next;
}

std::int64_t Transport::decode_errors() const {
  std::int64_t n = 0;
  for (const auto& in : inputs_) n += in->errors();
  return n;
}

std::int64_t Transport::unauthenticated() const {
  std::int64_t n = 0;
  for (const auto& in : inputs_) n += in->unauthenticated();
  return n;
}

}  // namespace hpr::node
