#pragma once
/// \file
/// One generic LCM node for a component of the graph (README.md, "The processes"): `run_node<B>`
/// runs the component of binding `B` as its own process. From the binding's typed channels it
/// subscribes to every channel the component reads (each decoded by its codec, hpr/msg/codec.hpp,
/// into the channel's slot), steps the component on its trigger once the channels it waits for
/// have reached their declared tick, reports what the step did and publishes what it wrote. No
/// process writes its own subscribe or advertise calls; the runtime refuses a channel that the
/// component's ports (`Component::kPorts`) do not declare, and the binding's channels are checked
/// against the ports at compile time.
///
/// A binding `B` (hpr/graph/bindings.hpp) declares:
///  - `Component`, `kSummary`, `kReads` and `kWrites` (typed channels, hpr/msg/channels.hpp, in the
///    order of Component::kPorts' reads and writes);
///  - a constructor from the robot and the configuration (the component and its node keys), and
///    `component()`, `period()` (the step's deadline [s]);
///  - `inputs(slots, tick)`: the step's inputs from the latest value of each channel read;
///  - `written(outputs, tick)`: for each channel written, the value to publish (null: nothing this
///    tick);
///  - `waits_for(channel)`, `timeout()`: which of the channels read the step waits for, how long;
///  - optionally `needs(channel, slots)` (whether the pending step needs a channel it waits for),
///    `on(value, slots)` (called with each value taken: an event channel such as OPERATOR, or a
///    channel heard since a restart), `restart()` (after the component's reset, when the trigger
///    follows a new tick stream), `parameters(set)` (live parameters), `prepare(outputs)` (sizes
///    the outputs once), `report(runtime, outputs, tick)` (instead of reporting the step's
///    StepReport as it is) and, for a component whose output must not silently stop,
///    `kSilentFault`, `silent_after()` and `silent_written()` (what to publish while the trigger
///    is silent: node::Runtime::while_silent).
///
/// A step that ran without an input it waited for (the timeout) is counted stale in HEALTH.

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <tuple>
#include <type_traits>
#include <utility>
#include <vector>

#include "hpr/common/config.hpp"
#include "hpr/common/ports.hpp"
#include "hpr/model/robot.hpp"
#include "hpr/msg/codec.hpp"
#include "hpr/node/command_line.hpp"
#include "hpr/node/runtime.hpp"

namespace hpr::graph {

/// The latest value taken from a channel.
template <class T>
struct Slot {
  T value{};
  std::int64_t tick = -1;  ///< the tick of the message it came in (−1: none yet)

  [[nodiscard]] bool heard() const { return tick >= 0; }
  /// Heard at tick `now - stale_ticks` or later.
  [[nodiscard]] bool fresh(std::int64_t now, std::int64_t stale_ticks) const { return heard() && tick >= now - stale_ticks; }
};

namespace detail {
template <class Channels>
struct SlotsOf;
template <class... Ch>
struct SlotsOf<std::tuple<Ch...>> {
  using type = std::tuple<Slot<typename msg::Codec<typename Ch::Message>::Value>...>;
};
}  // namespace detail

/// One slot per channel of `Channels` (a tuple of typed channels), in its order.
template <const auto& Channels>
using Slots = typename detail::SlotsOf<std::remove_cvref_t<decltype(Channels)>>::type;

/// The slot of value type `T` (each channel a component reads carries another type).
template <class T, class S>
[[nodiscard]] const Slot<T>& slot(const S& slots) {
  return std::get<Slot<T>>(slots);
}

namespace detail {

/// Whether binding `B`'s typed channels are its component's declared ports, in order.
template <class B>
constexpr bool channels_match_ports() {
  constexpr auto& ports = B::Component::kPorts;
  constexpr std::size_t nr = std::tuple_size_v<std::remove_cvref_t<decltype(B::kReads)>>;
  constexpr std::size_t nw = std::tuple_size_v<std::remove_cvref_t<decltype(B::kWrites)>>;
  if (ports.reads.size() != nr || ports.writes.size() != nw) return false;
  bool ok = true;
  std::size_t i = 0;
  std::apply([&](const auto&... ch) { ((ok = ok && ports.reads[i++].channel == std::string_view(ch.name)), ...); }, B::kReads);
  i = 0;
  std::apply([&](const auto&... ch) { ((ok = ok && ports.writes[i++] == std::string_view(ch.name)), ...); }, B::kWrites);
  return ok;
}

/// The index of the read the component steps on.
template <class B>
constexpr std::size_t trigger_index() {
  constexpr auto& reads = B::Component::kPorts.reads;
  std::size_t found = reads.size(), count = 0;
  for (std::size_t i = 0; i < reads.size(); ++i) {
    if (reads[i].trigger) {
      found = i;
      ++count;
    }
  }
  return count == 1 ? found : reads.size();
}

}  // namespace detail

/// The node of binding `B` on runtime `rt`: subscribes, waits, steps and publishes (see the file
/// comment). Lives as long as the runtime runs.
template <class B>
class ComponentNode {
 public:
  using Component = typename B::Component;
  static_assert(detail::channels_match_ports<B>(), "a binding's channels must be its component's ports, in order");
  static constexpr std::size_t kTrigger = detail::trigger_index<B>();
  static_assert(kTrigger < Component::kPorts.reads.size(), "a component steps on exactly one channel");
  static constexpr std::size_t kNumReads = std::tuple_size_v<std::remove_cvref_t<decltype(B::kReads)>>;
  static constexpr std::size_t kNumWrites = std::tuple_size_v<std::remove_cvref_t<decltype(B::kWrites)>>;

