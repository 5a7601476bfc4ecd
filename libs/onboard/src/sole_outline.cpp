#include "hpr/onboard/sole_outline.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>

namespace hpr::onboard {

using Eigen::Vector2d;

namespace {

double cross(const Vector2d& o, const Vector2d& a, const Vector2d& b) {
  return (a.x() - o.x()) * (b.y() - o.y()) - (a.y() - o.y()) * (b.x() - o.x());
}

double wrap(double a) { return std::remainder(a, 2.0 * M_PI); }

/// The long principal axis of a convex polygon's area [rad], or NaN when its two principal second
/// moments are within 10 % of each other.
double principal_axis(const std::vector<Vector2d>& hull) {
  Vector2d mean = Vector2d::Zero();
  for (const auto& p : hull) mean += p;
  mean /= static_cast<double>(hull.size());
  double A = 0, cx = 0, cy = 0, ixx = 0, iyy = 0, ixy = 0;  // ∫dA, ∫x, ∫y, ∫x², ∫y², ∫xy about `mean`
  for (size_t i = 0; i < hull.size(); ++i) {
    const Vector2d a = hull[i] - mean, b = hull[(i + 1) % hull.size()] - mean;
    const double c = a.x() * b.y() - b.x() * a.y();
    A += 0.5 * c;
    cx += (a.x() + b.x()) * c / 6.0;
    cy += (a.y() + b.y()) * c / 6.0;
    ixx += (a.x() * a.x() + a.x() * b.x() + b.x() * b.x()) * c / 12.0;
    iyy += (a.y() * a.y() + a.y() * b.y() + b.y() * b.y()) * c / 12.0;
    ixy += (a.x() * b.y() + 2 * a.x() * a.y() + 2 * b.x() * b.y() + b.x() * a.y()) * c / 24.0;
  }
  // Central moments: ∫(x − x̄)² = ∫x² − A x̄², with x̄ = ∫x / A.
  const double sxx = ixx - cx * cx / A, syy = iyy - cy * cy / A, sxy = ixy - cx * cy / A;
  const double mid = 0.5 * (sxx + syy), r = std::hypot(0.5 * (sxx - syy), sxy);
  if (mid + r < 1.1 * (mid - r)) return std::numeric_limits<double>::quiet_NaN();
  return 0.5 * std::atan2(2.0 * sxy, sxx - syy);
}

/// The y-interval of a convex polygon at abscissa x (empty, lo > hi, outside it).
std::pair<double, double> section(const std::vector<Vector2d>& hull, double x) {
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  constexpr double eps = 1e-12;
  for (size_t i = 0; i < hull.size(); ++i) {
    const Vector2d& a = hull[i];
    const Vector2d& b = hull[(i + 1) % hull.size()];
    if (x < std::min(a.x(), b.x()) - eps || x > std::max(a.x(), b.x()) + eps) continue;
    if (std::abs(b.x() - a.x()) <= eps) {
      lo = std::min({lo, a.y(), b.y()});
      hi = std::max({hi, a.y(), b.y()});
      continue;
    }
    const double t = std::clamp((x - a.x()) / (b.x() - a.x()), 0.0, 1.0);
    const double y = a.y() + t * (b.y() - a.y());
    lo = std::min(lo, y);
    hi = std::max(hi, y);
  }
  return {lo, hi};
}

}  // namespace

std::vector<Vector2d> convex_hull_2d(std::vector<Vector2d> pts) {
  std::sort(pts.begin(), pts.end(), [](const Vector2d& a, const Vector2d& b) { return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y()); });
  pts.erase(std::unique(pts.begin(), pts.end()), pts.end());
  if (pts.size() < 3) return pts;
  std::vector<Vector2d> h(2 * pts.size());
  size_t k = 0;
  for (const auto& p : pts) {
    while (k >= 2 && cross(h[k - 2], h[k - 1], p) <= 0) --k;
    h[k++] = p;
  }
  for (size_t i = pts.size() - 1, lower = k + 1; i-- > 0;) {
    while (k >= lower && cross(h[k - 2], h[k - 1], pts[i]) <= 0) --k;
    h[k++] = pts[i];
  }
  h.resize(k - 1);
  return h;
}

