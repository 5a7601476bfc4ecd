#pragma once
/// \file A test-side LCM endpoint: collects typed messages of chosen channels and waits for them.

#include <lcm/lcm-cpp.hpp>

#include <chrono>
#include <functional>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "hpr/common/auth.hpp"
#include "hpr/node/lcm_url.hpp"
#include "hpr/node/runtime.hpp"

namespace hpr::test {

class LcmListener {
 public:
  explicit LcmListener(const std::string& url) : lcm_(hpr::node::with_receive_buffer(url)) {}
  [[nodiscard]] bool good() const { return lcm_.good(); }
  lcm::LCM& lcm() { return lcm_; }

  /// Collects every decodable message of type Msg on `channel` into the returned vector.
  template <class Msg>
  std::shared_ptr<std::vector<Msg>> collect(const std::string& channel) {
    auto out = std::make_shared<std::vector<Msg>>();
    auto* handler = new Handler<Msg>{out};
    handlers_.emplace_back(handler, [](void* p) { delete static_cast<Handler<Msg>*>(p); });
    // A test counts messages: none may be dropped while it waits elsewhere.
    lcm_.subscribe(channel, &Handler<Msg>::on, handler)->setQueueCapacity(hpr::node::kCountingQueueCapacity);
    return out;
  }

  /// Publishes `m`; a signed type (OPERATOR, JOINT_COMMAND, ...) is signed with the deployment's
  /// key, as the stack's own senders sign it.
  template <class Msg>
  void publish(const std::string& channel, const Msg& m) {
    if constexpr (hpr::auth::Signed<Msg>) {
      hpr::node::publish_signed(lcm_, channel, m, key());
    } else {
      lcm_.publish(channel, &m);
    }
  }
  /// Stamps `m` as a process's Output does: this endpoint's identity and its next message count
  /// (a test that stands in for a process of the stack).
  template <class Msg>
  void stamp(Msg& m) {
    m.source = static_cast<std::int64_t>((std::uint64_t{identity_} << 32) | ++count_);
  }
  /// Publishes `m` as it is, with whatever its `mac` holds (a sender without the key).
  template <class Msg>
  void publish_unsigned(const std::string& channel, const Msg& m) {
    lcm_.publish(channel, &m);
  }
  /// The deployment's key (auth::key_path(), created when there is none).
  const hpr::auth::Key& key() {
    if (!key_) key_ = std::make_unique<hpr::auth::Key>(hpr::auth::load_or_create_key(hpr::auth::key_path()));
    return *key_;
  }

  /// Handles messages until `done()` or the timeout; returns done().
  bool wait_for(const std::function<bool()>& done, std::chrono::milliseconds timeout) {
    const auto end = std::chrono::steady_clock::now() + timeout;
    while (!done()) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(end - std::chrono::steady_clock::now());
      if (left.count() <= 0) return done();
      lcm_.handleTimeout(static_cast<int>(std::min<long>(left.count(), 50)));
    }
    return true;
  }

  /// Handles messages for `duration`.
  void spin_for(std::chrono::milliseconds duration) {
    wait_for([] { return false; }, duration);
  }

 private:
  std::unique_ptr<hpr::auth::Key> key_;
  std::uint32_t identity_ = std::random_device{}() | 0x80000000U;  // never 0 (unstamped)
  std::uint32_t count_ = 0;
  template <class Msg>
  struct Handler {
    std::shared_ptr<std::vector<Msg>> out;
    void on(const lcm::ReceiveBuffer* rbuf, const std::string& /*ch*/) {
      Msg m;
      if (m.decode(rbuf->data, 0, static_cast<int>(rbuf->data_size)) >= 0) out->push_back(std::move(m));
    }
  };
  lcm::LCM lcm_;
  std::vector<std::unique_ptr<void, void (*)(void*)>> handlers_;
};

}  // namespace hpr::test
