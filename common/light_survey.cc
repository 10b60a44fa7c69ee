// View poses from references, triangulation, bundle adjustment and uncertainties.
#include "common/light_survey.h"

#include <algorithm>
#include <cmath>
#include <set>

#include <Eigen/Dense>
#include <opencv2/calib3d.hpp>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"

namespace texfree::survey {
namespace {

cv::Mat DistortionMat(const CameraModel& camera) {
  if (camera.distortion.empty()) return cv::Mat();
  return cv::Mat(camera.distortion, true).reshape(1, 1);
}

cv::Vec3d RotationVector(const cv::Matx33d& R) {
  cv::Vec3d r;
  cv::Rodrigues(R, r);
  return r;
}

cv::Matx33d RotationMatrix(const cv::Vec3d& r) {
  cv::Matx33d R;
  cv::Rodrigues(r, R);
  return R;
}

// Pixel of X and its Jacobians with respect to the pose (rvec, t: 2x6) and the point (2x3).
cv::Point2d ProjectWithJacobians(const CameraModel& camera, const cv::Vec3d& rvec,
                                 const cv::Vec3d& t, const cv::Point3d& X,
                                 Eigen::Matrix<double, 2, 6>* d_pose,
                                 Eigen::Matrix<double, 2, 3>* d_point) {
  std::vector<cv::Point3d> object = {X};
  std::vector<cv::Point2d> image;
  cv::Mat jacobian;
  cv::projectPoints(object, rvec, t, cv::Mat(camera.K), DistortionMat(camera), image, jacobian);
  Eigen::Matrix<double, 2, 3> d_t;
  for (int r = 0; r < 2; ++r) {
    for (int c = 0; c < 6; ++c) {
      const double v = jacobian.at<double>(r, c);
      if (d_pose) (*d_pose)(r, c) = v;
      if (c >= 3) d_t(r, c - 3) = v;
    }
  }
  if (d_point) {
    const cv::Matx33d R = RotationMatrix(rvec);
    Eigen::Matrix3d Re;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) Re(r, c) = R(r, c);
    *d_point = d_t * Re;  // x_cam = R X + t
  }
  return image[0];
}

double Depth(const CameraPose& pose, const cv::Point3d& X) {
  const cv::Vec3d c = pose.R * cv::Vec3d(X.x, X.y, X.z) + pose.t;
  return c[2];
}

}  // namespace

cv::Point3d CameraPose::Center() const {
  const cv::Vec3d c = -(R.t() * t);
  return {c[0], c[1], c[2]};
}

cv::Point2d ProjectPoint(const CameraModel& camera, const CameraPose& pose, const cv::Point3d& X) {
  if (Depth(pose, X) <= 0) return {std::nan(""), std::nan("")};
  std::vector<cv::Point3d> object = {X};
  std::vector<cv::Point2d> image;
  cv::projectPoints(object, RotationVector(pose.R), pose.t, cv::Mat(camera.K),
                    DistortionMat(camera), image);
  return image[0];
}

absl::Status PoseOptions::Validate() const {
  if (min_references < 4) return absl::InvalidArgumentError("min_references must be at least 4");
  if (!(ransac_threshold_px > 0)) return absl::InvalidArgumentError("ransac_threshold_px must be > 0");
  if (ransac_iterations < 1) return absl::InvalidArgumentError("ransac_iterations must be >= 1");
  if (!(ransac_confidence > 0 && ransac_confidence < 1))
    return absl::InvalidArgumentError("ransac_confidence must be in (0, 1)");
  return absl::OkStatus();
}

absl::Status TriangulationOptions::Validate() const {
  if (min_views < 2) return absl::InvalidArgumentError("min_views must be at least 2");
  if (!(pixel_sigma > 0)) return absl::InvalidArgumentError("pixel_sigma must be > 0");
  if (max_iterations < 1) return absl::InvalidArgumentError("max_iterations must be >= 1");
  if (!(min_ray_angle_deg >= 0 && min_ray_angle_deg < 90))
    return absl::InvalidArgumentError("min_ray_angle_deg must be in [0, 90)");
  return absl::OkStatus();
}

