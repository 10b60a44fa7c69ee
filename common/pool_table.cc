// Table detection: cloth colour angle, outline, Hough sides, sub-pixel edges, corners, pose.
#include "common/pool_table.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "absl/strings/str_cat.h"
#include "common/connected_components.h"
#include "common/hough_lines.h"
#include "common/status_macros.h"

namespace texfree {
namespace {

constexpr double kPi = 3.14159265358979323846;

// 255 where the pixel's colour is within `angle_deg` of `ref` and brighter than
// `min_sum` (B + G + R), and nearer (in angle) to `ref` than to each of `rivals`: a wide
// cone about a cloth of little colour (a purple 18 degrees from grey) takes in a grey
// floor's (21 degrees from that purple, 5 from grey), and one about a burgundy a wooden
// floor's (18 degrees apart).
cv::Mat AngleMask(const cv::Mat& bgr, const cv::Vec3f& ref, double angle_deg, double min_sum,
                  const std::vector<cv::Vec3f>& rivals = {}) {
  cv::Mat mask(bgr.size(), CV_8UC1);
  const double c = std::cos(angle_deg * kPi / 180);
  const float c2 = static_cast<float>(c * c);
  const float ref_norm2 = ref.dot(ref);
  const float min_s = static_cast<float>(min_sum);
  // Nearer to ref than to a rival: p . ref / |ref| > p . rival / |rival| (both cosines times
  // |p|), i.e. p . (ref / |ref| - rival / |rival|) > 0.
  std::vector<cv::Vec3f> planes;
  for (const cv::Vec3f& rival : rivals)
    planes.push_back(ref / std::sqrt(ref_norm2) - rival / std::sqrt(rival.dot(rival)));
  for (int y = 0; y < bgr.rows; ++y) {
    const cv::Vec3b* p = bgr.ptr<cv::Vec3b>(y);
    uint8_t* m = mask.ptr<uint8_t>(y);
    for (int x = 0; x < bgr.cols; ++x) {
      const float b = p[x][0], g = p[x][1], r = p[x][2];
      const float dot = b * ref[0] + g * ref[1] + r * ref[2];
      const float n2 = b * b + g * g + r * r;
      bool in = b + g + r >= min_s && dot > 0 && dot * dot >= c2 * n2 * ref_norm2;
      for (size_t k = 0; in && k < planes.size(); ++k)
        in = b * planes[k][0] + g * planes[k][1] + r * planes[k][2] > 0;
      m[x] = in ? 255 : 0;
    }
  }
  return mask;
}

// The largest 8-connected region of `mask` (and its area).
cv::Mat LargestRegion(const cv::Mat& mask, int* area) {
  thread_local cv::Mat labels;  // kept per thread: a fresh one was faulted in every frame
  cv::Mat stats, centroids;
  const int n = ConnectedComponentsWithStats(mask, 8, &labels, &stats, &centroids);
  int best = 0, best_area = 0;
  for (int i = 1; i < n; ++i) {
    if (stats.at<int>(i, cv::CC_STAT_AREA) > best_area) {
      best_area = stats.at<int>(i, cv::CC_STAT_AREA);
      best = i;
    }
  }
  *area = best_area;
  if (best == 0) return cv::Mat::zeros(mask.size(), CV_8UC1);
  return labels == best;
}

// Mean colour of the masked pixels whose colour is within `angle_deg` of `ref`.
cv::Vec3f MeanColor(const cv::Mat& bgr, const cv::Mat& mask, const cv::Vec3f& ref,
                    double angle_deg) {
  cv::Vec3d sum(0, 0, 0);
  double n = 0;
  const double c = std::cos(angle_deg * kPi / 180);
  for (int y = 0; y < bgr.rows; y += 2) {
    const cv::Vec3b* p = bgr.ptr<cv::Vec3b>(y);
    const uint8_t* m = mask.ptr<uint8_t>(y);
    for (int x = 0; x < bgr.cols; x += 2) {
      if (!m[x]) continue;
      const cv::Vec3f v(p[x][0], p[x][1], p[x][2]);
      const double nv = cv::norm(v);
      if (nv < 1 || v.dot(ref) < c * nv * cv::norm(ref)) continue;
      sum += cv::Vec3d(v[0], v[1], v[2]);
      n += 1;
    }
  }
  if (n < 1) return ref;
  return cv::Vec3f(static_cast<float>(sum[0] / n), static_cast<float>(sum[1] / n),
                   static_cast<float>(sum[2] / n));
}

struct Line {  // n . p = rho, |n| = 1
  cv::Point2d n;
  double rho;
  double Distance(const cv::Point2d& p) const { return n.dot(p) - rho; }
};

bool Intersect(const Line& a, const Line& b, cv::Point2d* p) {
  const double det = a.n.x * b.n.y - a.n.y * b.n.x;
  if (std::abs(det) < 1e-9) return false;
  p->x = (a.rho * b.n.y - b.rho * a.n.y) / det;
  p->y = (a.n.x * b.rho - b.n.x * a.rho) / det;
  return true;
}

cv::Vec3f Bilinear(const cv::Mat& bgr, double x, double y) {
  x = std::clamp(x, 0.0, bgr.cols - 1.001);
  y = std::clamp(y, 0.0, bgr.rows - 1.001);
  const int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
  const float fx = static_cast<float>(x - x0), fy = static_cast<float>(y - y0);
  const cv::Vec3b& a = bgr.at<cv::Vec3b>(y0, x0);
  const cv::Vec3b& b = bgr.at<cv::Vec3b>(y0, x0 + 1);
  const cv::Vec3b& c = bgr.at<cv::Vec3b>(y0 + 1, x0);
  const cv::Vec3b& d = bgr.at<cv::Vec3b>(y0 + 1, x0 + 1);
  cv::Vec3f out;
  for (int k = 0; k < 3; ++k)
    out[k] = (1 - fy) * ((1 - fx) * a[k] + fx * b[k]) + fy * ((1 - fx) * c[k] + fx * d[k]);
  return out;
}

// Farther out than in: the outside plateau must be the rail, past a cushion face and top
// that the outline may have cut short.
constexpr double kEdgeInner = 5.0, kEdgeOuter = 7.0;
// How far from the sides EdgePoints reads pixels (its bilinear samples take the next pixel).
constexpr int kEdgeReachPx = static_cast<int>(kEdgeOuter) + 2;

// A table whose rails' luma is under kDarkRail of the cloth's (the median over its sides)
// has dark rails (black, dark stain), over kLightRail light ones (maple, ash): their sides
// are taken on the luma. Over the benchmark's seed-7 set the sides of its wood rails
// measure 0.51-0.88 (median 0.70), of black rails 0.20-0.49 (median 0.28): a side's own
// ratio swings with its light, the rails' material does not.
constexpr double kDarkRail = 0.45, kLightRail = 1.3;
// The same judged in light (PoolTableOptions::pixel_encoding kSrgb): seed 7's first 20
// frames rendered sRGB, black rails 0.07-0.32, wood 0.41-0.67, maple 2.5-3.0 (as encoded:
// 0.26-0.61, 0.66-0.88, 1.6-1.8; black rails read as wood in 4 of the 20, their corners
// 0.5 px off against 0.06).
constexpr double kDarkRailInLight = 0.36;
// How far inwards from where the luma steps off the rail's the cushion top's level is
// looked for (pixels: the blurred step and a top of a pixel or two), and the least step
// between the cushion top and the rail that is an edge (grey levels).
constexpr double kRailLumaReachPx = 3.0;
constexpr double kRailLumaMinStep = 20;

// Profiles across one side of the table, every 1.5 px along its middle 80%: colours from
// kEdgeInner px inside to kEdgeOuter px outside, every half pixel; and the rail's colour
// (the per-channel median of the outside plateaus).
constexpr double kEdgeStep = 0.5;
constexpr int kEdgeSamples = static_cast<int>((kEdgeInner + kEdgeOuter) / kEdgeStep) + 1;
struct SideProfiles {
  struct Profile {
    cv::Point2d base;
    std::array<cv::Vec3f, kEdgeSamples> colour;
    cv::Vec3f inside, outside;
  };
  cv::Point2d outward;
  std::vector<Profile> profiles;
  cv::Vec3f rail;
};

SideProfiles ProfilesAcross(const cv::Mat& bgr, const cv::Point2d& a, const cv::Point2d& b,
                            const cv::Point2d& outward) {
  SideProfiles side;
  side.outward = outward;
  const double length = cv::norm(b - a);
  const cv::Point2d dir = (b - a) / std::max(1e-9, length);
  for (double s = 0.1 * length; s <= 0.9 * length; s += 1.5) {
    SideProfiles::Profile p;
    p.base = a + dir * s;
    bool inside_image = true;
    for (int i = 0; i < kEdgeSamples && inside_image; ++i) {
      const cv::Point2d q = p.base + outward * (-kEdgeInner + i * kEdgeStep);
      inside_image = q.x >= 0 && q.y >= 0 && q.x <= bgr.cols - 1 && q.y <= bgr.rows - 1;
      if (inside_image) p.colour[i] = Bilinear(bgr, q.x, q.y);
    }
    if (!inside_image) continue;
    p.inside = (p.colour[0] + p.colour[1] + p.colour[2] + p.colour[3]) / 4.f;
    const int n = kEdgeSamples;
    p.outside = (p.colour[n - 1] + p.colour[n - 2] + p.colour[n - 3]) / 3.f;
    side.profiles.push_back(p);
  }
  if (side.profiles.empty()) return side;
  for (int k = 0; k < 3; ++k) {
    std::vector<float> v;
    for (const auto& p : side.profiles) v.push_back(p.outside[k]);
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    side.rail[k] = v[v.size() / 2];
  }
  return side;
}

// Sub-pixel points of the cloth/rail colour edge on a side's profiles: the place where
// the chromaticity is half-way between the cloth's and the rail's, which is where the
// edge is for any symmetric blur. Chromaticity, not colour: a cushion face seen beyond
// the cloth at a grazing angle is cloth in shade, as dark as the rail but of the cloth's
// hue, and the cloth-covered cushion top beyond it may be only a pixel or two wide. On a
// table with dark or light rails they are then taken on the luma: `rail_step` is -1 when
// the luma falls from a cushion top to the rail (dark rails), +1 when it rises (light
// rails), 0 otherwise.
std::vector<cv::Point2d> EdgePoints(const SideProfiles& side, const cv::Vec3f& cloth, int rail_step,
                                    PixelEncoding encoding) {
  constexpr double kInner = kEdgeInner, kOuter = kEdgeOuter, kStep = kEdgeStep;
  constexpr int kSamples = kEdgeSamples;
  // The colour crossing stands for the chromaticity crossing when this close (pixels).
  constexpr double kColourSnapPx = 1.0;
  std::vector<cv::Point2d> points;
  if (side.profiles.empty()) return points;
  const cv::Vec3f& rail = side.rail;
  const cv::Point2d& outward = side.outward;
  const auto chroma = [](const cv::Vec3f& c) {
    const float sum = std::max(1.f, c[0] + c[1] + c[2]);
    return cv::Vec2f(c[0] / sum, c[1] / sum);
  };
  {
    const cv::Vec2f step = chroma(cloth) - chroma(rail);
    if (step.dot(step) < 0.03f * 0.03f) return points;  // rail and cloth of one hue
  }
  // Blur mixes light: the crossings are taken in light for an sRGB picture (the tests on
  // the profiles stay on their values as read).
  const auto light = [encoding](const cv::Vec3f& c) { return ColourInLight(c, encoding); };
  const cv::Vec2f rail_chroma = chroma(light(rail));
  const cv::Vec2f chroma_step = chroma(light(cloth)) - rail_chroma;
  const float chroma_contrast = std::max(1e-6f, chroma_step.dot(chroma_step));
  for (const auto& p : side.profiles) {
    // Balls on the cushion, pockets and diamonds make profiles that are not this edge.
    if (cv::norm(p.outside - rail, cv::NORM_L1) > 60) continue;
    if (ColorAngleDeg(p.inside, cloth) > 12) continue;
    if (cv::norm(p.inside - p.outside, cv::NORM_L2SQR) < 15 * 15) continue;
    std::array<cv::Vec3f, kSamples> colour;  // in light for an sRGB picture
    for (int i = 0; i < kSamples; ++i) colour[i] = light(p.colour[i]);
    const cv::Vec3f outside = light(p.outside);
    const cv::Vec3f diff = light(p.inside) - outside;
    // f = 1 on the cloth's hue, 0 on the rail's.
    std::array<double, kSamples> f;
    for (int i = 0; i < kSamples; ++i)
      f[i] = (chroma(colour[i]) - rail_chroma).dot(chroma_step) / chroma_contrast;
    // The outermost fall from cloth to rail: the cloth-covered cushion top is the last
    // cloth before the rail.
    double best_t = 1e9;
    for (int i = kSamples - 2; i >= 0; --i) {
      if (f[i] >= 0.5 && f[i + 1] < 0.5) {
        best_t = -kInner + kStep * (i + (f[i] - 0.5) / (f[i] - f[i + 1]));
        break;
      }
    }
    if (best_t < -kInner + 1 || best_t > kOuter - 1.5) continue;
    // Blur mixes colours, not chromaticities, so a step in chromaticity between colours of
    // unequal brightness is crossed off its middle. Where the colour's own half-way
    // crossing (between the cloth inside and the rail outside) is next to it, it is the
    // same edge, and the place to take it.
    const float contrast = std::max(1e-6f, diff.dot(diff));
    double colour_t = 1e9;
    for (int i = 0; i + 1 < kSamples; ++i) {
      const double a = (colour[i] - outside).dot(diff) / contrast;
      const double b = (colour[i + 1] - outside).dot(diff) / contrast;
      if (a < 0.5 || b >= 0.5) continue;
      const double t = -kInner + kStep * (i + (a - 0.5) / (a - b));
      if (std::abs(t - best_t) < std::abs(colour_t - best_t)) colour_t = t;
    }
    if (std::abs(colour_t - best_t) < kColourSnapPx) best_t = colour_t;
    if (rail_step != 0) {
      // JPEG keeps the colour at half resolution: next to the lit cushion top, a dark
      // rail's pixels take on the cloth's chromaticity (and their colour, whose step is
      // mostly the brightness, is pulled the same way by what the chroma adds), so both
      // crossings lie out on the rail, by up to 3 px on a rail in shade; a light rail's
      // colour spreads onto the cushion top the same way. The luma is kept at full
      // resolution: the edge is where it is half-way between the cushion top's level and
      // the rail's. The top's level is found from the rail inwards: the luma farthest from
      // the rail's (y below, signed so that the top is above the rail) before it turns
      // back (the cushion face inside a far side's top is dark) or kRailLumaReachPx past
      // the start of the step.
      std::array<double, kSamples> y;
      for (int i = 0; i < kSamples; ++i) y[i] = -rail_step * PoolLuma(p.colour[i]);
      const double rail_y = -rail_step * PoolLuma(p.outside);
      constexpr double kFallBack = 4;  // grey levels: the luma turns back (into the face)
      const int reach = static_cast<int>(kRailLumaReachPx / kStep);
      double top_y = rail_y;
      int top = -1;   // the sample at the top's level
      int rise = -1;  // the first sample inwards clearly off the rail
      for (int i = kSamples - 1; i >= 0; --i) {
        if (rise < 0 && y[i] >= rail_y + 0.5 * kRailLumaMinStep) rise = i;
        if (rise >= 0 && (y[i] < top_y - kFallBack || rise - i > reach)) break;
        if (y[i] > top_y) top = i;
        top_y = std::max(top_y, y[i]);
      }
      if (top_y - rail_y >= kRailLumaMinStep && top >= 0) {
        // The half-way level in light, between the top's and the rail's.
        std::array<double, kSamples> yl;
        for (int i = 0; i < kSamples; ++i) yl[i] = -rail_step * PoolLuma(colour[i]);
        const double half = 0.5 * (yl[top] - rail_step * PoolLuma(outside));
        for (int i = kSamples - 1; i > 0; --i)
          if (yl[i - 1] >= half && yl[i] < half) {
            const double t = -kInner + kStep * (i - 1 + (yl[i - 1] - half) / (yl[i - 1] - yl[i]));
            if (t >= -kInner + 1 && t <= kOuter - 1.5) best_t = t;
            break;
          }
      }
    }
    points.push_back(p.base + outward * best_t);
  }
  return points;
}

// Weighted least-squares line (direction, point) through points: the principal axis of
// their weighted scatter.
cv::Vec4f WeightedLine(const std::vector<cv::Point2f>& pts, const std::vector<double>& w) {
  double sw = 0, sx = 0, sy = 0;
  for (size_t i = 0; i < pts.size(); ++i) {
    sw += w[i];
    sx += w[i] * pts[i].x;
    sy += w[i] * pts[i].y;
  }
  const double mx = sx / sw, my = sy / sw;
  double xx = 0, xy = 0, yy = 0;
  for (size_t i = 0; i < pts.size(); ++i) {
    const double dx = pts[i].x - mx, dy = pts[i].y - my;
    xx += w[i] * dx * dx;
    xy += w[i] * dx * dy;
    yy += w[i] * dy * dy;
  }
  const double angle = 0.5 * std::atan2(2 * xy, xx - yy);
  return cv::Vec4f(static_cast<float>(std::cos(angle)), static_cast<float>(std::sin(angle)),
                   static_cast<float>(mx), static_cast<float>(my));
}

// A line fitted with Huber's weights (c = 1.345 px, as cv::fitLine's DIST_HUBER) by
// iteratively reweighted least squares from the plain least-squares line. cv::fitLine
// does the same from 20 random starts of up to 30 iterations each, which made it a
// twentieth of the table's time; the line only chooses the inliers refitted below.
cv::Vec4f HuberLine(const std::vector<cv::Point2f>& pts) {
  constexpr double kHuber = 1.345;
  std::vector<double> w(pts.size(), 1.0);
  cv::Vec4f l = WeightedLine(pts, w);
  for (int iteration = 0; iteration < 30; ++iteration) {
    const double nx = -l[1], ny = l[0], rho = nx * l[2] + ny * l[3];
    for (size_t i = 0; i < pts.size(); ++i) {
      const double r = std::abs(nx * pts[i].x + ny * pts[i].y - rho);
      w[i] = r < kHuber ? 1.0 : kHuber / r;
    }
    const cv::Vec4f next = WeightedLine(pts, w);
    const double turn = std::abs(next[0] * l[1] - next[1] * l[0]);
    const double shift = std::abs(-next[1] * (next[2] - l[2]) + next[0] * (next[3] - l[3]));
    l = next;
    if (turn < 1e-6 && shift < 1e-4) break;
  }
  return l;
}

// Least-squares line through points with outlier pruning (Huber first, then L2 on the
// points within 1 px).
bool FitLine(const std::vector<cv::Point2d>& points, Line* line) {
  if (points.size() < 8) return false;
  std::vector<cv::Point2f> pts(points.begin(), points.end());
  cv::Vec4f l = HuberLine(pts);
  for (int round = 0; round < 2; ++round) {
    const cv::Point2d n(-l[1], l[0]);
    const double rho = n.dot(cv::Point2d(l[2], l[3]));
    std::vector<cv::Point2f> inliers;
    for (const auto& p : pts)
      if (std::abs(n.dot(cv::Point2d(p)) - rho) < (round == 0 ? 1.5 : 0.8)) inliers.push_back(p);
    if (inliers.size() < 8) break;
    cv::fitLine(inliers, l, cv::DIST_L2, 0, 0.01, 0.01);
  }
  line->n = cv::Point2d(-l[1], l[0]);
  line->rho = line->n.dot(cv::Point2d(l[2], l[3]));
  return true;
}

// Inconsistency of a plane->image homography with a rectangle seen by camera K: the
// first two columns of K^-1 H must be orthogonal and of equal length (appendix A).
double RectangleInconsistency(const cv::Matx33d& H, const cv::Matx33d& K) {
  const cv::Matx33d M = K.inv() * H;
  const cv::Vec3d c1(M(0, 0), M(1, 0), M(2, 0)), c2(M(0, 1), M(1, 1), M(2, 1));
  const double n1 = cv::norm(c1), n2 = cv::norm(c2);
  if (n1 < 1e-12 || n2 < 1e-12) return 1e9;
  return std::abs(n1 / n2 - 1) + std::abs(c1.dot(c2) / (n1 * n2));
}

PlanarPose ShiftPlaneToTable(const PlanarPose& plane_pose, double plane_z) {
  // x_cam = R (X - (0,0,z)) + t'  =>  t = t' - R (0,0,z).
  PlanarPose pose = plane_pose;
  pose.t = plane_pose.t - plane_pose.R * cv::Vec3d(0, 0, plane_z);
  return pose;
}

// An edge point farther than this from every side of the table (in the table plane) is
// not on the outline.
constexpr double kMaxSideGapMm = 40;

// Distinct Hough lines of the cloth outline tried as the table's sides (four sides, the
// pockets' cuts and a cushion's shadow).
constexpr size_t kMaxOutlineLines = 9;

}  // namespace

absl::Status PoolTableOptions::Validate() const {
  if (!(cloth_angle_deg > 0 && cloth_angle_deg < 45))
    return absl::InvalidArgumentError("cloth_angle_deg must be in (0, 45)");
  if (!(search_angle_deg >= cloth_angle_deg && search_angle_deg < 60))
    return absl::InvalidArgumentError("search_angle_deg must be in [cloth_angle_deg, 60)");
  if (!(min_cloth_brightness >= 0 && min_cloth_brightness < 1))
    return absl::InvalidArgumentError("min_cloth_brightness must be in [0, 1)");
  if (!(min_cloth_fraction > 0 && min_cloth_fraction < 1))
    return absl::InvalidArgumentError("min_cloth_fraction must be in (0, 1)");
  if (!(max_rectangle_inconsistency > 0))
    return absl::InvalidArgumentError("max_rectangle_inconsistency must be positive");
  if (!(cloth_close_fraction >= 0 && cloth_close_fraction <= 0.05))
    return absl::InvalidArgumentError(
        "cloth_close_fraction must be in [0, 0.05] (a share of the image's width)");
  if (other_cloth_colours < 0 || other_cloth_colours > 8)
    return absl::InvalidArgumentError("other_cloth_colours must be in [0, 8]");
  return absl::OkStatus();
}

const std::array<float, 256>& SrgbLightTable() {
  static const std::array<float, 256> table = [] {
    std::array<float, 256> t;
    for (int k = 0; k < 256; ++k) {
      const double x = k / 255.0;
      t[k] =
          static_cast<float>(255 * (x <= 0.04045 ? x / 12.92 : std::pow((x + 0.055) / 1.055, 2.4)));
    }
    return t;
  }();
  return table;
}

float SrgbLight(float level) {
  const std::array<float, 256>& t = SrgbLightTable();
  const int k = std::clamp(static_cast<int>(level), 0, 254);
  const float f = std::clamp(level - k, 0.f, 1.f);
  return t[k] * (1 - f) + t[k + 1] * f;
}

cv::Vec3f ColourInLight(const cv::Vec3f& colour, PixelEncoding encoding) {
  if (encoding == PixelEncoding::kLinear) return colour;
  return {SrgbLight(colour[0]), SrgbLight(colour[1]), SrgbLight(colour[2])};
}

double ColorAngleDeg(const cv::Vec3f& a, const cv::Vec3f& b) {
  const double na = cv::norm(a), nb = cv::norm(b);
  if (na < 1e-6 || nb < 1e-6) return 90;
  return std::acos(std::clamp(a.dot(b) / (na * nb), -1.0, 1.0)) * 180 / kPi;
}

double PoolLuma(const cv::Vec3f& bgr) { return 0.114 * bgr[0] + 0.587 * bgr[1] + 0.299 * bgr[2]; }

cv::Point2d ProjectIdeal(const PlanarPose& pose, const cv::Matx33d& K, const cv::Vec3d& point) {
  const cv::Vec3d q = K * (pose.R * point + pose.t);
  return {q[0] / q[2], q[1] / q[2]};
}

cv::Vec3d CameraCentre(const PlanarPose& pose) { return -(pose.R.t() * pose.t); }

bool BackProjectToPlane(const PlanarPose& pose, const cv::Matx33d& K, const cv::Point2d& pixel,
                        double z, cv::Point2d* table_xy) {
  const cv::Vec3d d_cam = K.inv() * cv::Vec3d(pixel.x, pixel.y, 1);
  const cv::Vec3d d = pose.R.t() * d_cam;
  const cv::Vec3d c = CameraCentre(pose);
  if (std::abs(d[2]) < 1e-12) return false;
  const double s = (z - c[2]) / d[2];
  if (s <= 0) return false;
  table_xy->x = c[0] + s * d[0];
  table_xy->y = c[1] + s * d[1];
  return true;
}

PlanarPose RotateTableFrame(const PlanarPose& pose, double length_mm, double width_mm) {
  const cv::Matx33d rz(-1, 0, 0, 0, -1, 0, 0, 0, 1);
  PlanarPose out;
  out.R = pose.R * rz;
  out.t = pose.t + pose.R * cv::Vec3d(length_mm, width_mm, 0);
  return out;
}

PoolUndistorter::PoolUndistorter(const CameraModel& camera) : camera_(camera) {
  if (camera_.has_distortion() && camera_.size.area() > 0) {
    cv::initUndistortRectifyMap(cv::Mat(camera_.K), cv::Mat(camera_.distortion), cv::Mat(),
                                cv::Mat(camera_.K), camera_.size, CV_16SC2, map1_, map2_);
    const cv::Matx33d half_K(camera_.K(0, 0) / 2, camera_.K(0, 1) / 2, camera_.K(0, 2) / 2, 0,
                             camera_.K(1, 1) / 2, camera_.K(1, 2) / 2, 0, 0, 1);
    const cv::Size half_size((camera_.size.width + 1) / 2, (camera_.size.height + 1) / 2);
    cv::initUndistortRectifyMap(cv::Mat(half_K), cv::Mat(camera_.distortion), cv::Mat(),
                                cv::Mat(half_K), half_size, CV_16SC2, half_map1_, half_map2_);
  }
}

cv::Mat PoolUndistorter::Undistort(const cv::Mat& bgr) const {
  if (map1_.empty() || bgr.size() != camera_.size) return bgr;
  cv::Mat out;
  cv::remap(bgr, out, map1_, map2_, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  return out;
}

void PoolUndistorter::UndistortRect(const cv::Mat& bgr, const cv::Rect& rect,
                                    cv::Mat* ideal) const {
  const cv::Rect r = rect & cv::Rect(0, 0, bgr.cols, bgr.rows);
  if (r.area() <= 0) return;
  cv::Mat out = (*ideal)(r);  // a view of *ideal: remap writes in place
  if (map1_.empty() || bgr.size() != camera_.size) {
    bgr(r).copyTo(out);
    return;
  }
  // Each output pixel depends only on its own map entry, so a part of the maps gives
  // exactly the pixels of the whole remap.
  cv::remap(bgr, out, map1_(r), map2_(r), cv::INTER_LINEAR, cv::BORDER_REPLICATE);
}

cv::Mat PoolUndistorter::UndistortHalf(const cv::Mat& half_bgr) const {
  if (half_map1_.empty() || half_bgr.size() != half_map1_.size()) return half_bgr;
  cv::Mat out;
  cv::remap(half_bgr, out, half_map1_, half_map2_, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  return out;
}

IdealView::IdealView(const PoolUndistorter& undistorter, const cv::Mat& distorted_bgr,
                     cv::Mat* storage)
    : distorted_(distorted_bgr) {
  cv::Mat half_distorted;
  cv::pyrDown(distorted_bgr, half_distorted);
  if (!undistorter.camera().has_distortion() || distorted_bgr.size() != undistorter.camera().size) {
    full_ = distorted_bgr;
    half_ = half_distorted;
    valid_ = image_rect();
    return;
  }
  undistorter_ = &undistorter;
  half_ = undistorter.UndistortHalf(half_distorted);
  cv::Mat own;
  cv::Mat& buffer = storage ? *storage : own;
  buffer.create(distorted_bgr.size(), distorted_bgr.type());  // kept when it fits already
  full_ = buffer;
}

IdealView::IdealView(const cv::Mat& ideal_bgr) : distorted_(ideal_bgr), full_(ideal_bgr) {
  cv::pyrDown(ideal_bgr, half_);
  valid_ = image_rect();
}

void IdealView::Require(const cv::Rect& rect) {
  const cv::Rect want = rect & image_rect();
  if (want.area() <= 0 || (want & valid_) == want) return;
  if (valid_.area() <= 0) {
    undistorter_->UndistortRect(distorted_, want, &full_);
    valid_ = want;
    return;
  }
  // The bounding box minus the valid rectangle: up to four strips.
  const cv::Rect box = want | valid_;
  const cv::Rect v = valid_;
  const cv::Rect strips[4] = {
      {box.x, box.y, box.width, v.y - box.y},                                   // above
      {box.x, v.y + v.height, box.width, box.y + box.height - v.y - v.height},  // below
      {box.x, v.y, v.x - box.x, v.height},                                      // left
      {v.x + v.width, v.y, box.x + box.width - v.x - v.width, v.height},        // right
  };
  for (const cv::Rect& strip : strips)
    if (strip.width > 0 && strip.height > 0) undistorter_->UndistortRect(distorted_, strip, &full_);
  valid_ = box;
}

cv::Point2d PoolUndistorter::Distort(const cv::Point2d& ideal) const {
  if (!camera_.has_distortion()) return ideal;
  const cv::Matx33d& K = camera_.K;
  std::vector<cv::Point3d> object{
      {(ideal.x - K(0, 2)) / K(0, 0), (ideal.y - K(1, 2)) / K(1, 1), 1.0}};
  std::vector<cv::Point2d> out;
  cv::projectPoints(object, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), cv::Mat(K),
                    cv::Mat(camera_.distortion), out);
  return out[0];
}

namespace {

// The table's cloth colour as the image shows it, when it is not the profile's (a blue or
// a red cloth, the profile holding the default green): the peaks of a hue histogram of the
// saturated, lit pixels of the half-resolution image, most common first, each as the mean
// colour of its pixels. Only peaks that cover min_fraction of the image (a table does).
std::vector<cv::Vec3f> DominantColours(const cv::Mat& small, double min_fraction, int max_colours) {
  constexpr int kBins = 36;           // 5 of OpenCV's hue units (10 degrees) each
  constexpr int kMinValue = 40;       // of 255: shadows' hue is noise
  cv::Mat hsv;
  cv::cvtColor(small, hsv, cv::COLOR_BGR2HSV);
  std::array<double, kBins> count{};
  std::array<cv::Vec3d, kBins> sum{};
  for (int y = 0; y < hsv.rows; ++y) {
    const cv::Vec3b* h = hsv.ptr<cv::Vec3b>(y);
    const cv::Vec3b* p = small.ptr<cv::Vec3b>(y);
    for (int x = 0; x < hsv.cols; ++x) {
      if (h[x][1] < kMinClothSaturation || h[x][2] < kMinValue) continue;
      const int bin = std::min(kBins - 1, h[x][0] * kBins / 180);
      count[bin] += 1;
      sum[bin] += cv::Vec3d(p[x][0], p[x][1], p[x][2]);
    }
  }
  // Peaks of the circularly smoothed histogram; a peak's colour is the mean over its bin
  // and the two beside it.
  std::vector<std::pair<double, int>> peaks;
  auto smoothed = [&](int i) {
    return count[(i + kBins - 1) % kBins] + 2 * count[i] + count[(i + 1) % kBins];
  };
  for (int i = 0; i < kBins; ++i) {
    const double c = smoothed(i);
    if (c >= smoothed((i + 1) % kBins) && c > smoothed((i + kBins - 1) % kBins))
      peaks.emplace_back(c, i);
  }
  std::sort(peaks.rbegin(), peaks.rend());
  std::vector<cv::Vec3f> colours;
  for (const auto& [c, i] : peaks) {
    const double n = count[(i + kBins - 1) % kBins] + count[i] + count[(i + 1) % kBins];
    if (n < min_fraction * static_cast<double>(small.total()) ||
        static_cast<int>(colours.size()) >= max_colours)
      break;
    const cv::Vec3d s = sum[(i + kBins - 1) % kBins] + sum[i] + sum[(i + 1) % kBins];
    colours.emplace_back(static_cast<float>(s[0] / n), static_cast<float>(s[1] / n),
                         static_cast<float>(s[2] / n));
  }
  return colours;
}

// Largest rectangle inconsistency of a table found in the colours nearest to the cloth's
// (see DetectPoolTable).
constexpr double kNearestMaxInconsistency = 0.05;

// The table found from a cloth colour `seed` (the wide search's centre): steps 1-8 below.
// The wide search leaves out colours nearer to one of `rivals` than to the seed.
absl::StatusOr<PoolTableDetection> DetectPoolTableFrom(IdealView* view, const cv::Matx33d& K,
                                                       const PoolTableProfile& profile,
                                                       const PoolTableOptions& options,
                                                       const cv::Vec3f& seed,
                                                       const std::vector<cv::Vec3f>& rivals = {}) {
  PoolTableDetection det;
  const cv::Mat& small = view->half();
  const cv::Mat& bgr = view->full();  // valid only where view->Require made it so
  // 1. Wide search for the cloth, then its colour measured on this image.
  int area = 0;
  cv::Mat region =
      LargestRegion(AngleMask(small, seed, options.search_angle_deg, 45, rivals), &area);
  const int min_area = static_cast<int>(options.min_cloth_fraction * small.total());
  if (area < min_area) {
    return absl::FailedPreconditionError(absl::StrCat(
        "no pool table in view: no region of the cloth colour (BGR ", std::lround(seed[0]), ",",
        std::lround(seed[1]), ",", std::lround(seed[2]), ") covers ",
        100 * options.min_cloth_fraction,
        "% of the image; point the camera at the table or calibrate the cloth colour"));
  }
  cv::Vec3f cloth = MeanColor(small, region, seed, options.search_angle_deg);
  cloth = MeanColor(small, region, cloth, options.cloth_angle_deg);
  const double brightness = (cloth[0] + cloth[1] + cloth[2]) / 3;
  det.cloth_bgr =
      cv::Vec3b(cv::saturate_cast<uint8_t>(cloth[0]), cv::saturate_cast<uint8_t>(cloth[1]),
                cv::saturate_cast<uint8_t>(cloth[2]));
  det.cloth_brightness = brightness;
  // 2. Seed eq. 4.1 at the cloth angle; the largest region is the table.
  cv::Mat mask = AngleMask(small, cloth, options.cloth_angle_deg,
                           3 * options.min_cloth_brightness * brightness);
  // Gaps up to options.cloth_close_fraction of the width closed (a cue stick's).
  const int close_size = 1 + 2 * std::max(1, static_cast<int>(std::lround(
                                                 0.5 * options.cloth_close_fraction * small.cols)));
  cv::morphologyEx(mask, mask, cv::MORPH_CLOSE,
                   cv::getStructuringElement(cv::MORPH_RECT, cv::Size(close_size, close_size)));
  det.cloth_mask = LargestRegion(mask, &area);
  if (area < min_area)
    return absl::FailedPreconditionError("no pool table in view: the cloth region is too small");

  // 3. Outline.
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(det.cloth_mask, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
  if (contours.empty()) return absl::FailedPreconditionError("no pool table in view");
  const auto& contour =
      *std::max_element(contours.begin(), contours.end(),
                        [](const auto& a, const auto& b) { return a.size() < b.size(); });
  int on_border = 0;
  for (const auto& p : contour)
    if (p.x <= 0 || p.y <= 0 || p.x >= small.cols - 1 || p.y >= small.rows - 1) ++on_border;
  const std::string partial_message =
      "only part of the table is in view: the cloth runs into the image border; step back "
      "or turn the camera so that all four cushions and corners are visible";
  if (on_border > static_cast<int>(contour.size() / 50) + 3) {
    // Or the whole table is in view and the region is not the table's alone: the cloth's
    // colour is the floor's or the walls' too (a brown cloth on a wooden floor).
    return absl::FailedPreconditionError(absl::StrCat(
        partial_message, ". If all of it is in view, the floor or the walls around it have the ",
        "cloth's colour (BGR ", static_cast<int>(det.cloth_bgr[0]), ",",
        static_cast<int>(det.cloth_bgr[1]), ",", static_cast<int>(det.cloth_bgr[2]),
        ") and the cloth cannot be told from them"));
  }

  // 4. Hough lines on the outline, clustered into distinct lines.
  const int threshold = std::max(10, static_cast<int>(contour.size() / 40));
  const std::vector<cv::Vec3f> hough =
      HoughLinesOnPoints(contour, small.size(), 1, kPi / 360, threshold);
  // A line is distinct when most of the outline points it passes near are not near a
  // stronger line already kept: the two halves of a side broken by a side pocket, or a
  // side's slight curve left by the lens, give many Hough lines within a few degrees and
  // pixels of one another, which must not crowd out a short side seen end-on.
  std::vector<Line> lines;
  std::vector<std::vector<int>> near;  // per kept line, its outline points (within 1.5 px)
  std::vector<uint8_t> explained(contour.size(), 0);
  for (const auto& h : hough) {
    Line l{{std::cos(h[1]), std::sin(h[1])}, h[0]};
    bool distinct = true;
    for (const auto& k : lines) {
      const double dot = l.n.dot(k.n);
      const double same_rho = dot > 0 ? std::abs(l.rho - k.rho) : std::abs(l.rho + k.rho);
      if (std::abs(dot) > std::cos(6 * kPi / 180) && same_rho < 6) distinct = false;
    }
    if (!distinct) continue;
    std::vector<int> points;
    int new_points = 0;
    for (size_t k = 0; k < contour.size(); ++k) {
      if (std::abs(l.Distance(cv::Point2d(contour[k]))) >= 1.5) continue;
      points.push_back(static_cast<int>(k));
      new_points += !explained[k];
    }
    if (2 * new_points < static_cast<int>(points.size())) continue;
    for (int k : points) explained[k] = 1;
    lines.push_back(l);
    near.push_back(std::move(points));
    if (lines.size() >= kMaxOutlineLines) break;
  }
  if (lines.size() < 4)
    return absl::FailedPreconditionError(
        "the cloth outline does not have four straight sides (is the whole table in view?)");
  // 5. The four lines that explain most of the outline and make a convex quadrilateral.
  const cv::Point2d centroid = [&] {
    cv::Point2d c(0, 0);
    for (const auto& p : contour) c += cv::Point2d(p);
    return c / static_cast<double>(contour.size());
  }();
  std::vector<double> line_angle(lines.size(), 0);  // of its outline points around the centroid
  for (size_t i = 0; i < lines.size(); ++i) {
    double sx = 0, sy = 0;
    for (int k : near[i]) {
      const double a = std::atan2(contour[k].y - centroid.y, contour[k].x - centroid.x);
      sx += std::cos(a);
      sy += std::sin(a);
    }
    line_angle[i] = std::atan2(sy, sx);
  }
  int best_score = -1;
  std::array<Line, 4> sides;
  std::array<cv::Point2d, 4> corners;
  const int m = static_cast<int>(lines.size());
  std::vector<uint8_t> covered(contour.size());
  for (int a = 0; a < m; ++a)
    for (int b = a + 1; b < m; ++b)
      for (int c = b + 1; c < m; ++c)
        for (int d = c + 1; d < m; ++d) {
          std::array<int, 4> idx = {a, b, c, d};
          // Order the lines by the angle of their outline points around the centroid.
          std::array<std::pair<double, int>, 4> order;
          bool empty = false;
          for (int i = 0; i < 4; ++i) {
            if (near[idx[i]].empty()) empty = true;
            order[i] = {line_angle[idx[i]], idx[i]};
          }
          if (empty) continue;
          std::sort(order.begin(), order.end());
          std::array<Line, 4> quad_sides;
          std::array<cv::Point2d, 4> quad;
          bool ok = true;
          for (int i = 0; i < 4; ++i) quad_sides[i] = lines[order[i].second];
          for (int i = 0; i < 4 && ok; ++i)
            ok = Intersect(quad_sides[i], quad_sides[(i + 1) % 4], &quad[i]);
          if (!ok) continue;
          // Convex, not degenerate, corners not far outside the image.
          double sign = 0;
          for (int i = 0; i < 4 && ok; ++i) {
            const cv::Point2d e1 = quad[(i + 1) % 4] - quad[i],
                              e2 = quad[(i + 2) % 4] - quad[(i + 1) % 4];
            const double cross = e1.x * e2.y - e1.y * e2.x;
            if (cv::norm(e1) < 10) ok = false;
            if (sign == 0) sign = cross;
            if (cross * sign <= 0) ok = false;
            if (std::abs(quad[i].x) > 4 * small.cols || std::abs(quad[i].y) > 4 * small.rows)
              ok = false;
          }
          if (!ok) continue;
          std::fill(covered.begin(), covered.end(), 0);
          for (int i : idx)
            for (int k : near[i]) covered[k] = 1;
          const int score = std::accumulate(covered.begin(), covered.end(), 0);
          if (score > best_score) {
            best_score = score;
            sides = quad_sides;
            corners = quad;
          }
        }
  if (best_score < static_cast<int>(contour.size() / 2))
    return absl::FailedPreconditionError(
        "the cloth outline is not a four-sided table (is the whole table in view?)");
  // Back to full resolution: pyrDown keeps every second pixel, so p_full = 2 p_small.
  for (auto& side : sides) side.rho *= 2;
  for (auto& corner : corners) corner *= 2;
  const cv::Point2d centroid_full = centroid * 2;
  // 6. Sub-pixel sides on the colour edge; corners between consecutive sides. Side i runs
  // from corner i-1 to corner i. Twice: the second pass starts from the refined lines.
  // The edge points of the last pass that lie on their side's line, for the pose.
  std::vector<cv::Point2f> side_points;
  for (int pass = 0; pass < 2; ++pass) {
    // EdgePoints' profiles reach kEdgeReachPx beyond the sides between the corners.
    std::vector<cv::Point2f> corner_points(corners.begin(), corners.end());
    const cv::Rect around = cv::boundingRect(corner_points);
    view->Require({around.x - kEdgeReachPx, around.y - kEdgeReachPx,
                   around.width + 2 * kEdgeReachPx, around.height + 2 * kEdgeReachPx});
    std::array<SideProfiles, 4> across;
    // The rails' luma over the cloth's, in light for an sRGB picture.
    const PixelEncoding encoding = options.pixel_encoding;
    const bool in_light = encoding == PixelEncoding::kSrgb;
    std::vector<double> rail_ratios;
    for (int i = 0; i < 4; ++i) {
      const cv::Point2d a = corners[(i + 3) % 4], b = corners[i];
      const cv::Point2d mid = (a + b) / 2;
      cv::Point2d outward(-(b - a).y, (b - a).x);
      outward /= cv::norm(outward);
      if (outward.dot(mid - centroid_full) < 0) outward = -outward;
      across[i] = ProfilesAcross(bgr, a, b, outward);
      if (!across[i].profiles.empty())
        rail_ratios.push_back(
            PoolLuma(ColourInLight(across[i].rail, encoding)) /
            std::max(in_light ? 0.1 : 1.0, PoolLuma(ColourInLight(cloth, encoding))));
    }
    // The median side's (with no side read, no side has points to place either).
    std::sort(rail_ratios.begin(), rail_ratios.end());
    const size_t m = rail_ratios.size();
    const double rail_ratio = m > 0 ? 0.5 * (rail_ratios[(m - 1) / 2] + rail_ratios[m / 2]) : 1;
    const int rail_step = rail_ratio < (in_light ? kDarkRailInLight : kDarkRail) ? -1
                          : rail_ratio > kLightRail                              ? 1
                                                                                 : 0;
    for (int i = 0; i < 4; ++i) {
      Line refined;
      const std::vector<cv::Point2d> points = EdgePoints(across[i], cloth, rail_step, encoding);
      if (FitLine(points, &refined)) {
        sides[i] = refined;
        if (pass == 1)
          for (const auto& p : points)
            if (std::abs(refined.n.dot(p) - refined.rho) < 1.0) side_points.emplace_back(p);
      }
    }
    for (int i = 0; i < 4; ++i) {
      if (!Intersect(sides[i], sides[(i + 1) % 4], &corners[i]))
        return absl::FailedPreconditionError("table sides are parallel in the image");
    }
  }
  for (const auto& c : corners) {
    if (c.x < -0.5 || c.y < -0.5 || c.x > bgr.cols - 0.5 || c.y > bgr.rows - 0.5)
      return absl::FailedPreconditionError(partial_message);
  }

  // 7. Which image corner is which table corner: of the 8 cyclic assignments, those that
  // put the camera above the cloth and are consistent with a rectangle of the profile's
  // proportions seen through K (the long/short side test of seed 4.3.4, made exact by the
  // intrinsics). The two survivors differ by the table's 180 degree symmetry.
  const double L = profile.length_mm, W = profile.width_mm, cw = profile.cushion_width_mm;
  const std::array<cv::Point2f, 4> plane = {cv::Point2f(-cw, -cw), cv::Point2f(L + cw, -cw),
                                            cv::Point2f(L + cw, W + cw), cv::Point2f(-cw, W + cw)};
  double best_inconsistency = 1e18;
  std::array<cv::Point2d, 4> best_order;
  for (int dir = -1; dir <= 1; dir += 2)
    for (int k = 0; k < 4; ++k) {
      std::array<cv::Point2f, 4> img;
      std::array<cv::Point2d, 4> ordered;
      for (int i = 0; i < 4; ++i) {
        ordered[i] = corners[((k + dir * i) % 4 + 4) % 4];
        img[i] = cv::Point2f(ordered[i]);
      }
      const cv::Matx33d H = cv::getPerspectiveTransform(plane.data(), img.data());
      auto pose = PoseFromHomography(H, K);
      if (!pose.ok() || CameraCentre(*pose)[2] <= 0) continue;
      const double inconsistency = RectangleInconsistency(H, K);
      if (inconsistency < best_inconsistency - 1e-9) {
        best_inconsistency = inconsistency;
        best_order = ordered;
      }
    }
  if (best_inconsistency > options.max_rectangle_inconsistency) {
    return absl::FailedPreconditionError(
        absl::StrCat("the table outline does not fit a ", L, " x ", W,
                     " mm table seen by this camera (inconsistency ", best_inconsistency,
                     "); check the table profile and the camera intrinsics"));
  }
  det.rectangle_inconsistency = best_inconsistency;
  det.corner_focal_px =
      FocalLengthFromRectangle(best_order, {K(0, 2), K(1, 2)}, L + 2 * cw, W + 2 * cw).value_or(0);
  std::vector<cv::Point2f> plane_points(plane.begin(), plane.end()), pixels;
  for (const auto& p : best_order) pixels.emplace_back(p);
  CameraModel ideal;
  ideal.K = K;
  ASSIGN_OR_RETURN(PlanarPose plane_pose, EstimatePlanarPose(plane_points, pixels, ideal));
  // The four corners come from four lines fitted one by one; a side seen end-on, or cut
  // short by balls and pockets, can tilt its line and move two corners. All the edge
  // points together with the known rectangle pin the pose better: each point is slid
  // onto the nearest side of the rectangle in the table plane and the pose re-estimated
  // from those pairs (point-to-line alignment, three rounds).
  for (int round = 0; round < 3 && side_points.size() >= 16; ++round) {
    const cv::Matx33d to_plane = HomographyFromPose(plane_pose, K).inv();
    std::vector<cv::Point2f> on_side, seen;
    for (const auto& p : side_points) {
      const cv::Point2d q = ApplyHomography(to_plane, p);
      const double x = std::clamp(q.x, -cw, L + cw), y = std::clamp(q.y, -cw, W + cw);
      const double to_side[4] = {std::abs(q.y + cw), std::abs(q.x - L - cw), std::abs(q.y - W - cw),
                                 std::abs(q.x + cw)};
      const int k = static_cast<int>(std::min_element(to_side, to_side + 4) - to_side);
      if (to_side[k] > kMaxSideGapMm) continue;
      const cv::Point2d snapped = k == 0   ? cv::Point2d(x, -cw)
                                  : k == 1 ? cv::Point2d(L + cw, y)
                                  : k == 2 ? cv::Point2d(x, W + cw)
                                           : cv::Point2d(-cw, y);
      on_side.emplace_back(snapped);
      seen.push_back(p);
    }
    if (on_side.size() < 16) break;
    auto refined = RefinePlanarPose(on_side, seen, ideal, plane_pose);
    if (!refined.ok()) break;
    plane_pose = *refined;
  }
  for (int i = 0; i < 4; ++i)
    best_order[i] = ProjectIdeal(plane_pose, K, {plane[i].x, plane[i].y, 0});
  PlanarPose pose = ShiftPlaneToTable(plane_pose, profile.cushion_height_mm);
  PlanarPose rotated = RotateTableFrame(pose, L, W);
  // Convention for a single image: the origin is the corner nearer the camera's side
  // (camera at Y < W/2 when it stands at a long side, X < L/2 at a short side).
  const cv::Vec3d c = CameraCentre(pose);
  det.long_side_view = std::abs(c[1] - W / 2) / W >= std::abs(c[0] - L / 2) / L;
  const bool keep = det.long_side_view ? c[1] < W / 2 : c[0] < L / 2;
  if (!keep) {
    std::swap(pose, rotated);
    std::rotate(best_order.begin(), best_order.begin() + 2, best_order.end());
  }
  det.pose = pose;
  det.rotated_pose = rotated;
  det.cushion_corners = best_order;
  return det;
}

}  // namespace

absl::StatusOr<PoolTableDetection> DetectPoolTable(const cv::Mat& bgr, const cv::Matx33d& K,
                                                   const PoolTableProfile& profile,
                                                   const PoolTableOptions& options) {
  RETURN_IF_ERROR(options.Validate());
  RETURN_IF_ERROR(profile.Validate());
  if (bgr.empty() || bgr.type() != CV_8UC3)
    return absl::InvalidArgumentError("table detection needs an 8-bit BGR image");
  IdealView view(bgr);
  return DetectPoolTable(&view, K, profile, options);
}

absl::StatusOr<PoolTableDetection> DetectPoolTable(IdealView* view, const cv::Matx33d& K,
                                                   const PoolTableProfile& profile,
                                                   const PoolTableOptions& options) {
  RETURN_IF_ERROR(options.Validate());
  RETURN_IF_ERROR(profile.Validate());
  if (view->full().empty() || view->full().type() != CV_8UC3)
    return absl::InvalidArgumentError("table detection needs an 8-bit BGR image");
  // The cloth, its outline and the Hough lines are found at half resolution (four times
  // fewer pixels); the sides are then refined on the full image.
  const cv::Mat& small = view->half();
  const cv::Vec3f profile_cloth(profile.cloth_bgr[0], profile.cloth_bgr[1], profile.cloth_bgr[2]);
  // PoolTableOptions::nearest_colour_cloth_search: first the colours nearer to the seed
  // than to grey and to the picture's other dominant colours (those over cloth_angle_deg
  // from it); a table so found must fit the profile's rectangle closely (the benchmark's
  // tables measure up to 0.03, a brown cloth taken together with its brown rails 0.09,
  // which the search over the whole cone refuses).
  std::vector<cv::Vec3f> dominant;
  if (options.nearest_colour_cloth_search || options.other_cloth_colours > 0)
    dominant = DominantColours(small, options.min_cloth_fraction,
                               std::max(3, options.other_cloth_colours));
  const auto find_from = [&](const cv::Vec3f& seed) {
    if (options.nearest_colour_cloth_search) {
      std::vector<cv::Vec3f> rivals = {cv::Vec3f(1, 1, 1)};
      for (const cv::Vec3f& colour : dominant)
        if (ColorAngleDeg(colour, seed) > options.cloth_angle_deg) rivals.push_back(colour);
      auto nearest = DetectPoolTableFrom(view, K, profile, options, seed, rivals);
      if (nearest.ok() && nearest->rectangle_inconsistency <= kNearestMaxInconsistency)
        return nearest;
    }
    return DetectPoolTableFrom(view, K, profile, options, seed);
  };
  auto found = find_from(profile_cloth);
  if (found.ok() || options.other_cloth_colours == 0) return found;
  // A cloth of another colour than the profile's (blue, red): the image's own dominant
  // colours, each of which must still give a table of the profile's proportions. When none
  // does, the profile colour's answer says what is wrong.
  for (size_t i = 0; i < dominant.size() && static_cast<int>(i) < options.other_cloth_colours;
       ++i) {
    const cv::Vec3f& colour = dominant[i];
    if (ColorAngleDeg(colour, profile_cloth) < options.search_angle_deg) continue;  // tried
    auto other = find_from(colour);
    if (!other.ok()) continue;
    other->cloth_not_profile_colour = true;
    return other;
  }
  return found;
}

}  // namespace texfree
