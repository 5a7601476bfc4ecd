#pragma once
/// \file
/// Components composed in one process by their bindings (hpr/graph/bindings.hpp), with the
/// connections computed from what each binding declares: what a part writes goes to every part
/// that reads the same channel, through the channel's conversion (hpr::msg::Codec, as the
/// processes exchange it) or handed over as a value. A channel that no part writes is an input of
/// the diagram (feed()). The parts step in the order given, and the order is checked at compile
/// time against the declared tick offsets: a channel read at the tick of the step (offset 0) is
/// written by an earlier part, one read at the previous tick (offset −1) by the reader itself or a
/// later one, so that every part sees what its process would see.

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <tuple>
#include <type_traits>
#include <utility>

#include "hpr/common/config.hpp"
#include "hpr/common/ports.hpp"
#include "hpr/graph/component_node.hpp"
#include "hpr/model/robot.hpp"
#include "hpr/msg/codec.hpp"

namespace hpr::graph {

namespace detail {

template <class T, class... Ts>
inline constexpr bool contains_v = (std::is_same_v<T, Ts> || ...);

/// A tuple of the distinct types of `Ts` (first occurrence kept).
template <class Acc, class... Ts>
struct Distinct {
  using type = Acc;
};
template <class... Acc, class T, class... Ts>
struct Distinct<std::tuple<Acc...>, T, Ts...> {
  using type = typename Distinct<std::conditional_t<contains_v<T, Acc...>, std::tuple<Acc...>, std::tuple<Acc..., T>>, Ts...>::type;
};

template <class Channels>
struct MessagesOf;
template <class... Ch>
struct MessagesOf<std::tuple<Ch...>> {
  using type = std::tuple<typename Ch::Message...>;
};
template <class T>
using MessagesOf_t = typename MessagesOf<std::remove_cvref_t<T>>::type;

template <class Tuple>
struct DistinctOf;
template <class... Ts>
struct DistinctOf<std::tuple<Ts...>> {
  using type = typename Distinct<std::tuple<>, Ts...>::type;
};

/// Whether parts whose ports are `ports`, stepped in that order, see what their processes see (see
/// the file comment), and no channel has two writers.
template <std::size_t N>
constexpr bool ordered(const std::array<Ports, N>& ports) {
  for (std::size_t p = 0; p < N; ++p) {
    for (const Read& r : ports[p].reads) {
      for (std::size_t w = 0; w < N; ++w) {
        if (!ports[w].writes_to(r.channel)) continue;
        if (r.tick_offset == 0 && w >= p) return false;
        if (r.tick_offset == -1 && w < p) return false;
        if (r.tick_offset != 0 && r.tick_offset != -1) return false;
      }
    }
    for (std::string_view ch : ports[p].writes) {
      for (std::size_t w = p + 1; w < N; ++w) {
        if (ports[w].writes_to(ch)) return false;
      }
    }
  }
  return true;
}

}  // namespace detail

template <class... B>
class Diagram {
 public:
  static constexpr std::size_t kParts = sizeof...(B);
  static_assert(detail::ordered<kParts>({B::Component::kPorts...}),
                "the parts of a diagram step in the order of their declared data flow, each channel with one writer");
  /// Every message type the parts read or write, once (each channel carries its own type).
  using Messages = typename detail::DistinctOf<decltype(std::tuple_cat(std::declval<detail::MessagesOf_t<decltype(B::kReads)>>()...,
                                                                       std::declval<detail::MessagesOf_t<decltype(B::kWrites)>>()...))>::type;

  /// The parts that `enabled` says, built from `robot` and its configuration; `messages`: every
  /// channel through its message (else the values handed over).
  Diagram(const model::RobotSpec& robot, const Config& cfg, const std::array<bool, kParts>& enabled, bool messages)
      : naming_(msg::Naming::of(robot)), messages_on_(messages) {
    for_each_part([&]<std::size_t P>() {
      if (!enabled[P]) return;
      using Part = std::tuple_element_t<P, std::tuple<B...>>;
      std::get<P>(parts_).emplace(robot, cfg);
      if constexpr (requires(Part& b) { b.prepare(std::get<P>(outputs_)); }) std::get<P>(parts_)->prepare(std::get<P>(outputs_));
    });
  }

  /// Binding `Part`, null when it is not built.
  template <class Part>
  [[nodiscard]] Part* part() {
    auto& p = std::get<std::optional<Part>>(parts_);
    return p ? &*p : nullptr;
  }
  template <class Part>
  [[nodiscard]] const Part* part() const {
    const auto& p = std::get<std::optional<Part>>(parts_);
    return p ? &*p : nullptr;
  }
  /// What part `Part` made in its last step.
  template <class Part>
  [[nodiscard]] const typename Part::Component::Outputs& outputs() const {
    return std::get<typename Part::Component::Outputs>(outputs_);
  }
  /// The latest value part `Part` took on the channel of value type `T`.
  template <class Part, class T>
  [[nodiscard]] const Slot<T>& slot() const {
    return graph::slot<T>(std::get<index_of<Part>()>(slots_));
  }
  /// The last message of type `Msg` (with messages on).
  template <class Msg>
  [[nodiscard]] const Msg& message() const {
    return std::get<Msg>(messages_);
  }

