// Perspective of a text page in a camera image, estimated from how densely its keypoints
// lie: an affine rectification for LLAH.
//
// LLAH's invariants (ratios of triangle areas) are affine invariants. A camera tilted 30-40
// degrees away from the page adds a projective part that changes those ratios across a
// neighbourhood of seven words by 10-20%, enough to move them into other quantisation
// levels, so the descriptors of a steep view stop matching the page's. The projective part
// can be read from the image itself: word keypoints are spread evenly over a page, and the
// homography G from image to page scales areas by det(G) / (g3 . p)^3 at image point p
// (g3 = G's third row). The distance from a keypoint to its k-th nearest neighbour thus
// grows as (g3 . p)^(3/2): a robust linear fit of that distance^(2/3) over the image gives
// g3 up to scale. Mapping the keypoints through P = [I 0; g3 / g33] leaves an affine image
// of the page, on which the invariants hold again.
#pragma once

#include <opencv2/core.hpp>
#include <optional>
#include <vector>

#include "absl/status/status.h"

namespace texfree {

struct TextPerspectiveOptions {
  // The local spacing is the distance to this nearest neighbour (beyond the word's own
  // line neighbours, so it follows the line spacing too).
  int neighbour = 4;
  // Fewer keypoints than this give no estimate. Views of large type hold only 20-60 words,
  // and the fit with 20 still measured better than none (10,000 pages: +1 point of top-1).
  int min_points = 20;
  // The rectification is applied only when the fitted depth varies over the keypoints by
  // at least this ratio (max / min): below it the view is close enough to affine, and a
  // fit of noisy spacings would only add noise.
  double min_depth_ratio = 1.15;
  // ...and is rejected beyond this ratio (a steeper view than the keypoints can describe,
  // or a fit fooled by the layout).
  double max_depth_ratio = 4.0;
  // Iterations of the robust (Tukey-weighted) least-squares fit.
  int iterations = 6;
  // The camera's focal length in pixels and principal point (0: unknown). With them the
  // fitted slope also gives the tilt, and the rectification undoes the foreshortening along
  // the slope (cos tilt, 0.77 at 40 degrees): LLAH's invariants are affine, but the seven
  // nearest neighbours it picks are not, and a page squeezed by a quarter along one axis
  // has other nearest neighbours. Without them the rectification stays affine.
  double focal_px = 0;
  cv::Point2d principal_point{0, 0};
  // ...from this many keypoints on: a slope fitted on fewer words (large type) is too often
  // the layout's (a heading, a short line), and a wrong stretch costs more than none (a
  // frontal view of 35 words was lost to one).
  int min_points_metric = 50;
  // A slope implying a steeper camera than this (1 / cos of its tilt, the angle between the
  // page's normal and the optical axis: 48 degrees) is taken for the layout's (large type, a
  // heading: a frontal view of 71 words fitted 1.56) and only the affine rectification is
  // applied: a wrong stretch costs more than the missing one. The stretch applied is the
  // one at the keypoints' centre, which adds the centre's angle off the axis.
  double max_stretch = 1.5;

  absl::Status Validate() const;
};

// The projective rectification P (image pixels -> an affine image of the page, in pixels
// around the keypoints' centre; close to a similarity image when the focal length is
// given), or nothing when the view is close to affine or the fit is not trustworthy.
std::optional<cv::Matx33d> EstimateTextPerspective(const std::vector<cv::Point2f> &points,
                                                   const TextPerspectiveOptions &options = {});

// points mapped through P.
// Refines a rectification's horizon so that, rectified, the text lines are parallel and
// evenly spaced: each keypoint's neighbours along `text_angle_rad` (within 20 degrees, as
// seen) should lie in one direction everywhere, and its nearest neighbour across the lines
// at one distance. Returns the rectification minimising that, searched from `start`'s
// horizon and from none: [I 0; g] about the keypoints' centre, with the foreshortening
// undone as EstimateTextPerspective does when options give the focal length; nothing with
// too few neighbour pairs.
std::optional<cv::Matx33d> RefineTextPerspective(const std::vector<cv::Point2f> &points,
                                                 double text_angle_rad,
                                                 const std::optional<cv::Matx33d> &start,
                                                 const TextPerspectiveOptions &options = {});

// How much a projective map P changes the scale over `points`: the ratio of the largest to
// the smallest depth (P's third row) at them; 1 for an affine map. 0 when a point is at or
// behind the horizon (or there are no points).
double DepthRatio(const cv::Matx33d &P, const std::vector<cv::Point2f> &points);

// P's perspective alone: the identity with P's third row (its horizon), scaled so that
// the depth is 1 at `at`. Its third row's first two entries are the depth's change per
// pixel there, relative to the depth at `at`. nullopt when `at` is at or behind P's horizon.
std::optional<cv::Matx33d> PerspectiveOnly(const cv::Matx33d &P, const cv::Point2d &at);

std::vector<cv::Point2f> ApplyPerspective(const cv::Matx33d &P,
                                          const std::vector<cv::Point2f> &points);

}  // namespace texfree
