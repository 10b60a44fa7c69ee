// EstimateTextPerspective: a robust linear fit of keypoint spacing^(2/3) over the image;
// RefineTextPerspective: the horizon that makes the text lines parallel and evenly spaced.
#include "common/text_perspective.h"

#include <algorithm>
#include <limits>
#include <cmath>

#include "absl/strings/str_cat.h"
#include "common/neighbor_grid.h"

namespace texfree {

absl::Status TextPerspectiveOptions::Validate() const {
  if (neighbour < 1 || neighbour > 16)
    return absl::InvalidArgumentError(
        absl::StrCat("neighbour must be in [1, 16], got ", neighbour));
  if (min_points < 10)
    return absl::InvalidArgumentError(
        absl::StrCat("min_points must be >= 10 (a plane fit of noisy spacings), got ", min_points));
  if (!(min_depth_ratio >= 1.0) || !(max_depth_ratio > min_depth_ratio))
    return absl::InvalidArgumentError(
        absl::StrCat("need 1 <= min_depth_ratio < max_depth_ratio, got ", min_depth_ratio, " and ",
                     max_depth_ratio));
  if (iterations < 1) return absl::InvalidArgumentError("iterations must be >= 1");
  if (!(focal_px >= 0))
    return absl::InvalidArgumentError(absl::StrCat("focal_px must be >= 0, got ", focal_px));
  if (!(max_stretch >= 1))
    return absl::InvalidArgumentError(absl::StrCat("max_stretch must be >= 1, got ", max_stretch));
  return absl::OkStatus();
}

namespace {
// The keypoints' centroid and RMS distance from it: the normalisation that keeps the fits
// well conditioned. False when the keypoints are (nearly) one point.
bool CentreAndSpread(const std::vector<cv::Point2f> &points, double *cx, double *cy, double *s) {
  const size_t n = points.size();
  *cx = *cy = *s = 0;
  if (n == 0) return false;
  for (const cv::Point2f &p : points) {
    *cx += p.x;
    *cy += p.y;
  }
  *cx /= n;
  *cy /= n;
  for (const cv::Point2f &p : points) *s += (p.x - *cx) * (p.x - *cx) + (p.y - *cy) * (p.y - *cy);
  *s = std::sqrt(*s / n);
  return *s >= 1e-6;
}

cv::Matx33d WithForeshortening(const cv::Matx33d &P, double gx, double gy, double cx, double cy,
                               const TextPerspectiveOptions &o);
}  // namespace

std::optional<cv::Matx33d> EstimateTextPerspective(const std::vector<cv::Point2f> &points,
                                                   const TextPerspectiveOptions &o) {
  const size_t n = points.size();
  if (n < static_cast<size_t>(std::max(o.min_points, o.neighbour + 1))) return std::nullopt;
  // Normalised coordinates around the centroid, so the fit is well conditioned.
  double cx = 0, cy = 0, s = 0;
  if (!CentreAndSpread(points, &cx, &cy, &s)) return std::nullopt;

  NeighborGrid grid(points);
  std::vector<double> u(n), v(n), y(n), w(n, 1.0);
  std::vector<int> nearest;
  for (size_t i = 0; i < n; ++i) {
    u[i] = (points[i].x - cx) / s;
    v[i] = (points[i].y - cy) / s;
    grid.Nearest(static_cast<int>(i), o.neighbour, &nearest);
    const double r = nearest.size() == static_cast<size_t>(o.neighbour)
                         ? cv::norm(points[i] - points[nearest.back()])
                         : 0.0;
    y[i] = std::cbrt(r * r);  // r^(2/3)
    if (r <= 0) w[i] = 0;
  }

  cv::Vec3d plane(0, 0, 0);  // y = a u + b v + c
  std::vector<double> residual(n);
  for (int it = 0; it < o.iterations; ++it) {
    cv::Matx33d A = cv::Matx33d::zeros();
    cv::Vec3d rhs(0, 0, 0);
    for (size_t i = 0; i < n; ++i) {
      if (w[i] <= 0) continue;
      const cv::Vec3d f(u[i], v[i], 1.0);
      A += w[i] * (f * f.t());
      rhs += w[i] * y[i] * f;
    }
    if (std::abs(cv::determinant(A)) < 1e-12) return std::nullopt;
    plane = A.inv() * rhs;
    // Tukey's biweight on residuals scaled by their median absolute value: paragraph gaps,
    // margins and headings give spacings far off the plane, and they are dropped.
    for (size_t i = 0; i < n; ++i)
      residual[i] = std::abs(y[i] - plane.dot(cv::Vec3d(u[i], v[i], 1)));
    std::vector<double> sorted = residual;
    std::nth_element(sorted.begin(), sorted.begin() + n / 2, sorted.end());
    const double c = 4.685 * 1.4826 * std::max(sorted[n / 2], 1e-9);
    for (size_t i = 0; i < n; ++i) {
      if (y[i] <= 0) continue;
      const double t = residual[i] / c;
      w[i] = t < 1 ? (1 - t * t) * (1 - t * t) : 0.0;
    }
  }
  if (!(plane[2] > 0)) return std::nullopt;
  const double ga = plane[0] / plane[2], gb = plane[1] / plane[2];
  // Depth over the keypoints that carried the fit.
  double lo = 1e9, hi = -1e9;
  for (size_t i = 0; i < n; ++i) {
    if (w[i] <= 0) continue;
    const double d = 1 + ga * u[i] + gb * v[i];
    lo = std::min(lo, d);
    hi = std::max(hi, d);
  }
  if (!(lo > 0.1) || hi / lo < o.min_depth_ratio || hi / lo > o.max_depth_ratio)
    return std::nullopt;
  // P = T^-1 * [I 0; ga gb 1] * T, with T the normalisation.
  const cv::Matx33d T(1 / s, 0, -cx / s, 0, 1 / s, -cy / s, 0, 0, 1);
  const cv::Matx33d Ti(s, 0, cx, 0, s, cy, 0, 0, 1);
  const cv::Matx33d Pn(1, 0, 0, 0, 1, 0, ga, gb, 1);
  const cv::Matx33d P = Ti * Pn * T;
  if (!(o.focal_px > 0) || n < static_cast<size_t>(o.min_points_metric)) return P;
  return WithForeshortening(P, ga / s, gb / s, cx, cy, o);
}

namespace {

cv::Matx33d WithForeshortening(const cv::Matx33d &P, double gx, double gy, double cx, double cy,
                               const TextPerspectiveOptions &o) {
  // 1/depth is affine in the image, w = 1 + gx (x - cx) + gy (y - cy) up to scale; for a plane
  // N.X = d seen by a pinhole it equals (N.(x - pp, y - pp, f)) / (f d), so the plane's normal
  // is N ~ (f gx, f gy, w(pp)). Around the keypoints' centre (fixed by P) the affine image is
  // squeezed along the slope by the cosine between N and the ray there; stretch it back.
  const double f = o.focal_px;
  const double w_pp = 1 + gx * (o.principal_point.x - cx) + gy * (o.principal_point.y - cy);
  const cv::Vec3d normal(f * gx, f * gy, w_pp);
  const cv::Vec3d ray((cx - o.principal_point.x) / f, (cy - o.principal_point.y) / f, 1);
  // normal . ray = w(centre) = 1.
  const double stretch = cv::norm(normal) * cv::norm(ray);
  const double g = std::hypot(gx, gy);
  // The guard against slopes of the layout's judges the camera's tilt (between the normal
  // and the optical axis, 1 / cos tilt = |N| / w(pp)), which such a slope overstates, not
  // the stretch at the keypoints' centre: that adds the centre's angle off the axis, and a
  // steep view's keypoints crowd towards its far side (views seen upright at 33-40 degrees
  // measured 1.5-1.6 there and were left affine).
  if (!(stretch > 1) || !(g > 0) || !(w_pp > 0) || cv::norm(normal) / w_pp > o.max_stretch)
    return P;
  const double dx = gx / g, dy = gy / g, e = stretch - 1;
  const cv::Matx33d S(1 + e * dx * dx, e * dx * dy, 0, e * dx * dy, 1 + e * dy * dy, 0, 0, 0, 1);
  const cv::Matx33d to_centre(1, 0, -cx, 0, 1, -cy, 0, 0, 1), back(1, 0, cx, 0, 1, cy, 0, 0, 1);
  return back * S * to_centre * P;
}

}  // namespace

std::optional<cv::Matx33d> RefineTextPerspective(const std::vector<cv::Point2f> &points,
                                                 double text_angle_rad,
                                                 const std::optional<cv::Matx33d> &start,
                                                 const TextPerspectiveOptions &o) {
  const size_t n = points.size();
  if (n < 12) return std::nullopt;
  double cx = 0, cy = 0, s = 0;
  if (!CentreAndSpread(points, &cx, &cy, &s)) return std::nullopt;
  // Image pixels -> normalised coordinates and back.
  const cv::Matx33d T(1 / s, 0, -cx / s, 0, 1 / s, -cy / s, 0, 0, 1);
  const cv::Matx33d Ti(s, 0, cx, 0, s, cy, 0, 0, 1);
  std::vector<cv::Point2d> q(n);
  for (size_t i = 0; i < n; ++i) q[i] = {(points[i].x - cx) / s, (points[i].y - cy) / s};
  // Neighbour pairs as seen: along the lines (the 2 nearest within 20 degrees of the text
  // direction, either way) and across them (the nearest within 25 degrees of the normal).
  const cv::Point2d along(std::cos(text_angle_rad), std::sin(text_angle_rad));
  const cv::Point2d across(-along.y, along.x);
  NeighborGrid grid(points);
  std::vector<int> nearest;
  std::vector<std::pair<int, int>> line_pairs, cross_pairs;
  for (size_t i = 0; i < n; ++i) {
    grid.Nearest(static_cast<int>(i), 12, &nearest);
    int taken = 0, next_line = -1;
    double next_offset = 1e18;
    for (int j : nearest) {
      const cv::Point2d d = q[j] - q[i];
      const double len = std::hypot(d.x, d.y);
      if (len <= 0) continue;
      const double c_along = std::abs(d.dot(along)) / len;
      if (taken < 2 && c_along > std::cos(20 * CV_PI / 180)) {
        if (static_cast<int>(i) < j) line_pairs.emplace_back(static_cast<int>(i), j);
        ++taken;
      }
      // The next line on the normal's side: the neighbour there (within 60 degrees of the
      // normal) nearest across the lines, wherever it lies along its line.
      const double offset = d.dot(across);
      if (offset > 0 && std::abs(d.dot(along)) < std::tan(60 * CV_PI / 180) * offset &&
          offset < next_offset) {
        next_offset = offset;
        next_line = j;
      }
    }
    if (next_line >= 0) cross_pairs.emplace_back(static_cast<int>(i), next_line);
  }
  if (line_pairs.size() < 8 || cross_pairs.size() < 8) return std::nullopt;
  const auto rectify = [](const cv::Point2d &p, const cv::Vec2d &g) {
    const double w = 1 + g[0] * p.x + g[1] * p.y;
    return cv::Point2d(p.x / w, p.y / w);
  };
  std::vector<double> a, l;
  // Robust spread (median absolute deviation) of the line directions and of the log line
  // spacing after rectification by g.
  const auto cost = [&](const cv::Vec2d &g) {
    a.clear();
    l.clear();
    for (const auto &[i, j] : line_pairs) {
      const double wi = 1 + g[0] * q[i].x + g[1] * q[i].y, wj = 1 + g[0] * q[j].x + g[1] * q[j].y;
      if (wi < 0.2 || wj < 0.2) return 1e9;
      const cv::Point2d d = rectify(q[j], g) - rectify(q[i], g);
      double angle = std::atan2(d.y, d.x);
      angle = std::remainder(angle - text_angle_rad, CV_PI);
      a.push_back(angle);
    }
    // The line pitch: each pair's offset across the rectified lines' median direction.
    std::vector<double> sorted_a = a;
    std::nth_element(sorted_a.begin(), sorted_a.begin() + sorted_a.size() / 2, sorted_a.end());
    const double direction = text_angle_rad + sorted_a[sorted_a.size() / 2];
    const cv::Point2d normal(-std::sin(direction), std::cos(direction));
    for (const auto &[i, j] : cross_pairs) {
      const double offset = std::abs((rectify(q[j], g) - rectify(q[i], g)).dot(normal));
      if (offset > 0) l.push_back(std::log(offset));
    }
    if (l.size() < 8) return 1e9;
    const auto mad = [](std::vector<double> &v) {
      std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
      const double m = v[v.size() / 2];
      for (double &x : v) x = std::abs(x - m);
      std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
      return v[v.size() / 2];
    };
    return mad(a) / 0.035 + mad(l) / 0.08;  // ~2 degrees, ~8% of a line pitch
  };
  cv::Vec2d g(0, 0);
  if (start) {
    const cv::Matx33d Pn = T * (*start) * Ti;
    if (std::abs(Pn(2, 2)) > 1e-12) g = cv::Vec2d(Pn(2, 0) / Pn(2, 2), Pn(2, 1) / Pn(2, 2));
  }
  double best = cost(g);
  // Also from no perspective at all.
  if (const double flat = cost(cv::Vec2d(0, 0)); flat < best) {
    g = cv::Vec2d(0, 0);
    best = flat;
  }
  for (double step = 0.2; step > 0.004; step *= 0.5) {
    for (bool moved = true; moved;) {
      moved = false;
      for (const cv::Vec2d &d :
           {cv::Vec2d(step, 0), cv::Vec2d(-step, 0), cv::Vec2d(0, step), cv::Vec2d(0, -step)}) {
        const double c = cost(g + d);
        if (c < best) {
          best = c;
          g += d;
          moved = true;
        }
      }
    }
  }
  const cv::Matx33d P = Ti * cv::Matx33d(1, 0, 0, 0, 1, 0, g[0], g[1], 1) * T;
  if (!(o.focal_px > 0) || n < static_cast<size_t>(o.min_points_metric)) return P;
  return WithForeshortening(P, g[0] / s, g[1] / s, cx, cy, o);
}

std::vector<cv::Point2f> ApplyPerspective(const cv::Matx33d &P,
                                          const std::vector<cv::Point2f> &points) {
  std::vector<cv::Point2f> out;
  out.reserve(points.size());
  for (const cv::Point2f &p : points) {
    const cv::Vec3d q = P * cv::Vec3d(p.x, p.y, 1.0);
    out.emplace_back(static_cast<float>(q[0] / q[2]), static_cast<float>(q[1] / q[2]));
  }
  return out;
}

double DepthRatio(const cv::Matx33d &P, const std::vector<cv::Point2f> &points) {
  double lo = std::numeric_limits<double>::max(), hi = 0;
  for (const cv::Point2f &q : points) {
    const double w = P(2, 0) * q.x + P(2, 1) * q.y + P(2, 2);
    lo = std::min(lo, w);
    hi = std::max(hi, w);
  }
  return !points.empty() && lo > 0 ? hi / lo : 0;
}

std::optional<cv::Matx33d> PerspectiveOnly(const cv::Matx33d &P, const cv::Point2d &at) {
  const double w = P(2, 0) * at.x + P(2, 1) * at.y + P(2, 2);
  if (!(std::isfinite(w) && w > 0)) return std::nullopt;
  return cv::Matx33d(1, 0, 0, 0, 1, 0, P(2, 0) / w, P(2, 1) / w, P(2, 2) / w);
}

}  // namespace texfree
