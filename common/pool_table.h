// Finding a pool table in a photograph (seed 4.3.1, 4.3.4): cloth segmentation by the
// colour angle to the cloth colour (eq. 4.1), the outline of the cloth, Hough lines
// clustered into the four sides, sub-pixel refinement of each side on the colour edge,
// corners as intersections, long or short side from the geometry, and the camera pose
// from the four corners (appendix A, then refined).
//
// Works on an undistorted ("ideal pinhole") image: see PoolUndistorter.
#pragma once

#include <array>
#include <opencv2/core.hpp>
#include <vector>

#include "absl/status/statusor.h"
#include "common/planar_pose.h"
#include "common/pool_profile.h"

namespace texfree {

struct PoolTableOptions {
  // Seed eq. 4.1: a pixel is cloth when its colour is within this angle of the cloth
  // colour (seed: 10 degrees).
  double cloth_angle_deg = 10;
  // First, wider pass that finds the cloth when the light changes its colour; the cloth
  // colour is then re-measured on the table itself.
  double search_angle_deg = 22;
  // The wide pass takes only colours nearer (in angle) to the cloth's than to grey and to
  // the picture's other dominant colours (hue peaks over cloth_angle_deg from it): a cloth
  // of little colour (a purple 18 degrees from grey) beside a grey floor (21 degrees from
  // it), or a burgundy on a wooden floor (18 degrees apart), took the floor in, and the
  // greys of the cloth's shade pulled its measured colour towards grey (on red cloth,
  // shadows then read as balls). A table so found must fit the profile's rectangle closely
  // (inconsistency at most 0.05; a brown cloth taken together with its brown rails
  // measures 0.09); else the whole cone is searched. false: the whole cone only (before
  // round 63).
  bool nearest_colour_cloth_search = true;
  // Pixels darker than this fraction of the cloth brightness are never cloth (their
  // colour angle is noise).
  double min_cloth_brightness = 0.3;
  // Smallest cloth area, fraction of the image, to call it a table.
  double min_cloth_fraction = 0.03;
  // Gaps in the cloth region up to this share of the image's width are closed before its
  // outline is taken (never less than the 3x3 closing at half resolution of before). A cue stick
  // laid over the cloth, its shaft and its shadow a few pixels wide, cut an inlet into the
  // region from the cushion it crosses, or cut the region in two: the outline then ran
  // along both of the stick's edges, the side search took that line for a side, and the
  // table was not found ("only part of the table is in view") or found wrong. On the ten
  // cue-stick benchmark sets rendered sRGB, 17 of 600 frames had no table and one a wrong
  // one; at 0.0125 (4 px at 320 px half width) every table is found, and the ten sets
  // without a stick measure the same. 0 keeps the 3x3 closing alone.
  double cloth_close_fraction = 0.0125;
  // Largest allowed inconsistency of the pose from the corners (0 = a perfect rectangle
  // of the profile's proportions seen by this camera).
  double max_rectangle_inconsistency = 0.2;
  // When no table is found in the profile's cloth colour, the image's this many most
  // common saturated colours are tried as the cloth's (a blue or red cloth with a profile
  // left at the default green); 0 = only the profile's colour.
  int other_cloth_colours = 3;
  // How the picture encodes the light (as PoolBallOptions::pixel_encoding, which
  // PoolAnalyzerOptions requires to agree): whether the rails are darker or lighter than
  // the cloth is judged in light for an sRGB picture.
  PixelEncoding pixel_encoding = PixelEncoding::kSrgb;

