// PoolAnalyzer: undistort, find the table, choose the origin, find and identify the balls.
#include "common/pool_analyzer.h"

#include <cmath>
#include <opencv2/imgproc.hpp>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "common/status_macros.h"
#include "common/timing.h"

namespace texfree {

namespace {

// Relative focal length error a note names (see ProfileNote).
constexpr double kNamedFocalError = 0.03;

// PoolAnalysis::profile_note for a table and its balls measured against `profile`.
// `focal_ratio`: the focal length the table's corners say (FocalLengthFromRectangle, the
// profile's sides taken as right) over the intrinsics', 0 when unfixed; `focal_px` the
// intrinsics' focal length in the picture's pixels.
std::string ProfileNote(const PoolTableProfile& profile, const PoolAnalyzerOptions& options,
                        double rectangle_inconsistency, double ball_size_ratio, double focal_ratio,
                        double focal_px) {
  const std::string table =
      absl::StrFormat("the profile's %.0f x %.0f mm table with %.1f mm balls", profile.length_mm,
                      profile.width_mm, 2 * profile.ball_radius_mm);
  if (rectangle_inconsistency > options.note_rectangle_inconsistency) {
    // The corners' focal length is named when it differs enough to be the cause (one
    // frame's estimate misses by about 1%, 2% at the 90th percentile).
    const std::string focal =
        focal_ratio > 0 && std::abs(focal_ratio - 1) > kNamedFocalError
            ? absl::StrFormat(
                  " (with the profile's sides the corners say a focal length of "
                  "about %.0f px, %.0f%% %s than the intrinsics' %.0f px)",
                  focal_ratio * focal_px, 100 * std::abs(focal_ratio - 1),
                  focal_ratio > 1 ? "longer" : "shorter", focal_px)
            : "";
    return absl::StrFormat(
        "the table's outline fits a rectangle of %s only to %.1f%%: if this table has other "
        "sides, give them (table.json: length_mm, width_mm, ball_radius_mm), else check the "
        "camera intrinsics%s; positions are off until then",
        table, 100 * rectangle_inconsistency, focal);
  }
  if (ball_size_ratio > 0 && (ball_size_ratio < options.min_ball_size_ratio ||
                              ball_size_ratio > options.max_ball_size_ratio))
    return absl::StrFormat(
        "the balls look %.2f times as large as %s predicts: if this table is %s, give its "
        "size and ball radius (table.json: length_mm, width_mm, ball_radius_mm); positions "
        "are off by about that factor until then",
        ball_size_ratio, table, ball_size_ratio > 1 ? "smaller" : "larger");
  return "";
}

}  // namespace

absl::Status PoolAnalyzerOptions::Validate() const {
  RETURN_IF_ERROR(table.Validate());
  RETURN_IF_ERROR(balls.Validate());
  if (table.pixel_encoding != balls.pixel_encoding)
    return absl::InvalidArgumentError(
        "table.pixel_encoding and balls.pixel_encoding differ: one picture has one encoding");
  if (max_working_pixels != 0 && max_working_pixels < 320 * 240)
    return absl::InvalidArgumentError(absl::StrCat(
        "max_working_pixels must be 0 (never reduce) or at least 320x240 = 76800, got ",
        max_working_pixels));
  if (!(note_rectangle_inconsistency > 0))
    return absl::InvalidArgumentError(absl::StrCat(
        "note_rectangle_inconsistency must be positive, got ", note_rectangle_inconsistency));
  if (!(min_ball_size_ratio > 0 && min_ball_size_ratio < 1 && max_ball_size_ratio > 1))
    return absl::InvalidArgumentError(
        absl::StrCat("min_ball_size_ratio must be in (0, 1) and max_ball_size_ratio over 1, got ",
                     min_ball_size_ratio, " and ", max_ball_size_ratio));
  return absl::OkStatus();
}

absl::StatusOr<PoolAnalyzer> PoolAnalyzer::Create(const PoolTableProfile& profile,
                                                  const CameraModel& camera,
                                                  const PoolAnalyzerOptions& options) {
  RETURN_IF_ERROR(profile.Validate());
  RETURN_IF_ERROR(camera.Validate());
  RETURN_IF_ERROR(options.Validate());
  return PoolAnalyzer(profile, camera, options);
}

absl::Status PoolAnalyzer::PrepareFor(const cv::Size& image_size, const cv::Size& working_size) {
  if (undistorter_ && image_size_ == image_size && undistorter_->camera().size == working_size)
    return absl::OkStatus();
  // Same sensor at another resolution: intrinsics scaled; anything else is a mistake.
  ASSIGN_OR_RETURN(CameraModel camera, CameraForImage(camera_, image_size));
  if (working_size != image_size) camera.K = ScaledIntrinsics(camera.K, image_size, working_size);
  camera.size = working_size;
  undistorter_.emplace(camera);
  image_size_ = image_size;
  return absl::OkStatus();
}

cv::Point2d PoolAnalyzer::ToImage(const cv::Point2d& working) const {
  const cv::Size& w = undistorter_->camera().size;
  return {(working.x + 0.5) * image_size_.width / w.width - 0.5,
          (working.y + 0.5) * image_size_.height / w.height - 0.5};
}

double PoolAnalyzer::ToImageScale() const {
  return static_cast<double>(image_size_.width) / undistorter_->camera().size.width;
}

cv::Point2d PoolAnalyzer::Project(const PlanarPose& pose, const cv::Vec3d& point_mm) const {
  if (!undistorter_) return {};
  const CameraModel& camera = undistorter_->camera();
  return ToImage(undistorter_->Distort(ProjectIdeal(pose, camera.K, point_mm)));
}

cv::Mat PoolAnalyzer::EmptyTable() const {
  if (!undistorter_ || last_working_.empty()) return {};
  return EmptyTableBackground(undistorter_->Undistort(last_working_), undistorter_->camera().K,
                              last_pose_, profile_, last_balls_);
}

double ArrangementDistance(const std::vector<PoolBall>& balls,
                           const std::vector<PoolBall>& reference, double cap_mm) {
  double sum = 0;
  for (const auto& b : balls) {
    double best = cap_mm;
    for (const auto& r : reference) {
      if (b.number >= 0 && r.number >= 0 && b.number != r.number) continue;
      best = std::min(best, std::hypot(b.x_mm - r.x_mm, b.y_mm - r.y_mm));
    }
    sum += best;
  }
  return sum;
}

absl::StatusOr<PoolAnalysis> PoolAnalyzer::Analyze(const cv::Mat& bgr,
                                                   const std::vector<PoolBall>* reference) {
  if (bgr.empty() || bgr.depth() != CV_8U || bgr.channels() != 3)
    return absl::InvalidArgumentError("pool analysis needs an 8-bit colour (BGR) image");
  PoolAnalysis analysis;
  auto t0 = SteadyClock::now();
  const cv::Size working = WorkingSize(bgr.size(), options_.max_working_pixels);
  RETURN_IF_ERROR(PrepareFor(bgr.size(), working));
  cv::Mat reduced;
  if (working != bgr.size()) {
    cv::resize(bgr, reduced, working, 0, 0, cv::INTER_AREA);
    analysis.timings_ms.emplace_back("reduce", MillisecondsSince(t0));
    t0 = SteadyClock::now();
  }
  const cv::Matx33d& K = undistorter_->camera().K;
  last_working_ = reduced.empty() ? bgr : reduced;
  // Undistorted at half resolution now, at full resolution around the table as it is found.
  IdealView ideal(*undistorter_, last_working_, &ideal_storage_);
  analysis.timings_ms.emplace_back("undistort", MillisecondsSince(t0));
  t0 = SteadyClock::now();
  ASSIGN_OR_RETURN(PoolTableDetection table, DetectPoolTable(&ideal, K, profile_, options_.table));
  analysis.timings_ms.emplace_back("table", MillisecondsSince(t0));
  t0 = SteadyClock::now();
  std::vector<PoolDetectedBall> detected =
      DetectPoolBalls(&ideal, K, table.pose, profile_, table.cloth_bgr, options_.balls,
                      &light_gains_, &analysis.ball_size_ratio);
  analysis.timings_ms.emplace_back("balls", MillisecondsSince(t0));
  analysis.rectangle_inconsistency = table.rectangle_inconsistency;
  analysis.profile_note =
      ProfileNote(profile_, options_, analysis.rectangle_inconsistency, analysis.ball_size_ratio,
                  table.corner_focal_px / K(0, 0), K(0, 0) * ToImageScale());
  PlanarPose pose = table.pose;
  const double L = profile_.length_mm, W = profile_.width_mm;
  auto to_balls = [&](bool rotated) {
    std::vector<PoolBall> out;
    for (const auto& d : detected) {
      PoolBall b;
      b.number = d.number;
      b.x_mm = rotated ? L - d.x_mm : d.x_mm;
      b.y_mm = rotated ? W - d.y_mm : d.y_mm;
      b.radius_px = d.radius_px * ToImageScale();
      b.confidence = d.confidence;
      out.push_back(b);
    }
    return out;
  };
  analysis.balls = to_balls(false);
  if (reference && !reference->empty()) {
    // Seed 4.5: of the two origins, keep the one whose arrangement matches the reference.
    const double cap = 4 * profile_.ball_radius_mm;
    std::vector<PoolBall> rotated = to_balls(true);
    if (ArrangementDistance(rotated, *reference, cap) <
        ArrangementDistance(analysis.balls, *reference, cap)) {
      analysis.balls = std::move(rotated);
      pose = table.rotated_pose;
      for (auto& d : detected) {
        d.x_mm = L - d.x_mm;
        d.y_mm = W - d.y_mm;
      }
    }
    analysis.origin_from_arrangement = true;
  }
  analysis.pose = pose;
  last_pose_ = pose;
  last_balls_ = detected;
  for (auto& d : last_balls_) {
    d.ideal_pixel = ToImage(d.ideal_pixel);
    d.radius_px *= ToImageScale();
  }
  analysis.long_side_view = table.long_side_view;
  analysis.cloth_bgr = table.cloth_bgr;
  analysis.cloth_not_profile_colour = table.cloth_not_profile_colour;
  analysis.light_gains = light_gains_;
  for (auto& b : analysis.balls) b.pixel = Project(pose, {b.x_mm, b.y_mm, profile_.ball_radius_mm});
  const cv::Vec3d corners[4] = {{0, 0, 0}, {L, 0, 0}, {L, W, 0}, {0, W, 0}};
  for (int i = 0; i < 4; ++i) analysis.cloth_corners[i] = Project(pose, corners[i]);
  return analysis;
}

}  // namespace texfree
