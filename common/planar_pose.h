// Camera pose of a plane from a homography (seed appendix A) and its
// refinement.
#pragma once

#include <array>
#include <opencv2/core.hpp>
#include <optional>
#include <vector>

#include "absl/status/statusor.h"

namespace texfree {

// How a picture's values relate to the light: sRGB-encoded (what phones, cameras and JPEG
// files give) or in proportion to it (a raw-like picture, or a renderer that writes its
// light out unencoded).
enum class PixelEncoding { kSrgb, kLinear };

struct CameraModel {
  cv::Matx33d K = cv::Matx33d::eye();
  std::vector<double> distortion;  // OpenCV order k1 k2 p1 p2 [k3 ...]; empty = none
  cv::Size size;

  absl::Status Validate() const;
  bool has_distortion() const;
};

// World -> camera: x_cam = R * X + t. The plane is Z = 0 of the world frame.
struct PlanarPose {
  cv::Matx33d R = cv::Matx33d::eye();
  cv::Vec3d t;
};

// Resizing: pixel centres are kept, x' = (x + 0.5) * s - 0.5 along each axis.
// The intrinsics of the same camera in the image resized from `from` to `to` pixels.
cv::Matx33d ScaledIntrinsics(const cv::Matx33d &K, const cv::Size &from, const cv::Size &to);
// The homography taking pixels of an image of `from` pixels to the image resized to `to`.
cv::Matx33d PixelScaling(const cv::Size &from, const cv::Size &to);
// The camera's model for pictures of `image` pixels: as given when its size is unset (0) or
// `image`; the same sensor read out at another resolution (the same aspect ratio within 1%)
// gets its intrinsics scaled; another aspect ratio is an InvalidArgument error naming both.
absl::StatusOr<CameraModel> CameraForImage(const CameraModel &camera, const cv::Size &image);
// `image` reduced to at most `max_pixels` pixels with its aspect ratio; `image` itself when it
// is not larger or max_pixels <= 0 (no limit).
cv::Size WorkingSize(const cv::Size &image, int64_t max_pixels);
// The same, divided by the smallest whole factor that brings it to at most `max_pixels`
// (INTER_AREA's fast path: a 12 MP picture is reduced by 3 in ~5 ms instead of ~22 ms by
// 2.5), with the sides rounded down.
cv::Size WholeFactorWorkingSize(const cv::Size &image, int64_t max_pixels);

// Appendix A: [r1 r2 t] = K^-1 H up to scale, r3 = r1 x r2, then the closest
// rotation (SVD). The sign is fixed so that visible_point (a plane point seen
// in the image, e.g. the centre of the inliers) lies in front of the camera.
absl::StatusOr<PlanarPose> PoseFromHomography(const cv::Matx33d &H, const cv::Matx33d &K,
                                              const cv::Point2d &visible_point = {0, 0});

// Pose from plane points (Z = 0) and their pixels, honouring lens distortion:
// IPPE then Levenberg-Marquardt on the reprojection error. Needs at least 4
// correspondences.
absl::StatusOr<PlanarPose> EstimatePlanarPose(const std::vector<cv::Point2f> &plane,
                                              const std::vector<cv::Point2f> &pixels,
                                              const CameraModel &camera);

// The same Levenberg-Marquardt refinement started from `initial` instead of IPPE's
// solution, for a pose already close (re-fitted to new correspondences).
absl::StatusOr<PlanarPose> RefinePlanarPose(const std::vector<cv::Point2f> &plane,
                                            const std::vector<cv::Point2f> &pixels,
                                            const CameraModel &camera, const PlanarPose &initial);

// The homography plane -> pixels of a pose: K [r1 r2 t], normalised to H(2,2)
// = 1.
cv::Matx33d HomographyFromPose(const PlanarPose &pose, const cv::Matx33d &K);

// The focal length (pixels, square pixels) under which `corners` (ideal pixels, in the
// order (0,0), (width,0), (width,height), (0,height) of a rectangle of those sides) are a
// rectangle seen by a camera with this principal point: the homography's first two
// columns, through K^-1, orthogonal and of equal length, solved for 1/f^2 in least
// squares. nullopt when the view leaves it unfixed (both vanishing points at infinity, a
// rectangle seen square on) or the solution is not a real focal length.
std::optional<double> FocalLengthFromRectangle(const std::array<cv::Point2d, 4> &corners,
                                               const cv::Point2d &principal_point, double width,
                                               double height);

// Applies a homography to a point.
cv::Point2d ApplyHomography(const cv::Matx33d &H, const cv::Point2d &p);

// The homography's Jacobian at p (output pixels per input pixel): nullopt when p lies at or
// behind the horizon (w <= 0) or the Jacobian is not finite.
std::optional<cv::Matx22d> HomographyJacobian(const cv::Matx33d &H, const cv::Point2d &p);

// Local area scale of H around p: sqrt |det J|, 0 where the Jacobian is undefined. How
// much larger a small thing at p is drawn (a text's font size, a stroke's width).
double HomographyLocalScale(const cv::Matx33d &H, const cv::Point2d &p);

// Applies a homography to points: false when one lies at or behind the horizon (w <= 0,
// behind the camera) or maps to a non-finite point; `out` then holds the points before it.
bool MapPointsInFront(const cv::Matx33d &H, const std::vector<cv::Point2d> &in,
                      std::vector<cv::Point2d> *out);

// A rectangle's corners: top-left, top-right, bottom-right, bottom-left (clockwise in
// image axes).
std::vector<cv::Point2d> RectCorners(const cv::Rect2d &r);

// Checks a page homography against the plane points seen in the image: finite, every seen
// point on the same side of the horizon, the page not mirrored, its local scale in
// (1/40, 40) at their centre and not stretched 8 times more one way than the other there
// (a page seen nearly edge-on, 83 degrees or more). H is known up to scale, sign included: it is
// negated if need be so that w > 0 at the seen points (in front of the camera). False for no
// points.
bool MakePlausibleHomography(cv::Matx33d *H, const std::vector<cv::Point2f> &seen);

}  // namespace texfree
