#pragma once
/// \file
/// A process's view of LCM, held to what the process declares (hpr/common/ports.hpp): it opens the
/// LCM URL, makes the typed inputs and outputs, reads the typed inputs from liblcm or from a socket
/// of its own (hpr/node/udpm.hpp), signs what it publishes and checks what it reads
/// (hpr/common/auth.hpp), and stamps its clocked messages with the process's identity.
///
/// Every subscription and every publication names a channel the declaration lists; another throws
/// std::logic_error naming the process and the channel, so a node that drifts from its
/// declaration fails at start. Only the runtime's own channels are outside the declaration:
/// HEALTH and PARAMS, which every node publishes, and OPERATOR, which a node with live parameters
/// reads (hpr/node/parameter_server.hpp).

#include <lcm/lcm-cpp.hpp>

#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "hpr/common/auth.hpp"
#include "hpr/common/channel.hpp"
#include "hpr/common/ports.hpp"
#include "hpr/node/input.hpp"
#include "hpr/node/output.hpp"
#include "hpr/node/udpm.hpp"

namespace hpr::node {

struct TransportOptions {
  std::string channel_prefix;  ///< prepended to every channel name
  /// Whether the signed types are authenticated (RuntimeOptions::authenticate).
  bool authenticate = true;
  /// Whether the typed inputs of a udpm URL are read from a socket of the transport's own
  /// (RuntimeOptions::receive_direct).
  bool receive_direct = false;
};

class Transport {
 public:
  /// The raw bytes of one message on a channel.
  using BytesHandler = std::function<void(const std::uint8_t* data, std::size_t size)>;

  /// Opens LCM on `lcm_url` (throws LcmError with the fix when multicast is not routable) for node
  /// `node` of process `declared`. Inputs report to `events` and follow `rules` (both outlive the
  /// transport); a backlog on liblcm's queue is drained until `stop()` holds.
  Transport(const Ports& declared, std::string node, const std::string& lcm_url, TransportOptions options, InputEvents& events,
            const StreamRules& rules, std::function<bool()> stop);
  ~Transport();
  Transport(const Transport&) = delete;
  Transport& operator=(const Transport&) = delete;

  /// Subscribes to `ch` (hpr/msg/channels.hpp): `validate` refuses a decoded message with a reason,
  /// `on_message` sees each accepted one.
  template <class Msg>
  Input<Msg>& subscribe(const Channel<Msg>& ch, typename Input<Msg>::Validator validate = {},
                        typename Input<Msg>::Callback on_message = {}) {
    check_declared(ch.name, false);
    return make_input<Msg>(ch.name, std::move(validate), std::move(on_message));
  }
  /// An output on `ch`, stamped with source_id() (a clocked type) and signed (a signed type).
  template <class Msg>
  Output<Msg> advertise(const Channel<Msg>& ch) {
    check_declared(ch.name, true);
    return make_output<Msg>(ch.name);
  }
  /// Every message on channel `name` as it came, undecoded and unchecked (a viewer that shows
  /// what goes by, a recorder). Up to `queue_capacity` messages wait between two loop passes.
  void subscribe_bytes(std::string_view name, BytesHandler handler, int queue_capacity = 30);
  /// Publishes `size` bytes on channel `name` as they are (a tool's or a test's own encoding).
  void publish_bytes(std::string_view name, const void* data, std::size_t size);

  /// The full channel name with the configured prefix.
  [[nodiscard]] std::string channel(std::string_view name) const { return options_.channel_prefix + std::string(name); }
  /// This process's identity on the clocked channels it publishes (random, nonzero, chosen at start).
  [[nodiscard]] std::int64_t source_id() const { return source_id_; }
  /// The deployment's key (the code of every signed type), read on first use (throws
  /// auth::AuthError when it cannot be); null when authentication is off (then logs once that
  /// anyone may command and feed the robot).
  const auth::Key* deployment_key();
  [[nodiscard]] bool authenticates() const { return options_.authenticate; }

