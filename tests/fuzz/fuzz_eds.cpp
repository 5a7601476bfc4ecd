// Fuzz target: a drive's electronic data sheet (CiA 306), as the hal reads hal.drives[].eds. The
// input is the file's text: it is read into an object dictionary or refused with a ConfigError,
// nothing else; every value of a dictionary read reads for every node id without failing, and fits
// its entry's size.
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "hpr/hal/eds.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace hpr::hal::canopen;
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  try {
    const ObjectDictionary od = ObjectDictionary::parse(text, "fuzz.eds");
    for (const auto& [address, e] : od.entries()) {
      if (od.find(address.first, address.second) != &e) std::abort();
      for (int node : {1, 64, 127}) {
        const auto v = od.value(e.index, e.subindex, node);
        const int bytes = size_of(e.type);
        if (v && bytes < 8 && (*v >> (8 * bytes)) != 0) std::abort();
      }
    }
  } catch (const hpr::ConfigError&) {
    // Refused, with its message.
  }
  return 0;
}
