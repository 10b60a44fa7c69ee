// Tests of NeighborGrid: k-nearest queries must equal a brute-force search on seeded
// random point sets (uniform, clustered, with duplicates, degenerate sizes).
#include "common/neighbor_grid.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <set>
#include <utility>
#include <vector>

namespace texfree {
namespace {

float Dist2(const cv::Point2f& a, const cv::Point2f& b) {
  const float dx = a.x - b.x, dy = a.y - b.y;
  return dx * dx + dy * dy;
}

// Brute force: squared distances of every point except `exclude`, sorted ascending.
std::vector<std::pair<float, int>> BruteForce(const std::vector<cv::Point2f>& points,
                                              const cv::Point2f& p, int exclude) {
  std::vector<std::pair<float, int>> all;
  for (int i = 0; i < static_cast<int>(points.size()); ++i) {
    if (i != exclude) all.emplace_back(Dist2(points[i], p), i);
  }
  std::sort(all.begin(), all.end());
  return all;
}

// Checks `got` against brute force: right size, no duplicates, no excluded index,
// non-decreasing distances, the i-th distance equal to the true i-th smallest distance
// (so the sets are equal up to ties at the k-th distance), and every point strictly
// closer than the k-th distance present.
void ExpectMatchesBruteForce(const std::vector<cv::Point2f>& points, const cv::Point2f& p,
                             int exclude, int k, const std::vector<int>& got) {
  const auto truth = BruteForce(points, p, exclude);
  const size_t expected = std::min<size_t>(k, truth.size());
  ASSERT_EQ(got.size(), expected) << "k=" << k << " n=" << points.size();
  std::set<int> unique(got.begin(), got.end());
  EXPECT_EQ(unique.size(), got.size()) << "duplicate indices";
  EXPECT_EQ(unique.count(exclude), 0u) << "excluded index returned";
  for (size_t i = 0; i < got.size(); ++i) {
    ASSERT_GE(got[i], 0);
    ASSERT_LT(got[i], static_cast<int>(points.size()));
    EXPECT_EQ(Dist2(points[got[i]], p), truth[i].first) << "rank " << i;
    if (i > 0) {
      EXPECT_LE(Dist2(points[got[i - 1]], p), Dist2(points[got[i]], p));
    }
  }
  if (expected == 0) return;
  const float kth = truth[expected - 1].first;
  for (const auto& [d2, i] : truth) {
    if (d2 >= kth) break;
    EXPECT_EQ(unique.count(i), 1u) << "missing strictly closer point " << i;
  }
}

std::vector<cv::Point2f> UniformPoints(std::mt19937& rng, int n, float w, float h) {
  std::uniform_real_distribution<float> ux(0, w), uy(0, h);
  std::vector<cv::Point2f> pts(n);
  for (auto& p : pts) p = {ux(rng), uy(rng)};
  return pts;
}

// A few tight clusters far apart plus sparse background points: cells become very
// unbalanced, which is where a grid search can stop too early.
std::vector<cv::Point2f> ClusteredPoints(std::mt19937& rng, int n) {
  std::uniform_real_distribution<float> u(0, 2000);
  std::normal_distribution<float> tight(0, 3);
  std::vector<cv::Point2f> centers(5);
  for (auto& c : centers) c = {u(rng), u(rng)};
  std::vector<cv::Point2f> pts;
  for (int i = 0; i < n; ++i) {
    if (i % 10 == 0) {
      pts.emplace_back(u(rng), u(rng));
    } else {
      const cv::Point2f& c = centers[i % centers.size()];
      pts.emplace_back(c.x + tight(rng), c.y + tight(rng));
    }
  }
  return pts;
}

TEST(NeighborGridTest, UniformPointsMatchBruteForce) {
  std::mt19937 rng(11);
  for (int trial = 0; trial < 5; ++trial) {
    const auto pts = UniformPoints(rng, 300 + 100 * trial, 1000, 1400);
    NeighborGrid grid(pts);
    std::vector<int> out;
    for (int k : {1, 3, 7, 15}) {
      for (int i = 0; i < static_cast<int>(pts.size()); i += 7) {
        grid.Nearest(i, k, &out);
        ExpectMatchesBruteForce(pts, pts[i], i, k, out);
      }
    }
  }
}

TEST(NeighborGridTest, ClusteredPointsMatchBruteForce) {
  std::mt19937 rng(12);
  const auto pts = ClusteredPoints(rng, 500);
  for (double per_cell : {0.5, 2.0, 8.0}) {
    NeighborGrid grid(pts, per_cell);
    std::vector<int> out;
    for (int k : {1, 7, 30}) {
      for (int i = 0; i < static_cast<int>(pts.size()); i += 3) {
        grid.Nearest(i, k, &out);
        ExpectMatchesBruteForce(pts, pts[i], i, k, out);
      }
    }
  }
}

TEST(NeighborGridTest, DuplicatePointsAreReturnedAtDistanceZero) {
  std::mt19937 rng(13);
  auto pts = UniformPoints(rng, 100, 500, 500);
  // Every point three times: the two copies of a point are its nearest neighbours.
  const size_t n = pts.size();
  for (size_t i = 0; i < n; ++i) pts.push_back(pts[i]);
  for (size_t i = 0; i < n; ++i) pts.push_back(pts[i]);
  NeighborGrid grid(pts);
  std::vector<int> out;
  for (int i = 0; i < static_cast<int>(pts.size()); ++i) {
    grid.Nearest(i, 5, &out);
    ExpectMatchesBruteForce(pts, pts[i], i, 5, out);
    ASSERT_GE(out.size(), 2u);
    EXPECT_EQ(Dist2(pts[out[0]], pts[i]), 0.f);
    EXPECT_EQ(Dist2(pts[out[1]], pts[i]), 0.f);
  }
}

TEST(NeighborGridTest, AllPointsIdentical) {
  const std::vector<cv::Point2f> pts(20, cv::Point2f(5.5f, -3.25f));
  NeighborGrid grid(pts);
  std::vector<int> out;
  grid.Nearest(4, 7, &out);
  ExpectMatchesBruteForce(pts, pts[4], 4, 7, out);
  grid.Nearest(4, 50, &out);
  EXPECT_EQ(out.size(), 19u);
}

TEST(NeighborGridTest, KLargerThanSetReturnsAllOthersInOrder) {
  std::mt19937 rng(14);
  const auto pts = UniformPoints(rng, 12, 100, 100);
  NeighborGrid grid(pts);
  std::vector<int> out;
  for (int i = 0; i < static_cast<int>(pts.size()); ++i) {
    grid.Nearest(i, 100, &out);
    ExpectMatchesBruteForce(pts, pts[i], i, 100, out);
    EXPECT_EQ(out.size(), pts.size() - 1);
  }
}

TEST(NeighborGridTest, SinglePointAndEmptySet) {
  const std::vector<cv::Point2f> one = {{10, 20}};
  NeighborGrid grid(one);
  std::vector<int> out = {42};
  grid.Nearest(0, 5, &out);
  EXPECT_TRUE(out.empty());
  grid.NearestTo({0, 0}, 3, -1, &out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0], 0);

