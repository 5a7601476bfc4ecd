#pragma once
/// \file
/// BALANCE_STATUS and CAM_REFERENCE: the channels between the wbc, the reference generator and the
/// motion optimiser, converted once for the nodes, the in-process pipeline, replay and the tests.
/// A message with a non-finite value, inverted limits or an unknown enumeration is refused with the
/// reason; times travel in whole microseconds.

#include <humanoid/balance_status_t.hpp>
#include <humanoid/cam_reference_t.hpp>
#include <string>

#include "hpr/balance/ports.hpp"
#include "hpr/msg/robot_io.hpp"

namespace hpr::msg {

/// `names.feet` name the contact wrenches.
void to_message(const balance::BalanceStatus& s, const RobotNames& names, humanoid::balance_status_t& m);
/// Empty when `m` is valid (filled into `s`), else the reason.
std::string from_message(const humanoid::balance_status_t& m, balance::BalanceStatus& s);

void to_message(const balance::CamReference& r, humanoid::cam_reference_t& m);
std::string from_message(const humanoid::cam_reference_t& m, balance::CamReference& r);

}  // namespace hpr::msg
