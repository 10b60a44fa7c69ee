// Tests of ConnectedComponentsWithStats against OpenCV's connectedComponentsWithStats on
// random masks of specks, blobs and frames, with 4- and 8-connectivity.
#include "common/connected_components.h"

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>
#include <random>

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

}  // namespace
}  // namespace texfree