  const std::vector<cv::Point2f> none;
  NeighborGrid empty(none);
  out = {1, 2};
  empty.NearestTo({0, 0}, 3, -1, &out);
  EXPECT_TRUE(out.empty());
}

TEST(NeighborGridTest, ZeroKReturnsNothing) {
  std::mt19937 rng(15);
  const auto pts = UniformPoints(rng, 50, 100, 100);
  NeighborGrid grid(pts);
  std::vector<int> out = {1};
  grid.Nearest(3, 0, &out);
  EXPECT_TRUE(out.empty());
}

TEST(NeighborGridTest, CollinearPointsMatchBruteForce) {
  // Zero-height bounding box (a single text line): the grid degenerates to one row.
  std::mt19937 rng(16);
  std::uniform_real_distribution<float> u(0, 1000);
  std::vector<cv::Point2f> pts(200);
  for (auto& p : pts) p = {u(rng), 50.f};
  NeighborGrid grid(pts);
  std::vector<int> out;
  for (int i = 0; i < static_cast<int>(pts.size()); i += 5) {
    grid.Nearest(i, 7, &out);
    ExpectMatchesBruteForce(pts, pts[i], i, 7, out);
  }
}

TEST(NeighborGridTest, QueriesOutsideTheBoundingBoxMatchBruteForce) {
  std::mt19937 rng(17);
  const auto pts = UniformPoints(rng, 400, 1000, 1000);
  NeighborGrid grid(pts);
  std::uniform_real_distribution<float> far(-3000, 4000);
  std::vector<int> out;
  for (int t = 0; t < 200; ++t) {
    const cv::Point2f q(far(rng), far(rng));
    grid.NearestTo(q, 7, -1, &out);
    ExpectMatchesBruteForce(pts, q, -1, 7, out);
  }
}

TEST(NeighborGridTest, WideAspectRatioAndOutlierMatchBruteForce) {
  // One far outlier stretches the bounding box: most cells are empty, and the cell count
  // hits the 4096 cap on one axis.
  std::mt19937 rng(18);
  auto pts = UniformPoints(rng, 300, 100, 100);
  pts.emplace_back(1e6f, 50.f);
  NeighborGrid grid(pts);
  std::vector<int> out;
  for (int i = 0; i < static_cast<int>(pts.size()); i += 3) {
    grid.Nearest(i, 7, &out);
    ExpectMatchesBruteForce(pts, pts[i], i, 7, out);
  }
  grid.Nearest(static_cast<int>(pts.size()) - 1, 3, &out);
  ExpectMatchesBruteForce(pts, pts.back(), static_cast<int>(pts.size()) - 1, 3, out);
}

TEST(NeighborGridTest, CappedGridOnVeryLongStripMatchesBruteForce) {
  // A 1e7 x 1 strip needs more than 4096 columns of the chosen cell size; the grid caps
  // the column count, so far points share the last column.
  std::mt19937 rng(19);
  std::uniform_real_distribution<float> ux(0, 1e7f), uy(0, 1);
  std::vector<cv::Point2f> pts(300);
  for (auto& p : pts) p = {ux(rng), uy(rng)};
  NeighborGrid grid(pts);
  std::vector<int> out;
  for (int i = 0; i < static_cast<int>(pts.size()); i += 2) {
    grid.Nearest(i, 7, &out);
    ExpectMatchesBruteForce(pts, pts[i], i, 7, out);
  }
}

}  // namespace
}  // namespace texfree
