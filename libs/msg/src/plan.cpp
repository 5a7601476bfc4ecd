#include "hpr/msg/plan.hpp"

#include <fmt/format.h>

#include <cmath>

#include "arrays.hpp"
#include "task_fields.hpp"

namespace hpr::msg {

namespace {

void put_rotation(const Eigen::Matrix3d& R, double* rows) {
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) rows[3 * i + j] = R(i, j);
  }
}

Eigen::Matrix3d get_rotation(const double* rows) {
  Eigen::Matrix3d R;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) R(i, j) = rows[3 * i + j];
  }
  return R;
}

/// Empty when the 9 numbers at `rows` are a rotation matrix, else why not.
std::string check_rotation(const double* rows, const char* what) {
  if (!detail::finite(rows, 9)) return fmt::format("non-finite {} orientation", what);
  const Eigen::Matrix3d R = get_rotation(rows);
  constexpr double kTol = 1e-9;
  const double off = (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (off > kTol) return fmt::format("{} orientation is not a rotation: |RᵀR − I| = {:.3g}", what, off);
  if (std::abs(R.determinant() - 1.0) > kTol) return fmt::format("{} orientation is a reflection (det {:.3g})", what, R.determinant());
  return {};
}

}  // namespace

void to_message(const balance::BalancePlan& p, const std::vector<std::string>& free_names, const RobotNames& names,
                humanoid::balance_plan_t& m) {
  const balance::TaskReference& r = p.reference;
  m.tick = p.tick;
  m.utime = static_cast<int64_t>(std::llround(r.time * 1e6));
  m.stage = static_cast<int8_t>(p.stage);
  m.settled = r.settled;
  detail::put_task(r, free_names, names, m);
  put_rotation(r.R_base, &m.R_WB[0][0]);
  m.R_WF.resize(2);
  for (size_t f = 0; f < 2; ++f) {
    m.R_WF[f].resize(9);
    put_rotation(r.feet[f].X_WS.R, m.R_WF[f].data());
  }
  m.f_ext_W[0] = p.f_ext_W.x();
  m.f_ext_W[1] = p.f_ext_W.y();
}

std::string from_message(const humanoid::balance_plan_t& m, const std::vector<std::string>& free_names, balance::BalancePlan& p) {
  if (std::string why = detail::check_task(m, free_names); !why.empty()) return why;
  if (m.stage < 0 || m.stage >= balance::kPlanStages) return fmt::format("unknown stage {}", static_cast<int>(m.stage));
  if (!detail::finite(m.f_ext_W, 2)) return "non-finite external force";
  for (size_t f = 0; f < 2; ++f) {
    if (m.foot_load_limit[f] < 0.0 || m.foot_load_limit[f] > 1.0) {
      return fmt::format("{} foot's load limit {} is not in [0, 1]", m.foot_name[f], m.foot_load_limit[f]);
    }
  }
  if (std::string why = check_rotation(&m.R_WB[0][0], "base"); !why.empty()) return why;
  for (size_t f = 0; f < 2; ++f) {
    if (std::string why = check_rotation(m.R_WF[f].data(), "sole"); !why.empty()) return m.foot_name[f] + " " + why;
  }
  balance::TaskReference& r = p.reference;
  p.tick = m.tick;
  p.stage = static_cast<balance::PlanStage>(m.stage);
  p.f_ext_W = Eigen::Vector2d(m.f_ext_W[0], m.f_ext_W[1]);
  detail::get_task(m, r);
  r.settled = m.settled != 0;
  r.R_base = get_rotation(&m.R_WB[0][0]);
  for (size_t f = 0; f < 2; ++f) r.feet[f].X_WS.R = get_rotation(m.R_WF[f].data());
  return "";
}

}  // namespace hpr::msg
