// WordKeypointExtractor implementation.
#include "common/word_keypoints.h"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "absl/strings/str_cat.h"
#include "common/neighbor_grid.h"

namespace texfree {
namespace {

int OddAtLeast(double v, int minimum) {
  int i = std::max(minimum, static_cast<int>(std::lround(v)));
  return i | 1;
}

cv::Mat InkMask(const cv::Mat& smooth, int block, double offset) {
  cv::Mat ink;
  cv::adaptiveThreshold(smooth, ink, 255, cv::ADAPTIVE_THRESH_MEAN_C, cv::THRESH_BINARY_INV,
                        block, offset);
  return ink;
}

struct Blob {
  float short_side, long_side, angle;  // minimum-area rectangle, angle of the long side
  cv::Point2f center;
};

// Minimum-area rectangles of the ink's outer contours: rotation-invariant sizes. Every
// component's outer boundary counts, also inside a frame (page edge, table, figure box):
// RETR_CCOMP puts all outer boundaries at the top level, holes below them.
std::vector<Blob> Blobs(const cv::Mat& mask, double min_side) {
  std::vector<std::vector<cv::Point>> contours;
  std::vector<cv::Vec4i> hierarchy;
  cv::findContours(mask, contours, hierarchy, cv::RETR_CCOMP, cv::CHAIN_APPROX_SIMPLE);
  std::vector<Blob> out;
  out.reserve(contours.size());
  for (size_t i = 0; i < contours.size(); ++i) {
    const auto& c = contours[i];
    if (hierarchy[i][3] >= 0) continue;  // a hole
    if (c.size() < 3) continue;
    const cv::RotatedRect r = cv::minAreaRect(c);
    float a = r.size.width, b = r.size.height;
    float angle = r.angle * static_cast<float>(CV_PI / 180.0);
    if (b > a) {
      std::swap(a, b);
      angle += static_cast<float>(CV_PI / 2);
    }
    if (b < min_side) continue;
    out.push_back({b, a, angle, r.center});
  }
  return out;
}

// Direction from each letter-sized blob to its nearest neighbour: letters of a word are
// closest along the line. Doubled-angle mean, so opposite directions agree.
double NeighborDirection(const std::vector<Blob>& blobs, double size) {
  std::vector<cv::Point2f> centers;
  for (const Blob& b : blobs)
    if (b.short_side > 0.4 * size && b.short_side < 2.5 * size) centers.push_back(b.center);
  if (centers.size() < 3) return 0;
  NeighborGrid grid(centers);
  std::vector<int> nn;
  double sx = 0, sy = 0;
  for (size_t i = 0; i < centers.size(); ++i) {
    grid.Nearest(static_cast<int>(i), 1, &nn);
    if (nn.empty()) continue;
    const cv::Point2f d = centers[nn[0]] - centers[i];
    const double len = std::hypot(d.x, d.y);
    if (len < 1e-3 || len > 4.0 * size) continue;
    const double a = 2.0 * std::atan2(d.y, d.x);
    sx += std::cos(a);
    sy += std::sin(a);
  }
  return 0.5 * std::atan2(sy, sx);
}

double Quantile(std::vector<float> v, double q) {
  if (v.empty()) return 0;
  const size_t i = std::min(v.size() - 1, static_cast<size_t>(q * v.size()));
  std::nth_element(v.begin(), v.begin() + i, v.end());
  return v[i];
}

// Short side of elongated blobs (words, or letters fused into words): a text size that is
// the same whether or not letters touch at this resolution.
bool WordHeight(const std::vector<Blob>& blobs, double elongation, double* height) {
  std::vector<float> sides;
  for (const Blob& b : blobs)
    if (b.long_side >= elongation * b.short_side) sides.push_back(b.short_side);
  if (sides.size() < 8) return false;
  *height = Quantile(sides, 0.5);
  return true;
}

// Text line direction: length-weighted doubled-angle mean of elongated blobs near the
// typical height.
double LineDirection(const std::vector<Blob>& blobs, double height) {
  double sx = 0, sy = 0;
  for (const Blob& b : blobs) {
    if (b.long_side < 1.8 * b.short_side || b.short_side > 2.0 * height) continue;
    sx += b.long_side * std::cos(2.0 * b.angle);
    sy += b.long_side * std::sin(2.0 * b.angle);
  }
  return 0.5 * std::atan2(sy, sx);
}

// A 1-pixel-wide line of the given length and angle, as a structuring element.
cv::Mat LineKernel(double length, double angle) {
  const int half = std::max(1, static_cast<int>(std::ceil(length / 2.0)));
  const int size = 2 * half + 1;
  cv::Mat k = cv::Mat::zeros(size, size, CV_8U);
  const double c = std::cos(angle), s = std::sin(angle);
  const cv::Point a(static_cast<int>(std::lround(half - c * length / 2)),
                    static_cast<int>(std::lround(half - s * length / 2)));
  const cv::Point b(static_cast<int>(std::lround(half + c * length / 2)),
                    static_cast<int>(std::lround(half + s * length / 2)));
  cv::line(k, a, b, cv::Scalar(1), 1, cv::LINE_8);
  return k;
}

}  // namespace

absl::Status WordKeypointOptions::Validate() const {
  if (threshold_offset < 0 || threshold_offset > 128)
    return absl::InvalidArgumentError(
        absl::StrCat("threshold_offset must be in [0, 128], got ", threshold_offset));
  if (gap_factor <= 0 || gap_factor > 3)
    return absl::InvalidArgumentError(absl::StrCat("gap_factor must be in (0, 3], got ", gap_factor));
  if (min_char_height < 1 || max_char_height <= min_char_height)
    return absl::InvalidArgumentError("need 1 <= min_char_height < max_char_height");
  if (min_word_area_factor < 0 || max_word_length_factor <= 1 || max_word_height_factor <= 1)
    return absl::InvalidArgumentError("word size factors out of range");
  if (max_keypoints < 1 || max_keypoints > 65535)
    return absl::InvalidArgumentError("max_keypoints must be in [1, 65535]");
  return absl::OkStatus();
}

WordKeypointExtractor::WordKeypointExtractor(WordKeypointOptions options)
    : options_(std::move(options)) {}

WordKeypoints WordKeypointExtractor::Extract(const cv::Mat& gray) const {
  CV_Assert(gray.type() == CV_8UC1);
  WordKeypoints result;
  if (gray.empty()) return result;
  const WordKeypointOptions& o = options_;
  cv::Mat smooth;
  cv::GaussianBlur(gray, smooth, cv::Size(3, 3), 0.7);

  // Pass 1: window from the image size, only to measure the text.
  const int block1 = OddAtLeast(std::min(gray.cols, gray.rows) / 20.0, 15);
  const cv::Mat ink1 = InkMask(smooth, block1, o.threshold_offset);
  std::vector<Blob> blobs = Blobs(ink1, o.min_char_height * 0.5);
  if (blobs.size() < 8) return result;
  std::vector<float> sides;
  for (const Blob& b : blobs) sides.push_back(b.short_side);
  // Letters (short side ~ letter width) or fused words (short side ~ word height).
  const double s0 = std::max(o.min_char_height, Quantile(sides, 0.5));
  double angle = NeighborDirection(blobs, s0);
  // Provisional words: close gaps of 0.45 s0 along the line, then measure word height.
  cv::Mat words;
  cv::morphologyEx(ink1, words, cv::MORPH_CLOSE, LineKernel(0.45 * s0, angle));
  double h = 0;
  std::vector<Blob> word_blobs = Blobs(words, o.min_char_height);
  if (!WordHeight(word_blobs, 1.6, &h)) return result;
  if (h < o.min_char_height || h > o.max_char_height) return result;
  angle = LineDirection(word_blobs, h);

  // Pass 2: window matched to the text (a few word heights), final closing.
  const int block2 = OddAtLeast(3.0 * h, 7);
  const cv::Mat ink = block2 == block1 ? ink1 : InkMask(smooth, block2, o.threshold_offset);
  cv::morphologyEx(ink, words, cv::MORPH_CLOSE, LineKernel(o.gap_factor * h, angle));
  result.char_height = h;
  result.text_angle_rad = angle;

  cv::Mat labels, stats, centroids;
  const int n = cv::connectedComponentsWithStats(words, labels, stats, centroids, 8, CV_32S);
  struct Word {
    cv::Point2f c;
    int area;
  };
  std::vector<Word> found;
  blobs.reserve(n);
  const double min_area = o.min_word_area_factor * h * h;
  for (int i = 1; i < n; ++i) {
    const int x = stats.at<int>(i, cv::CC_STAT_LEFT), y = stats.at<int>(i, cv::CC_STAT_TOP);
    const int w = stats.at<int>(i, cv::CC_STAT_WIDTH), bh = stats.at<int>(i, cv::CC_STAT_HEIGHT);
    const int area = stats.at<int>(i, cv::CC_STAT_AREA);
    if (area < min_area) continue;
    if (std::max(w, bh) > o.max_word_length_factor * h) continue;
    // Figures and merged paragraphs: far more ink than the longest word could hold.
    if (area > o.max_word_length_factor * o.max_word_height_factor * h * h) continue;
    if (area < 0.08 * w * bh) continue;  // thin frames
    if (o.drop_border_blobs &&
        (x <= 1 || y <= 1 || x + w >= gray.cols - 1 || y + bh >= gray.rows - 1))
      continue;
    found.push_back({cv::Point2f(static_cast<float>(centroids.at<double>(i, 0)),
                                 static_cast<float>(centroids.at<double>(i, 1))),
                     area});
  }
  if (static_cast<int>(found.size()) > o.max_keypoints) {
    std::nth_element(found.begin(), found.begin() + o.max_keypoints, found.end(),
                     [](const Word& a, const Word& b) { return a.area > b.area; });
    found.resize(o.max_keypoints);
  }
  result.points.reserve(found.size());
  for (const Word& w : found) result.points.push_back(w.c);
  return result;
}

}  // namespace texfree
