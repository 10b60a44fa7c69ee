// Planar pose estimation.
#include "common/planar_pose.h"

#include <cmath>
#include <opencv2/calib3d.hpp>

#include "absl/strings/str_cat.h"

namespace texfree {

cv::Matx33d PixelScaling(const cv::Size &from, const cv::Size &to) {
  const double sx = static_cast<double>(to.width) / from.width;
  const double sy = static_cast<double>(to.height) / from.height;
  return cv::Matx33d(sx, 0, 0.5 * sx - 0.5, 0, sy, 0.5 * sy - 0.5, 0, 0, 1);
}

cv::Matx33d ScaledIntrinsics(const cv::Matx33d &K, const cv::Size &from, const cv::Size &to) {
  // K' = S K with S = PixelScaling (no skew): focal lengths and principal point scale alike.
  return PixelScaling(from, to) * K;
}

absl::StatusOr<CameraModel> CameraForImage(const CameraModel &camera, const cv::Size &image) {
  if (camera.size.area() <= 0 || camera.size == image) return camera;
  const double sx = static_cast<double>(image.width) / camera.size.width;
  const double sy = static_cast<double>(image.height) / camera.size.height;
  if (std::abs(sx / sy - 1) > 0.01) {
    return absl::InvalidArgumentError(absl::StrCat(
        "the image is ", image.width, "x", image.height, " but the intrinsics are for ",
        camera.size.width, "x", camera.size.height, " (a different aspect ratio)"));
  }
  CameraModel scaled = camera;
  scaled.K = ScaledIntrinsics(camera.K, camera.size, image);
  scaled.size = image;
  return scaled;
}

cv::Size WorkingSize(const cv::Size &image, int64_t max_pixels) {
  const int64_t pixels = static_cast<int64_t>(image.width) * image.height;
  if (max_pixels <= 0 || pixels <= max_pixels) return image;
  const double s = std::sqrt(static_cast<double>(max_pixels) / pixels);
  return {std::max(1, static_cast<int>(image.width * s)),
          std::max(1, static_cast<int>(image.height * s))};
}

cv::Size WholeFactorWorkingSize(const cv::Size &image, int64_t max_pixels) {
  const int64_t pixels = static_cast<int64_t>(image.width) * image.height;
  if (max_pixels <= 0 || pixels <= max_pixels) return image;
  int factor = static_cast<int>(std::ceil(std::sqrt(static_cast<double>(pixels) / max_pixels)));
  while (static_cast<int64_t>(image.width / factor) * (image.height / factor) > max_pixels)
    ++factor;
  return {std::max(1, image.width / factor), std::max(1, image.height / factor)};
}

absl::Status CameraModel::Validate() const {
  if (!(K(0, 0) > 0) || !(K(1, 1) > 0))
    return absl::InvalidArgumentError("camera focal lengths fx, fy must be positive");
  if (!std::isfinite(K(0, 2)) || !std::isfinite(K(1, 2)))
    return absl::InvalidArgumentError("camera principal point must be finite");
  if (!distortion.empty() && distortion.size() != 4 && distortion.size() != 5 &&
      distortion.size() != 8 && distortion.size() != 12 && distortion.size() != 14)
    return absl::InvalidArgumentError(absl::StrCat(
        "distortion has ", distortion.size(), " coefficients; OpenCV takes 4, 5, 8, 12 or 14"));
  for (double d : distortion)
    if (!std::isfinite(d)) return absl::InvalidArgumentError("distortion must be finite");
  return absl::OkStatus();
}

bool CameraModel::has_distortion() const {
  for (double d : distortion)
    if (d != 0) return true;
  return false;
}

absl::StatusOr<PlanarPose> PoseFromHomography(const cv::Matx33d &H, const cv::Matx33d &K,
                                              const cv::Point2d &visible_point) {
  const cv::Matx33d M = K.inv() * H;
  cv::Vec3d c1(M(0, 0), M(1, 0), M(2, 0)), c2(M(0, 1), M(1, 1), M(2, 1)),
      c3(M(0, 2), M(1, 2), M(2, 2));
  const double n1 = cv::norm(c1), n2 = cv::norm(c2);
  if (!(n1 > 1e-12) || !(n2 > 1e-12) || !std::isfinite(n1 + n2))
    return absl::InvalidArgumentError("degenerate homography: cannot recover a pose");
  double lambda = 2.0 / (n1 + n2);
  // H is known up to sign: choose the one that puts the visible point in front
  // of the camera (the plane's origin may be behind it when the camera is close
  // and tilted).
  const double depth = M(2, 0) * visible_point.x + M(2, 1) * visible_point.y + M(2, 2);
  if (depth * lambda < 0) lambda = -lambda;
  const cv::Vec3d r1 = c1 * lambda, r2 = c2 * lambda, r3 = r1.cross(r2);
  cv::Matx33d Q(r1[0], r2[0], r3[0], r1[1], r2[1], r3[1], r1[2], r2[2], r3[2]);
  cv::SVD svd(Q);
  cv::Mat R = svd.u * svd.vt;
  if (cv::determinant(R) < 0) return absl::InvalidArgumentError("homography mirrors the plane");
  PlanarPose pose;
  pose.R = cv::Matx33d(R);
  pose.t = c3 * lambda;
  return pose;
}

namespace {

// IPPE (when `initial` is null) then Levenberg-Marquardt on the reprojection error.
absl::StatusOr<PlanarPose> SolvePlanarPose(const std::vector<cv::Point2f> &plane,
                                           const std::vector<cv::Point2f> &pixels,
                                           const CameraModel &camera, const PlanarPose *initial) {
  if (plane.size() != pixels.size() || plane.size() < 4)
    return absl::InvalidArgumentError("planar pose needs at least 4 correspondences");
  std::vector<cv::Point3f> object;
  object.reserve(plane.size());
  for (const auto &p : plane) object.emplace_back(p.x, p.y, 0.f);
  cv::Mat rvec, tvec;
  const cv::Mat K(camera.K);
  const cv::Mat dist = camera.distortion.empty() ? cv::Mat() : cv::Mat(camera.distortion);
  bool ok = false;
  try {
    if (initial != nullptr) {
      cv::Rodrigues(cv::Mat(initial->R), rvec);
      tvec = cv::Mat(initial->t).clone();
      ok = true;
    } else {
      ok = cv::solvePnP(object, pixels, K, dist, rvec, tvec, false, cv::SOLVEPNP_IPPE);
    }
    if (ok) cv::solvePnPRefineLM(object, pixels, K, dist, rvec, tvec);
  } catch (const cv::Exception &e) {
    return absl::InvalidArgumentError(absl::StrCat("pose estimation failed: ", e.what()));
  }
  if (!ok) return absl::InvalidArgumentError("pose estimation did not converge");
  cv::Mat R;
  cv::Rodrigues(rvec, R);
  PlanarPose pose;
  pose.R = cv::Matx33d(R);
  pose.t = cv::Vec3d(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2));
  return pose;
}

}  // namespace