  absl::Status Validate() const;
};

// A table found in an ideal (undistorted) image.
struct PoolTableDetection {
  // Outer corners of the cloth-covered cushion tops (ideal pixels), in the order of the
  // table frame: (-c,-c), (L+c,-c), (L+c,W+c), (-c,W+c) at Z = cushion height.
  std::array<cv::Point2d, 4> cushion_corners;
  PlanarPose pose;  // table frame -> camera (Z = 0 is the cloth)
  // The same table with the origin at the opposite corner (the table's 180 degree
  // symmetry): which of the two is right is decided by the ball arrangement (seed 4.5).
  PlanarPose rotated_pose;
  cv::Vec3b cloth_bgr;         // measured on this image
  double cloth_brightness;     // mean of B, G, R of the cloth
  // The cloth was found among the image's own colours, not the profile's (other_cloth_colours).
  bool cloth_not_profile_colour = false;
  bool long_side_view = true;  // camera stands at a long side
  double rectangle_inconsistency = 0;
  // The focal length (ideal pixels) under which the four corners as measured (before the
  // pose's reprojection) are the profile's rectangle (FocalLengthFromRectangle); 0 when
  // the view leaves it unfixed.
  double corner_focal_px = 0;
  cv::Mat cloth_mask;  // CV_8U, 255 = cloth (largest region), at half resolution
};

// Finds the table in `ideal_bgr` (8-bit BGR, undistorted with K). Errors:
// FAILED_PRECONDITION when no cloth-coloured region of table size is in view ("no pool
// table in view"), when the table is cut by the image border ("only part of the table is
// in view") or its outline is not four straight sides; INVALID_ARGUMENT for bad
// options/profile.
absl::StatusOr<PoolTableDetection> DetectPoolTable(const cv::Mat& ideal_bgr, const cv::Matx33d& K,
                                                   const PoolTableProfile& profile,
                                                   const PoolTableOptions& options = {});

class IdealView;
// The same on a picture undistorted on demand: the cloth and its outline on view->half(),
// the sides on view->full() around the table, which it makes valid (IdealView::Require).
absl::StatusOr<PoolTableDetection> DetectPoolTable(IdealView* view, const cv::Matx33d& K,
                                                   const PoolTableProfile& profile,
                                                   const PoolTableOptions& options = {});

// The light (on the same 0-255 scale) that an sRGB grey level encodes; a fractional level
// (a median) interpolated.
float SrgbLight(float level);
// SrgbLight of each whole level, for per-pixel loops.
const std::array<float, 256>& SrgbLightTable();
// A colour (BGR, 0-255) as the light it stands for, on the same scale: each channel
// decoded (SrgbLight) for kSrgb, the colour itself for kLinear.
cv::Vec3f ColourInLight(const cv::Vec3f& colour, PixelEncoding encoding);

// Colour angle (degrees) between two BGR colours (seed eq. 4.1).
double ColorAngleDeg(const cv::Vec3f& a, const cv::Vec3f& b);

// Rec. 601 luma of a BGR colour: the brightness JPEG keeps at full resolution (its colour
// it keeps at half).
double PoolLuma(const cv::Vec3f& bgr);

// Projects a table-frame point (mm) with a pose into ideal pixels.
cv::Point2d ProjectIdeal(const PlanarPose& pose, const cv::Matx33d& K, const cv::Vec3d& point);

// Intersects the ray through ideal pixel `pixel` with the plane Z = z of the table frame.
// Returns false when the ray is parallel to the plane or the plane is behind the camera.
bool BackProjectToPlane(const PlanarPose& pose, const cv::Matx33d& K, const cv::Point2d& pixel,
                        double z, cv::Point2d* table_xy);

// The camera centre in the table frame.
cv::Vec3d CameraCentre(const PlanarPose& pose);

// The same table seen with the origin at the opposite corner (x -> L - x, y -> W - y).
PlanarPose RotateTableFrame(const PlanarPose& pose, double length_mm, double width_mm);

// Undistortion of a camera's images into the ideal pinhole image with the same K, with the
// remap tables (full and half resolution) computed once. Not thread-safe to construct; the
// const methods are.
class PoolUndistorter {
 public:
  explicit PoolUndistorter(const CameraModel& camera);
  // Copies (or remaps when the camera has distortion) `bgr` to the ideal image.
  cv::Mat Undistort(const cv::Mat& bgr) const;
  // Remaps only `rect` of the ideal image into (*ideal)(rect); *ideal must already have
  // the picture's size and type. The pixels are exactly those Undistort gives there.
  void UndistortRect(const cv::Mat& bgr, const cv::Rect& rect, cv::Mat* ideal) const;
  // The ideal image at half resolution from cv::pyrDown of the picture: the half-size
  // camera (K halved, p_full = 2 p_half as pyrDown keeps every second pixel) undistorted.
  cv::Mat UndistortHalf(const cv::Mat& half_bgr) const;
  // Ideal pixels -> distorted image pixels.
  cv::Point2d Distort(const cv::Point2d& ideal) const;
  const CameraModel& camera() const { return camera_; }

 private:
  CameraModel camera_;
  cv::Mat map1_, map2_;            // full resolution
  cv::Mat half_map1_, half_map2_;  // half resolution (pyrDown's size)
};

// One picture's ideal image, undistorted only where the analysis looks. The table is
// found on the whole picture at half resolution, its sides and balls at full resolution
// only around the table: remapping a whole 640x480 picture was an eighth of a frame's
// time, and the table covers a quarter to a half of a typical view. Inside valid(),
// full() holds exactly PoolUndistorter::Undistort's pixels; outside, whatever `storage`
// held. Not thread-safe.
class IdealView {
 public:
  // `storage` (optional) receives the full-resolution pixels; when it already has the
  // picture's size and type its buffer is reused (no allocation, no page faults per
  // frame). `undistorter` and `distorted_bgr` must outlive the view.
  IdealView(const PoolUndistorter& undistorter, const cv::Mat& distorted_bgr,
            cv::Mat* storage = nullptr);
  // A picture without lens distortion (or undistorted already): every pixel is valid.
  explicit IdealView(const cv::Mat& ideal_bgr);

  const cv::Mat& half() const { return half_; }
  const cv::Mat& full() const { return full_; }
  const cv::Rect& valid() const { return valid_; }
  cv::Rect image_rect() const { return {0, 0, full_.cols, full_.rows}; }
  // Makes `rect` (clipped to the picture) valid, remapping the part not valid yet; valid()
  // becomes the bounding box of the two.
  void Require(const cv::Rect& rect);

 private:
  const PoolUndistorter* undistorter_ = nullptr;  // null: the picture is ideal already
  cv::Mat distorted_;
  cv::Mat full_, half_;
  cv::Rect valid_;
};

}  // namespace texfree
