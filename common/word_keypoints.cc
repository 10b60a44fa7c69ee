// WordKeypointExtractor implementation.
#include "common/word_keypoints.h"

#include <algorithm>
#include <array>
#include <cfloat>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <opencv2/imgproc.hpp>
#include <optional>

#include "absl/strings/str_cat.h"
#include "common/connected_components.h"
#include "common/neighbor_grid.h"

namespace texfree {
namespace {

int OddAtLeast(double v, int minimum) {
  int i = std::max(minimum, static_cast<int>(std::lround(v)));
  return i | 1;
}

struct Blob {
  float short_side, long_side,
      angle;  // minimum-area rectangle, angle of the long side
  cv::Point2f center;
};

// Minimum-area rectangles of the ink's components (their outer contours'): rotation-invariant
// sizes. Every component counts, also inside a frame (page edge, table, figure box). Specks
// whose bounding box cannot hold a rectangle of short side min_side are dropped before any
// rectangle is fitted.
std::vector<Blob> Blobs(const cv::Mat &mask, double min_side) {
  std::vector<Blob> out;
  for (const cv::RotatedRect &r : ComponentMinAreaRects(mask, min_side)) {
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

// Direction from each letter-sized blob to its nearest neighbour: letters of a
// word are closest along the line. Doubled-angle mean, so opposite directions
// agree.
double NeighborDirection(const std::vector<Blob> &blobs, double size) {
  std::vector<cv::Point2f> centers;
  for (const Blob &b : blobs)
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

// The q-quantile of the blobs' short sides, each blob weighted by its rectangle's area:
// noise and JPEG specks, which outnumber the letters of large text under noise, weigh little.
// Weights are capped at the 90th percentile area, so that the few large blobs (the dark
// surroundings of the page, figures) do not decide either.
double AreaWeightedShortSide(const std::vector<Blob> &blobs, double q) {
  std::vector<float> areas;
  for (const Blob &b : blobs) areas.push_back(b.short_side * b.long_side);
  const double cap = 0.5 * Quantile(areas, 0.9);
  std::vector<std::pair<float, double>> v;  // short side, weight
  double total = 0;
  for (const Blob &b : blobs) {
    const double w = std::min<double>(cap, static_cast<double>(b.short_side) * b.long_side);
    v.emplace_back(b.short_side, w);
    total += w;
  }
  if (v.empty() || !(total > 0)) return 0;
  std::sort(v.begin(), v.end());
  double seen = 0;
  for (const auto &[side, w] : v) {
    seen += w;
    if (seen >= q * total) return side;
  }
  return v.back().first;
}

double MedianShortSide(const std::vector<Blob> &blobs) {
  std::vector<float> sides;
  sides.reserve(blobs.size());
  for (const Blob &b : blobs) sides.push_back(b.short_side);
  return Quantile(std::move(sides), 0.5);
}

// Short side of elongated blobs (words, or letters fused into words): a text
// size that is the same whether or not letters touch at this resolution.
bool WordHeight(const std::vector<Blob> &blobs, double elongation, double *height) {
  std::vector<float> sides;
  for (const Blob &b : blobs)
    if (b.long_side >= elongation * b.short_side) sides.push_back(b.short_side);
  if (sides.size() < 8) return false;
  *height = Quantile(sides, 0.5);
  return true;
}

// Letters apart (Extract): the fewest provisional blobs, and the largest angle between the
// re-closed words and the letters' neighbour direction, for which the text is measured again.
constexpr size_t kMinLettersToMeasureAgain = 60;
constexpr double kMaxReclosedLineTurn = 15.0 * CV_PI / 180.0;

// Angle between two line directions (radians, modulo pi), in [0, pi/2].
double AngleApart(double a, double b) {
  const double d = std::abs(std::remainder(a - b, CV_PI));
  return std::min(d, CV_PI - d);
}

// Share of the blobs' rectangle area (blobs at least half a letter wide) in elongated
// blobs: near 1 when the provisional closing fused letters into words, low when it left
// them apart (the elongated blobs are then single tall letters lying across the line).
double ElongatedAreaShare(const std::vector<Blob> &blobs, double letter_size, double elongation) {
  double elongated = 0, total = 0;
  for (const Blob &b : blobs) {
    if (b.short_side < 0.5 * letter_size) continue;
    const double area = static_cast<double>(b.short_side) * b.long_side;
    total += area;
    if (b.long_side >= elongation * b.short_side) elongated += area;
  }
  return total > 0 ? elongated / total : 0;
}

// Text line direction: length-weighted doubled-angle mean of elongated blobs
// near the typical height.
double LineDirection(const std::vector<Blob> &blobs, double height) {
  double sx = 0, sy = 0;
  for (const Blob &b : blobs) {
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

struct Word {
  cv::Point2f center;
  double area;
};

// One ink component (a letter, or letters fused at this resolution): its pixel
// count, centroid and extents along the text line (u) and across it (n).
struct Glyph {
  double area = 0, sx = 0, sy = 0;
  float min_u = FLT_MAX, max_u = -FLT_MAX, min_n = FLT_MAX, max_n = -FLT_MAX;
  int left = 0, top = 0, right = 0, bottom = 0;
  float height() const { return max_n - min_n; }
};

int Find(std::vector<int> &parent, int i) {
  while (parent[i] != i) i = parent[i] = parent[parent[i]];
  return i;
}

// Letters -> words with one line-shaped closing for the whole image: gaps
// shorter than gap_factor * h along the text direction are filled.
std::vector<Word> CloseAlongLines(const cv::Mat &ink, double h, double angle,
                                  const WordKeypointOptions &o) {
  cv::Mat words;
  cv::morphologyEx(ink, words, cv::MORPH_CLOSE, LineKernel(o.gap_factor * h, angle));
  cv::Mat labels, stats, centroids;
  const int n = ConnectedComponentsWithStats(words, 8, &labels, &stats, &centroids);
  std::vector<Word> found;
  const double min_area = o.min_word_area_factor * h * h;
  for (int i = 1; i < n; ++i) {
    const int x = stats.at<int>(i, cv::CC_STAT_LEFT), y = stats.at<int>(i, cv::CC_STAT_TOP);
    const int w = stats.at<int>(i, cv::CC_STAT_WIDTH), bh = stats.at<int>(i, cv::CC_STAT_HEIGHT);
    const int area = stats.at<int>(i, cv::CC_STAT_AREA);
    if (area < min_area) continue;
    if (std::max(w, bh) > o.max_word_length_factor * h) continue;
    // Figures and merged paragraphs: far more ink than the longest word could
    // hold.
    if (area > o.max_word_length_factor * o.max_word_height_factor * h * h) continue;
    if (area < 0.08 * w * bh) continue;  // thin frames
    if (o.drop_border_blobs &&
        (x <= 1 || y <= 1 || x + w >= ink.cols - 1 || y + bh >= ink.rows - 1))
      continue;
    found.push_back({cv::Point2f(static_cast<float>(centroids.at<double>(i, 0)),
                                 static_cast<float>(centroids.at<double>(i, 1))),
                     static_cast<double>(area)});
  }
  return found;
}

// Letter spacing differs between fonts (monospace letters sit far apart) while
// word spaces are wider still: the gaps from each glyph to its nearest
// neighbour on the line form two modes, letter gaps (the majority) and word
// gaps. Otsu's split between them, when the two modes are clearly apart;
// otherwise (letters fused at this resolution: only word gaps are left) the
// default.
double WordGapThreshold(const std::vector<float> &gaps, double fallback) {
  constexpr double kLow = -0.2, kHigh = 1.6, kBin = 0.02;
  constexpr int kBins = static_cast<int>((kHigh - kLow) / kBin);
  std::array<double, kBins> hist{};
  double total = 0;
  // Gaps past the histogram are word gaps too (wide or justified monospace sets them at
  // 1.5-3 text heights): they count towards the word-gap share below, not the split.
  double beyond = 0;
  for (float g : gaps) {
    const int b = static_cast<int>((g - kLow) / kBin);
    if (b < 0) continue;
    if (g >= kHigh || b >= kBins) {
      beyond += 1;
      continue;
    }
    hist[static_cast<size_t>(b)] += 1;
    total += 1;
  }
  if (total < 40) return fallback;
  double sum_all = 0;
  for (int b = 0; b < kBins; ++b) sum_all += hist[static_cast<size_t>(b)] * b;
  double w0 = 0, sum0 = 0, best = -1;
  int split = -1;
  for (int b = 0; b < kBins - 1; ++b) {
    w0 += hist[static_cast<size_t>(b)];
    sum0 += hist[static_cast<size_t>(b)] * b;
    const double w1 = total - w0;
    if (w0 < 1 || w1 < 1) continue;
    const double m0 = sum0 / w0, m1 = (sum_all - sum0) / w1;
    const double between = w0 * w1 * (m0 - m1) * (m0 - m1);
    if (between > best) {
      best = between;
      split = b;
    }
  }
  if (split < 0) return fallback;
  double w_low = 0, s_low = 0;
  for (int b = 0; b <= split; ++b) {
    w_low += hist[static_cast<size_t>(b)];
    s_low += hist[static_cast<size_t>(b)] * b;
  }
  const double w_high = total - w_low;
  const double mean_low = kLow + kBin * (s_low / w_low + 0.5);
  const double mean_high = kLow + kBin * ((sum_all - s_low) / w_high + 0.5);
  // Letter gaps must be the majority and well apart from word gaps.
  if (w_low < 0.4 * total || mean_high - mean_low < 0.25) return fallback;
  const double threshold = std::clamp(kLow + kBin * (split + 1), 0.5 * fallback, 4.0 * fallback);
  if (w_high >= 0.08 * total) return threshold;
  // Few word gaps within the histogram: a split is trusted only when the gaps past it make
  // up the word gaps (wide monospace), and only to raise the threshold, since blurred views
  // with letters fused leave a spurious upper mode of line ends and columns.
  const double all = total + beyond;
  if (w_low < 0.4 * all || w_high + beyond < 0.08 * all) return fallback;
  return std::max(threshold, fallback);
}

// Letters -> words with sizes measured locally, so that one image may hold text
// of several sizes, or text whose size changes across the image (perspective):
// two glyphs on the same line (their extents across the line overlap) join when
// the gap between them along the line is below gap_factor times the local text
// height (median height of the glyph's neighbours). A closing with one kernel
// for the whole image cannot do this.
std::vector<Word> GroupLettersIntoWords(const cv::Mat &ink, double h, double angle,
                                        const WordKeypointOptions &o) {
  // Every glyph's statistics from its runs (LabelMaskRuns numbers glyphs as
  // cv::connectedComponents would, from 1 here): OpenCV's connectedComponentsWithStats
  // measures the same area, box and centroid several times slower.
  thread_local std::vector<MaskRun> runs;
  const int count = LabelMaskRuns(ink, &runs) + 1;  // label 0: the background
  const float ux = static_cast<float>(std::cos(angle)), uy = static_cast<float>(std::sin(angle));
  std::vector<Glyph> glyphs(static_cast<size_t>(count));
  for (Glyph &g : glyphs) {
    g.left = g.top = INT32_MAX;
    g.right = g.bottom = -1;
  }
  // u and n are monotonic along a row (in floating point too), so a run's extremes are at its
  // ends, and its sums are closed forms.
  for (const MaskRun &r : runs) {
    Glyph &g = glyphs[static_cast<size_t>(r.component) + 1];
    const int x0 = r.x0, x1 = r.x1, y = r.y;
    const float u0 = x0 * ux + y * uy, n0 = -x0 * uy + y * ux;
    const float u1 = x1 * ux + y * uy, n1 = -x1 * uy + y * ux;
    g.min_u = std::min({g.min_u, u0, u1});
    g.max_u = std::max({g.max_u, u0, u1});
    g.min_n = std::min({g.min_n, n0, n1});
    g.max_n = std::max({g.max_n, n0, n1});
    const int length = x1 - x0 + 1;
    g.area += length;
    g.sx += 0.5 * (static_cast<double>(x0) + x1) * length;
    g.sy += static_cast<double>(y) * length;
    g.left = std::min(g.left, x0);
    g.right = std::max(g.right, x1);
    g.top = std::min(g.top, y);
    g.bottom = std::max(g.bottom, y);
  }
  // Glyphs that may be part of words: not noise specks, not rules, frames or
  // figures.
  const double max_extent = o.max_word_length_factor * h;
  std::vector<int> kept;
  std::vector<cv::Point2f> centers;
  for (int i = 1; i < count; ++i) {
    Glyph &g = glyphs[static_cast<size_t>(i)];
    // One past the last column and row, as left + width and top + height.
    ++g.right;
    ++g.bottom;
    if (g.area < 2) continue;
    if (g.max_u - g.min_u > max_extent || g.height() > o.max_word_height_factor * h) continue;
    kept.push_back(i);
    centers.emplace_back(static_cast<float>(g.sx / g.area), static_cast<float>(g.sy / g.area));
  }
  std::vector<Word> words;
  if (kept.size() < 2) return words;
  NeighborGrid grid(centers);
  constexpr int kNeighbors = 8;
  std::vector<int> nn;
  // Local text height: median height of the glyph and its neighbours (robust to
  // dots, commas and ascenders).
  std::vector<float> local_h(kept.size());
  std::vector<float> heights;
  // Each glyph's neighbours, kept for the pairing below (nn_begin[a]..nn_begin[a + 1]).
  std::vector<int> neighbours, nn_begin(kept.size() + 1, 0);
  neighbours.reserve(kept.size() * kNeighbors);
  for (size_t a = 0; a < kept.size(); ++a) {
    grid.Nearest(static_cast<int>(a), kNeighbors, &nn);
    neighbours.insert(neighbours.end(), nn.begin(), nn.end());
    nn_begin[a + 1] = static_cast<int>(neighbours.size());
    heights.clear();
    heights.push_back(glyphs[static_cast<size_t>(kept[a])].height());
    for (int b : nn) heights.push_back(glyphs[static_cast<size_t>(kept[b])].height());
    std::nth_element(heights.begin(), heights.begin() + heights.size() / 2, heights.end());
    local_h[a] = std::max(1.0f, heights[heights.size() / 2]);
  }
  // Candidate pairs on the same line (their extents across the line overlap by
  // half the smaller glyph) with their gap along the line relative to the local
  // height.
  struct Pair {
    int a, b;
    float gap;
  };
  std::vector<Pair> pairs;
  std::vector<float> next_gap;  // per glyph: the gap to the next glyph along its line
  for (size_t a = 0; a < kept.size(); ++a) {
    const Glyph &ga = glyphs[static_cast<size_t>(kept[a])];
    float nearest = FLT_MAX;
    for (int i = nn_begin[a]; i < nn_begin[a + 1]; ++i) {
      const int b = neighbours[static_cast<size_t>(i)];
      const Glyph &gb = glyphs[static_cast<size_t>(kept[b])];
      const float overlap = std::min(ga.max_n, gb.max_n) - std::max(ga.min_n, gb.min_n);
      if (overlap < 0.5f * std::min(ga.height(), gb.height())) continue;
      const float lh = std::max(local_h[a], local_h[static_cast<size_t>(b)]);
      const float gap = (std::max(ga.min_u, gb.min_u) - std::min(ga.max_u, gb.max_u)) / lh;
      if (gb.min_u + gb.max_u > ga.min_u + ga.max_u) nearest = std::min(nearest, gap);
      if (gap > 2.0f) continue;
      if (static_cast<int>(a) < b) pairs.push_back({static_cast<int>(a), b, gap});
    }
    if (nearest < FLT_MAX) next_gap.push_back(nearest);
  }
  const double threshold = WordGapThreshold(next_gap, o.letter_gap_factor);
  std::vector<int> parent(kept.size());
  std::iota(parent.begin(), parent.end(), 0);
  for (const Pair &p : pairs) {
    if (p.gap > threshold) continue;
    const int ra = Find(parent, p.a), rb = Find(parent, p.b);
    if (ra != rb) parent[static_cast<size_t>(std::max(ra, rb))] = std::min(ra, rb);
  }
  // Accumulate the groups.
  std::vector<Glyph> groups(kept.size());
  std::vector<float> group_h(kept.size(), 0);
  for (size_t a = 0; a < kept.size(); ++a) {
    const int r = Find(parent, static_cast<int>(a));
    const Glyph &g = glyphs[static_cast<size_t>(kept[a])];
    Glyph &w = groups[static_cast<size_t>(r)];
    if (w.area == 0) {
      w.left = g.left;
      w.top = g.top;
      w.right = g.right;
      w.bottom = g.bottom;
    }
    w.area += g.area;
    w.sx += g.sx;
    w.sy += g.sy;
    w.min_u = std::min(w.min_u, g.min_u);
    w.max_u = std::max(w.max_u, g.max_u);
    w.min_n = std::min(w.min_n, g.min_n);
    w.max_n = std::max(w.max_n, g.max_n);
    w.left = std::min(w.left, g.left);
    w.top = std::min(w.top, g.top);
    w.right = std::max(w.right, g.right);
    w.bottom = std::max(w.bottom, g.bottom);
    group_h[static_cast<size_t>(r)] = std::max(group_h[static_cast<size_t>(r)], local_h[a]);
  }
  for (size_t r = 0; r < groups.size(); ++r) {
    const Glyph &w = groups[r];
    if (w.area == 0) continue;
    const double lh = group_h[r];
    if (w.area < o.min_word_area_factor * lh * lh) continue;  // dots, specks
    if (w.max_u - w.min_u > max_extent) continue;             // rules
    if (o.drop_border_blobs &&
        (w.left <= 1 || w.top <= 1 || w.right >= ink.cols - 1 || w.bottom >= ink.rows - 1))
      continue;
    words.push_back(
        {cv::Point2f(static_cast<float>(w.sx / w.area), static_cast<float>(w.sy / w.area)),
         w.area});
  }
  return words;
}

}  // namespace

// The same box mean as cv::adaptiveThreshold; OpenCV then looks each pixel up in a table,
// which took as long as the mean itself.
cv::Mat InkMask(const cv::Mat &smooth, int block, double offset) {
  CV_Assert(smooth.type() == CV_8UC1 && block % 2 == 1 && block > 1);
  thread_local cv::Mat mean;
  cv::boxFilter(smooth, mean, CV_8U, cv::Size(block, block), cv::Point(-1, -1), true,
                cv::BORDER_REPLICATE | cv::BORDER_ISOLATED);
  const int delta = cvFloor(offset);
  cv::Mat ink(smooth.size(), CV_8UC1);
  for (int y = 0; y < smooth.rows; ++y) {
    const uchar *s = smooth.ptr<uchar>(y), *m = mean.ptr<uchar>(y);
    uchar *d = ink.ptr<uchar>(y);
    for (int x = 0; x < smooth.cols; ++x) d[x] = m[x] - s[x] >= delta ? 255 : 0;
  }
  return ink;
}

absl::Status WordKeypointOptions::Validate() const {
  if (threshold_offset < 0 || threshold_offset > 128)
    return absl::InvalidArgumentError(
        absl::StrCat("threshold_offset must be in [0, 128], got ", threshold_offset));
  if (letter_gap_factor <= 0 || letter_gap_factor > 2)
    return absl::InvalidArgumentError(
        absl::StrCat("letter_gap_factor must be in (0, 2], got ", letter_gap_factor));
  if (gap_factor <= 0 || gap_factor > 3)
    return absl::InvalidArgumentError(
        absl::StrCat("gap_factor must be in (0, 3], got ", gap_factor));
  if (min_char_height < 1 || max_char_height <= min_char_height)
    return absl::InvalidArgumentError("need 1 <= min_char_height < max_char_height");
  if (min_word_area_factor < 0 || max_word_length_factor <= 1 || max_word_height_factor <= 1)
    return absl::InvalidArgumentError("word size factors out of range");
  if (!(min_word_area_share >= 0 && min_word_area_share <= 1) ||
      !(min_reclosed_word_area_share >= min_word_area_share && min_reclosed_word_area_share <= 1))
    return absl::InvalidArgumentError(absl::StrCat(
        "need 0 <= min_word_area_share (", min_word_area_share,
        ") <= min_reclosed_word_area_share (", min_reclosed_word_area_share, ") <= 1"));
  if (max_keypoints < 1 || max_keypoints > 65535)
    return absl::InvalidArgumentError("max_keypoints must be in [1, 65535]");
  if (!(half_resolution_above_char_height >= 0))
    return absl::InvalidArgumentError(
        absl::StrCat("half_resolution_above_char_height must be >= 0 (0: never), got ",
                     half_resolution_above_char_height));
  if (half_resolution_above_char_height > 0 &&
      half_resolution_above_char_height < 2 * min_char_height)
    return absl::InvalidArgumentError(absl::StrCat(
        "half_resolution_above_char_height must be 0 or at least 2 * min_char_height (",
        2 * min_char_height, "), got ", half_resolution_above_char_height));
  return absl::OkStatus();
}

WordKeypointExtractor::WordKeypointExtractor(WordKeypointOptions options)
    : options_(std::move(options)) {}

WordKeypoints WordKeypointExtractor::Extract(const cv::Mat &gray) const {
  CV_Assert(gray.type() == CV_8UC1);
  WordKeypoints result;
  if (gray.empty()) return result;
  const WordKeypointOptions &o = options_;
  cv::Mat smooth;
  cv::GaussianBlur(gray, smooth, cv::Size(3, 3), 0.7);

  // Pass 1: window from the image size, only to measure the text.
  const int block1 = OddAtLeast(std::min(gray.cols, gray.rows) / 20.0, 15);
  const cv::Mat ink1 = InkMask(smooth, block1, o.threshold_offset);
  std::vector<Blob> blobs = Blobs(ink1, o.min_char_height * 0.5);
  if (blobs.size() < 8) return result;
  // Letters (short side ~ letter width) or fused words (short side ~ word
  // height).
  const double s0 =
      std::max(o.min_char_height, o.area_weighted_text_size ? AreaWeightedShortSide(blobs, 0.5)
                                                            : MedianShortSide(blobs));
  double angle = NeighborDirection(blobs, s0);
  // Provisional words: close gaps of 0.45 s0 along the line, then measure word
  // height.
  const auto close_along = [&](double bridge) {
    cv::Mat closed;
    cv::morphologyEx(ink1, closed, cv::MORPH_CLOSE, LineKernel(bridge * s0, angle));
    return Blobs(closed, o.min_char_height);
  };
  double h = 0;
  std::vector<Blob> word_blobs = close_along(0.45);
  if (!WordHeight(word_blobs, 1.6, &h)) return result;
  std::optional<double> reclosed_angle;  // the re-closed words' line direction, when kept
  // Sharp type seen close (serif text above all) can keep its letters further apart than
  // those bridges: then the few elongated blobs are tall letters ('l', 'h', 'd') lying
  // across the line, and their width (a third of the word height) would be taken for it,
  // cutting the view into letters. The letters themselves are then the blobs, so their
  // nearest-neighbour direction is the line's: close again along it with longer bridges,
  // and keep the reading in which the blobs are words (most of the area elongated). Fused
  // text (share 0.85-1 on the benchmark's pages and views) never gets here, nor does text
  // foreshortened across its lines, whose words are flat.
  // The words so formed must lie along the direction they were joined in: a figure's bars
  // or a table's rules, closed together with a few lines of small text, lie across it.
  // And a reading of a few dozen blobs is too little evidence to overrule the first.
  if (h < s0 && word_blobs.size() >= kMinLettersToMeasureAgain &&
      ElongatedAreaShare(word_blobs, s0, 1.6) < o.min_word_area_share) {
    for (const double bridge : {0.9, 1.35}) {
      std::vector<Blob> closed_blobs = close_along(bridge);
      double closed_h = 0;
      if (ElongatedAreaShare(closed_blobs, s0, 1.6) < o.min_reclosed_word_area_share ||
          !WordHeight(closed_blobs, 1.6, &closed_h) || closed_h <= h)
        continue;
      const double closed_angle = LineDirection(closed_blobs, closed_h);
      if (AngleApart(closed_angle, angle) > kMaxReclosedLineTurn) continue;
      h = closed_h;
      reclosed_angle = closed_angle;
      break;
    }
  }
  if (h < o.min_char_height || h > o.max_char_height) return result;
  angle = reclosed_angle ? *reclosed_angle : LineDirection(word_blobs, h);

  // Pass 2: window matched to the text (a few word heights); letters grouped into words.
  const int block2 = OddAtLeast(3.0 * h, 7);
  return GroupWords(gray, smooth, h, angle, block2 == block1 ? ink1 : cv::Mat());
}

WordKeypoints WordKeypointExtractor::Extract(const cv::Mat &gray, const TextGeometry &known) const {
  CV_Assert(gray.type() == CV_8UC1);
  const WordKeypointOptions &o = options_;
  if (gray.empty() || !(known.char_height >= o.min_char_height) ||
      known.char_height > o.max_char_height)
    return {};
  cv::Mat smooth;
  if (!(o.half_resolution_above_char_height > 0 &&
        known.char_height > o.half_resolution_above_char_height))
    cv::GaussianBlur(gray, smooth, cv::Size(3, 3), 0.7);  // GroupWords smooths its own half
  return GroupWords(gray, smooth, known.char_height, known.text_angle_rad, cv::Mat());
}

WordKeypoints WordKeypointExtractor::GroupWords(const cv::Mat &gray, const cv::Mat &smooth,
                                                double h, double angle, cv::Mat ink) const {
  const WordKeypointOptions &o = options_;
  WordKeypoints result;
  result.char_height = h;
  result.text_angle_rad = angle;
  // Large text: group at half resolution, where the text is still taller than
  // half_resolution_above_char_height / 2 pixels.
  const bool half =
      o.half_resolution_above_char_height > 0 && h > o.half_resolution_above_char_height;
  double scale = 1.0;
  cv::Mat work_smooth = smooth;
  if (half) {
    cv::Mat reduced;
    cv::resize(gray, reduced, cv::Size((gray.cols + 1) / 2, (gray.rows + 1) / 2), 0, 0,
               cv::INTER_AREA);
    cv::GaussianBlur(reduced, work_smooth, cv::Size(3, 3), 0.7);
    scale = 2.0;
    ink = cv::Mat();
  }
  const double work_h = h / scale;
  if (ink.empty()) ink = InkMask(work_smooth, OddAtLeast(3.0 * work_h, 7), o.threshold_offset);
  std::vector<Word> found = o.grouping == WordGrouping::kLetterGraph
                                ? GroupLettersIntoWords(ink, work_h, angle, o)
                                : CloseAlongLines(ink, work_h, angle, o);
  if (static_cast<int>(found.size()) > o.max_keypoints) {
    std::nth_element(found.begin(), found.begin() + o.max_keypoints, found.end(),
                     [](const Word &a, const Word &b) { return a.area > b.area; });
    found.resize(o.max_keypoints);
  }
  result.points.reserve(found.size());
  // A half-resolution pixel i covers full-resolution pixels 2i and 2i + 1.
  const float offset = half ? 0.5f : 0.0f;
  for (const Word &w : found)
    result.points.emplace_back(static_cast<float>(w.center.x * scale) + offset,
                               static_cast<float>(w.center.y * scale) + offset);
  return result;
}

}  // namespace texfree