  /// `v` on the channel of message `Msg` at tick `tick`, from outside the diagram (a channel no
  /// part writes: ROBOT_STATE, OPERATOR), to every part that reads it.
  /// `through_message` false: handed over as it is, whatever the diagram's setting.
  template <class Msg>
  void feed(const typename msg::Codec<Msg>::Value& v, std::int64_t tick, bool through_message = true) {
    deliver<Msg>(v, tick, through_message && messages_on_);
  }

  /// Steps every part built once, in order, at tick `tick`, and delivers what each writes to the
  /// parts that read it. `around(index, step)` runs each part's step (a timer, a probe).
  template <class Around>
  void step(std::int64_t tick, Around&& around) {
    for_each_part([&]<std::size_t P>() {
      auto& part = std::get<P>(parts_);
      if (!part) return;
      auto& out = std::get<P>(outputs_);
      const auto& slots = std::get<P>(slots_);
      around(P, [&] { part->component().step(part->inputs(slots, tick), out); });
      publish<P>(part->written(out, tick), tick, std::make_index_sequence<std::tuple_size_v<decltype(part->written(out, tick))>>{});
    });
  }

  /// A clock that restarted: every part's component and binding start again and every value taken
  /// is forgotten.
  void reset() {
    for_each_part([&]<std::size_t P>() {
      auto& part = std::get<P>(parts_);
      if (!part) return;
      part->component().reset();
      if constexpr (requires { part->restart(); }) part->restart();
      std::apply([](auto&... s) { ((s.tick = -1), ...); }, std::get<P>(slots_));
    });
  }

  [[nodiscard]] const msg::Naming& naming() const { return naming_; }

 private:
  template <class Part>
  static constexpr std::size_t index_of() {
    constexpr std::array same{std::is_same_v<Part, B>...};
    for (std::size_t i = 0; i < kParts; ++i) {
      if (same[i]) return i;
    }
    return kParts;
  }
  template <class F>
  static void for_each_part(F&& f) {
    [&]<std::size_t... P>(std::index_sequence<P...>) { (f.template operator()<P>(), ...); }(std::make_index_sequence<kParts>{});
  }

  template <std::size_t P, class Written, std::size_t... I>
  void publish(const Written& written, std::int64_t tick, std::index_sequence<I...>) {
    using Part = std::tuple_element_t<P, std::tuple<B...>>;
    ((std::get<I>(written) != nullptr
          ? deliver<typename std::remove_cvref_t<decltype(std::get<I>(Part::kWrites))>::Message>(*std::get<I>(written), tick, messages_on_)
          : void()),
     ...);
  }

  /// `v` through message `Msg` (or as it is) into the slot of every part that reads it.
  template <class Msg>
  void deliver(const typename msg::Codec<Msg>::Value& v, std::int64_t tick, bool through_message) {
    using Value = typename msg::Codec<Msg>::Value;
    const Value* source = &v;
    if (through_message) msg::Codec<Msg>::encode(v, naming_, std::get<Msg>(messages_));
    bool decoded = false;
    for_each_part([&]<std::size_t P>() {
      auto& part = std::get<P>(parts_);
      if (!part) return;
      using Part = std::tuple_element_t<P, std::tuple<B...>>;
      using PartSlots = Slots<Part::kReads>;
      if constexpr (has_slot<Value>(static_cast<PartSlots*>(nullptr))) {
        Slot<Value>& s = std::get<Slot<Value>>(std::get<P>(slots_));
        if (through_message && !decoded) {
          const std::string why = msg::Codec<Msg>::decode(std::get<Msg>(messages_), naming_, s.value);
          if (!why.empty()) throw std::runtime_error(std::string("in-process ") + Msg::getTypeName() + " refused: " + why);
          decoded = true;
          source = &s.value;
        } else if (&s.value != source) {
          s.value = *source;
        }
        s.tick = tick;
        if constexpr (requires { part->on(s.value, std::get<P>(slots_)); }) part->on(s.value, std::get<P>(slots_));
      }
    });
  }
  template <class T, class... S>
  static constexpr bool has_slot(std::tuple<S...>*) {
    return detail::contains_v<Slot<T>, S...>;
  }

  msg::Naming naming_;
  bool messages_on_;
  std::tuple<std::optional<B>...> parts_;
  std::tuple<Slots<B::kReads>...> slots_;
  std::tuple<typename B::Component::Outputs...> outputs_;
  Messages messages_{};
};

}  // namespace hpr::graph
