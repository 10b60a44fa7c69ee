// Planar pose estimation.
#include "common/planar_pose.h"

#include <cfloat>
#include <cmath>
#include <limits>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

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

// Sum of squared reprojection errors (pixels^2) of plane points (Z = 0) under a pinhole
// camera; infinity when a point is not in front of the camera.
double PinholeCost(const std::vector<cv::Point2f> &plane, const std::vector<cv::Point2f> &pixels,
                   const cv::Matx33d &K, const cv::Matx33d &R, const cv::Vec3d &t) {
  double cost = 0;
  for (size_t i = 0; i < plane.size(); ++i) {
    const cv::Vec3d X = R * cv::Vec3d(plane[i].x, plane[i].y, 0) + t;
    if (X[2] <= 1e-9) return std::numeric_limits<double>::infinity();
    const double u = (K(0, 0) * X[0] + K(0, 1) * X[1]) / X[2] + K(0, 2) - pixels[i].x;
    const double v = K(1, 1) * X[1] / X[2] + K(1, 2) - pixels[i].y;
    cost += u * u + v * v;
  }
  return cost;
}

// Levenberg-Marquardt on the reprojection error for a camera without lens distortion, with
// the derivatives written out: a rotation step on the left (R <- exp([w]x) R) and a
// translation step. cv::solvePnPRefineLM differentiates its general projection (distortion
// and intrinsics included) at every point and iteration, which made it a twentieth of a
// pool frame for the table's 500-900 edge points; this is the same minimum at a tenth of
// the cost. Stops as solvePnPRefineLM does: 20 iterations, or a step under FLT_EPSILON.
// It projects with the whole K, skew included (cv::projectPoints leaves skew out).
PlanarPose RefinePinholePose(const std::vector<cv::Point2f> &plane,
                             const std::vector<cv::Point2f> &pixels, const cv::Matx33d &K,
                             const PlanarPose &initial) {
  cv::Matx33d R = initial.R;
  cv::Vec3d t = initial.t;
  double cost = PinholeCost(plane, pixels, K, R, t);
  double lambda = 1e-3;
  for (int iteration = 0; iteration < 20 && std::isfinite(cost); ++iteration) {
    cv::Matx<double, 6, 6> JtJ = cv::Matx<double, 6, 6>::zeros();
    cv::Vec<double, 6> Jtr = cv::Vec<double, 6>::all(0);
    for (size_t i = 0; i < plane.size(); ++i) {
      const cv::Vec3d RP = R * cv::Vec3d(plane[i].x, plane[i].y, 0);
      const cv::Vec3d X = RP + t;
      const double iz = 1 / X[2];
      const double ru = (K(0, 0) * X[0] + K(0, 1) * X[1]) * iz + K(0, 2) - pixels[i].x;
      const double rv = K(1, 1) * X[1] * iz + K(1, 2) - pixels[i].y;
      // d(u, v)/dX, then dX/dw = -[RP]x and dX/dt = I.
      const cv::Vec3d du(K(0, 0) * iz, K(0, 1) * iz, -(K(0, 0) * X[0] + K(0, 1) * X[1]) * iz * iz);
      const cv::Vec3d dv(0, K(1, 1) * iz, -K(1, 1) * X[1] * iz * iz);
      const cv::Vec3d du_dw = RP.cross(du), dv_dw = RP.cross(dv);  // -[RP]x^T d = RP x d
      const double ju[6] = {du_dw[0], du_dw[1], du_dw[2], du[0], du[1], du[2]};
      const double jv[6] = {dv_dw[0], dv_dw[1], dv_dw[2], dv[0], dv[1], dv[2]};
      for (int a = 0; a < 6; ++a) {
        Jtr[a] += ju[a] * ru + jv[a] * rv;
        for (int b = a; b < 6; ++b) JtJ(a, b) += ju[a] * ju[b] + jv[a] * jv[b];
      }
    }
    for (int a = 0; a < 6; ++a)
      for (int b = 0; b < a; ++b) JtJ(a, b) = JtJ(b, a);
    bool improved = false;
    cv::Vec<double, 6> step;
    for (int attempt = 0; attempt < 10 && !improved; ++attempt) {
      cv::Matx<double, 6, 6> A = JtJ;
      for (int a = 0; a < 6; ++a) A(a, a) *= 1 + lambda;
      if (!cv::solve(A, -Jtr, step, cv::DECOMP_CHOLESKY)) {
        lambda *= 10;
        continue;
      }
      cv::Matx33d dR;
      cv::Rodrigues(cv::Vec3d(step[0], step[1], step[2]), dR);
      const cv::Matx33d R_new = dR * R;
      const cv::Vec3d t_new = t + cv::Vec3d(step[3], step[4], step[5]);
      const double cost_new = PinholeCost(plane, pixels, K, R_new, t_new);
      if (cost_new <= cost) {
        R = R_new;
        t = t_new;
        cost = cost_new;
        lambda = std::max(lambda / 10, 1e-12);
        improved = true;
      } else {
        lambda *= 10;
      }
    }
    if (!improved || cv::norm(step) < FLT_EPSILON) break;
  }
  PlanarPose pose;
  pose.R = R;
  pose.t = t;
  return pose;
}