absl::StatusOr<PlanarPose> EstimatePlanarPose(const std::vector<cv::Point2f> &plane,
                                              const std::vector<cv::Point2f> &pixels,
                                              const CameraModel &camera) {
  return SolvePlanarPose(plane, pixels, camera, nullptr);
}

absl::StatusOr<PlanarPose> RefinePlanarPose(const std::vector<cv::Point2f> &plane,
                                            const std::vector<cv::Point2f> &pixels,
                                            const CameraModel &camera, const PlanarPose &initial) {
  return SolvePlanarPose(plane, pixels, camera, &initial);
}

cv::Matx33d HomographyFromPose(const PlanarPose &pose, const cv::Matx33d &K) {
  const cv::Matx33d Rt(pose.R(0, 0), pose.R(0, 1), pose.t[0], pose.R(1, 0), pose.R(1, 1), pose.t[1],
                       pose.R(2, 0), pose.R(2, 1), pose.t[2]);
  cv::Matx33d H = K * Rt;
  return H * (1.0 / H(2, 2));
}

cv::Point2d ApplyHomography(const cv::Matx33d &H, const cv::Point2d &p) {
  const double w = H(2, 0) * p.x + H(2, 1) * p.y + H(2, 2);
  return {(H(0, 0) * p.x + H(0, 1) * p.y + H(0, 2)) / w,
          (H(1, 0) * p.x + H(1, 1) * p.y + H(1, 2)) / w};
}

bool MakePlausibleHomography(cv::Matx33d *H_inout, const std::vector<cv::Point2f> &seen) {
  cv::Matx33d &H = *H_inout;
  if (seen.empty()) return false;
  for (double v : H.val)
    if (!std::isfinite(v)) return false;
  cv::Point2d c(0, 0);
  size_t positive = 0, negative = 0;
  for (const auto &p : seen) {
    const double w = H(2, 0) * p.x + H(2, 1) * p.y + H(2, 2);
    positive += w > 1e-9;
    negative += w < -1e-9;
    c += cv::Point2d(p.x, p.y);
  }
  if (positive != seen.size() && negative != seen.size()) return false;
  if (negative > 0) H = H * -1.0;
  c *= 1.0 / seen.size();
  const cv::Point2d p0 = ApplyHomography(H, c), px = ApplyHomography(H, c + cv::Point2d(1, 0)),
                    py = ApplyHomography(H, c + cv::Point2d(0, 1));
  const cv::Point2d ex = px - p0, ey = py - p0;
  const double det = ex.x * ey.y - ex.y * ey.x;
  if (!(det > 0)) return false;
  const double scale = std::sqrt(det);
  return scale > 1.0 / 40 && scale < 40;
}

}  // namespace texfree
