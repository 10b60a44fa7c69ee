// FigureKeypointExtractor: corners of a drawn chart, against the exact geometry of its
// drawing and of a perspective view of it.
#include "common/figure_keypoints.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <opencv2/imgproc.hpp>
#include <random>

#include "common/planar_pose.h"

namespace texfree {
namespace {

// A bar chart and a polyline with markers on white paper, with the points a reader would
// call its corners: the bars' corners and the polyline's vertices. A corner is the centroid
// of its blob of cornerness: a marker's (a disc of kMarkerRadius) near its centre, a right
// angle's about 1.5 px inside it (the blob reaches further into the angle than out of it).
constexpr float kMarkerRadius = 4;
struct Chart {
  cv::Mat image;
  std::vector<cv::Point2f> corners;
  std::vector<float> tolerance;  // per corner, in the chart's pixels
};

Chart DrawChart() {
  Chart chart;
  chart.image = cv::Mat(700, 900, CV_8UC1, cv::Scalar(235));
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> height(60, 260);
  for (int i = 0; i < 6; ++i) {
    const int x = 80 + 60 * i, top = 320 - height(rng);
    cv::rectangle(chart.image, cv::Rect(x, top, 30, 320 - top), cv::Scalar(60), cv::FILLED);
    chart.corners.emplace_back(x - 0.5f, top - 0.5f);
    chart.corners.emplace_back(x + 29.5f, top - 0.5f);
    chart.corners.emplace_back(x - 0.5f, 319.5f);
    chart.corners.emplace_back(x + 29.5f, 319.5f);
    chart.tolerance.insert(chart.tolerance.end(), 4, 2.5f);
  }
  std::vector<cv::Point> line;
  for (int i = 0; i < 9; ++i) line.emplace_back(90 + 85 * i, 620 - height(rng));
  cv::polylines(chart.image, line, false, cv::Scalar(40), 2, cv::LINE_AA);
  for (const cv::Point &p : line) {
    cv::circle(chart.image, p, static_cast<int>(kMarkerRadius), cv::Scalar(40), cv::FILLED,
               cv::LINE_AA);
    chart.corners.emplace_back(static_cast<float>(p.x), static_cast<float>(p.y));
    chart.tolerance.push_back(kMarkerRadius + 1.5f);
  }
  return chart;
}

// The share of `truth` points (inside the image, away from its border) with a keypoint within
// their `tolerance` times `scale`, and the share of keypoints within that of a truth point.
std::pair<double, double> Agreement(const std::vector<cv::Point2f> &keypoints,
                                    const std::vector<cv::Point2f> &truth,
                                    const std::vector<float> &tolerance, double scale,
                                    const cv::Size &size) {
  auto near = [&](const cv::Point2f &k, size_t t) {
    return cv::norm(k - truth[t]) <= tolerance[t] * scale;
  };
  int inside = 0, found = 0, right = 0;
  for (size_t t = 0; t < truth.size(); ++t) {
    const cv::Point2f &p = truth[t];
    if (p.x < 8 || p.y < 8 || p.x > size.width - 8 || p.y > size.height - 8) continue;
    ++inside;
    found += std::any_of(keypoints.begin(), keypoints.end(),
                         [&](const cv::Point2f &k) { return near(k, t); });
  }
  for (const cv::Point2f &k : keypoints) {
    bool any = false;
    for (size_t t = 0; t < truth.size() && !any; ++t) any = near(k, t);
    right += any;
  }
  return {inside ? static_cast<double>(found) / inside : 0,
          keypoints.empty() ? 0 : static_cast<double>(right) / keypoints.size()};
}

TEST(FigureKeypointExtractorTest, FindsTheChartsCornersAndOnlyThem) {
  const Chart chart = DrawChart();
  const cv::Mat before = chart.image.clone();
  const auto keypoints = FigureKeypointExtractor().Extract(chart.image, {}, 0);
  // The picture is the caller's: registration cuts it into words again afterwards.
  EXPECT_EQ(cv::norm(chart.image, before, cv::NORM_INF), 0);
  const auto [found, right] =
      Agreement(keypoints, chart.corners, chart.tolerance, 1.0, chart.image.size());
  EXPECT_GE(found, 0.95) << keypoints.size() << " keypoints";
  EXPECT_GE(right, 0.8);
}

// Seen in perspective (30 degrees of tilt), blurred, noisy and unevenly lit, the corners are
// found where the homography puts the drawn ones.
TEST(FigureKeypointExtractorTest, CornersFollowTheViewsHomography) {
  const Chart chart = DrawChart();
  const cv::Matx33d H(0.8, 0.12, 20, -0.05, 0.62, 60, 0.00012, 0.00045, 1);
  cv::Mat view;
  cv::warpPerspective(chart.image, view, cv::Mat(H), {640, 480}, cv::INTER_LINEAR,
                      cv::BORDER_CONSTANT, cv::Scalar(235));
  cv::GaussianBlur(view, view, cv::Size(0, 0), 0.8);
  cv::Mat light(view.size(), CV_32F), noise(view.size(), CV_32F);
  for (int y = 0; y < view.rows; ++y)
    for (int x = 0; x < view.cols; ++x) light.at<float>(y, x) = 0.7f + 0.3f * x / view.cols;
  cv::randn(noise, 0, 3);
  cv::Mat lit;
  view.convertTo(lit, CV_32F);
  lit = lit.mul(light) + noise;
  lit.convertTo(view, CV_8U);
  std::vector<cv::Point2f> truth;
  for (const cv::Point2f &c : chart.corners) {
    const cv::Point2d p = ApplyHomography(H, cv::Point2d(c.x, c.y));
    truth.emplace_back(static_cast<float>(p.x), static_cast<float>(p.y));
  }
  const auto keypoints = FigureKeypointExtractor().Extract(view, {}, 0);
  // The view is 0.6-0.8 times the chart's size, plus a pixel of blur and resampling.
  std::vector<float> tolerance = chart.tolerance;
  for (float &t : tolerance) t = 0.8f * t + 1.0f;
  const auto [found, right] = Agreement(keypoints, truth, tolerance, 1.0, view.size());
  EXPECT_GE(found, 0.8) << keypoints.size() << " keypoints";
  EXPECT_GE(right, 0.8);
}

// With centroids, a plot's marker gives one corner at its centre, on the page and in a
// perspective view alike: its rim's maxima (where the segments meet it) would move from one
// to another as the view changes which is strongest.
TEST(FigureKeypointExtractorTest, MarkersGiveOneCornerAtTheirCentre) {
  cv::Mat page(500, 900, CV_8UC1, cv::Scalar(238));
  std::vector<cv::Point> line;
  std::mt19937 rng(11);
  std::uniform_int_distribution<int> height(120, 380);
  for (int i = 0; i < 10; ++i) line.emplace_back(60 + 85 * i, height(rng));
  cv::polylines(page, line, false, cv::Scalar(50), 2, cv::LINE_AA);
  for (const cv::Point &p : line) cv::circle(page, p, 4, cv::Scalar(50), cv::FILLED, cv::LINE_AA);
  const cv::Matx33d H(0.72, 0.1, 10, -0.04, 0.66, 50, 0.0001, 0.0003, 1);
  cv::Mat view;
  cv::warpPerspective(page, view, cv::Mat(H), {640, 480}, cv::INTER_LINEAR, cv::BORDER_CONSTANT,
                      cv::Scalar(238));
  cv::GaussianBlur(view, view, cv::Size(0, 0), 0.7);
  const FigureKeypointExtractor extractor;
  for (const bool warped : {false, true}) {
    const auto keypoints = extractor.Extract(warped ? view : page, {}, 0);
    for (const cv::Point &p : line) {
      const cv::Point2d centre =
          warped ? ApplyHomography(H, cv::Point2d(p.x, p.y)) : cv::Point2d(p.x, p.y);
      int near = 0;
      double best = 1e9;
      for (const cv::Point2f &k : keypoints) {
        const double d = cv::norm(cv::Point2d(k.x, k.y) - centre);
        best = std::min(best, d);
        near += d < 8;
      }
      EXPECT_LT(best, 1.5) << (warped ? "view" : "page") << ", marker at " << p;
      EXPECT_EQ(near, 1) << (warped ? "view" : "page") << ", marker at " << p;
    }
  }
}

// Text is the word extractor's: corners near a word keypoint are left out, and letters,
// smaller than a figure, give none.
TEST(FigureKeypointExtractorTest, TextGivesNoCorners) {
  cv::Mat page(400, 600, CV_8UC1, cv::Scalar(240));
  std::vector<cv::Point2f> words;
  for (int line = 0; line < 8; ++line)
    for (int word = 0; word < 6; ++word) {
      const cv::Point origin(30 + 95 * word, 50 + 40 * line);
      cv::putText(page, "word", origin, cv::FONT_HERSHEY_SIMPLEX, 0.6, cv::Scalar(30), 1,
                  cv::LINE_AA);
      words.emplace_back(origin.x + 22.f, origin.y - 6.f);
    }
  EXPECT_TRUE(FigureKeypointExtractor().Extract(page, words, 12).empty());
  // A fused line of text (a long bar of ink) beside the words: its corners are the text's.
  cv::rectangle(page, cv::Rect(30, 360, 540, 10), cv::Scalar(30), cv::FILLED);
  words.emplace_back(300.f, 365.f);
  for (int x = 60; x < 560; x += 60) words.emplace_back(static_cast<float>(x), 365.f);
  EXPECT_TRUE(FigureKeypointExtractor().Extract(page, words, 12).empty());
  EXPECT_FALSE(FigureKeypointExtractor().Extract(page, {}, 12).empty());
}

TEST(FigureKeypointOptionsTest, ValidateExplainsWhatIsWrong) {
  EXPECT_TRUE(FigureKeypointOptions().Validate().ok());
  FigureKeypointOptions o;
  o.block_size = 4;
  EXPECT_NE(o.Validate().message().find("block_size"), std::string::npos);
  o = {};
  o.min_distance_px = 0;
  EXPECT_NE(o.Validate().message().find("min_distance_px"), std::string::npos);
  o = {};
  o.ink_window_share = 0;
  EXPECT_NE(o.Validate().message().find("ink_window_share"), std::string::npos);
  o = {};
  o.max_keypoints = 0;
  EXPECT_FALSE(o.Validate().ok());
  o = {};
  o.centroid_max_blob_px = -1;
  EXPECT_NE(o.Validate().message().find("centroid_max_blob_px"), std::string::npos);
}

}  // namespace
}  // namespace texfree
