#pragma once
/// \file A test-side LCM endpoint: collects typed messages of chosen channels and waits for them.

#include <lcm/lcm-cpp.hpp>

#include <chrono>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "hpr/node/lcm_url.hpp"

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

  template <class Msg>
  void publish(const std::string& channel, const Msg& m) {
    lcm_.publish(channel, &m);
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