  ComponentNode(node::Runtime& rt, B& binding, msg::Naming naming) : rt_(rt), b_(binding), naming_(std::move(naming)) {
    subscribe_all(std::make_index_sequence<kNumReads>{});
    advertise_all(std::make_index_sequence<kNumWrites>{});
    if constexpr (requires { b_.parameters(rt_.parameters()); }) b_.parameters(rt_.parameters());
    if constexpr (requires { b_.prepare(out_); }) b_.prepare(out_);
    std::vector<node::Sync> sync;
    for (std::size_t i = 0; i < kNumReads; ++i) {
      const Read& r = Component::kPorts.reads[i];
      if (i == kTrigger || !b_.waits_for(r.channel)) continue;
      node::Sync s{inputs_[i], r.tick_offset, {}, r.optional};
      if constexpr (requires { b_.needs(r.channel, slots_); }) {
        s.needed = [this, ch = r.channel] { return b_.needs(ch, slots_); };
      }
      sync.push_back(std::move(s));
    }
    rt_.on_restart(*inputs_[kTrigger], [this] {
      b_.component().reset();
      if constexpr (requires { b_.restart(); }) b_.restart();
    });
    rt_.on_tick(*inputs_[kTrigger], std::move(sync), b_.timeout(), [this](const node::TickInfo& info) { step(info); });
    if constexpr (requires { b_.silent_written(); }) {
      rt_.while_silent(*inputs_[kTrigger], b_.silent_after(), B::kSilentFault,
                       [this] { publish(b_.silent_written(), std::make_index_sequence<kNumWrites>{}); });
    }
  }

 private:
  template <std::size_t... I>
  void subscribe_all(std::index_sequence<I...>) {
    (subscribe<I>(), ...);
  }
  template <std::size_t I>
  void subscribe() {
    const auto& ch = std::get<I>(B::kReads);
    using Msg = typename std::remove_cvref_t<decltype(ch)>::Message;
    using Value = typename msg::Codec<Msg>::Value;
    // Decoded into a scratch value and swapped in when valid: a refused message leaves the slot.
    auto scratch = std::make_shared<Value>();
    inputs_[I] = &rt_.subscribe(
        ch,
        [this, scratch](const Msg& m) { return msg::Codec<Msg>::decode(m, naming_, *scratch); },
        [this, scratch](const Msg& m) { this->template take<I>(m.tick, *scratch); });
  }
  template <std::size_t I, class Value>
  void take(std::int64_t tick, Value& decoded) {
    auto& slot = std::get<I>(slots_);
    std::swap(slot.value, decoded);
    slot.tick = tick;
    if constexpr (requires { b_.on(slot.value, slots_); }) b_.on(slot.value, slots_);
  }
  template <std::size_t... I>
  void advertise_all(std::index_sequence<I...>) {
    outputs_.emplace(rt_.advertise(std::get<I>(B::kWrites))...);
  }

  void step(const node::TickInfo& info) {
    if (info.timed_out) rt_.count_stale();
    b_.component().step(b_.inputs(slots_, info.tick), out_);
    if constexpr (requires { b_.report(rt_, out_, info.tick); }) {
      b_.report(rt_, out_, info.tick);
    } else {
      rt_.report(out_.report);
    }
    publish(b_.written(out_, info.tick), std::make_index_sequence<kNumWrites>{});
  }
  template <class Written, std::size_t... I>
  void publish(const Written& written, std::index_sequence<I...>) {
    (publish_one<I>(std::get<I>(written)), ...);
  }
  template <std::size_t I, class Value>
  void publish_one(const Value* v) {
    if (v == nullptr) return;
    using Msg = typename std::remove_cvref_t<decltype(std::get<I>(B::kWrites))>::Message;
    auto& m = std::get<I>(messages_);
    msg::Codec<Msg>::encode(*v, naming_, m);
    std::get<I>(*outputs_).publish(m);
  }

  template <class Channels>
  struct Io;
  template <class... Ch>
  struct Io<std::tuple<Ch...>> {
    using Outputs = std::tuple<node::Output<typename Ch::Message>...>;
    using Messages = std::tuple<typename Ch::Message...>;
  };
  using WriteIo = Io<std::remove_cvref_t<decltype(B::kWrites)>>;

  node::Runtime& rt_;
  B& b_;
  const msg::Naming naming_;
  Slots<B::kReads> slots_;
  std::array<node::InputBase*, kNumReads> inputs_{};
  std::optional<typename WriteIo::Outputs> outputs_;
  typename WriteIo::Messages messages_{};
  typename Component::Outputs out_{};
};

/// The process of binding `B`: parses the command line, loads the configuration, runs the node
/// until stopped (exit codes: node::run_main).
template <class B>
int run_node(int argc, char** argv) {
  return node::run_main(argc, argv, std::string(B::Component::kPorts.name), B::kSummary, [](const node::CommandLine& cl, const Config& cfg) {
    const auto robot = model::RobotSpec::load(cfg.section("robot"));
    B binding(robot, cfg);
    node::Runtime rt(B::Component::kPorts, cl.name, node::lcm_url(cl, cfg), node::runtime_options(cfg, binding.period()));
    ComponentNode<B> node(rt, binding, msg::Naming::of(robot));
    return rt.run();
  });
}

}  // namespace hpr::graph