// IPPE (when `initial` is null) then Levenberg-Marquardt on the reprojection error.
absl::StatusOr<PlanarPose> SolvePlanarPose(const std::vector<cv::Point2f> &plane,
                                           const std::vector<cv::Point2f> &pixels,
                                           const CameraModel &camera, const PlanarPose *initial) {
  if (plane.size() != pixels.size() || plane.size() < 4)
    return absl::InvalidArgumentError("planar pose needs at least 4 correspondences");
  // Without distortion, and with every point in front of the starting pose, the pinhole
  // refinement (OpenCV's otherwise).
  if (initial != nullptr && !camera.has_distortion() &&
      std::isfinite(PinholeCost(plane, pixels, camera.K, initial->R, initial->t)))
    return RefinePinholePose(plane, pixels, camera.K, *initial);
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

std::optional<double> FocalLengthFromRectangle(const std::array<cv::Point2d, 4> &corners,
                                               const cv::Point2d &principal_point, double width,
                                               double height) {
  const float w = static_cast<float>(width), h = static_cast<float>(height);
  const cv::Point2f plane[4] = {{0, 0}, {w, 0}, {w, h}, {0, h}};
  cv::Point2f pixels[4];
  for (int i = 0; i < 4; ++i) pixels[i] = cv::Point2f(corners[i] - principal_point);
  const cv::Matx33d H = cv::getPerspectiveTransform(plane, pixels);
  // With h1, h2 the columns: h1 . h2 = 0 and |h1| = |h2| through K^-1, linear in 1 / f^2:
  //   (h1x h2x + h1y h2y) / f^2 + h1z h2z = 0
  //   (h1x^2 + h1y^2 - h2x^2 - h2y^2) / f^2 + h1z^2 - h2z^2 = 0
  // Each row is scaled to the size of its terms so that both weigh alike.
  const cv::Vec3d h1(H(0, 0), H(1, 0), H(2, 0)), h2(H(0, 1), H(1, 1), H(2, 1));
  const double xy1 = h1[0] * h1[0] + h1[1] * h1[1], xy2 = h2[0] * h2[0] + h2[1] * h2[1];
  const double a1 = h1[0] * h2[0] + h1[1] * h2[1], b1 = h1[2] * h2[2];
  const double a2 = xy1 - xy2, b2 = h1[2] * h1[2] - h2[2] * h2[2];
  const double s1 = std::sqrt(xy1 * xy2), s2 = xy1 + xy2;
  if (!(s1 > 0 && s2 > 0)) return std::nullopt;
  const double A1 = a1 / s1, B1 = b1 / s1, A2 = a2 / s2, B2 = b2 / s2;
  const double AA = A1 * A1 + A2 * A2;
  if (!(AA > 0)) return std::nullopt;
  // Both vanishing points at infinity (h1z = h2z = 0) leave 1 / f^2 = 0: not fixed.
  const double inv_f2 = -(A1 * B1 + A2 * B2) / AA;
  if (!(inv_f2 > 0) || !std::isfinite(inv_f2)) return std::nullopt;
  return 1 / std::sqrt(inv_f2);
}

cv::Point2d ApplyHomography(const cv::Matx33d &H, const cv::Point2d &p) {
  const double w = H(2, 0) * p.x + H(2, 1) * p.y + H(2, 2);
  return {(H(0, 0) * p.x + H(0, 1) * p.y + H(0, 2)) / w,
          (H(1, 0) * p.x + H(1, 1) * p.y + H(1, 2)) / w};
}

std::optional<cv::Matx22d> HomographyJacobian(const cv::Matx33d &H, const cv::Point2d &p) {
  const double w = H(2, 0) * p.x + H(2, 1) * p.y + H(2, 2);
  if (!(w > 0)) return std::nullopt;
  const double x = (H(0, 0) * p.x + H(0, 1) * p.y + H(0, 2)) / w;
  const double y = (H(1, 0) * p.x + H(1, 1) * p.y + H(1, 2)) / w;
  const cv::Matx22d J((H(0, 0) - x * H(2, 0)) / w, (H(0, 1) - x * H(2, 1)) / w,
                      (H(1, 0) - y * H(2, 0)) / w, (H(1, 1) - y * H(2, 1)) / w);
  for (int i = 0; i < 4; ++i)
    if (!std::isfinite(J.val[i])) return std::nullopt;
  return J;
}

double HomographyLocalScale(const cv::Matx33d &H, const cv::Point2d &p) {
  const auto J = HomographyJacobian(H, p);
  return J ? std::sqrt(std::abs(cv::determinant(*J))) : 0.0;
}

bool MapPointsInFront(const cv::Matx33d &H, const std::vector<cv::Point2d> &in,
                      std::vector<cv::Point2d> *out) {
  out->clear();
  out->reserve(in.size());
  for (const cv::Point2d &p : in) {
    const double w = H(2, 0) * p.x + H(2, 1) * p.y + H(2, 2);
    if (!(w > 1e-12)) return false;
    const cv::Point2d q((H(0, 0) * p.x + H(0, 1) * p.y + H(0, 2)) / w,
                        (H(1, 0) * p.x + H(1, 1) * p.y + H(1, 2)) / w);
    if (!std::isfinite(q.x) || !std::isfinite(q.y)) return false;
    out->push_back(q);
  }
  return true;
}

std::vector<cv::Point2d> RectCorners(const cv::Rect2d &r) {
  return {r.tl(), {r.x + r.width, r.y}, r.br(), {r.x, r.y + r.height}};
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
  if (!(scale > 1.0 / 40 && scale < 40)) return false;
  // The local map's singular values s1 >= s2: s1 s2 = det, s1^2 + s2^2 = |ex|^2 + |ey|^2.
  // A plane tilted by t from the camera axis is shortened by cos t along the tilt, so a map
  // squeezing one way kMaxAnisotropy times more than the other sees the page nearly edge-on
  // (83 degrees): such a fit collapses the page towards a line, along which chance
  // alignments with the view's keypoints are many (a heading and a polyline matched a
  // three-column page's words that way at 10,000 pages).
  constexpr double kMaxAnisotropy = 8.0;
  const double sum = ex.dot(ex) + ey.dot(ey);
  const double root = std::sqrt(std::max(0.0, sum * sum - 4 * det * det));
  const double s1 = std::sqrt((sum + root) / 2), s2 = std::sqrt(std::max(0.0, (sum - root) / 2));
  return s1 <= kMaxAnisotropy * s2;
}

}  // namespace texfree
