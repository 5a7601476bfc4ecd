// Fuzz target: the YAML configuration loader and the validating loaders of the sections that need
// no other file. Any text is accepted or refused with ConfigError (naming file, key and value);
// no other exception escapes, and no number read is NaN.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "hpr/balance/task_reference.hpp"
#include "hpr/common/config.hpp"
#include "hpr/estimator/estimator.hpp"
#include "hpr/reference_gen/generator.hpp"

namespace {

template <class F>
void refused_only_with_config_error(F&& f) {
  try {
    f();
  } catch (const hpr::ConfigError& e) {
    if (std::string(e.what()).empty()) std::abort();
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  refused_only_with_config_error([&] {
    const hpr::Config cfg = hpr::Config::parse(text, "fuzz.yaml");
    refused_only_with_config_error([&] {
      const auto g = hpr::reference_gen::GeneratorConfig::load(cfg.section("reference_gen"));
      for (const auto& a : g.axes) {
        if (!std::isfinite(a.alpha) || !std::isfinite(a.beta)) std::abort();
      }
    });
    refused_only_with_config_error([&] { (void)hpr::estimator::EstimatorConfig::load(cfg.section("estimator")); });
    refused_only_with_config_error([&] { (void)hpr::balance::PostureReferenceConfig::load(cfg.section("balance")); });
    refused_only_with_config_error([&] {
      for (const auto& k : cfg.keys()) {
        if (cfg.is_scalar(k)) {
          (void)cfg.string(k);
          refused_only_with_config_error([&] {
            if (std::isnan(cfg.real(k))) std::abort();  // ±.inf is YAML's own spelling, accepted where the range allows
          });
        }
      }
    });
  });
  return 0;
}
