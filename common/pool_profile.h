// The description of a pool table that the pool assistant needs: playing-surface size,
// ball radius, cushion height and width, pocket mouths, and the colours of the cloth and
// of each ball (as seen under the table's light; CalibrateColors learns them).
#pragma once

#include <array>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace texfree {

inline constexpr int kPoolBallCount = 10;  // cue (0) and 1..9 for 9-ball

// OpenCV's HSV saturation (of 255) under which a colour is not a cloth's: grey paper,
// walls and floors. The table and the balls are found by their colour angle to the cloth's,
// and to a grey every grey, beige or dim pixel (the floor, the rails) is cloth.
inline constexpr int kMinClothSaturation = 60;
// Whether `bgr` has too little colour for a cloth (kMinClothSaturation).
bool IsNearlyGreyCloth(const cv::Vec3b& bgr);

struct PoolTableProfile {
  std::string name = "9ft";
  // Playing surface inside the cushion noses, mm. Default: a standard 9-ft table.
  double length_mm = 2540;
  double width_mm = 1270;
  double ball_radius_mm = 28.575;  // 2 1/4 inch balls
  // Top of the cushion above the cloth (WPA: nose at 63.5% of the ball diameter).
  double cushion_height_mm = 36.5;
  // Cloth-covered cushion top from the nose to the wooden rail: the outline of the cloth
  // seen by the camera is the playing surface grown by this much, at the cushion height.
  double cushion_width_mm = 50;
  double corner_pocket_mm = 115;  // mouth widths
  double side_pocket_mm = 130;
  // Colours, BGR. Default cloth: a mid green; default balls: a common ball set.
  cv::Vec3b cloth_bgr{90, 128, 40};
  std::array<cv::Vec3b, kPoolBallCount> ball_bgr = {
      cv::Vec3b{225, 232, 236}, cv::Vec3b{20, 190, 245}, cv::Vec3b{170, 60, 30},
      cv::Vec3b{40, 30, 205},   cv::Vec3b{120, 40, 90},  cv::Vec3b{25, 110, 245},
      cv::Vec3b{50, 115, 15},   cv::Vec3b{35, 35, 120},  cv::Vec3b{25, 25, 25},
      cv::Vec3b{20, 190, 245}};

  // Says what is wrong: sizes must be positive and plausible (a ball smaller than the
  // table, cushions lower than the ball diameter, pockets wider than a ball), and the
  // cloth a colour, not nearly grey (IsNearlyGreyCloth).
  absl::Status Validate() const;
};

// Seed 4.2.2: learns the colours from a photograph. The cloth colour is the peak of the
// colour histogram of `cloth_region` (a region of the cloth that may hold balls); each
// (number, region) of `ball_regions` gives that ball's colour as the mean of the region's
// pixels that are not cloth-coloured. Errors: INVALID_ARGUMENT for regions outside the
// image, empty regions, numbers outside 0..9 or a ball region without ball pixels.
absl::StatusOr<PoolTableProfile> CalibratePoolColors(
    const cv::Mat& bgr, const cv::Rect& cloth_region,
    const std::vector<std::pair<int, cv::Rect>>& ball_regions, PoolTableProfile profile);

// A standard 9-ft table: 2540 x 1270 mm, ball radius 28.575 mm.
PoolTableProfile NineFootPoolProfile();

// The table of seed 4.6: 1330 x 700 mm, ball radius 24 mm, cushion 37 mm.
PoolTableProfile BenchPoolProfile();

}  // namespace texfree
