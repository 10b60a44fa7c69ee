// Photogrammetry of a light survey (seed ch. 7): pose each view from reference lights with
// surveyed coordinates (PnP + RANSAC, then Levenberg-Marquardt, lens distortion honoured),
// triangulate the other lights seen in two or more posed views (linear DLT, then Gauss-Newton
// on the pixel reprojection error), optionally a bundle adjustment of the view poses and
// points with the references held fixed, and 1-sigma uncertainties from the covariance.
//
// Why not Ceres: problems here are small (tens of views, hundreds of points), so a dense
// Levenberg-Marquardt over Eigen with OpenCV's analytic projection Jacobians solves them in
// milliseconds without a heavy new dependency.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "absl/status/statusor.h"
#include "common/planar_pose.h"

namespace texfree::survey {

// World -> camera: x_cam = R * X + t.
struct CameraPose {
  cv::Matx33d R = cv::Matx33d::eye();
  cv::Vec3d t;
  cv::Point3d Center() const;  // camera centre in world coordinates
};

// Pixel of a world point (distortion applied). Point behind the camera: NaN pixel.
cv::Point2d ProjectPoint(const CameraModel& camera, const CameraPose& pose, const cv::Point3d& X);

struct PoseOptions {
  // References needed to pose a view (PnP is determined from 4; fewer is refused).
  int min_references = 4;
  // RANSAC inlier threshold in pixels: a light centroid is good to a fraction of a pixel, a
  // wrong reference coordinate moves it by many.
  double ransac_threshold_px = 4.0;
  int ransac_iterations = 2000;
  double ransac_confidence = 0.999;

  absl::Status Validate() const;
};

struct PoseResult {
  CameraPose pose;
  std::vector<int> inliers;  // indices into the inputs
  double rms_px = 0;         // over inliers, after refinement
};

// FAILED_PRECONDITION when fewer than min_references points or RANSAC finds no pose with at
// least min_references inliers; INVALID_ARGUMENT for mismatched inputs.
absl::StatusOr<PoseResult> EstimateViewPose(const std::vector<cv::Point3d>& world,
                                            const std::vector<cv::Point2d>& pixels,
                                            const CameraModel& camera, const PoseOptions& options);

struct TriangulationOptions {
  int min_views = 2;
  // Prior 1-sigma of a light centroid, pixels; the uncertainty uses the larger of this and
  // the residual's own estimate when there is enough redundancy.
  double pixel_sigma = 0.3;
  int max_iterations = 20;
  // Rays closer than this angle (degrees) do not fix depth: refused.
  double min_ray_angle_deg = 1.0;

  absl::Status Validate() const;
};

struct TriangulatedPoint {
  cv::Point3d position;
  int views = 0;
  double rms_px = 0;
  cv::Vec3d sigma;  // 1-sigma per axis, metres (poses taken as exact)
};

// One light's observations in posed views. FAILED_PRECONDITION when too few views, rays too
// parallel, or the point lies behind a camera.
absl::StatusOr<TriangulatedPoint> TriangulatePoint(const std::vector<CameraPose>& poses,
                                                   const std::vector<cv::Point2d>& pixels,
                                                   const CameraModel& camera,
                                                   const TriangulationOptions& options);

// ---- whole survey ----

struct LightObservation {
  uint32_t id = 0;
  cv::Point2d pixel;
  bool conflict = false;  // ignored: the same ID decoded twice in this view
};

struct ViewInput {
  std::string name;
  std::vector<LightObservation> lights;
};

struct SolveOptions {
  PoseOptions pose;
  TriangulationOptions triangulation;
  bool bundle_adjustment = false;
  int bundle_iterations = 50;

  absl::Status Validate() const;
};

struct ViewSolution {
  std::string name;
  bool posed = false;
  std::string pose_error;  // why not, when not posed
  CameraPose pose;
  int references_used = 0;
  double reprojection_rms_px = 0;  // over every light of the view with a 3D position
};

struct SolvedPoint {
  uint32_t id = 0;
  cv::Point3d position;
  int views = 0;
  double rms_px = 0;
  cv::Vec3d sigma;
};

struct SurveySolution {
  std::vector<ViewSolution> views;
  std::vector<SolvedPoint> points;  // sorted by id; references are not repeated here
  bool bundle_adjusted = false;
  double bundle_initial_rms_px = 0;
  double bundle_final_rms_px = 0;
};

// Poses every view that sees >= min_references references, triangulates every non-reference
// light seen in >= min_views posed views, then optionally bundle-adjusts. FAILED_PRECONDITION
// when fewer than two views could be posed.
absl::StatusOr<SurveySolution> SolveSurvey(const CameraModel& camera,
                                           const std::map<uint32_t, cv::Point3d>& references,
                                           const std::vector<ViewInput>& views,
                                           const SolveOptions& options);

}  // namespace texfree::survey
