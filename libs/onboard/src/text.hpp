#pragma once
// Private to the onboarding library: names compared without case.
#include <cctype>
#include <string>

namespace hpr::onboard::detail {

/// `s` in lower case (ASCII).
inline std::string lower(std::string s) {
  for (auto& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

}  // namespace hpr::onboard::detail
