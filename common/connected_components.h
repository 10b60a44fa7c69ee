// Connected-component labelling with each component's area, bounding box and centroid.
#pragma once

#include <opencv2/core.hpp>

namespace texfree {

// The same labels, and the same statistics (cv::CC_STAT_* columns) and centroids for every
// component, as cv::connectedComponentsWithStats(mask, labels, stats, centroids,
// connectivity, CV_32S), returning the number of labels (background included); the
// background's row (label 0) is left zero. OpenCV 4.6 gathers the statistics
// pixel by pixel through a generic visitor; summing them in one scan of the labels is
// several times faster, which counts for the word and ball extractors that label every
// frame. Thread-safe (no shared state).
int ConnectedComponentsWithStats(const cv::Mat &mask, int connectivity, cv::Mat *labels,
                                 cv::Mat *stats, cv::Mat *centroids);

}  // namespace texfree
