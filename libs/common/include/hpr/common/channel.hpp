#pragma once
/// \file
/// A channel of the stack: its name on LCM and, as a type, the message it carries. The stack's
/// channels are declared once, in hpr/msg/channels.hpp; a node subscribes and advertises through
/// them (node::Runtime), so the message type always matches the channel.

namespace hpr {

template <class Msg>
struct Channel {
  using Message = Msg;
  const char* name;  ///< the channel on LCM (before a runtime's channel prefix)
};

}  // namespace hpr
