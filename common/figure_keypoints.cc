// FigureCornerExtractor implementation.
#include "common/figure_keypoints.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <optional>

#include "absl/strings/str_cat.h"
#include "common/neighbor_grid.h"

namespace texfree {
namespace {

int OddAtLeast(double v, int minimum) { return std::max(minimum, static_cast<int>(std::lround(v))) | 1; }

// Angle between two directions (radians), modulo pi.
double LineAngleApart(double a, double b) {
  double d = std::fmod(std::abs(a - b), CV_PI);
  return std::min(d, CV_PI - d);
}

// The point `length` along the closed polygon from vertex i (backwards when negative).
cv::Point2d AlongPolygon(const std::vector<cv::Point> &polygon, size_t i, double length) {
  const size_t n = polygon.size();
  const int step = length < 0 ? -1 : 1;
  double left = std::abs(length);
  size_t at = i;
  for (size_t k = 0; k < n; ++k) {
    const size_t next = (at + n + step) % n;
    const cv::Point2d from(polygon[at]), to(polygon[next]);
    const double edge = std::hypot(to.x - from.x, to.y - from.y);
    if (edge >= left) return from + (to - from) * (left / edge);
    left -= edge;
    at = next;
  }
  return cv::Point2d(polygon[at]);
}

struct Corner {
  cv::Point2f point;
  double turn;  // radians
};

}  // namespace

absl::Status FigureCornerOptions::Validate() const {
  if (!(threshold_offset > 0 && threshold_offset < 255))
    return absl::InvalidArgumentError("figure corners: threshold_offset must be in (0, 255)");
  if (!(window >= 3))
    return absl::InvalidArgumentError("figure corners: window must be at least 3 text heights");
  if (!(min_extent > 0))
    return absl::InvalidArgumentError("figure corners: min_extent must be positive");
  if (!(min_text_thickness >= 0 && min_text_thickness <= max_text_thickness))
    return absl::InvalidArgumentError(
        "figure corners: need 0 <= min_text_thickness <= max_text_thickness");
  if (!(polygon_tolerance > 0 && polygon_tolerance < 2))
    return absl::InvalidArgumentError("figure corners: polygon_tolerance must be in (0, 2)");
  if (!(min_edge > 0))
    return absl::InvalidArgumentError("figure corners: min_edge must be positive");
  if (!(min_turn_deg > 0 && min_turn_deg < 180))
    return absl::InvalidArgumentError("figure corners: min_turn_deg must be in (0, 180)");
  if (!(merge_radius >= 0) || !(border_margin >= 0) || !(word_clearance >= 0))
    return absl::InvalidArgumentError(
        "figure corners: merge_radius, border_margin and word_clearance cannot be negative");
  if (!(marker_thickness == 0 || marker_thickness > 1))
    return absl::InvalidArgumentError(
        "figure corners: marker_thickness must be 0 (off) or above 1");
  if (!(height_per_stroke > 0))
    return absl::InvalidArgumentError("figure corners: height_per_stroke must be positive");
  if (max_corners < 0)
    return absl::InvalidArgumentError("figure corners: max_corners cannot be negative");
  return absl::OkStatus();
}

FigureCornerExtractor::FigureCornerExtractor(FigureCornerOptions options)
    : options_(std::move(options)) {}

FigureCorners FigureCornerExtractor::Extract(const cv::Mat &gray, double char_height,
                                             double text_angle_rad,
                                             const std::vector<cv::Point2f> &words) const {
  CV_Assert(gray.type() == CV_8UC1);
  const FigureCornerOptions &o = options_;
  FigureCorners result;
  std::vector<cv::Point2f> &out = result.points;
  if (gray.empty() || o.max_corners == 0) return result;
  cv::Mat smooth;
  cv::GaussianBlur(gray, smooth, cv::Size(3, 3), 0.7);
  const bool text = char_height > 0;
  double h = char_height;
  // The window: wide enough that a bar or a dark area is ink throughout (in a narrow one
  // it is ink along its edges only, and the inner edges move with the window): a few
  // dozen text heights, or a quarter of the image without text.
  const int block = text ? OddAtLeast(o.window * h, 7)
                         : OddAtLeast(std::min(gray.cols, gray.rows) / 4.0, 15);
  cv::Mat ink;
  cv::adaptiveThreshold(smooth, ink, 255, cv::ADAPTIVE_THRESH_MEAN_C, cv::THRESH_BINARY_INV,
                        block, o.threshold_offset);
  std::vector<std::vector<cv::Point>> contours;
  std::vector<cv::Vec4i> hierarchy;
  cv::findContours(ink, contours, hierarchy, cv::RETR_CCOMP, cv::CHAIN_APPROX_NONE);

  struct Outline {
    size_t contour;
    cv::RotatedRect rect;
    double long_side, short_side, angle;
  };
  std::vector<Outline> outlines;
  for (size_t i = 0; i < contours.size(); ++i) {
    if (hierarchy[i][3] >= 0 || contours[i].size() < 8) continue;  // a hole, or a speck
    const cv::RotatedRect r = cv::minAreaRect(contours[i]);
    double a = r.size.width, b = r.size.height, angle = r.angle * CV_PI / 180.0;
    if (b > a) {
      std::swap(a, b);
      angle += CV_PI / 2;
    }
    outlines.push_back({i, r, a, b, angle});
  }
  if (!text) {
    // The strokes' width: ink pixels over half the outline length of the components larger
    // than a letter could be in any view (a twelfth of the image's short side), the
    // thinnest of them.
    const double large = std::min(gray.cols, gray.rows) / 12.0;
    cv::Mat labels;
    cv::Mat stats, centroids;
    cv::connectedComponentsWithStats(ink, labels, stats, centroids, 8, CV_32S);
    std::vector<double> widths;
    for (const Outline &ol : outlines) {
      if (ol.long_side < large) continue;
      const cv::Point p = contours[ol.contour][0];
      const int label = labels.at<int>(p);
      if (label <= 0) continue;
      const double area = stats.at<int>(label, cv::CC_STAT_AREA);
      const double perimeter = cv::arcLength(contours[ol.contour], true);
      if (perimeter > 0) widths.push_back(2.0 * area / perimeter);
    }
    if (widths.empty()) return result;
    // The thinnest: a bar or a dark area is a large component too, and much wider.
    h = o.height_per_stroke * std::max(1.0, *std::min_element(widths.begin(), widths.end()));
  }
  if (!(h > 0)) return result;
  result.char_height = h;

  const double margin = std::max(2.0, o.border_margin * h);
  const double min_turn = o.min_turn_deg * CV_PI / 180.0;
  std::vector<Corner> corners;
  std::vector<cv::Point> polygon;
  cv::Mat strokes;  // the figure components' ink
  if (o.marker_thickness > 0) strokes = cv::Mat::zeros(ink.size(), CV_8U);
  for (const Outline &ol : outlines) {
    if (ol.long_side < o.min_extent * h) continue;
    if (text && ol.short_side >= o.min_text_thickness * h &&
        ol.short_side <= o.max_text_thickness * h &&
        LineAngleApart(ol.angle, text_angle_rad) < 20 * CV_PI / 180)
      continue;  // a word or a line of text
    if (!strokes.empty())
      cv::drawContours(strokes, contours, static_cast<int>(ol.contour), cv::Scalar(255),
                       cv::FILLED);
    // The outer boundary and the holes': where plot lines cross each other or an axis they
    // enclose paper, and most of their bends lie on those holes' boundaries.
    for (int c = static_cast<int>(ol.contour); c >= 0;
         c = c == static_cast<int>(ol.contour) ? hierarchy[c][2] : hierarchy[c][0]) {
    if (contours[c].size() < 8) continue;
    cv::approxPolyDP(contours[c], polygon, o.polygon_tolerance * h, true);
    const size_t n = polygon.size();
    if (n < 3) continue;
    for (size_t i = 0; i < n; ++i) {
      const cv::Point2d p(polygon[i]);
      if (p.x < margin || p.y < margin || p.x > gray.cols - 1 - margin ||
          p.y > gray.rows - 1 - margin)
        continue;
      // The turn between chords of min_edge text heights on either side: a bevel of a few
      // pixels at a corner turns as much at each of its ends (and they merge below), while
      // a threshold's ragged edge along soft shading (a photograph), turning as sharply
      // every few pixels, hardly turns over such a chord.
      const cv::Point2d a = p - AlongPolygon(polygon, i, -o.min_edge * h);
      const cv::Point2d b = AlongPolygon(polygon, i, o.min_edge * h) - p;
      const double la = std::hypot(a.x, a.y), lb = std::hypot(b.x, b.y);
      if (la <= 0 || lb <= 0) continue;
      const double turn = std::acos(std::clamp((a.x * b.x + a.y * b.y) / (la * lb), -1.0, 1.0));
      if (turn >= min_turn) corners.push_back({cv::Point2f(p), turn});
    }
    }
  }
  if (!strokes.empty()) {
    // Marker dots on a plot's lines (and lines crossing): where a stroke is much thicker
    // than strokes are. The ridge of the distance transform holds the half-widths; those
    // of strokes (thinner than 0.8 text heights) give the strokes' median, and a dot
    // is at most one and a half text heights across.
    strokes &= ink;
    cv::Mat dist, ridge;
    cv::distanceTransform(strokes, dist, cv::DIST_L2, 3);
    cv::dilate(dist, ridge, cv::Mat());
    std::vector<float> half_widths;
    for (int y = 0; y < dist.rows; ++y) {
      const float *d = dist.ptr<float>(y), *r = ridge.ptr<float>(y);
      for (int x = 0; x < dist.cols; ++x)
        if (d[x] > 0 && d[x] >= r[x] && d[x] <= 0.4 * h) half_widths.push_back(d[x]);
    }
    if (!half_widths.empty()) {
      std::nth_element(half_widths.begin(), half_widths.begin() + half_widths.size() / 2,
                       half_widths.end());
      const float stroke = half_widths[half_widths.size() / 2];
      const float low = static_cast<float>(o.marker_thickness) * stroke;
      const float high = static_cast<float>(0.75 * h);
      const int radius = std::max(1, static_cast<int>(std::lround(0.5 * h)));
      cv::Mat peak;
      cv::dilate(dist, peak,
                 cv::getStructuringElement(cv::MORPH_ELLIPSE,
                                           cv::Size(2 * radius + 1, 2 * radius + 1)));
      for (int y = 0; y < dist.rows; ++y) {
        const float *d = dist.ptr<float>(y), *p = peak.ptr<float>(y);
        for (int x = 0; x < dist.cols; ++x) {
          if (d[x] < low || d[x] > high || d[x] < p[x]) continue;
          if (x < margin || y < margin || x > gray.cols - 1 - margin ||
              y > gray.rows - 1 - margin)
            continue;
          corners.push_back({cv::Point2f(static_cast<float>(x), static_cast<float>(y)), CV_PI});
        }
      }
    }
  }
  // One point per bend: the sharpest corner seeds a cluster, the others within the merge
  // radius join it, and the cluster's mean is the keypoint.
  std::stable_sort(corners.begin(), corners.end(),
                   [](const Corner &a, const Corner &b) { return a.turn > b.turn; });
  const float r2 = static_cast<float>(o.merge_radius * h * o.merge_radius * h);
  std::vector<cv::Point2f> sum;
  std::vector<int> count;
  std::vector<cv::Point2f> seed;
  for (const Corner &c : corners) {
    size_t k = 0;
    for (; k < seed.size(); ++k) {
      const cv::Point2f d = c.point - seed[k];
      if (d.dot(d) <= r2) break;
    }
    if (k == seed.size()) {
      if (static_cast<int>(seed.size()) >= o.max_corners) continue;
      seed.push_back(c.point);
      sum.push_back(c.point);
      count.push_back(1);
    } else {
      sum[k] += c.point;
      ++count[k];
    }
  }
  out.reserve(seed.size());
  // Text seen close in a steep view is larger than the median text height: the clearance
  // grows with the nearest word's own spacing (to its nearest word, about a line apart).
  std::optional<NeighborGrid> grid;
  if (words.size() >= 2) grid.emplace(words);
  std::vector<int> nearest;
  for (size_t k = 0; k < seed.size(); ++k) {
    const cv::Point2f p = sum[k] * (1.0f / count[k]);
    if (grid) {
      grid->NearestTo(p, 1, -1, &nearest);
      if (!nearest.empty()) {
        const int w = nearest[0];
        const double d = cv::norm(words[w] - p);
        std::vector<int> next;
        grid->Nearest(w, 1, &next);
        const double spacing = next.empty() ? 0 : cv::norm(words[next[0]] - words[w]);
        // A word of a text block (a neighbour within a few text heights), not a lone label.
        const double local = spacing <= 4 * h ? std::max(h, spacing) : h;
        if (d < o.word_clearance * local) continue;
      }
    }
    out.push_back(p);
  }
  return result;
}

}  // namespace texfree
