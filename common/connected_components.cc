// ConnectedComponentsWithStats: OpenCV's labelling, statistics summed in one scan.
#include "common/connected_components.h"

#include <algorithm>
#include <cstdint>
#include <opencv2/imgproc.hpp>
#include <vector>

namespace texfree {

int ConnectedComponentsWithStats(const cv::Mat &mask, int connectivity, cv::Mat *labels,
                                 cv::Mat *stats, cv::Mat *centroids) {
  const int n = cv::connectedComponents(mask, *labels, connectivity, CV_32S);
  *stats = cv::Mat::zeros(n, cv::CC_STAT_MAX, CV_32S);
  *centroids = cv::Mat::zeros(n, 2, CV_64F);
  std::vector<int> left(n, INT32_MAX), top(n, INT32_MAX), right(n, -1), bottom(n, -1), area(n, 0);
  std::vector<int64_t> sum_x(n, 0), sum_y(n, 0);
  for (int y = 0; y < labels->rows; ++y) {
    const int *row = labels->ptr<int>(y);
    for (int x = 0; x < labels->cols; ++x) {
      const int l = row[x];
      if (l == 0) continue;
      left[l] = std::min(left[l], x);
      right[l] = std::max(right[l], x);
      top[l] = std::min(top[l], y);
      bottom[l] = std::max(bottom[l], y);
      ++area[l];
      sum_x[l] += x;
      sum_y[l] += y;
    }
  }
  // connectedComponents numbers the components 1..n-1 without gaps: each has pixels.
  for (int l = 1; l < n; ++l) {
    int *s = stats->ptr<int>(l);
    s[cv::CC_STAT_LEFT] = left[l];
    s[cv::CC_STAT_TOP] = top[l];
    s[cv::CC_STAT_WIDTH] = right[l] - left[l] + 1;
    s[cv::CC_STAT_HEIGHT] = bottom[l] - top[l] + 1;
    s[cv::CC_STAT_AREA] = area[l];
    centroids->at<double>(l, 0) = static_cast<double>(sum_x[l]) / area[l];
    centroids->at<double>(l, 1) = static_cast<double>(sum_y[l]) / area[l];
  }
  return n;
}

}  // namespace texfree
