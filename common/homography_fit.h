// Homography fitting for the many small point sets of guided matching and verification:
// least squares (normalised DLT, then Levenberg-Marquardt on the reprojection error), and
// RANSAC and PROSAC over minimal four-point samples, in fixed-size arithmetic.
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

// PROSAC (Chum and Matas, CVPR 2005) for pairs ordered best first (e.g. by how many
// descriptors agree on them): the first sample is the four best pairs, and later ones are
// drawn from a head of the list that grows to the whole list over the sample budget, so
// that a good model comes from the likeliest pairs first. Each model's consensus is checked under
// Wald's sequential test (SPRT), so that a bad model costs a few pairs' checks; every new
// best one is locally optimised (refitted on the consensus of a narrowing threshold while
// that gathers more pairs). Sampling stops when enough samples were drawn for `confidence`
// given the best consensus' share of all pairs (at least 100, at most `max_iterations`). The
// consensus are the pairs mapped within `threshold` pixels of their dst; the answer is
// FitHomography of the best one. Deterministic: a fixed seed. False when no consensus has more than
// the four pairs that define its homography (for 4 pairs: when they have none). `inliers`
// (optional) receives the final consensus, one flag per pair.
bool FitHomographyProsac(const std::vector<cv::Point2f> &src, const std::vector<cv::Point2f> &dst,
                         double threshold, int max_iterations, cv::Matx33d *H,
                         std::vector<char> *inliers = nullptr, double confidence = 0.995);

}  // namespace texfree
