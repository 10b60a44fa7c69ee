// Pool table profiles and their validation.
#include "common/pool_profile.h"

#include <cmath>

#include "absl/strings/str_cat.h"

namespace texfree {

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
  return absl::OkStatus();
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
