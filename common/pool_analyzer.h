// The pool assistant's image analysis (seed 4.2.1, 4.3, 4.5): one photograph and the
// camera intrinsics -> the table (corners, pose) and the balls (numbers, positions in mm).
// In a live view, the origin among the table's symmetric corners is chosen so that the
// ball arrangement matches the one found before (seed 4.5).
#pragma once

#include <array>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "absl/status/statusor.h"
#include "common/planar_pose.h"
#include "common/pool_balls.h"
#include "common/pool_profile.h"
#include "common/pool_table.h"

namespace texfree {

struct PoolAnalyzerOptions {
  PoolTableOptions table;
  PoolBallOptions balls;
  // Larger images are analysed reduced (area-averaged, intrinsics scaled alike) to at most
  // this many pixels; every result is still given in the pixels of the image as passed.
  // The ball fits sample the rim and the cloth beside it a pixel or two apart, as a
  // 640x480 view's blur spans: at 1280x960 (the default) the benchmark's balls were all
  // within 10 mm, at 1920x1440 dark balls whose blurred rim spans several pixels were
  // fitted 11-21 mm off, in 1.6 times the time. 0: never reduce.
  int64_t max_working_pixels = 1280 * 960;
  absl::Status Validate() const;
};

struct PoolBall {
  int number = -1;            // 0 = cue, 1..9, -1 = unknown
  double x_mm = 0, y_mm = 0;  // table frame, centre at Z = ball radius
  cv::Point2d pixel;          // projection of the centre in the (distorted) image
  double radius_px = 0;
  double confidence = 0;
};

struct PoolAnalysis {
  // Playing-surface corners (0,0), (L,0), (L,W), (0,W) in image pixels.
  std::array<cv::Point2d, 4> cloth_corners;
  PlanarPose pose;  // table -> camera
  bool long_side_view = true;
  // True when the origin was chosen by matching a previous ball arrangement.
  bool origin_from_arrangement = false;
  cv::Vec3b cloth_bgr;
  bool cloth_not_profile_colour = false;  // PoolTableDetection's
  // The white balance (BGR gains) the balls were read with: (1, 1, 1) under a light of
  // the profile's colours; under warm lamps about (1.2, 0.96, 0.88). Kept by the analyzer
  // for the next picture (PoolBallOptions::white_balance_min_cast).
  cv::Vec3f light_gains{1, 1, 1};
  std::vector<PoolBall> balls;
  std::vector<std::pair<std::string, double>> timings_ms;
};

// Not thread-safe (keeps the undistortion tables of the last image size); use one per
// stream or per call.
class PoolAnalyzer {
 public:
  // INVALID_ARGUMENT for a bad profile, camera or options.
  static absl::StatusOr<PoolAnalyzer> Create(const PoolTableProfile& profile,
                                             const CameraModel& camera,
                                             const PoolAnalyzerOptions& options = {});

  // Analyses one BGR image. With `reference` (balls of an earlier analysis of the same
  // table), the origin is the one whose ball arrangement matches it best. Errors as
  // DetectPoolTable, plus INVALID_ARGUMENT when the image size does not fit the camera.
  absl::StatusOr<PoolAnalysis> Analyze(const cv::Mat& bgr,
                                       const std::vector<PoolBall>* reference = nullptr);

  // Projects a table point (mm) into the last analysed image (distorted pixels, at the size
  // it was passed).
  cv::Point2d Project(const PlanarPose& pose, const cv::Vec3d& point_mm) const;

  // Figure 4.10 for the last analysed image: the table without its balls (undistorted, at
  // the working size: max_working_pixels). It reads the image passed to Analyze, which must
  // not have been overwritten since.
  cv::Mat EmptyTable() const;

  const PoolTableProfile& profile() const { return profile_; }
  // The balls of the last analysis with their colour evidence (votes, white share, lit
  // brightness), in the order of PoolAnalysis::balls.
  // Their ideal pixels and radii are of the image at the size it was passed.
  const std::vector<PoolDetectedBall>& last_detected_balls() const { return last_balls_; }

 private:
  PoolAnalyzer(PoolTableProfile profile, CameraModel camera, PoolAnalyzerOptions options)
      : profile_(std::move(profile)), camera_(std::move(camera)), options_(options) {}
  // Undistortion for an image of `image_size` analysed at `working_size`.
  absl::Status PrepareFor(const cv::Size& image_size, const cv::Size& working_size);
  // A working-size pixel in the image as passed, and the scale from one to the other.
  cv::Point2d ToImage(const cv::Point2d& working) const;
  double ToImageScale() const;

  PoolTableProfile profile_;
  CameraModel camera_;  // as given
  PoolAnalyzerOptions options_;
  std::optional<PoolUndistorter> undistorter_;  // for the current working size
  cv::Size image_size_;                         // of the image as passed
  // The last picture at the working size (distorted; EmptyTable undistorts it whole), and
  // the buffer its ideal image is remapped into, kept from frame to frame.
  cv::Mat last_working_;
  cv::Mat ideal_storage_;
  PlanarPose last_pose_;
  std::vector<PoolDetectedBall> last_balls_;
  cv::Vec3f light_gains_{1, 1, 1};  // the white balance found on an earlier picture
};

// Sum over `balls` of the distance to the nearest reference ball with the same number
// (any number when either is unknown), each capped at `cap_mm`.
double ArrangementDistance(const std::vector<PoolBall>& balls,
                           const std::vector<PoolBall>& reference, double cap_mm);

}  // namespace texfree
