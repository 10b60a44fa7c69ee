// Connected-component labelling with each component's area, bounding box and centroid.
#pragma once

#include <opencv2/core.hpp>
#include <vector>

namespace texfree {

// The same labels, and the same statistics (cv::CC_STAT_* columns) and centroids for every
// component, as cv::connectedComponentsWithStats(mask, labels, stats, centroids,
// connectivity, CV_32S), returning the number of labels (background included); the
// background's row (label 0) is left zero. OpenCV 4.6 gathers the statistics
// pixel by pixel through a generic visitor; summing them run by run is several times
// faster, which counts for the ball and table finders that label every frame. For an
// 8-bit mask the runs come from LabelMaskRuns and are painted into `labels`; otherwise
// OpenCV labels and the runs are read back. Thread-safe.
int ConnectedComponentsWithStats(const cv::Mat &mask, int connectivity, cv::Mat *labels,
                                 cv::Mat *stats, cv::Mat *centroids);

// A row's run x0..x1 (inclusive) of non-zero pixels, and its connected component.
struct MaskRun {
  int y, x0, x1, component;
};

// Labels the 8- (or 4-) connected components of `mask` (CV_8UC1, non-zero pixels) run by
// run: `runs` in raster order, each with its component, numbered from 0 as
// cv::connectedComponents (connectivity, CV_32S) numbers its labels from 1 (OpenCV 4.6: with
// 8, in the raster order of their first 2x2 blocks; with 4, of their first pixels);
// returns the number of components. Text is a few runs per letter and row, so this is
// several times faster than labelling every pixel when only the components' row extents
// are needed. Thread-safe.
int LabelMaskRuns(const cv::Mat &mask, std::vector<MaskRun> *runs, int connectivity = 8);

// The minimum-area rectangle of each 8-connected component of `mask` (non-zero pixels)
// whose bounding box could hold a rectangle of short side `min_short_side`
// ((width - 1) * (height - 1) >= min_short_side^2), in the order of the components' first pixels;
// smaller components, and lines one pixel thin, are left out. These are the rectangles
// cv::minAreaRect gives for the components' outer contours as cv::findContours traces them (to
// float rounding; of two rectangles of equal area either may come), found several times faster: a
// contour's hull is its component's, which the end pixels of the component's rows span, and the
// runs (LabelMaskRuns) give those instead of tracing every outline. Thread-safe (its buffers are
// per thread).
std::vector<cv::RotatedRect> ComponentMinAreaRects(const cv::Mat &mask, double min_short_side);

}  // namespace texfree
