// Tests of ConnectedComponentsWithStats against OpenCV's connectedComponentsWithStats on
// random masks of specks, blobs and frames, with 4- and 8-connectivity, and of
// ComponentMinAreaRects against the rectangles of cv::findContours' outlines, on those masks
// and on the ink of rendered camera views of text.
#include "common/connected_components.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <random>
#include <tuple>
#include <vector>

#include "common/image_io.h"
#include "tests/data/camera_view.h"
#include "tests/data/page_renderer.h"

namespace texfree {
namespace {

cv::Mat RandomMask(uint32_t seed) {
  std::mt19937 rng(seed);
  cv::Mat mask = cv::Mat::zeros(173, 241, CV_8UC1);
  std::uniform_int_distribution<int> x(0, mask.cols - 1), y(0, mask.rows - 1), r(1, 9);
  for (int i = 0; i < 60; ++i) cv::circle(mask, {x(rng), y(rng)}, r(rng), 255, -1);
  for (int i = 0; i < 400; ++i) mask.at<uchar>(y(rng), x(rng)) = 255;  // specks
  cv::rectangle(mask, {5, 5}, {120, 90}, 255, 1);                      // a frame with blobs inside
  cv::line(mask, {0, 172}, {240, 100}, 255, 1);                        // touches the border
  return mask;
}

TEST(ConnectedComponentsTest, MatchesOpenCvLabelsStatisticsAndCentroids) {
  for (uint32_t seed : {1u, 2u, 3u}) {
    for (int connectivity : {4, 8}) {
      SCOPED_TRACE("seed " + std::to_string(seed) + " connectivity " +
                   std::to_string(connectivity));
      const cv::Mat mask = RandomMask(seed);
      cv::Mat labels, stats, centroids, cv_labels, cv_stats, cv_centroids;
      const int n = ConnectedComponentsWithStats(mask, connectivity, &labels, &stats, &centroids);
      const int cv_n = cv::connectedComponentsWithStats(mask, cv_labels, cv_stats, cv_centroids,
                                                        connectivity, CV_32S);
      ASSERT_EQ(n, cv_n);
      ASSERT_GT(n, 50);
      EXPECT_EQ(cv::countNonZero(labels != cv_labels), 0);
      for (int l = 1; l < n; ++l) {
        for (int c = 0; c < cv::CC_STAT_MAX; ++c)
          ASSERT_EQ(stats.at<int>(l, c), cv_stats.at<int>(l, c)) << "label " << l << " stat " << c;
        EXPECT_NEAR(centroids.at<double>(l, 0), cv_centroids.at<double>(l, 0), 1e-9);
        EXPECT_NEAR(centroids.at<double>(l, 1), cv_centroids.at<double>(l, 1), 1e-9);
      }
    }
  }
}

TEST(ConnectedComponentsTest, EmptyMaskHasOnlyTheBackground) {
  cv::Mat labels, stats, centroids;
  EXPECT_EQ(
      ConnectedComponentsWithStats(cv::Mat::zeros(10, 10, CV_8UC1), 8, &labels, &stats, &centroids),
      1);
  EXPECT_EQ(stats.rows, 1);
  EXPECT_EQ(cv::countNonZero(labels), 0);
}

// The runs, painted with their component + 1, are OpenCV's 8-connected labels: the same
// components, numbered alike. Masks of odd and even sizes, specks at every parity.
TEST(LabelMaskRunsTest, RunsPaintOpenCvsLabels) {
  for (uint32_t seed : {1u, 2u, 3u, 4u}) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    cv::Mat mask = RandomMask(seed);
    if (seed % 2 == 0) mask = mask(cv::Rect(1, 1, mask.cols - 2, mask.rows - 1)).clone();
    std::vector<MaskRun> runs;
    const int n = LabelMaskRuns(mask, &runs);
    cv::Mat painted = cv::Mat::zeros(mask.size(), CV_32S), cv_labels;
    for (const MaskRun &r : runs) {
      ASSERT_LE(r.x0, r.x1);
      for (int x = r.x0; x <= r.x1; ++x) painted.at<int>(r.y, x) = r.component + 1;
    }
    EXPECT_EQ(n + 1, cv::connectedComponents(mask, cv_labels, 8, CV_32S));
    EXPECT_EQ(cv::countNonZero(painted != cv_labels), 0);
    EXPECT_EQ(static_cast<int>(runs.size()),
              cv::countNonZero(mask(cv::Rect(1, 0, mask.cols - 1, mask.rows)) &
                               ~mask(cv::Rect(0, 0, mask.cols - 1, mask.rows))) +
                  cv::countNonZero(mask.col(0)));  // one run per rising edge
  }
  std::vector<MaskRun> runs;
  EXPECT_EQ(LabelMaskRuns(cv::Mat::zeros(5, 20, CV_8UC1), &runs), 0);
  EXPECT_TRUE(runs.empty());
  EXPECT_EQ(LabelMaskRuns(cv::Mat(3, 21, CV_8UC1, cv::Scalar(7)), &runs), 1);  // wider than 8
  EXPECT_EQ(runs.size(), 3u);
}

// The rectangles the word extractor took before ComponentMinAreaRects: every outer outline
// (holes skipped) with at least 3 points and a large enough bounding box.
std::vector<cv::RotatedRect> OutlineRects(const cv::Mat &mask, double min_short_side) {
  std::vector<std::vector<cv::Point>> contours;
  std::vector<cv::Vec4i> hierarchy;
  cv::findContours(mask, contours, hierarchy, cv::RETR_CCOMP, cv::CHAIN_APPROX_SIMPLE);
  std::vector<cv::RotatedRect> rects;
  for (size_t i = 0; i < contours.size(); ++i) {
    if (hierarchy[i][3] >= 0 || contours[i].size() < 3) continue;
    const cv::Rect box = cv::boundingRect(contours[i]);
    if (static_cast<double>(box.width - 1) * (box.height - 1) <
        0.999 * min_short_side * min_short_side)
      continue;
    rects.push_back(cv::minAreaRect(contours[i]));
  }
  return rects;
}

// Short side, long side, the long side's direction modulo pi (radians), centre: the same
// rectangle whichever corner and side OpenCV reports it from.
struct RectShape {
  float short_side, long_side, direction, cx, cy;
};

std::vector<RectShape> Shapes(const std::vector<cv::RotatedRect> &rects) {
  std::vector<RectShape> out;
  for (const cv::RotatedRect &r : rects) {
    float a = r.size.width, b = r.size.height, angle = r.angle * static_cast<float>(CV_PI / 180);
    if (b > a) {
      std::swap(a, b);
      angle += static_cast<float>(CV_PI / 2);
    }
    angle = std::fmod(angle + static_cast<float>(4 * CV_PI), static_cast<float>(CV_PI));
    out.push_back({b, a, angle, r.center.x, r.center.y});
  }
  std::sort(out.begin(), out.end(), [](const RectShape &p, const RectShape &q) {
    return std::tie(p.cy, p.cx, p.long_side) < std::tie(q.cy, q.cx, q.long_side);
  });
  return out;
}

// The same components, each with a rectangle of the same (minimum) area. A blob may have
// several rectangles of that area (three pixels in an L: 2 x 2 and 1.79 x 2.24; 3 x 1 and
// 3.16 x 0.95 for a short staircase; discs, many), of which OpenCV's float calipers take
// whichever rounds smallest and ComponentMinAreaRects the first from the top-left corner, so
// the shapes must agree on at least `min_same_share` of them (on text, 94-99% do: the rest
// are specks of a few pixels).
void ExpectSameRects(const cv::Mat &mask, double min_short_side, double min_same_share) {
  const std::vector<RectShape> got = Shapes(ComponentMinAreaRects(mask, min_short_side));
  const std::vector<RectShape> want = Shapes(OutlineRects(mask, min_short_side));
  ASSERT_EQ(got.size(), want.size());
  std::vector<char> used(got.size(), 0);
  size_t same_shape = 0;
  for (const RectShape &w : want) {
    SCOPED_TRACE("rectangle at " + std::to_string(w.cx) + "," + std::to_string(w.cy));
    const double area = static_cast<double>(w.short_side) * w.long_side;
    const auto same_shape_as_w = [&w](const RectShape &g) {
      const double d = std::abs(g.direction - w.direction);
      return std::abs(g.cx - w.cx) < 1e-3 && std::abs(g.cy - w.cy) < 1e-3 &&
             std::abs(g.short_side - w.short_side) < 1e-3 &&
             std::abs(g.long_side - w.long_side) < 1e-3 &&
             (g.long_side - g.short_side < 1e-3 || std::min(d, CV_PI - d) < 1e-4);
    };
    const auto same_area_near_w = [&w, area](const RectShape &g) {
      return std::hypot(g.cx - w.cx, g.cy - w.cy) < 3 &&
             std::abs(static_cast<double>(g.short_side) * g.long_side - area) < 1e-3 * (1 + area);
    };
    int match = -1;
    for (size_t i = 0; i < got.size() && match < 0; ++i)
      if (!used[i] && same_shape_as_w(got[i])) match = static_cast<int>(i);
    if (match >= 0) {
      ++same_shape;
    } else {
      for (size_t i = 0; i < got.size() && match < 0; ++i)
        if (!used[i] && same_area_near_w(got[i])) match = static_cast<int>(i);
    }
    ASSERT_GE(match, 0) << "no rectangle of area " << area << " there";
    used[static_cast<size_t>(match)] = 1;
  }
  EXPECT_GE(static_cast<double>(same_shape), min_same_share * static_cast<double>(want.size()));
}

TEST(ComponentMinAreaRectsTest, MatchesOutlineRectanglesOnRandomMasks) {
  for (uint32_t seed : {1u, 2u, 3u}) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    const cv::Mat mask = RandomMask(seed);
    for (double min_side : {0.5, 1.5, 3.0}) ExpectSameRects(mask, min_side, 0.8);
    EXPECT_GT(ComponentMinAreaRects(mask, 1.5).size(), 30u);
  }
}

