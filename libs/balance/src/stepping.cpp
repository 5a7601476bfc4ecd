#include "hpr/balance/stepping.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>

#include "hpr/model/robot.hpp"

namespace hpr::balance {

using Eigen::Vector2d;

double lip_omega(double z_c, double g) { return std::sqrt(g / z_c); }

Vector2d capture_point(const Vector2d& c, const Vector2d& cd, double omega) { return c + cd / omega; }

Vector2d push_shift(const Vector2d& f, double m, double omega, double t_remaining) {
  return f / (m * omega * omega) * -std::expm1(-omega * std::max(t_remaining, 0.0));
}

Vector2d dcm_after(const Vector2d& xi0, const Vector2d& p, double omega, double t) {
  return p + (xi0 - p) * std::exp(omega * t);
}

Vector2d Sole::to_local(const Vector2d& x) const { return Eigen::Rotation2Dd(-yaw) * (x - centre); }

Vector2d Sole::to_world(const Vector2d& local) const { return centre + Eigen::Rotation2Dd(yaw) * local; }

namespace {

double cross(const Vector2d& o, const Vector2d& a, const Vector2d& b) {
  return (a.x() - o.x()) * (b.y() - o.y()) - (a.y() - o.y()) * (b.x() - o.x());
}

/// Distance from x to the segment [a, b].
double segment_distance(const Vector2d& x, const Vector2d& a, const Vector2d& b) {
  const Vector2d d = b - a;
  const double len2 = d.squaredNorm();
  const double s = len2 > 0 ? std::clamp((x - a).dot(d) / len2, 0.0, 1.0) : 0.0;
  return (a + s * d - x).norm();
}

}  // namespace

namespace {

/// The convex hull of the corners of the soles in contact, each shrunk by `inset` on every side
/// (Andrew's monotone chain), counter-clockwise into `hull`; returns the number of vertices (at
/// most 8, on the stack).
int support_hull(const std::array<Sole, 2>& soles, const std::array<bool, 2>& contact, double inset,
                 std::array<Vector2d, 16>& hull) {
  std::array<Vector2d, 8> pts;
  int n = 0;
  for (int k = 0; k < 2; ++k) {
    if (!contact[static_cast<size_t>(k)]) continue;
    const Sole& s = soles[static_cast<size_t>(k)];
    const double hl = std::max(s.half_length - inset, 0.0), hw = std::max(s.half_width - inset, 0.0);
    for (const double sx : {-1.0, 1.0}) {
      for (const double sy : {-1.0, 1.0}) pts[static_cast<size_t>(n++)] = s.to_world({sx * hl, sy * hw});
    }
  }
  if (n == 0) return 0;
  // Insertion sort by (x, y): at most 8 points.
  for (int i = 1; i < n; ++i) {
    const Vector2d key = pts[static_cast<size_t>(i)];
    int j = i - 1;
    while (j >= 0 && (pts[static_cast<size_t>(j)].x() > key.x() ||
                      (pts[static_cast<size_t>(j)].x() == key.x() && pts[static_cast<size_t>(j)].y() > key.y()))) {
      pts[static_cast<size_t>(j + 1)] = pts[static_cast<size_t>(j)];
      --j;
    }
    pts[static_cast<size_t>(j + 1)] = key;
  }
  int h = 0;
  for (int i = 0; i < n; ++i) {
    while (h >= 2 && cross(hull[static_cast<size_t>(h - 2)], hull[static_cast<size_t>(h - 1)], pts[static_cast<size_t>(i)]) <= 0) --h;
    hull[static_cast<size_t>(h++)] = pts[static_cast<size_t>(i)];
  }
  for (int i = n - 2, lower = h + 1; i >= 0; --i) {
    while (h >= lower && cross(hull[static_cast<size_t>(h - 2)], hull[static_cast<size_t>(h - 1)], pts[static_cast<size_t>(i)]) <= 0) --h;
    hull[static_cast<size_t>(h++)] = pts[static_cast<size_t>(i)];
  }
  return std::max(h - 1, 1);  // the last point repeats the first
}

/// The point of the convex polygon `poly` (its first `n` vertices, counter-clockwise) nearest to
/// `x`: x itself inside, else its projection on the boundary.
template <size_t N>
Vector2d nearest_in_polygon(const std::array<Vector2d, N>& poly, int n, const Vector2d& x) {
  if (n == 1) return poly[0];
  bool inside = n >= 3;
  double best = std::numeric_limits<double>::infinity();
  Vector2d nearest = x;
  for (int i = 0; i < n; ++i) {
    const Vector2d& a = poly[static_cast<size_t>(i)];
    const Vector2d& b = poly[static_cast<size_t>((i + 1) % n)];
    if (cross(a, b, x) < 0) inside = false;
    const Vector2d d = b - a;
    const double len2 = d.squaredNorm();
    const double s = len2 > 0 ? std::clamp((x - a).dot(d) / len2, 0.0, 1.0) : 0.0;
    const Vector2d q = a + s * d;
    if ((q - x).squaredNorm() < best) {
      best = (q - x).squaredNorm();
      nearest = q;
    }
  }
  return inside ? x : nearest;
}

/// Clips the convex polygon `poly` (first `n` vertices) to the half-plane e·p ≤ d, in place
/// (Sutherland–Hodgman); returns the new count.
int clip(std::array<Vector2d, 8>& poly, int n, const Vector2d& e, double d) {
  std::array<Vector2d, 8> out;
  int m = 0;
  for (int i = 0; i < n; ++i) {
    const Vector2d& a = poly[static_cast<size_t>(i)];
    const Vector2d& b = poly[static_cast<size_t>((i + 1) % n)];
    const double fa = e.dot(a) - d, fb = e.dot(b) - d;
    if (fa <= 0) out[static_cast<size_t>(m++)] = a;
    if ((fa < 0 && fb > 0) || (fa > 0 && fb < 0)) out[static_cast<size_t>(m++)] = a + (b - a) * (fa / (fa - fb));
  }
  poly = out;
  return m;
}

}  // namespace

double support_distance(const std::array<Sole, 2>& soles, const std::array<bool, 2>& contact, const Vector2d& x) {
  std::array<Vector2d, 16> hull;
  const int h = support_hull(soles, contact, 0.0, hull);
  if (h == 0) return std::numeric_limits<double>::infinity();
  bool inside = h >= 3;
  double d = std::numeric_limits<double>::infinity();
  for (int i = 0; i < h; ++i) {
    const Vector2d& a = hull[static_cast<size_t>(i)];
    const Vector2d& b = hull[static_cast<size_t>((i + 1) % h)];
    if (cross(a, b, x) < 0) inside = false;
    d = std::min(d, segment_distance(x, a, b));
  }
  return inside ? -d : d;
}

Vector2d support_point(const std::array<Sole, 2>& soles, const std::array<bool, 2>& contact, const Vector2d& x,
                       double inset) {
  std::array<Vector2d, 16> hull;
  const int h = support_hull(soles, contact, inset, hull);
  if (h == 0) return x;
  return nearest_in_polygon(hull, h, x);
}

SteppingConfig SteppingConfig::load(const Config& c) {
  SteppingConfig s;
  s.enabled = c.boolean_or("enabled", s.enabled);
  s.margin = c.real_or("margin", s.margin, -0.1, 0.2);
  s.cmp_reach = c.real_or("cmp_reach", s.cmp_reach, 0.0, 0.5);
  s.cmp_reach_backward = c.real_or("cmp_reach_backward", s.cmp_reach, 0.0, 0.5);
  s.cmp_reach_sideways = c.real_or("cmp_reach_sideways", s.cmp_reach, 0.0, 0.5);
  s.lean_range = c.real_or("lean_range", s.lean_range, 0.0, 1.5);
  s.t_min = c.real_or("t_min", s.t_min, 0.05, 2.0);
  s.t_max = c.real_or("t_max", s.t_max, s.t_min, 3.0);
  s.t_nominal = c.real_or("t_nominal", s.t_nominal, s.t_min, s.t_max);
  s.dcm_offset = c.real_or("dcm_offset", s.dcm_offset, -0.2, 0.2);
  s.reach_forward = c.real_or("reach_forward", s.reach_forward, 0.0, 2.0);
  s.reach_backward = c.real_or("reach_backward", s.reach_backward, 0.0, 2.0);
  s.min_width = c.real_or("min_width", s.min_width, 0.0, 2.0);
  s.max_width = c.real_or("max_width", s.max_width, s.min_width, 2.0);
  s.weight_position = c.real_or("weight_position", s.weight_position, 0.0, 1e6);
  s.weight_offset = c.real_or("weight_offset", s.weight_offset, 1e-6, 1e6);
  s.weight_time = c.real_or("weight_time", s.weight_time, 0.0, 1e6);
  s.time_samples = static_cast<int>(c.integer_or("time_samples", s.time_samples, 1, 1000));
  if (c.has("ground")) {
    const auto g = c.reals("ground", 4, -1e4, 1e4);
    if (!(g[0] < g[1]) || !(g[2] < g[3])) c.fail("ground", "must be [x_min, x_max, y_min, y_max] with x_min < x_max and y_min < y_max");
    s.ground = std::array<double, 4>{g[0], g[1], g[2], g[3]};
  }
  return s;
}

Vector2d stance_cmp(const Sole& stance, const Vector2d& xi) {
  Vector2d p = stance.to_local(xi);
  p.x() = std::clamp(p.x(), -stance.half_length, stance.half_length);
  p.y() = std::clamp(p.y(), -stance.half_width, stance.half_width);
  return stance.to_world(p);
}

double StepPlanner::excess(const std::array<Sole, 2>& soles, const std::array<bool, 2>& contact, const Vector2d& xi,
                           const Vector2d& lean) const {
  // The direction of ξ from the centre of the soles in contact, and their mean heading.
  Vector2d centre = Vector2d::Zero(), heading = Vector2d::Zero();
  int n = 0;
  for (size_t k = 0; k < 2; ++k) {
    if (!contact[k]) continue;
    centre += soles[k].centre;
    heading += Vector2d(std::cos(soles[k].yaw), std::sin(soles[k].yaw));
    ++n;
  }
  const Vector2d d = xi - centre / std::max(n, 1);
  const double norm = d.norm(), hnorm = heading.norm();
  double reach = config_.cmp_reach;
  if (n > 0 && norm > 0.0) {
    if (hnorm > 0.0) {
      const double along = d.dot(heading) / (norm * hnorm);  // cos of the angle to x
      const double behind = std::max(0.0, -along);
      const double side2 = std::max(0.0, 1.0 - along * along);  // sin² of that angle
      reach += (config_.cmp_reach_backward - config_.cmp_reach) * behind * behind +
               (config_.cmp_reach_sideways - config_.cmp_reach) * (side2 * side2) * (side2 * side2);
    }
    if (config_.lean_range > 0.0) {
      const double leaning = std::max(0.0, lean.dot(d) / norm);  // sin of the lean towards ξ
      reach *= std::max(0.0, 1.0 - leaning / std::sin(config_.lean_range));
    }
  }
  return support_distance(soles, contact, xi) - reach + config_.margin;
}

bool StepPlanner::step_needed(const std::array<Sole, 2>& soles, const std::array<bool, 2>& contact, const Vector2d& xi,
                              const Vector2d& lean) const {
  return config_.enabled && excess(soles, contact, xi, lean) > 0.0;
}

int StepPlanner::choose_swing(const std::array<Sole, 2>& soles, const Vector2d& xi, const std::array<double, 2>& load) const {
  const Sole& r = soles[model::kRight];
  const Sole& l = soles[model::kLeft];
  const Vector2d across = l.centre - r.centre;  // towards the left foot
  const double half = 0.5 * across.norm();
  if (half > 0) {
    const double lateral = (xi - 0.5 * (l.centre + r.centre)).dot(across) / (2.0 * half);
    if (lateral > half) return model::kLeft;
    if (lateral < -half) return model::kRight;
  }
  return load[model::kLeft] < load[model::kRight] ? model::kLeft : model::kRight;
}

StepPlan StepPlanner::plan(const std::array<Sole, 2>& soles, int swing, const Vector2d& xi, double omega, double elapsed) const {
  const SteppingConfig& c = config_;
  const double t_lo = std::max(c.t_min - elapsed, 1e-3), t_hi = std::max(c.t_max - elapsed, t_lo);
  const double t_nom = std::clamp(c.t_nominal - elapsed, t_lo, t_hi);
  StepPlan best;
  best.cost = std::numeric_limits<double>::infinity();
  best.swing = swing;
  best.placeable = false;  // until a duration has a landing on the declared ground
  const int samples = t_hi > t_lo ? std::max(c.time_samples, 2) : 1;
  for (int i = 0; i < samples; ++i) {
    const double T = samples == 1 ? t_lo : t_lo + (t_hi - t_lo) * i / (samples - 1);
    const StepPlan p = evaluate(soles, swing, xi, omega, T, t_nom);
    if (p.cost < best.cost) best = p;
  }
  return best;
}

StepPlan StepPlanner::plan_landing(const std::array<Sole, 2>& soles, int swing, const Vector2d& xi, double omega,
                                   double remaining) const {
  return evaluate(soles, swing, xi, omega, std::max(remaining, 0.0), std::max(remaining, 0.0));
}

StepPlan StepPlanner::evaluate(const std::array<Sole, 2>& soles, int swing, const Vector2d& xi, double omega, double T,
                               double t_nom) const {
  const SteppingConfig& c = config_;
  const Sole& stance = soles[static_cast<size_t>(1 - swing)];
  const Sole& moving = soles[static_cast<size_t>(swing)];
  // The swing side in the stance frame: +y when the left foot swings (it lies to the stance's left).
  const double side = swing == model::kLeft ? 1.0 : -1.0;
  // The CMP during the swing: the stance sole's point nearest the DCM (the ankle strategy at its edge).
  const Vector2d p_st = stance_cmp(stance, xi);
  // The nominal landing: where the swing foot stands now, relative to the stance foot, at least
  // min_width to the side.
  Vector2d nominal_local = stance.to_local(moving.centre);
  nominal_local.y() = side * std::clamp(side * nominal_local.y(), c.min_width, c.max_width);
  nominal_local.x() = std::clamp(nominal_local.x(), -c.reach_backward, c.reach_forward);
  const Vector2d xi_T = dcm_after(xi, p_st, omega, T);
  const Vector2d away = xi_T - p_st;
  const Vector2d b = away.norm() > 1e-9 ? Vector2d(c.dcm_offset * away.normalized()) : Vector2d::Zero();
  // min w_p ‖u − u_nom‖² + w_b ‖ξ_T − b − u‖² over the reach box: the box is axis-aligned in the
  // stance frame and the cost isotropic, so the clamped free minimiser is the constrained one.
  const Vector2d want_local = stance.to_local(xi_T - b);
  const Vector2d free_local = (c.weight_position * nominal_local + c.weight_offset * want_local) / (c.weight_position + c.weight_offset);
  Vector2d u_local = free_local;
  bool placeable = true;
  if (!c.ground) {
    u_local.x() = std::clamp(u_local.x(), -c.reach_backward, c.reach_forward);
    u_local.y() = side * std::clamp(side * u_local.y(), c.min_width, c.max_width);
  } else {
    // The box (counter-clockwise in the stance frame, so in the world) clipped to the declared
    // ground less the landed sole's extent; the isotropic cost's constrained minimiser is the free
    // one's projection on that convex polygon.
    const double y_lo = side > 0 ? c.min_width : -c.max_width, y_hi = side > 0 ? c.max_width : -c.min_width;
    std::array<Vector2d, 8> region;
    region[0] = stance.to_world({-c.reach_backward, y_lo});
    region[1] = stance.to_world({c.reach_forward, y_lo});
    region[2] = stance.to_world({c.reach_forward, y_hi});
    region[3] = stance.to_world({-c.reach_backward, y_hi});
    const double cy = std::abs(std::cos(stance.yaw)), sy = std::abs(std::sin(stance.yaw));
    const double ex = moving.half_length * cy + moving.half_width * sy, ey = moving.half_length * sy + moving.half_width * cy;
    const auto& g = *c.ground;
    int n = 4;
    n = clip(region, n, Vector2d(-1, 0), -(g[0] + ex));
    n = clip(region, n, Vector2d(1, 0), g[1] - ex);
    n = clip(region, n, Vector2d(0, -1), -(g[2] + ey));
    n = clip(region, n, Vector2d(0, 1), g[3] - ey);
    placeable = n > 0;
    if (placeable) u_local = stance.to_local(nearest_in_polygon(region, n, stance.to_world(free_local)));
  }
  StepPlan p;
  p.placeable = placeable;
  p.swing = swing;
  p.duration = T;
  p.target = stance.to_world(u_local);
  p.yaw = stance.yaw;
  p.xi_touchdown = xi_T;
  p.reachable = (u_local - free_local).norm() < 1e-9;
  p.cost = placeable ? c.weight_position * (u_local - nominal_local).squaredNorm() + c.weight_offset * (want_local - u_local).squaredNorm() +
                           c.weight_time * (T - t_nom) * (T - t_nom)
                     : std::numeric_limits<double>::infinity();
  return p;
}

}  // namespace hpr::balance
