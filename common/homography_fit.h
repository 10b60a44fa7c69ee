// Homography fitting for the many small point sets of guided matching: least squares
// (normalised DLT, then Levenberg-Marquardt on the reprojection error) and RANSAC over
// minimal four-point samples, in fixed-size arithmetic.
#pragma once

#include <opencv2/core.hpp>
#include <vector>

namespace texfree {

// The homography H that maps src[i] onto dst[i] with the least squared reprojection error
// in dst (as cv::findHomography's method 0): a normalised DLT, then up to
// `max_refine_iterations` Levenberg-Marquardt steps. False for fewer than 4 pairs, sizes
// that differ, or points whose DLT has no unique solution (all but one collinear). H is
// scaled to H(2, 2) = 1.
bool FitHomography(const std::vector<cv::Point2f> &src, const std::vector<cv::Point2f> &dst,
                   cv::Matx33d *H, int max_refine_iterations = 10);

// RANSAC (as cv::findHomography's cv::RANSAC, drawing the same samples): minimal samples of
// four pairs, drawn by a generator with a fixed seed (the same input gives the same
// answer), that keep their orientation and have no three points collinear; the consensus is the
// pairs that the sample's homography maps within `threshold` pixels of their dst. The number of
// samples adapts to 99.5% confidence, up to `max_iterations`. The largest consensus is refitted by
// FitHomography. False when no sample gives a homography of at least 4 pairs. `inliers`
// (optional) receives the final consensus, one flag per pair.
bool FitHomographyRansac(const std::vector<cv::Point2f> &src, const std::vector<cv::Point2f> &dst,
                         double threshold, int max_iterations, cv::Matx33d *H,
                         std::vector<char> *inliers = nullptr);

}  // namespace texfree