absl::Status SolveOptions::Validate() const {
  if (absl::Status s = pose.Validate(); !s.ok()) return s;
  if (absl::Status s = triangulation.Validate(); !s.ok()) return s;
  if (bundle_iterations < 1) return absl::InvalidArgumentError("bundle_iterations must be >= 1");
  return absl::OkStatus();
}

absl::StatusOr<PoseResult> EstimateViewPose(const std::vector<cv::Point3d>& world,
                                            const std::vector<cv::Point2d>& pixels,
                                            const CameraModel& camera, const PoseOptions& options) {
  if (absl::Status s = options.Validate(); !s.ok()) return s;
  if (absl::Status s = camera.Validate(); !s.ok()) return s;
  if (world.size() != pixels.size()) {
    return absl::InvalidArgumentError("world points and pixels differ in number");
  }
  if (static_cast<int>(world.size()) < options.min_references) {
    return absl::FailedPreconditionError(absl::StrCat(
        "a view needs at least ", options.min_references, " reference lights to be posed; it sees ",
        world.size()));
  }
  cv::Vec3d rvec, tvec;
  std::vector<int> inliers;
  bool found = false;
  try {
    found = cv::solvePnPRansac(world, pixels, cv::Mat(camera.K), DistortionMat(camera), rvec, tvec,
                               false, options.ransac_iterations,
                               static_cast<float>(options.ransac_threshold_px),
                               options.ransac_confidence, inliers, cv::SOLVEPNP_ITERATIVE);
  } catch (const cv::Exception& e) {
    return absl::FailedPreconditionError(absl::StrCat("pose estimation failed: ", e.what()));
  }
  if (!found || static_cast<int>(inliers.size()) < options.min_references) {
    return absl::FailedPreconditionError(absl::StrCat(
        "no camera pose agrees with ", options.min_references,
        " or more of the view's reference lights within ", options.ransac_threshold_px,
        " px: check the reference coordinates and the intrinsics"));
  }
  std::vector<cv::Point3d> world_in;
  std::vector<cv::Point2d> pixels_in;
  for (int i : inliers) {
    world_in.push_back(world[i]);
    pixels_in.push_back(pixels[i]);
  }
  try {
    cv::solvePnPRefineLM(world_in, pixels_in, cv::Mat(camera.K), DistortionMat(camera), rvec, tvec,
                         cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 50,
                                          1e-10));
  } catch (const cv::Exception& e) {
    return absl::FailedPreconditionError(absl::StrCat("pose refinement failed: ", e.what()));
  }
  PoseResult result;
  result.pose.R = RotationMatrix(rvec);
  result.pose.t = tvec;
  // Inliers again with the refined pose (a refinement can recover borderline points).
  result.inliers.clear();
  double sum_sq = 0;
  for (size_t i = 0; i < world.size(); ++i) {
    const cv::Point2d p = ProjectPoint(camera, result.pose, world[i]);
    const double e = cv::norm(p - pixels[i]);
    if (std::isfinite(e) && e <= options.ransac_threshold_px) {
      result.inliers.push_back(static_cast<int>(i));
      sum_sq += e * e;
    }
  }
  if (static_cast<int>(result.inliers.size()) < options.min_references) {
    return absl::FailedPreconditionError("the refined pose lost its inliers");
  }
  result.rms_px = std::sqrt(sum_sq / result.inliers.size());
  return result;
}

