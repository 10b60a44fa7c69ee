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
  // Signs that the profile is not the table in view (or the intrinsics not the camera's),
  // reported in PoolAnalysis::profile_note; the analysis itself goes on.
  // - A table of the profile's size but another aspect ratio: the four corners fit a
  //   rectangle of the profile's sides only so well (PoolTableDetection's
  //   rectangle_inconsistency): at most 0.0095 over the benchmark's 1330 x 700 mm sets with
  //   the right profile (0.015 on one frame of the 9-ft set's 120), 0.020-0.032 for the
  //   1330 x 700 mm table read as a 9-ft one (2:1 against 1.9:1). Over
  //   note_rectangle_inconsistency the note says so.
  // - A profile whose table is larger or smaller than the table in view for its balls (all
  //   standard tables are 2:1, so only the balls tell a 7-ft table from a 9-ft one): the
  //   pose puts the table farther or nearer than it is, and the balls look larger or
  //   smaller than it predicts (DetectPoolBalls' ball_size_ratio: 0.89-1.27 over the
  //   benchmark's sets with the right profile, up to 1.35 for the 9-ft set's 3-4 px balls;
  //   a profile of a table 1.28 times as large: 1.07-1.56, median 1.38). Outside
  //   [min_ball_size_ratio, max_ball_size_ratio] the note says so.
  double note_rectangle_inconsistency = 0.018;
  double min_ball_size_ratio = 0.7;
  double max_ball_size_ratio = 1.45;
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
  // How large the balls look against the table profile (DetectPoolBalls' ball_size_ratio):
  // about 1 when the profile's table and ball sizes are the table's; 0 when fewer than
  // three balls were seen.
  double ball_size_ratio = 0;
  // PoolTableDetection's: how far the four corners are from a rectangle of the profile's
  // sides seen by this camera.
  double rectangle_inconsistency = 0;
  // Set when either says the profile is not this table's (PoolAnalyzerOptions): what
  // looks wrong and what to check; empty otherwise.
  std::string profile_note;
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