SoleRectangle sole_rectangle(const std::vector<Vector2d>& outline, double forward_yaw) {
  SoleRectangle s;
  s.yaw = forward_yaw;
  const std::vector<Vector2d> hull = convex_hull_2d(outline);
  if (hull.empty()) return s;
  if (hull.size() < 3) {
    // A point or a segment: no area. The segment's direction (towards forward) and length.
    const Vector2d d = hull.back() - hull.front();
    s.centre = 0.5 * (hull.front() + hull.back());
    s.length = d.norm();
    if (s.length > 0) s.yaw = forward_yaw + wrap(std::atan2(d.y(), d.x()) - forward_yaw);
    if (std::cos(s.yaw - forward_yaw) < 0) s.yaw = forward_yaw + wrap(s.yaw + M_PI - forward_yaw);
    return s;
  }
  double yaw = principal_axis(hull);
  if (std::isnan(yaw)) yaw = forward_yaw;
  double off = wrap(yaw - forward_yaw);
  if (std::abs(off) > 0.5 * M_PI) off = wrap(off + M_PI);  // the end of the axis nearer forward is +x
  if (std::abs(off) < 0.5 * M_PI / 180.0) off = 0.0;
  s.yaw = forward_yaw + off;

  // The hull in the sole's frame (x along the axis).
  const Eigen::Rotation2Dd R_SL(-s.yaw);
  std::vector<Vector2d> u;
  u.reserve(hull.size());
  for (const auto& p : hull) u.push_back(R_SL * p);
  // Candidate ends of the rectangle: the hull's vertices and 128 even steps between its extremes.
  // A rectangle [a, b] × [y0, y1] lies inside a convex polygon iff its four corners do, and the
  // polygon's lower boundary is convex and its upper one concave in x, so the widest band over
  // [a, b] is the overlap of the sections at a and at b.
  double x_lo = std::numeric_limits<double>::infinity(), x_hi = -x_lo;
  for (const auto& p : u) {
    x_lo = std::min(x_lo, p.x());
    x_hi = std::max(x_hi, p.x());
  }
  std::vector<double> xs;
  for (const auto& p : u) xs.push_back(p.x());
  for (int i = 0; i <= 128; ++i) xs.push_back(x_lo + (x_hi - x_lo) * i / 128.0);
  std::sort(xs.begin(), xs.end());
  xs.erase(std::unique(xs.begin(), xs.end()), xs.end());
  std::vector<std::pair<double, double>> sec;
  sec.reserve(xs.size());
  for (double x : xs) sec.push_back(section(u, x));
  double best = -1.0, best_len = 0.0;
  Vector2d c = Vector2d::Zero();
  double width = 0.0;
  const double tie = 1e-12 * (x_hi - x_lo) * (x_hi - x_lo);
  for (size_t i = 0; i < xs.size(); ++i) {
    for (size_t j = i + 1; j < xs.size(); ++j) {
      const double y0 = std::max(sec[i].first, sec[j].first), y1 = std::min(sec[i].second, sec[j].second);
      const double len = xs[j] - xs[i], w = std::max(0.0, y1 - y0), area = len * w;
      if (area > best + tie || (area >= best - tie && len > best_len)) {
        best = area;
        best_len = len;
        width = w;
        c = Vector2d(0.5 * (xs[i] + xs[j]), w > 0 ? 0.5 * (y0 + y1) : 0.5 * (sec[i].first + sec[i].second));
      }
    }
  }
  s.length = best_len;
  s.width = width;
  s.centre = R_SL.inverse() * c;
  return s;
}

}  // namespace hpr::onboard
