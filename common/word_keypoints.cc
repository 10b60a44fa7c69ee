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

struct CharStats {
  double height = 0;
  double angle = 0;
  bool ok = false;
};

// Character height and line direction from ink components.
CharStats EstimateCharacters(const cv::Mat& ink, const WordKeypointOptions& o) {
  cv::Mat labels, stats, centroids;
  const int n = cv::connectedComponentsWithStats(ink, labels, stats, centroids, 8, CV_32S);
  std::vector<float> heights;
  std::vector<cv::Point2f> centers;
  heights.reserve(n);
  for (int i = 1; i < n; ++i) {
    const int w = stats.at<int>(i, cv::CC_STAT_WIDTH);
    const int h = stats.at<int>(i, cv::CC_STAT_HEIGHT);
    const int area = stats.at<int>(i, cv::CC_STAT_AREA);
    if (h < o.min_char_height || h > o.max_char_height) continue;
    if (w > 4 * h || h > 4 * w + 2) continue;  // rules, frames, stray lines
    if (area < 0.15 * w * h) continue;          // hollow frames
    heights.push_back(static_cast<float>(h));
    centers.emplace_back(static_cast<float>(centroids.at<double>(i, 0)),
                         static_cast<float>(centroids.at<double>(i, 1)));
  }
  CharStats out;
  if (heights.size() < 8) return out;
  std::vector<float> sorted = heights;
  // Upper-middle quantile: letters with ascenders dominate word height, small marks do not.
  const size_t q = sorted.size() * 6 / 10;
  std::nth_element(sorted.begin(), sorted.begin() + q, sorted.end());
  out.height = sorted[q];
  // Direction to each character's nearest neighbour, folded to [0, pi), doubled-angle mean.
  NeighborGrid grid(centers);
  std::vector<int> nn;
  double sx = 0, sy = 0;
  for (size_t i = 0; i < centers.size(); ++i) {
    if (std::abs(heights[i] - out.height) > 0.5 * out.height) continue;
    grid.Nearest(static_cast<int>(i), 1, &nn);
    if (nn.empty()) continue;
    const cv::Point2f d = centers[nn[0]] - centers[i];
    const double len = std::hypot(d.x, d.y);
    if (len > 2.0 * out.height || len < 1e-3) continue;
    const double a = 2.0 * std::atan2(d.y, d.x);
    sx += std::cos(a);
    sy += std::sin(a);
  }
  out.angle = 0.5 * std::atan2(sy, sx);
  out.ok = true;
  return out;
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

  // Pass 1: window from the image size, only to measure the characters.
  const int block1 = OddAtLeast(std::min(gray.cols, gray.rows) / 20.0, 15);
  CharStats chars = EstimateCharacters(InkMask(smooth, block1, o.threshold_offset), o);
  if (!chars.ok) return result;
  // Pass 2: window matched to the characters (a few heights wide, so a letter's inside is
  // compared against paper, not against other ink).
  const int block2 = OddAtLeast(3.0 * chars.height, 7);
  cv::Mat ink = block2 == block1 ? InkMask(smooth, block1, o.threshold_offset)
                                 : InkMask(smooth, block2, o.threshold_offset);
  const CharStats refined = EstimateCharacters(ink, o);
  if (refined.ok) chars = refined;
  const double h = chars.height;
  result.char_height = h;
  result.text_angle_rad = chars.angle;

  cv::Mat words;
  cv::morphologyEx(ink, words, cv::MORPH_CLOSE, LineKernel(o.gap_factor * h, chars.angle));

  cv::Mat labels, stats, centroids;
  const int n = cv::connectedComponentsWithStats(words, labels, stats, centroids, 8, CV_32S);
  struct Blob {
    cv::Point2f c;
    int area;
  };
  std::vector<Blob> blobs;
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
    blobs.push_back({cv::Point2f(static_cast<float>(centroids.at<double>(i, 0)),
                                 static_cast<float>(centroids.at<double>(i, 1))),
                     area});
  }
  if (static_cast<int>(blobs.size()) > o.max_keypoints) {
    std::nth_element(blobs.begin(), blobs.begin() + o.max_keypoints, blobs.end(),
                     [](const Blob& a, const Blob& b) { return a.area > b.area; });
    blobs.resize(o.max_keypoints);
  }
  result.points.reserve(blobs.size());
  for (const Blob& b : blobs) result.points.push_back(b.c);
  return result;
}

}  // namespace texfree