TEST(ComponentMinAreaRectsTest, MatchesOutlineRectanglesOnTheInkOfCameraViews) {
  std::mt19937_64 rng(9);
  for (int view = 0; view < 4; ++view) {
    const testdata::RenderedPage page = testdata::RenderTextPage(4 + view);
    SCOPED_TRACE("view " + std::to_string(view));
    const testdata::CameraViewOptions options = testdata::RandomViewOptions(rng, page.image.size());
    const cv::Mat gray = ToGray(testdata::RenderCameraView(page.image, options, view).image);
    cv::Mat ink;
    cv::adaptiveThreshold(gray, ink, 255, cv::ADAPTIVE_THRESH_MEAN_C, cv::THRESH_BINARY_INV,
                          15 + 6 * view, 4 + 2 * view);
    const std::vector<cv::RotatedRect> rects = ComponentMinAreaRects(ink, 1.5);
    EXPECT_GT(rects.size(), 100u);
    ExpectSameRects(ink, 1.5, 0.9);
  }
}

TEST(ComponentMinAreaRectsTest, KnownShapes) {
  cv::Mat mask = cv::Mat::zeros(60, 80, CV_8UC1);
  cv::rectangle(mask, {10, 10}, {29, 14}, 255, -1);  // 20 x 5 pixels: centres span 19 x 4
  cv::line(mask, {40, 5}, {70, 5}, 255, 1);          // one pixel thin: no rectangle
  mask.at<uchar>(50, 50) = 255;                      // a speck
  const std::vector<cv::RotatedRect> rects = ComponentMinAreaRects(mask, 1.0);
  ASSERT_EQ(rects.size(), 1u);
  EXPECT_NEAR(rects[0].center.x, 19.5, 1e-4);
  EXPECT_NEAR(rects[0].center.y, 12.0, 1e-4);
  EXPECT_NEAR(std::max(rects[0].size.width, rects[0].size.height), 19.0, 1e-4);
  EXPECT_NEAR(std::min(rects[0].size.width, rects[0].size.height), 4.0, 1e-4);
  EXPECT_TRUE(ComponentMinAreaRects(cv::Mat::zeros(10, 10, CV_8UC1), 1.0).empty());
}

}  // namespace
}  // namespace texfree