  /// The descriptor that becomes readable when a message for a typed input is waiting.
  [[nodiscard]] int receive_fd() const;
  /// Whether the typed inputs are read from the transport's own socket.
  [[nodiscard]] bool receives_directly() const { return receiver_ != nullptr; }
  /// The own socket's reader (null: through liblcm): what it refused and what it held.
  [[nodiscard]] const UdpmReceiver* direct_receiver() const { return receiver_.get(); }
  /// liblcm's descriptor when it must be watched besides receive_fd() (the own socket reads the
  /// typed inputs and something subscribed through liblcm); -1 otherwise.
  [[nodiscard]] int extra_fd() const;
  /// Handles what is waiting on receive_fd() (`typed`) and on extra_fd() (`extra`), without blocking.
  void receive(bool typed, bool extra);

  /// Lets each input that holds a new tick stream follow it once its own has been quiet long enough.
  void follow_quiet_streams(double now);
  /// The earliest time an input may follow a held stream (inf: none holds one).
  [[nodiscard]] double next_follow_time() const;
  /// Messages the typed inputs refused (including those held) and those refused for their code.
  [[nodiscard]] std::int64_t decode_errors() const;
  [[nodiscard]] std::int64_t unauthenticated() const;

 private:
  friend class Health;
  friend class ParameterServer;

  /// Throws std::logic_error when the declaration does not list `channel` among its reads (or,
  /// `write`, its writes).
  void check_declared(std::string_view channel, bool write) const;
  /// An input on `name`, declared or not (the runtime's own OPERATOR input is not the process's).
  template <class Msg>
  Input<Msg>& make_input(std::string_view name, typename Input<Msg>::Validator validate, typename Input<Msg>::Callback on_message) {
    const auth::Key* key = nullptr;
    if constexpr (auth::Signed<Msg>) key = deployment_key();
    auto in = std::make_unique<Input<Msg>>(events_, rules_, receiver_ ? nullptr : lcm_.get(), channel(name), std::move(validate),
                                           std::move(on_message), key);
    auto& ref = *in;
    if (receiver_) by_channel_[ref.channel()].push_back(&ref);
    inputs_.push_back(std::move(in));
    return ref;
  }
  template <class Msg>
  Output<Msg> make_output(std::string_view name) {
    const auth::Key* key = nullptr;
    if constexpr (auth::Signed<Msg>) key = deployment_key();
    return Output<Msg>(lcm_.get(), channel(name), key, source_id_, counter_);
  }
  /// Publishes a message the runtime itself sends (HEALTH signed, PARAMS), through a buffer kept
  /// between calls.
  template <class Msg>
  void publish_own(std::string_view name, const Msg& m) {
    const std::string full = channel(name);
    const auth::Key* key = nullptr;
    if constexpr (auth::Signed<Msg>) key = deployment_key();
    const int used = encode_message(m, own_buffer_, full, key);
    if (used >= 0) lcm_->publish(full, own_buffer_.data(), static_cast<unsigned>(used));
  }
  /// Reads what is waiting on the own socket and hands each message to its channel's inputs.
  void receive_direct();
  void handle_lcm();

  Ports declared_;
  std::string node_;
  TransportOptions options_;
  InputEvents& events_;
  const StreamRules& rules_;
  std::function<bool()> stop_;
  std::unique_ptr<lcm::LCM> lcm_;
  std::unique_ptr<UdpmReceiver> receiver_;  ///< the typed inputs' socket (null: through liblcm)
  std::map<std::string, std::vector<InputBase*>, std::less<>> by_channel_;  ///< with receiver_
  MessageSink deliver_;                     ///< receive_direct's sink, made once
  std::int64_t refused_reported_ = 0;
  double last_refusal_log_ = -1e9;
  bool bytes_subscribed_ = false;
  struct BytesSubscription {
    BytesHandler handler;
    void on_lcm(const lcm::ReceiveBuffer* rbuf, const std::string& /*channel*/) {
      handler(static_cast<const std::uint8_t*>(rbuf->data), rbuf->data_size);
    }
  };
  std::vector<std::unique_ptr<BytesSubscription>> bytes_;
  std::vector<std::unique_ptr<InputBase>> inputs_;
  std::vector<std::uint8_t> own_buffer_;  ///< HEALTH's and PARAMS's encoding
  std::unique_ptr<auth::Key> key_;
  bool warned_unauthenticated_ = false;
  std::int64_t source_id_ = 0;  ///< the identity in the upper 32 bits, the lower 32 zero
  SourceCounter counter_ = std::make_shared<std::atomic<std::uint32_t>>(0);
};

}  // namespace hpr::node