absl::StatusOr<TriangulatedPoint> TriangulatePoint(const std::vector<CameraPose>& poses,
                                                   const std::vector<cv::Point2d>& pixels,
                                                   const CameraModel& camera,
                                                   const TriangulationOptions& options) {
  if (absl::Status s = options.Validate(); !s.ok()) return s;
  if (poses.size() != pixels.size()) {
    return absl::InvalidArgumentError("poses and pixels differ in number");
  }
  const int n = static_cast<int>(poses.size());
  if (n < options.min_views) {
    return absl::FailedPreconditionError(
        absl::StrCat("seen in ", n, " posed views; triangulation needs ", options.min_views));
  }
  // Linear (DLT) on undistorted normalised coordinates.
  std::vector<cv::Point2d> normalised;
  cv::undistortPoints(pixels, normalised, cv::Mat(camera.K), DistortionMat(camera));
  Eigen::MatrixXd A(2 * n, 4);
  std::vector<cv::Vec3d> rays(n);
  for (int i = 0; i < n; ++i) {
    const cv::Matx33d& R = poses[i].R;
    const cv::Vec3d& t = poses[i].t;
    const double x = normalised[i].x, y = normalised[i].y;
    for (int c = 0; c < 3; ++c) {
      A(2 * i, c) = x * R(2, c) - R(0, c);
      A(2 * i + 1, c) = y * R(2, c) - R(1, c);
    }
    A(2 * i, 3) = x * t[2] - t[0];
    A(2 * i + 1, 3) = y * t[2] - t[1];
    rays[i] = cv::normalize(poses[i].R.t() * cv::Vec3d(x, y, 1));
    const double norm = A.row(2 * i).norm() + A.row(2 * i + 1).norm();
    A.row(2 * i) /= norm;
    A.row(2 * i + 1) /= norm;
  }
  double max_angle = 0;
  for (int i = 0; i < n; ++i)
    for (int j = i + 1; j < n; ++j)
      max_angle = std::max(max_angle, std::acos(std::clamp(rays[i].dot(rays[j]), -1.0, 1.0)));
  if (max_angle * 180 / CV_PI < options.min_ray_angle_deg) {
    return absl::FailedPreconditionError(absl::StrCat(
        "rays meet at ", max_angle * 180 / CV_PI, " degrees, under ", options.min_ray_angle_deg,
        ": move the viewpoints further apart"));
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(A, Eigen::ComputeFullV);
  const Eigen::Vector4d h = svd.matrixV().col(3);
  if (std::fabs(h[3]) < 1e-12) return absl::FailedPreconditionError("point at infinity");
  cv::Point3d X(h[0] / h[3], h[1] / h[3], h[2] / h[3]);
  for (const auto& pose : poses) {
    if (Depth(pose, X) <= 0) return absl::FailedPreconditionError("point lies behind a camera");
  }
  // Gauss-Newton on the pixel reprojection error (distortion included).
  std::vector<cv::Vec3d> rvecs(n);
  for (int i = 0; i < n; ++i) rvecs[i] = RotationVector(poses[i].R);
  Eigen::Matrix3d JtJ;
  double sum_sq = 0;
  for (int iter = 0; iter < options.max_iterations; ++iter) {
    JtJ.setZero();
    Eigen::Vector3d Jtr = Eigen::Vector3d::Zero();
    sum_sq = 0;
    for (int i = 0; i < n; ++i) {
      Eigen::Matrix<double, 2, 3> J;
      const cv::Point2d p = ProjectWithJacobians(camera, rvecs[i], poses[i].t, X, nullptr, &J);
      const Eigen::Vector2d r(p.x - pixels[i].x, p.y - pixels[i].y);
      sum_sq += r.squaredNorm();
      JtJ += J.transpose() * J;
      Jtr += J.transpose() * r;
    }
    const Eigen::Vector3d step = JtJ.ldlt().solve(-Jtr);
    X += cv::Point3d(step[0], step[1], step[2]);
    if (step.norm() < 1e-9) break;
  }
  // Final residual and normal matrix at the solution.
  JtJ.setZero();
  sum_sq = 0;
  for (int i = 0; i < n; ++i) {
    Eigen::Matrix<double, 2, 3> J;
    const cv::Point2d p = ProjectWithJacobians(camera, rvecs[i], poses[i].t, X, nullptr, &J);
    sum_sq += (p.x - pixels[i].x) * (p.x - pixels[i].x) + (p.y - pixels[i].y) * (p.y - pixels[i].y);
    JtJ += J.transpose() * J;
  }
  TriangulatedPoint result;
  result.position = X;
  result.views = n;
  result.rms_px = std::sqrt(sum_sq / n);
  // sigma^2 (J^T J)^-1, sigma from the prior or, with redundancy, the residuals.
  const int dof = 2 * n - 3;
  double sigma = options.pixel_sigma;
  if (dof >= 3) sigma = std::max(sigma, std::sqrt(sum_sq / dof));
  const Eigen::Matrix3d covariance = sigma * sigma * JtJ.inverse();
  result.sigma = cv::Vec3d(std::sqrt(covariance(0, 0)), std::sqrt(covariance(1, 1)),
                           std::sqrt(covariance(2, 2)));
  return result;
}

namespace {

struct BundleObservation {
  int view = 0;        // index into posed views
  int point = -1;      // index into free points, or -1 for a fixed reference
  cv::Point3d fixed;   // the reference position when point == -1
  cv::Point2d pixel;
};

// Dense Levenberg-Marquardt over [rvec t] per view and X per free point. Returns the marginal
// 1-sigma of each free point from the inverse normal matrix.
absl::Status BundleAdjust(const CameraModel& camera, std::vector<CameraPose>* poses,
                          std::vector<cv::Point3d>* points,
                          const std::vector<BundleObservation>& observations, int max_iterations,
                          double pixel_sigma, std::vector<cv::Vec3d>* point_sigma,
                          double* initial_rms, double* final_rms) {
  const int views = static_cast<int>(poses->size());
  const int free_points = static_cast<int>(points->size());
  const int params = 6 * views + 3 * free_points;
  const int residuals = 2 * static_cast<int>(observations.size());
  if (params > 3000) {
    return absl::FailedPreconditionError(absl::StrCat(
        "bundle adjustment of ", params, " parameters is over the dense solver's limit of 3000"));
  }
  if (residuals <= params) {
    return absl::FailedPreconditionError("bundle adjustment needs more observations than unknowns");
  }
  std::vector<cv::Vec3d> rvecs(views), tvecs(views);
  for (int v = 0; v < views; ++v) {
    rvecs[v] = RotationVector((*poses)[v].R);
    tvecs[v] = (*poses)[v].t;
  }
  std::vector<cv::Point3d> X = *points;
  auto evaluate = [&](const std::vector<cv::Vec3d>& rv, const std::vector<cv::Vec3d>& tv,
                      const std::vector<cv::Point3d>& xs, Eigen::MatrixXd* J, Eigen::VectorXd* r) {
    double cost = 0;
    if (J) J->setZero(residuals, params);
    if (r) r->resize(residuals);
    for (size_t i = 0; i < observations.size(); ++i) {
      const auto& o = observations[i];
      const cv::Point3d& P = o.point >= 0 ? xs[o.point] : o.fixed;
      Eigen::Matrix<double, 2, 6> d_pose;
      Eigen::Matrix<double, 2, 3> d_point;
      const cv::Point2d p = ProjectWithJacobians(camera, rv[o.view], tv[o.view], P,
                                                 J ? &d_pose : nullptr, J ? &d_point : nullptr);
      const double rx = p.x - o.pixel.x, ry = p.y - o.pixel.y;
      cost += rx * rx + ry * ry;
      if (r) {
        (*r)[2 * i] = rx;
        (*r)[2 * i + 1] = ry;
      }
      if (J) {
        J->block<2, 6>(2 * i, 6 * o.view) = d_pose;
        if (o.point >= 0) J->block<2, 3>(2 * i, 6 * views + 3 * o.point) = d_point;
      }
    }
    return cost;
  };
  Eigen::MatrixXd J;
  Eigen::VectorXd r;
  double cost = evaluate(rvecs, tvecs, X, &J, &r);
  *initial_rms = std::sqrt(cost / observations.size());
  double lambda = 1e-3;
  for (int iter = 0; iter < max_iterations; ++iter) {
    const Eigen::MatrixXd H = J.transpose() * J;
    const Eigen::VectorXd g = J.transpose() * r;
    bool improved = false;
    for (int attempt = 0; attempt < 10 && !improved; ++attempt) {
      Eigen::MatrixXd damped = H;
      for (int k = 0; k < params; ++k) damped(k, k) += lambda * std::max(H(k, k), 1e-9);
      const Eigen::VectorXd step = damped.ldlt().solve(-g);
      std::vector<cv::Vec3d> rv = rvecs, tv = tvecs;
      std::vector<cv::Point3d> xs = X;
      for (int v = 0; v < views; ++v) {
        for (int c = 0; c < 3; ++c) {
          rv[v][c] += step[6 * v + c];
          tv[v][c] += step[6 * v + 3 + c];
        }
      }
      for (int p = 0; p < free_points; ++p) {
        xs[p] += cv::Point3d(step[6 * views + 3 * p], step[6 * views + 3 * p + 1],
                             step[6 * views + 3 * p + 2]);
      }
      const double new_cost = evaluate(rv, tv, xs, nullptr, nullptr);
      if (std::isfinite(new_cost) && new_cost < cost) {
        const bool converged = cost - new_cost < 1e-12 * cost;
        rvecs = rv, tvecs = tv, X = xs;
        cost = evaluate(rvecs, tvecs, X, &J, &r);
        lambda = std::max(lambda / 10, 1e-12);
        improved = true;
        if (converged) iter = max_iterations;
      } else {
        lambda *= 10;
      }
    }
    if (!improved) break;
  }
  *final_rms = std::sqrt(cost / observations.size());
  for (int v = 0; v < views; ++v) {
    (*poses)[v].R = RotationMatrix(rvecs[v]);
    (*poses)[v].t = tvecs[v];
  }
  *points = X;
  // Covariance: sigma^2 (J^T J)^-1, sigma from the prior or the residual if larger.
  const double sigma =
      std::max(pixel_sigma, std::sqrt(cost / std::max(1, residuals - params)));
  const Eigen::MatrixXd H = J.transpose() * J;
  Eigen::FullPivLU<Eigen::MatrixXd> lu(H);
  point_sigma->assign(free_points, cv::Vec3d(0, 0, 0));
  if (lu.isInvertible()) {
    const Eigen::MatrixXd covariance = sigma * sigma * lu.inverse();
    for (int p = 0; p < free_points; ++p) {
      const int k = 6 * views + 3 * p;
      (*point_sigma)[p] = cv::Vec3d(std::sqrt(covariance(k, k)), std::sqrt(covariance(k + 1, k + 1)),
                                    std::sqrt(covariance(k + 2, k + 2)));
    }
  }
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<SurveySolution> SolveSurvey(const CameraModel& camera,
                                           const std::map<uint32_t, cv::Point3d>& references,
                                           const std::vector<ViewInput>& views,
                                           const SolveOptions& options) {
  if (absl::Status s = options.Validate(); !s.ok()) return s;
  if (absl::Status s = camera.Validate(); !s.ok()) return s;
  SurveySolution solution;
  std::vector<int> posed;  // indices of posed views
  for (const ViewInput& view : views) {
    ViewSolution vs;
    vs.name = view.name;
    std::vector<cv::Point3d> world;
    std::vector<cv::Point2d> pixels;
    for (const auto& light : view.lights) {
      if (light.conflict) continue;
      auto ref = references.find(light.id);
      if (ref == references.end()) continue;
      world.push_back(ref->second);
      pixels.push_back(light.pixel);
    }
    auto pose = EstimateViewPose(world, pixels, camera, options.pose);
    if (pose.ok()) {
      vs.posed = true;
      vs.pose = pose->pose;
      vs.references_used = static_cast<int>(pose->inliers.size());
      posed.push_back(static_cast<int>(solution.views.size()));
    } else {
      vs.pose_error = std::string(pose.status().message());
    }
    solution.views.push_back(std::move(vs));
  }
  if (posed.size() < 2) {
    std::vector<std::string> reasons;
    for (const auto& v : solution.views) {
      if (!v.posed) reasons.push_back(absl::StrCat("view '", v.name, "': ", v.pose_error));
    }
    return absl::FailedPreconditionError(absl::StrCat(
        "triangulation needs at least 2 posed views; ", posed.size(), " of ", views.size(),
        " could be posed", reasons.empty() ? "" : ". ", absl::StrJoin(reasons, "; ")));
  }
  // Observations of every non-reference light in posed views.
  std::map<uint32_t, std::vector<std::pair<int, cv::Point2d>>> seen;  // id -> (view, pixel)
  for (int v : posed) {
    for (const auto& light : views[v].lights) {
      if (light.conflict || references.count(light.id)) continue;
      seen[light.id].emplace_back(v, light.pixel);
    }
  }
  for (const auto& [id, obs] : seen) {
    std::vector<CameraPose> poses;
    std::vector<cv::Point2d> pixels;
    for (const auto& [v, pixel] : obs) {
      poses.push_back(solution.views[v].pose);
      pixels.push_back(pixel);
    }
    if (static_cast<int>(obs.size()) < options.triangulation.min_views) continue;
    auto point = TriangulatePoint(poses, pixels, camera, options.triangulation);
    if (!point.ok()) continue;
    solution.points.push_back({id, point->position, point->views, point->rms_px, point->sigma});
  }
  if (options.bundle_adjustment && !solution.points.empty()) {
    std::vector<CameraPose> poses;
    std::map<int, int> slot_of_view;
    for (int v : posed) {
      slot_of_view[v] = static_cast<int>(poses.size());
      poses.push_back(solution.views[v].pose);
    }
    std::vector<cv::Point3d> points;
    std::map<uint32_t, int> slot_of_point;
    for (const auto& p : solution.points) {
      slot_of_point[p.id] = static_cast<int>(points.size());
      points.push_back(p.position);
    }
    std::vector<BundleObservation> observations;
    for (int v : posed) {
      for (const auto& light : views[v].lights) {
        if (light.conflict) continue;
        BundleObservation o;
        o.view = slot_of_view[v];
        o.pixel = light.pixel;
        if (auto ref = references.find(light.id); ref != references.end()) {
          // Only references that agreed with the view's pose (outliers stay out).
          const cv::Point2d p = ProjectPoint(camera, solution.views[v].pose, ref->second);
          if (!(cv::norm(p - light.pixel) <= options.pose.ransac_threshold_px)) continue;
          o.fixed = ref->second;
        } else if (auto s = slot_of_point.find(light.id); s != slot_of_point.end()) {
          o.point = s->second;
        } else {
          continue;
        }
        observations.push_back(o);
      }
    }
    std::vector<cv::Vec3d> sigma;
    absl::Status s = BundleAdjust(camera, &poses, &points, observations, options.bundle_iterations,
                                  options.triangulation.pixel_sigma, &sigma,
                                  &solution.bundle_initial_rms_px, &solution.bundle_final_rms_px);
    if (!s.ok()) return s;
    solution.bundle_adjusted = true;
    for (int v : posed) solution.views[v].pose = poses[slot_of_view[v]];
    for (auto& p : solution.points) {
      const int k = slot_of_point[p.id];
      p.position = points[k];
      if (sigma[k] != cv::Vec3d(0, 0, 0)) p.sigma = sigma[k];
    }
  }
  // Residuals with the final poses and points.
  std::map<uint32_t, cv::Point3d> all = references;
  for (const auto& p : solution.points) all[p.id] = p.position;
  std::map<uint32_t, std::pair<double, int>> point_residuals;
  for (int v : posed) {
    double sum_sq = 0;
    int count = 0;
    for (const auto& light : views[v].lights) {
      if (light.conflict) continue;
      auto X = all.find(light.id);
      if (X == all.end()) continue;
      const double e = cv::norm(ProjectPoint(camera, solution.views[v].pose, X->second) - light.pixel);
      if (!std::isfinite(e)) continue;
      const bool is_reference = references.count(light.id) > 0;
      if (is_reference && e > options.pose.ransac_threshold_px) continue;  // outlier reference
      sum_sq += e * e;
      ++count;
      if (!is_reference) {
        point_residuals[light.id].first += e * e;
        point_residuals[light.id].second += 1;
      }
    }
    solution.views[v].reprojection_rms_px = count ? std::sqrt(sum_sq / count) : 0;
  }
  for (auto& p : solution.points) {
    const auto& [sum_sq, count] = point_residuals[p.id];
    if (count) p.rms_px = std::sqrt(sum_sq / count);
  }
  return solution;
}

}  // namespace texfree::survey
