#include "hpr/msg/log_check.hpp"

#include <type_traits>

#include "hpr/common/auth.hpp"
#include "hpr/msg/channels.hpp"

namespace hpr::msg {
namespace {

/// Calls f.template operator()<Msg>() for the type of `channel`; false when it has none.
template <class F>
bool with_type(const std::string& channel, F&& f) {
  return channels::with_channel(channel, [&](const auto& c) {
    f.template operator()<typename std::remove_cvref_t<decltype(c)>::Message>();
  });
}

}  // namespace

std::string type_of_channel(const std::string& channel) {
  std::string out;
  with_type(channel, [&]<class Msg>() { out = std::string("humanoid.") + Msg::getTypeName(); });
  return out;
}

bool carries_code(const std::string& channel) {
  bool signed_type = false;
  with_type(channel, [&]<class Msg>() { signed_type = auth::Signed<Msg>; });
  return signed_type;
}

std::string check_message(const std::string& channel, const void* data, int size) {
  std::string why;
  with_type(channel, [&]<class Msg>() {
    Msg m;
    bool ok = false;
    try {
      ok = m.decode(data, 0, size) == size;
    } catch (const std::exception&) {
      ok = false;
    }
    if (!ok) why = std::string("does not decode as humanoid.") + Msg::getTypeName();
  });
  return why;
}

}  // namespace hpr::msg
