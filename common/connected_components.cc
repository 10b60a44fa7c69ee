// Connected components of binary masks: run labelling (LabelMaskRuns), statistics summed per
// run (ConnectedComponentsWithStats) and the components' minimum-area rectangles.
#include "common/connected_components.h"

#include <algorithm>
#include <cfloat>
#include <climits>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <opencv2/imgproc.hpp>
#include <vector>

namespace texfree {
namespace {

// A component's box, pixel count and coordinate sums, gathered run by run.
struct RunStats {
  int left = INT_MAX, top = INT_MAX, right = -1, bottom = -1, area = 0;
  int64_t sum_x = 0, sum_y = 0;
  void Add(int y, int x0, int x1) {
    const int length = x1 - x0 + 1;
    left = std::min(left, x0);
    right = std::max(right, x1);
    top = std::min(top, y);
    bottom = std::max(bottom, y);
    area += length;
    sum_x += static_cast<int64_t>(x0 + x1) * length / 2;  // x0 + x1 and length: not both odd
    sum_y += static_cast<int64_t>(y) * length;
  }
};

}  // namespace

int ConnectedComponentsWithStats(const cv::Mat &mask, int connectivity, cv::Mat *labels,
                                 cv::Mat *stats, cv::Mat *centroids) {
  std::vector<RunStats> sums;
  if ((connectivity == 8 || connectivity == 4) && mask.type() == CV_8UC1) {
    // Runs, numbered as OpenCV numbers its labels, painted into the label image.
    thread_local std::vector<MaskRun> runs;
    sums.assign(static_cast<size_t>(LabelMaskRuns(mask, &runs, connectivity)) + 1, RunStats());
    labels->create(mask.size(), CV_32S);
    // Row by row with memset: Mat::setTo copies a converted scalar block by block, which
    // took as long as the labelling itself.
    for (int y = 0; y < labels->rows; ++y)
      std::memset(labels->ptr<int>(y), 0, sizeof(int) * static_cast<size_t>(labels->cols));
    for (const MaskRun &r : runs) {
      int *row = labels->ptr<int>(r.y);
      std::fill(row + r.x0, row + r.x1 + 1, r.component + 1);
      sums[static_cast<size_t>(r.component) + 1].Add(r.y, r.x0, r.x1);
    }
  } else {
    sums.assign(static_cast<size_t>(cv::connectedComponents(mask, *labels, connectivity, CV_32S)),
                RunStats());
    for (int y = 0; y < labels->rows; ++y) {
      const int *row = labels->ptr<int>(y);
      for (int x0 = 0; x0 < labels->cols;) {
        const int l = row[x0];
        int x1 = x0;
        while (x1 + 1 < labels->cols && row[x1 + 1] == l) ++x1;
        if (l != 0) sums[static_cast<size_t>(l)].Add(y, x0, x1);
        x0 = x1 + 1;
      }
    }
  }
  const int n = static_cast<int>(sums.size());
  *stats = cv::Mat::zeros(n, cv::CC_STAT_MAX, CV_32S);
  *centroids = cv::Mat::zeros(n, 2, CV_64F);
  // Labels are numbered 1..n-1 without gaps: each has pixels.
  for (int l = 1; l < n; ++l) {
    const RunStats &c = sums[static_cast<size_t>(l)];
    int *s = stats->ptr<int>(l);
    s[cv::CC_STAT_LEFT] = c.left;
    s[cv::CC_STAT_TOP] = c.top;
    s[cv::CC_STAT_WIDTH] = c.right - c.left + 1;
    s[cv::CC_STAT_HEIGHT] = c.bottom - c.top + 1;
    s[cv::CC_STAT_AREA] = c.area;
    centroids->at<double>(l, 0) = static_cast<double>(c.sum_x) / c.area;
    centroids->at<double>(l, 1) = static_cast<double>(c.sum_y) / c.area;
  }
  return n;
}

namespace {

// Background is most of a page and letters' runs are short: rows are searched eight bytes at
// a time. The first non-zero byte of a little-endian word is its lowest set bit's; its first
// zero byte is the lowest bit of (w - 0x01..01) & ~w & 0x80..80 (borrows only carry past
// zero bytes, so bits above the first may be spurious, the lowest never is).
constexpr uint64_t kOnes = 0x0101010101010101ull, kHighs = 0x8080808080808080ull;

uint64_t Load8(const uchar *p) {
  uint64_t w;
  std::memcpy(&w, p, 8);
#if __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__
  w = __builtin_bswap64(w);
#endif
  return w;
}

// The first x' >= x with row[x'] != 0, or cols.
int NextNonZero(const uchar *row, int x, int cols) {
  for (; x + 8 <= cols; x += 8)
    if (const uint64_t w = Load8(row + x)) return x + (__builtin_ctzll(w) >> 3);
  while (x < cols && row[x] == 0) ++x;
  return x;
}

// The first x' >= x with row[x'] == 0, or cols.
int NextZero(const uchar *row, int x, int cols) {
  for (; x + 8 <= cols; x += 8) {
    const uint64_t w = Load8(row + x);
    if (const uint64_t zeros = (w - kOnes) & ~w & kHighs) return x + (__builtin_ctzll(zeros) >> 3);
  }
  while (x < cols && row[x] != 0) ++x;
  return x;
}

int64_t Cross(const cv::Point &o, const cv::Point &a, const cv::Point &b) {
  return static_cast<int64_t>(a.x - o.x) * (b.y - o.y) -
         static_cast<int64_t>(a.y - o.y) * (b.x - o.x);
}

// Strict convex hull (no collinear vertices) of points sorted by (y, x): Andrew's monotone
// chain, in linear time since they come sorted.
void SortedPointsHull(const std::vector<cv::Point> &points, std::vector<cv::Point> *hull) {
  hull->assign(2 * points.size(), cv::Point());
  std::vector<cv::Point> &h = *hull;
  size_t k = 0;
  for (const cv::Point &p : points) {
    while (k >= 2 && Cross(h[k - 2], h[k - 1], p) <= 0) --k;
    h[k++] = p;
  }
  for (size_t i = points.size() - 1, lower = k + 1; i-- > 0;) {
    while (k >= lower && Cross(h[k - 2], h[k - 1], points[i]) <= 0) --k;
    h[k++] = points[i];
  }
  h.resize(k > 1 ? k - 1 : k);
}

// The minimum-area rectangle around a convex polygon has a side on one of its edges
// (Freeman and Shapira, 1975): every edge is tried against every vertex. Hulls of letters
// have a handful of vertices, for which this is several times faster than cv::minAreaRect
// (hull, conversion to float and rotating calipers, each with its allocations). Of edges
// giving the same area, the first from the top-left vertex is kept. `width` lies along that
// edge and `angle` is its direction, in degrees, as cv::RotatedRect has them.
cv::RotatedRect ConvexPolygonMinAreaRect(const std::vector<cv::Point> &hull) {
  const size_t m = hull.size();
  double best_area = DBL_MAX;
  cv::RotatedRect best;
  for (size_t i = 0; i < m; ++i) {
    const cv::Point &p = hull[i], &q = hull[(i + 1) % m];
    const double length = std::hypot(q.x - p.x, q.y - p.y);
    const double ux = (q.x - p.x) / length, uy = (q.y - p.y) / length;
    double min_u = 0, max_u = 0, min_v = 0, max_v = 0;  // p is at the origin
    for (const cv::Point &r : hull) {
      const double dx = r.x - p.x, dy = r.y - p.y;
      const double u = dx * ux + dy * uy, v = dy * ux - dx * uy;
      min_u = std::min(min_u, u);
      max_u = std::max(max_u, u);
      min_v = std::min(min_v, v);
      max_v = std::max(max_v, v);
    }
    const double area = (max_u - min_u) * (max_v - min_v);
    if (!(area < best_area - 1e-9 * (1 + area))) continue;
    best_area = area;
    const double cu = 0.5 * (min_u + max_u), cv_ = 0.5 * (min_v + max_v);
    best.center = cv::Point2f(static_cast<float>(p.x + cu * ux - cv_ * uy),
                              static_cast<float>(p.y + cu * uy + cv_ * ux));
    best.size = cv::Size2f(static_cast<float>(max_u - min_u), static_cast<float>(max_v - min_v));
    best.angle = static_cast<float>(std::atan2(uy, ux) * 180.0 / CV_PI);
  }
  return best;
}

}  // namespace

int LabelMaskRuns(const cv::Mat &mask, std::vector<MaskRun> *runs, int connectivity) {
  CV_Assert(mask.type() == CV_8UC1);
  CV_Assert(connectivity == 4 || connectivity == 8);
  // Runs touch runs of the row above that overlap them, widened by a pixel for 8.
  const int reach = connectivity == 8 ? 1 : 0;
  runs->clear();
  thread_local std::vector<int> parent;
  parent.clear();
  const auto find = [](int i) {
    while (parent[static_cast<size_t>(i)] != i)
      i = parent[static_cast<size_t>(i)] =
          parent[static_cast<size_t>(parent[static_cast<size_t>(i)])];
    return i;
  };
  size_t previous_row = 0;  // first run of the row above
  for (int y = 0; y < mask.rows; ++y) {
    const uchar *row = mask.ptr<uchar>(y);
    const size_t row_start = runs->size();
    for (int x = NextNonZero(row, 0, mask.cols); x < mask.cols;) {
      const int end = NextZero(row, x + 1, mask.cols);
      runs->push_back({y, x, end - 1, 0});
      parent.push_back(static_cast<int>(parent.size()));
      x = NextNonZero(row, end, mask.cols);
    }
    // Both rows are sorted, so one sweep finds every touching pair.
    size_t above = previous_row;
    for (size_t i = row_start; i < runs->size(); ++i) {
      const MaskRun &r = (*runs)[i];
      while (above < row_start && (*runs)[above].x1 < r.x0 - reach) ++above;
      for (size_t j = above; j < row_start && (*runs)[j].x0 <= r.x1 + reach; ++j) {
        // The earlier run's root is kept, so that a component's root is its first run.
        const int a = find(static_cast<int>(i)), b = find(static_cast<int>(j));
        if (a != b) parent[static_cast<size_t>(std::max(a, b))] = std::min(a, b);
      }
    }
    previous_row = row_start;
  }
  // Components numbered as cv::connectedComponents numbers them (8-connectivity, OpenCV
  // 4.6): in the raster order of their first 2x2 blocks, the cells its labelling works in.
  // A block's pixels are all 8-connected, so no two components share a first block. The
  // word extractor's glyph order, and with it the order of its keypoints, stays as it was
  // with OpenCV's labels.
  int count = 0;
  for (size_t i = 0; i < runs->size(); ++i) {
    const int root = find(static_cast<int>(i));
    (*runs)[i].component =
        root == static_cast<int>(i) ? count++ : (*runs)[static_cast<size_t>(root)].component;
  }
  // With 4-connectivity OpenCV labels pixel by pixel (Wu's SAUF), in the raster order of
  // each component's first pixel: that of its first run, its root, as numbered above.
  if (connectivity == 4) return count;
  thread_local std::vector<std::pair<int64_t, int>> first_block;  // (block key, component)
  first_block.assign(static_cast<size_t>(count), {INT64_MAX, 0});
  for (const MaskRun &r : *runs) {
    const int64_t key = (static_cast<int64_t>(r.y >> 1) << 32) | (r.x0 >> 1);
    auto &f = first_block[static_cast<size_t>(r.component)];
    f = {std::min(f.first, key), r.component};
  }
  std::sort(first_block.begin(), first_block.end());
  thread_local std::vector<int> number;
  number.resize(static_cast<size_t>(count));
  for (int k = 0; k < count; ++k)
    number[static_cast<size_t>(first_block[static_cast<size_t>(k)].second)] = k;
  for (MaskRun &r : *runs) r.component = number[static_cast<size_t>(r.component)];
  return count;
}

std::vector<cv::RotatedRect> ComponentMinAreaRects(const cv::Mat &mask, double min_short_side) {
  thread_local std::vector<MaskRun> runs;
  thread_local std::vector<RunStats> boxes;
  thread_local std::vector<int> first_extent, row_min, row_max;
  thread_local std::vector<cv::Point> ends, hull;
  const size_t count = static_cast<size_t>(LabelMaskRuns(mask, &runs));
  boxes.assign(count, RunStats());
  for (const MaskRun &r : runs) boxes[static_cast<size_t>(r.component)].Add(r.y, r.x0, r.x1);
  // Each kept component gets one slot per row for the row's end pixels.
  const double min_box = 0.999 * min_short_side * min_short_side;
  first_extent.assign(count, -1);
  int extents = 0;
  for (size_t c = 0; c < count; ++c) {
    const RunStats &b = boxes[c];
    if (static_cast<double>(b.right - b.left) * (b.bottom - b.top) < min_box) continue;
    first_extent[c] = extents;
    extents += b.bottom - b.top + 1;
  }
  row_min.assign(static_cast<size_t>(extents), INT_MAX);
  row_max.assign(static_cast<size_t>(extents), -1);
  for (const MaskRun &r : runs) {
    const size_t c = static_cast<size_t>(r.component);
    if (first_extent[c] < 0) continue;
    const size_t i = static_cast<size_t>(first_extent[c] + r.y - boxes[c].top);
    row_min[i] = std::min(row_min[i], r.x0);
    row_max[i] = std::max(row_max[i], r.x1);
  }
  std::vector<cv::RotatedRect> rects;
  for (size_t c = 0; c < count; ++c) {
    if (first_extent[c] < 0) continue;
    ends.clear();
    for (int y = boxes[c].top; y <= boxes[c].bottom; ++y) {
      const size_t i = static_cast<size_t>(first_extent[c] + y - boxes[c].top);
      ends.emplace_back(row_min[i], y);
      if (row_max[i] != row_min[i]) ends.emplace_back(row_max[i], y);
    }
    SortedPointsHull(ends, &hull);
    if (hull.size() < 3) continue;  // a straight line one pixel thin
    rects.push_back(ConvexPolygonMinAreaRect(hull));
  }
  return rects;
}

}  // namespace texfree
