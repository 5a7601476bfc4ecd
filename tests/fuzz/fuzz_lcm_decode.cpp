// Fuzz target: every LCM type's decoder. The first byte picks the type, the rest is the message.
// A decoder must return an error or a message, never crash, never allocate more than the input
// can hold (the hardened decoders check counts against the bytes left), and what it accepts must
// encode to as many bytes and read back the same.
#include <cstdint>
#include <cstdlib>
#include <vector>

#include "all_types.hpp"

namespace {

template <class Msg>
void check(const std::uint8_t* data, std::size_t size) {
  Msg m{};
  const int used = m.decode(data, 0, static_cast<int>(size));
  if (used < 0) return;
  const auto bytes = hpr::test::encode(m);
  // What was accepted is written back in as many bytes (a string's terminator byte is not checked
  // on reading, so the bytes themselves may differ there), and reads back to the same message.
  if (bytes.size() != static_cast<std::size_t>(used)) std::abort();
  Msg again{};
  if (again.decode(bytes.data(), 0, static_cast<int>(bytes.size())) != used || hpr::test::encode(again) != bytes) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  int index = 0;
  static const int types = hpr::test::type_count();
  const int wanted = data[0] % types;
  hpr::test::for_each_type([&]<class Msg>(const char*) {
    if (index++ == wanted) check<Msg>(data + 1, size - 1);
  });
  return 0;
}
