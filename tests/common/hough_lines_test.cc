// Tests of HoughLinesOnPoints: exact agreement with cv::HoughLines on drawn outlines and
// random pixels, and the sides of a known quadrilateral.
#include "common/hough_lines.h"

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>
#include <random>

namespace texfree {
namespace {

constexpr double kHalfDegree = CV_PI / 360;

std::vector<cv::Vec3f> OpenCvLines(const cv::Mat& image, int threshold) {
  std::vector<cv::Vec3f> lines;
  cv::HoughLines(image, lines, 1, kHalfDegree, threshold);
  return lines;
}

TEST(HoughLinesOnPointsTest, SameLinesVotesAndOrderAsOpenCv) {
  for (uint32_t seed : {1u, 2u, 3u, 4u}) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(0, 1);
    cv::Mat image = cv::Mat::zeros(240, 320, CV_8UC1);
    // A perspective quadrilateral (a table outline), notched by a "pocket", and clutter.
    std::vector<cv::Point> quad = {{static_cast<int>(40 + 30 * u(rng)), 60},
                                   {static_cast<int>(280 - 30 * u(rng)), 55},
                                   {300, static_cast<int>(200 + 20 * u(rng))},
                                   {static_cast<int>(15 + 10 * u(rng)), 215}};
    cv::polylines(image, quad, true, 255, 1);
    cv::circle(image, {160, 57}, 6, 0, -1);
    for (int i = 0; i < 150; ++i)
      image.at<uchar>(static_cast<int>(u(rng) * 240), static_cast<int>(u(rng) * 320)) = 255;
    std::vector<cv::Point> points;
    cv::findNonZero(image, points);
    // Duplicates and order must not matter.
    points.insert(points.end(), points.begin(), points.begin() + 40);
    std::shuffle(points.begin(), points.end(), rng);
    for (int threshold : {10, 25, 60}) {
      const auto expected = OpenCvLines(image, threshold);
      const auto lines = HoughLinesOnPoints(points, image.size(), 1, kHalfDegree, threshold);
      ASSERT_EQ(lines.size(), expected.size()) << "threshold " << threshold;
      for (size_t i = 0; i < lines.size(); ++i) {
        EXPECT_EQ(lines[i][0], expected[i][0]) << i;
        EXPECT_EQ(lines[i][1], expected[i][1]) << i;
        EXPECT_EQ(lines[i][2], expected[i][2]) << i;
      }
    }
  }
}

TEST(HoughLinesOnPointsTest, FindsTheSidesOfAKnownQuadrilateral) {
  // Sides of a rectangle rotated by 30 degrees about (160, 120): normals at 30 and 120
  // degrees, at distances 60 and 100 from the centre.
  const double a = 30 * CV_PI / 180;
  const cv::Point2d c(160, 120), n1(std::cos(a), std::sin(a)), n2(-std::sin(a), std::cos(a));
  std::vector<cv::Point> corners;
  for (const auto& [s1, s2] : {std::pair{1, 1}, {-1, 1}, {-1, -1}, {1, -1}}) {
    const cv::Point2d p = c + n1 * (60.0 * s1) + n2 * (100.0 * s2);
    corners.emplace_back(cvRound(p.x), cvRound(p.y));
  }
  cv::Mat image = cv::Mat::zeros(240, 320, CV_8UC1);
  cv::polylines(image, corners, true, 255, 1);
  std::vector<cv::Point> points;
  cv::findNonZero(image, points);
  const auto lines = HoughLinesOnPoints(points, image.size(), 1, kHalfDegree, 40);
  ASSERT_GE(lines.size(), 4u);
  // Each true side has a line within 1 degree and 1.5 px among the strongest ones.
  for (int side = 0; side < 4; ++side) {
    const cv::Point2d n = side % 2 == 0 ? n1 : n2;
    const double dist = side % 2 == 0 ? 60 : 100;
    const double rho = n.dot(c) + (side < 2 ? dist : -dist);
    bool found = false;
    for (size_t i = 0; i < std::min<size_t>(lines.size(), 8); ++i) {
      double t = lines[i][1], r = lines[i][0];
      const double nt = std::atan2(n.y, n.x);
      double dt = std::remainder(t - nt, CV_PI);
      if (std::abs(dt) > 1 * CV_PI / 180) continue;
      // theta and theta + pi are the same line with rho negated.
      const double r_same = std::abs(std::remainder(t - nt, 2 * CV_PI)) < CV_PI / 2 ? r : -r;
      if (std::abs(r_same - rho) < 1.5) found = true;
    }
    EXPECT_TRUE(found) << "side " << side << " rho " << rho;
  }
}

TEST(HoughLinesOnPointsTest, NothingFromNothing) {
  EXPECT_TRUE(HoughLinesOnPoints({}, {320, 240}, 1, kHalfDegree, 10).empty());
  EXPECT_TRUE(HoughLinesOnPoints({{5, 5}}, {320, 240}, 0, kHalfDegree, 0).empty());
  // Points outside the image are not votes.
  EXPECT_TRUE(HoughLinesOnPoints({{-5, 5}, {500, 5}}, {320, 240}, 1, kHalfDegree, 0).empty());
}

}  // namespace
}  // namespace texfree
