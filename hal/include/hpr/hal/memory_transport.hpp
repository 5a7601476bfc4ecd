#pragma once
/// \file
/// A CAN bus in memory: two connected ends, each a CanTransport (tests and benchmarks; a flush
/// delivers the queued frames to the other end, in order).
#include <deque>
#include <memory>
#include <utility>

#include "hpr/hal/can.hpp"

namespace hpr::hal {

class MemoryTransport final : public CanTransport {
 public:
  /// Two connected ends.
  static std::pair<std::unique_ptr<MemoryTransport>, std::unique_ptr<MemoryTransport>> pair() {
    auto a = std::unique_ptr<MemoryTransport>(new MemoryTransport);
    auto b = std::unique_ptr<MemoryTransport>(new MemoryTransport);
    a->peer_ = b.get();
    b->peer_ = a.get();
    return {std::move(a), std::move(b)};
  }
  ~MemoryTransport() override {
    if (peer_ != nullptr) peer_->peer_ = nullptr;
  }
  bool send(const CanFrame& frame) override {
    queue_.push_back(frame);
    return true;
  }
  void flush() override {
    for (const auto& f : queue_) {
      if (peer_ == nullptr) break;
      if (account_error_frame(f, peer_->counters_)) continue;
      peer_->inbox_.push_back(f);
      ++counters_.tx_frames;
    }
    queue_.clear();
  }
  int receive(std::vector<CanFrame>& out) override {
    const int n = static_cast<int>(inbox_.size());
    for (const auto& f : inbox_) out.push_back(f);
    counters_.rx_frames += n;
    inbox_.clear();
    return n;
  }
  [[nodiscard]] int fd() const override { return -1; }
  [[nodiscard]] const BusCounters& counters() const override { return counters_; }
  void clear_bus_off() override { counters_.bus_off = false; }
  [[nodiscard]] std::string describe() const override { return "memory"; }

 private:
  MemoryTransport() = default;
  MemoryTransport* peer_ = nullptr;
  std::deque<CanFrame> queue_, inbox_;
  BusCounters counters_;
};

}  // namespace hpr::hal
