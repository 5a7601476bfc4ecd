// When a node's code runs (hpr/node/scheduler.hpp).
#include "hpr/node/scheduler.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "hpr/common/log.hpp"
#include "hpr/common/time.hpp"

namespace hpr::node {

void Scheduler::on_tick(InputBase& primary, std::vector<Sync> synced, double timeout_s, StepFn step) {
  primary.follow_ticks();
  for (auto& s : synced) s.input->follow_ticks();
  const std::size_t n = synced.size();
  Trigger t{&primary, std::move(synced), timeout_s, std::move(step), -1, -1, 0.0, std::vector<char>(n, 0)};
  triggers_.push_back(std::move(t));
}

void Scheduler::on_restart(InputBase& primary, std::function<void()> reset) {
  primary.follow_ticks();
  restarts_.emplace_back(&primary, std::move(reset));
}

void Scheduler::every(double period_s, std::function<void()> fn) {
  timers_.push_back(Timer{period_s, monotonic_s() + period_s, std::move(fn)});
}

void Scheduler::while_silent(const InputBase& input, double timeout_s, const std::string& fault, std::function<void()> fn) {
  every(timeout_s, [this, &input, timeout_s, fault, fn = std::move(fn), silent = false]() mutable {
    if (!input.has_value()) return;
    const double age = monotonic_s() - input.receive_time();
    if (age <= timeout_s) {
      if (silent) {
        log::info("{} back at tick {}", input.channel(), input.tick());
        health_.clear_fault(fault);
        silent = false;
      }
      return;
    }
    if (!silent) log::warn("{} stale since tick {}", input.channel(), input.tick());
    silent = true;
    health_.set_fault(fault, fmt::format("no {} for {:.0f} ms", input.channel(), age * 1e3));
    fn();
  });
}

void Scheduler::on_input(InputBase& in) {
  const double now = monotonic_s();
  for (auto& t : triggers_) {
    for (std::size_t i = 0; i < t.synced.size(); ++i) {
      if (t.synced[i].input == &in && t.absent[i] != 0) {
        t.absent[i] = 0;
        health_.clear_fault("absent:" + in.channel());
        log::info("{} is back at tick {}: waited for again", in.channel(), in.tick());
      }
    }
    if (t.primary == &in && in.tick() > t.last_tick && in.tick() != t.pending_tick) {
      // A newer primary tick while one is still waiting for its synced inputs: the robot's clock has
      // moved on, so the newest tick is served at once with the inputs at hand (timed_out) rather
      // than waiting longer and falling behind. In lockstep the next tick cannot arrive before
      // this node has answered, so there every step sees its synced inputs.
      const bool waiting = t.pending_tick > t.last_tick;
      t.deadline = waiting ? now : now + t.timeout_s;
      t.pending_tick = in.tick();
      const double dt = now - t.arrival;
      if (t.arrival > 0.0 && dt > 1e-5 && dt < 1.0) t.period = t.period > 0.0 ? 0.9 * t.period + 0.1 * dt : dt;
      t.arrival = now;
    }
  }
  check_triggers(now);
}

void Scheduler::on_reject(InputBase& in, std::size_t bytes, const std::string& why) { health_.refused(in, bytes, why); }

void Scheduler::on_follow(InputBase& in, std::int64_t old_tick, std::int64_t new_tick) {
  for (auto& t : triggers_) {
    if (t.primary != &in) continue;
    // The clock this trigger stepped on is gone: step the new one from its tick, and take the
    // synced inputs' next ticks as they come (their sources restarted too, or will).
    t.last_tick = -1;
    t.pending_tick = -1;
    for (auto& s : t.synced) {
      if (s.input->tick() > new_tick + s.tick_offset) s.input->restart_stream();
      s.input->follow_if_quiet(std::numeric_limits<double>::infinity());
    }
  }
  for (auto& [input, reset] : restarts_) {
    if (input == &in) reset();
  }
  health_.followed(in, old_tick, new_tick);
}

bool Scheduler::step_waits_at(const InputBase& in, std::int64_t tick) const {
  return std::any_of(triggers_.begin(), triggers_.end(), [&](const Trigger& t) {
    return t.primary == &in && t.pending_tick == tick && t.pending_tick > t.last_tick;
  });
}

void Scheduler::mark_absent(Trigger& t, std::size_t i) {
  t.absent[i] = 1;
  const InputBase& in = *t.synced[i].input;
  const std::string text = fmt::format("{} absent since tick {}: stepping without it", in.channel(), t.pending_tick);
  log::warn("{} (no message within {} s)", text, t.timeout_s);
  health_.set_fault("absent:" + in.channel(), text);
}

void Scheduler::check_triggers(double now) {
  for (auto& t : triggers_) check_trigger(t, now);
}

void Scheduler::check_trigger(Trigger& t, double now) {
  if (t.pending_tick < 0 || t.pending_tick <= t.last_tick) return;
  TickInfo info;
  info.tick = t.pending_tick;
  bool waiting = false;
  for (std::size_t i = 0; i < t.synced.size(); ++i) {
    const Sync& s = t.synced[i];
    if (s.input->tick() < t.pending_tick + s.tick_offset && (!s.needed || s.needed())) {
      info.late.push_back(s.input);
      // An optional input silent for a whole timeout is absent, however the steps were released.
      if (s.optional && t.absent[i] == 0 && s.input->has_value() && now - s.input->receive_time() > t.timeout_s) mark_absent(t, i);
      waiting = waiting || t.absent[i] == 0;
    }
  }
  if (waiting && now < t.deadline) return;
  if (!info.late.empty()) {
    info.timed_out = true;
    health_.count_stale();
  }
  for (std::size_t i = 0; i < t.synced.size() && waiting; ++i) {
    const Sync& s = t.synced[i];
    if (!s.optional || t.absent[i] != 0 || std::find(info.late.begin(), info.late.end(), s.input) == info.late.end()) continue;
    mark_absent(t, i);
  }
  t.last_tick = t.pending_tick;
  health_.begin_step();
  const double t0 = monotonic_s();
  try {
    t.step(info);
    health_.clear_fault("step");
  } catch (const std::exception& e) {
    log::error("step of tick {} failed: {}", info.tick, e.what());
    health_.set_fault("step", std::string("step failed: ") + e.what());
  }
  health_.end_step(info.tick, monotonic_s() - t0);
}

void Scheduler::run_timers(double now) {
  for (auto& t : timers_) {
    if (now >= t.next) {
      t.next += t.period;
      if (t.next < now) t.next = now + t.period;  // skip missed periods rather than bursting
      t.fn();
    }
  }
}

double Scheduler::next_arrival() const {
  double due = 0.0;
  for (const auto& t : triggers_) {
    if (t.period > 0.0 && (due == 0.0 || t.arrival + t.period < due)) due = t.arrival + t.period;
  }
  return due;
}

double Scheduler::next_event() const {
  double next = std::numeric_limits<double>::infinity();
  for (const auto& t : timers_) next = std::min(next, t.next);
  for (const auto& t : triggers_) {
    if (t.pending_tick > t.last_tick) next = std::min(next, t.deadline);
  }
  return next;
}

}  // namespace hpr::node
