// Fuzz target: the URDF loader. Any text is either a description (which then builds a model, or is
// refused with ModelError) or refused with ModelError naming what is wrong; nothing else escapes.
#include <cstdint>
#include <cstdlib>
#include <string>

#include "hpr/model/model.hpp"
#include "hpr/model/urdf.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string xml(reinterpret_cast<const char*>(data), size);
  hpr::model::UrdfOptions options;
  options.resolve_meshes = false;  // no files behind the text
  try {
    const auto d = hpr::model::parse_urdf(xml, "fuzz.urdf", options);
    try {
      (void)hpr::model::Model::build(d, hpr::model::ModelOptions{});
    } catch (const hpr::model::ModelError&) {
    }
  } catch (const hpr::model::ModelError& e) {
    if (std::string(e.what()).empty()) std::abort();
  }
  return 0;
}
