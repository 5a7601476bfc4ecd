#pragma once
/// \file
/// The interface every controller of the stack has (estimator, reference_gen, motion_opt, wbc), so
/// that a process and the composed one run it the same way (README.md, "The processes"):
///
///   struct Inputs  { const T& required; OptionalRef<U> optional; ... };   // one tick's inputs
///   struct Outputs { ...; StepReport report; };                           // one tick's outputs
///   void step(const Inputs&, Outputs&);   // one tick, no allocation
///   void reset();                         // a clock that restarted
///
/// An optional input (a channel the component can do without, or one that went stale) is an
/// OptionalRef: empty when absent. The report says how the tick ended and which faults it raised
/// or cleared, under keys the component declares once (its kFaultKeys); a node applies it to HEALTH
/// (node::Runtime::report), so a fault reads the same whether the component runs alone or composed.

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <concepts>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>

namespace hpr {

/// A non-owning optional input: a reference to this tick's value, or nothing.
template <class T>
class OptionalRef {
 public:
  OptionalRef() = default;
  OptionalRef(std::nullopt_t) {}  // NOLINT(google-explicit-constructor): reads as std::optional
  OptionalRef(const T& value) : value_(&value) {}  // NOLINT(google-explicit-constructor)
  /// `value` when `present`, else nothing.
  static OptionalRef when(bool present, const T& value) { return present ? OptionalRef(value) : OptionalRef(); }

  [[nodiscard]] bool has_value() const { return value_ != nullptr; }
  explicit operator bool() const { return has_value(); }
  const T& operator*() const { return *value_; }
  const T* operator->() const { return value_; }
  [[nodiscard]] const T& value() const {
    if (value_ == nullptr) throw std::bad_optional_access();
    return *value_;
  }

 private:
  const T* value_ = nullptr;
};

/// How a component's tick ended (a node's lifecycle follows it).
enum class StepOutcome : std::int8_t {
  kNotReady,  ///< stepping, but not ready to act (no usable estimate yet, a filter initialising)
  kRunning,   ///< acting
  kDamping,   ///< its output is a damping command
};

/// What one tick of a component reports besides its outputs: its outcome and, for each of the
/// fault keys it declares, whether the tick raised the fault (with its text), cleared it, or left
/// it as it was. Fixed storage: filling it never allocates.
class StepReport {
 public:
  static constexpr std::size_t kMaxFaults = 8;
  static constexpr std::size_t kTextSize = 240;  ///< longer texts are cut
  enum class Change : std::int8_t { kUnchanged, kRaised, kCleared };
  struct Fault {
    std::string_view key;
    Change change = Change::kUnchanged;
    std::array<char, kTextSize> text{};
    std::size_t size = 0;
    [[nodiscard]] std::string_view message() const { return {text.data(), size}; }
  };

  StepReport() = default;
  /// `keys`: the fault keys the component may raise (string literals: the report keeps views).
  explicit StepReport(std::span<const std::string_view> keys) {
    if (keys.size() > kMaxFaults) throw std::logic_error("StepReport: more than kMaxFaults fault keys");
    for (std::string_view k : keys) faults_[n_++].key = k;
  }

  /// A new tick: running, no fault changed.
  void begin() {
    outcome = StepOutcome::kRunning;
    for (std::size_t i = 0; i < n_; ++i) faults_[i].change = Change::kUnchanged;
  }
  /// Raises `key` with the formatted text.
  template <class... Args>
  void raise(std::string_view key, fmt::format_string<Args...> format, Args&&... args) {
    Fault& f = entry(key);
    f.change = Change::kRaised;
    f.size = fmt::format_to_n(f.text.data(), f.text.size(), format, std::forward<Args>(args)...).size;
    f.size = std::min(f.size, f.text.size());
  }
  /// Clears `key`.
  void clear(std::string_view key) { entry(key).change = Change::kCleared; }
  /// Raises `key` with `text` when `on`, else clears it.
  void set(std::string_view key, bool on, std::string_view text) {
    if (on) {
      raise(key, "{}", text);
    } else {
      clear(key);
    }
  }

  [[nodiscard]] std::span<const Fault> faults() const { return {faults_.data(), n_}; }
  /// The fault of `key` (throws std::logic_error for a key the component did not declare).
  [[nodiscard]] const Fault& fault(std::string_view key) const {
    for (std::size_t i = 0; i < n_; ++i) {
      if (faults_[i].key == key) return faults_[i];
    }
    throw std::logic_error("fault key '" + std::string(key) + "' is not declared by this component");
  }
  /// Whether the tick raised `key`.
  [[nodiscard]] bool raised(std::string_view key) const { return fault(key).change == Change::kRaised; }

  StepOutcome outcome = StepOutcome::kRunning;

 private:
  Fault& entry(std::string_view key) { return const_cast<Fault&>(std::as_const(*this).fault(key)); }
  std::array<Fault, kMaxFaults> faults_{};
  std::size_t n_ = 0;
};

/// A controller of the stack (see the file comment).
template <class C>
concept Component = requires(C& c, const typename C::Inputs& in, typename C::Outputs& out) {
  { c.step(in, out) } -> std::same_as<void>;
  { c.reset() } -> std::same_as<void>;
  { out.report } -> std::convertible_to<const StepReport&>;
  { C::kFaultKeys } -> std::convertible_to<std::span<const std::string_view>>;
};

}  // namespace hpr
