// Pool table profiles and their validation.
#include "common/pool_profile.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "absl/strings/str_cat.h"
#include "common/status_macros.h"

namespace texfree {

bool IsNearlyGreyCloth(const cv::Vec3b& bgr) {
  const int most = std::max({bgr[0], bgr[1], bgr[2]});
  const int least = std::min({bgr[0], bgr[1], bgr[2]});
  return most == 0 || 255 * (most - least) < kMinClothSaturation * most;
}

absl::Status PoolTableProfile::Validate() const {
  auto finite_positive = [](double v) { return std::isfinite(v) && v > 0; };
  if (!finite_positive(length_mm) || !finite_positive(width_mm))
    return absl::InvalidArgumentError("table length_mm and width_mm must be positive");
  if (length_mm < width_mm)
    return absl::InvalidArgumentError(absl::StrCat("table length_mm (", length_mm,
                                                   ") must not be less than width_mm (",
                                                   width_mm, ")"));
  if (length_mm > 10000)
    return absl::InvalidArgumentError("table length_mm is over 10 m: give millimetres");
  if (!finite_positive(ball_radius_mm) || ball_radius_mm * 8 > width_mm)
    return absl::InvalidArgumentError(absl::StrCat(
        "ball_radius_mm (", ball_radius_mm, ") must be positive and small against the table"));
  if (!finite_positive(cushion_height_mm) || cushion_height_mm > 2 * ball_radius_mm)
    return absl::InvalidArgumentError(
        absl::StrCat("cushion_height_mm (", cushion_height_mm,
                     ") must be positive and below the ball diameter (", 2 * ball_radius_mm, ")"));
  if (!std::isfinite(cushion_width_mm) || cushion_width_mm < 0 ||
      cushion_width_mm > width_mm / 4)
    return absl::InvalidArgumentError("cushion_width_mm must be in [0, width/4]");
  if (!finite_positive(corner_pocket_mm) || corner_pocket_mm < 2 * ball_radius_mm ||
      corner_pocket_mm > width_mm / 2)
    return absl::InvalidArgumentError(absl::StrCat(
        "corner_pocket_mm (", corner_pocket_mm, ") must be wider than a ball and below width/2"));
  if (!finite_positive(side_pocket_mm) || side_pocket_mm < 2 * ball_radius_mm ||
      side_pocket_mm > width_mm / 2)
    return absl::InvalidArgumentError(absl::StrCat(
        "side_pocket_mm (", side_pocket_mm, ") must be wider than a ball and below width/2"));
  if (IsNearlyGreyCloth(cloth_bgr))
    return absl::InvalidArgumentError(absl::StrCat(
        "cloth_color (BGR ", static_cast<int>(cloth_bgr[0]), ",", static_cast<int>(cloth_bgr[1]),
        ",", static_cast<int>(cloth_bgr[2]),
        ") is nearly grey: the table and the balls are found by the cloth's colour, and a grey, "
        "black or white cloth cannot be told from the floor and the rails; give the colour of a "
        "coloured cloth (green, blue, red)"));
  return absl::OkStatus();
}

absl::StatusOr<PoolTableProfile> CalibratePoolColors(
    const cv::Mat& bgr, const cv::Rect& cloth_region,
    const std::vector<std::pair<int, cv::Rect>>& ball_regions, PoolTableProfile profile) {
  if (bgr.empty() || bgr.type() != CV_8UC3)
    return absl::InvalidArgumentError("colour calibration needs an 8-bit colour image");
  const cv::Rect image(0, 0, bgr.cols, bgr.rows);
  if (cloth_region.area() <= 0 || (cloth_region & image) != cloth_region)
    return absl::InvalidArgumentError(absl::StrCat(
        "cloth region ", cloth_region.width, "x", cloth_region.height, " at (", cloth_region.x,
        ", ", cloth_region.y, ") is empty or outside the ", bgr.cols, "x", bgr.rows, " image"));
  // Peak of a 16-level-per-channel histogram, then the mean of the pixels in that bin.
  std::vector<int> histogram(16 * 16 * 16, 0);
  auto bin = [](const cv::Vec3b& p) { return (p[0] >> 4) * 256 + (p[1] >> 4) * 16 + (p[2] >> 4); };
  for (int y = cloth_region.y; y < cloth_region.y + cloth_region.height; ++y)
    for (int x = cloth_region.x; x < cloth_region.x + cloth_region.width; ++x)
      ++histogram[bin(bgr.at<cv::Vec3b>(y, x))];
  const int peak = static_cast<int>(std::max_element(histogram.begin(), histogram.end()) -
                                    histogram.begin());
  cv::Vec3d sum(0, 0, 0);
  int n = 0;
  for (int y = cloth_region.y; y < cloth_region.y + cloth_region.height; ++y)
    for (int x = cloth_region.x; x < cloth_region.x + cloth_region.width; ++x) {
      const cv::Vec3b& p = bgr.at<cv::Vec3b>(y, x);
      if (bin(p) != peak) continue;
      sum += cv::Vec3d(p[0], p[1], p[2]);
      ++n;
    }
  const cv::Vec3d cloth = sum / std::max(1, n);
  profile.cloth_bgr = cv::Vec3b(cv::saturate_cast<uint8_t>(cloth[0]),
                                cv::saturate_cast<uint8_t>(cloth[1]),
                                cv::saturate_cast<uint8_t>(cloth[2]));
  // Balls: the pixels more than 10 degrees (seed eq. 4.1) away from the cloth colour.
  const double cos_limit = std::cos(10 * 3.14159265358979 / 180);
  for (const auto& [number, region] : ball_regions) {
    if (number < 0 || number >= kPoolBallCount)
      return absl::InvalidArgumentError(
          absl::StrCat("ball number ", number, " is not 0 (cue) .. 9"));
    if (region.area() <= 0 || (region & image) != region)
      return absl::InvalidArgumentError(
          absl::StrCat("the region of ball ", number, " is empty or outside the image"));
    cv::Vec3d ball(0, 0, 0);
    int count = 0;
    for (int y = region.y; y < region.y + region.height; ++y)
      for (int x = region.x; x < region.x + region.width; ++x) {
        const cv::Vec3b& p = bgr.at<cv::Vec3b>(y, x);
        const cv::Vec3d v(p[0], p[1], p[2]);
        const double nv = cv::norm(v), nc = cv::norm(cloth);
        if (nv > 1e-6 && nc > 1e-6 && v.dot(cloth) >= cos_limit * nv * nc) continue;
        ball += v;
        ++count;
      }
    if (count < 5)
      return absl::InvalidArgumentError(absl::StrCat(
          "the region of ball ", number, " holds no pixels that differ from the cloth colour"));
    ball /= count;
    profile.ball_bgr[number] = cv::Vec3b(cv::saturate_cast<uint8_t>(ball[0]),
                                         cv::saturate_cast<uint8_t>(ball[1]),
                                         cv::saturate_cast<uint8_t>(ball[2]));
  }
  RETURN_IF_ERROR(profile.Validate());
  return profile;
}

PoolTableProfile NineFootPoolProfile() { return PoolTableProfile(); }

PoolTableProfile BenchPoolProfile() {
  PoolTableProfile p;
  p.name = "bench";
  p.length_mm = 1330;
  p.width_mm = 700;
  p.ball_radius_mm = 24;
  p.cushion_height_mm = 37;
  p.cushion_width_mm = 42;
  p.corner_pocket_mm = 100;
  p.side_pocket_mm = 110;
  return p;
}

}  // namespace texfree
