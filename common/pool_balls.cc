// Ball extraction, sphere fitting, identification by colour votes, empty-table background.
#include "common/pool_balls.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <opencv2/imgproc.hpp>
#include <utility>

#include "absl/strings/str_cat.h"
#include "common/connected_components.h"
#include "common/pool_table.h"

namespace texfree {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Apparent radius in pixels of a ball of radius r mm centred at table point (x, y, r):
// focal length times radius over distance.
double ApparentRadiusPx(const PlanarPose& pose, const cv::Matx33d& K, const cv::Point2d& xy,
                        double r) {
  return K(0, 0) * r / cv::norm(pose.R * cv::Vec3d(xy.x, xy.y, r) + pose.t);
}

double SmoothStep(double x) {
  x = std::clamp(x, 0.0, 1.0);
  return x * x * (3 - 2 * x);
}

// A soft threshold: 0 at `edge`, rising smoothly to 1 at `edge + width` (width < 0: 1 below
// the edge), 0 and 1 beyond.
float SoftThreshold(float x, float edge, float width) {
  return static_cast<float>(SmoothStep((x - edge) / width));
}

// Hue (degrees) and saturation of a BGR colour in the opponent-colour plane.
void HueSaturation(const cv::Vec3f& bgr, double* hue, double* saturation, double* intensity) {
  const double b = bgr[0], g = bgr[1], r = bgr[2];
  const double i = (b + g + r) / 3;
  const double cx = r - 0.5 * g - 0.5 * b, cy = 0.8660254 * (g - b);
  *hue = std::atan2(cy, cx) * 180 / kPi;
  *saturation = std::hypot(cx, cy) / std::max(1.0, i);
  *intensity = i;
}

// Angle between two hues, degrees in [0, 180].
double HueGapDeg(double a, double b) {
  const double gap = std::abs(a - b);
  return gap > 180 ? 360 - gap : gap;
}

// The playing surface's outline (cushion noses, table frame (0,0)-(L,W)) at height z,
// projected to whole pixels less `offset`.
std::vector<cv::Point> TableOutlinePx(const PlanarPose& pose, const cv::Matx33d& K, double L,
                                      double W, double z, const cv::Point& offset = {0, 0}) {
  std::vector<cv::Point> corners;
  for (const cv::Vec3d& p :
       {cv::Vec3d(0, 0, z), cv::Vec3d(L, 0, z), cv::Vec3d(L, W, z), cv::Vec3d(0, W, z)}) {
    const cv::Point2d q = ProjectIdeal(pose, K, p);
    corners.emplace_back(cvRound(q.x) - offset.x, cvRound(q.y) - offset.y);
  }
  return corners;
}

// Where balls can be seen: the bounding box of the playing surface from the cloth up to a
// ball's height, in the image. `hull` (optional) receives the convex outline.
cv::Rect BallSearchRect(const PlanarPose& pose, const cv::Matx33d& K, double L, double W, double r,
                        const cv::Size& image_size, std::vector<cv::Point>* hull = nullptr) {
  std::vector<cv::Point> hull_points = TableOutlinePx(pose, K, L, W, 0);
  for (const cv::Point& p : TableOutlinePx(pose, K, L, W, 2 * r)) hull_points.push_back(p);
  std::vector<cv::Point> own;
  std::vector<cv::Point>& out = hull ? *hull : own;
  cv::convexHull(hull_points, out);
  return cv::boundingRect(out) & cv::Rect(0, 0, image_size.width, image_size.height);
}

// Radius of the light blur DetectPoolBallsOnce reads the picture through (sigma 0.8 gives
// OpenCV's 7-tap kernel for 8-bit images).
constexpr double kOutlineBlurSigma = 0.8;
constexpr int kOutlineBlurRadius = 3;

// How far beyond BallSearchRect the ball finder reads pixels: the box of a ball is at most
// its apparent radius (SilhouetteScorer::Box) from the ball, and the local cloth and the
// colour distance are read up to half a box beyond it; plus the blur's reach.
int BallReadMarginPx(const PlanarPose& pose, const cv::Matx33d& K, double L, double W, double r) {
  // The nearest a ball's centre can be to the camera: the table point under it.
  const cv::Vec3d c = CameraCentre(pose);
  const cv::Vec3d nearest(std::clamp(c[0], 0.0, L), std::clamp(c[1], 0.0, W), r);
  const double distance = std::max(1e-9, cv::norm(nearest - c));
  const double box_half = 1.35 * K(0, 0) * r / distance + 2.5 + 1;
  return static_cast<int>(std::ceil(box_half)) + kOutlineBlurRadius + 2;
}

// AddDarkness: a cell by the cushions whose level (CushionShade) is under this share of
// the cloth's is in deep shade (faces with the lamps behind them measure 0.2-0.45, lit ones
// 0.4-0.9), and there a pixel under kShadeColourFloor times the level has no colour to
// speak of: the near-black face read as coloured ball by its hue's noise, and left false
// balls along it (benchmark seeds 7 and 19 with --lamp-shift 0,500,0: 12 + 17 -> 10 + 10
// false balls; the twenty sets: one false ball more, one ball fewer located on each ten).
// Over all shaded cells, a dark 6 or 8 before a lit face lost its colour there (three
// more balls over 10 mm on the green sets).
constexpr float kFullShade = 0.3f;
constexpr float kShadeColourFloor = 1.5f;

// Ball-ness of dark pixels (the 8) added to `ballness` (over `roi`, by colour): darkness
// measured against the cloth's colour, and where `shade` is given (the cloth's B + G + R
// as lit at each pixel, CushionShade) also against the cloth as lit there
// (PoolBallOptions::cushion_shade_dark_share).
void AddDarkness(const cv::Mat& bgr, const cv::Rect& roi, const cv::Vec3f& cloth,
                 const PoolBallOptions& o, const cv::Mat& shade, cv::Mat* ballness) {
  const float cloth_sum = cloth[0] + cloth[1] + cloth[2];
  const float dark_hi_share = static_cast<float>(o.dark_fraction + 0.1);
  const float dark_lo_share = static_cast<float>(o.dark_fraction - 0.05);
  const float shade_share = static_cast<float>(o.cushion_shade_dark_share);
  const float cloth_dark_hi = static_cast<float>((o.dark_fraction + 0.1) * cloth_sum);
  const float cloth_dark_lo = static_cast<float>((o.dark_fraction - 0.05) * cloth_sum);
  const float lo_of_hi = dark_lo_share / dark_hi_share;
  for (int y = 0; y < roi.height; ++y) {
    const cv::Vec3b* p = bgr.ptr<cv::Vec3b>(y + roi.y) + roi.x;
    const float* lit = shade.empty() ? nullptr : shade.ptr<float>(y);
    float* q = ballness->ptr<float>(y);
    for (int x = 0; x < roi.width; ++x) {
      const float sum = static_cast<float>(p[x][0]) + p[x][1] + p[x][2];
      // `shade` holds the cloth's own level where no cell is darker.
      const bool shaded = lit && lit[x] < cloth_sum;
      const float dark_hi = shaded ? std::min(cloth_dark_hi, shade_share * lit[x]) : cloth_dark_hi;
      const float dark_lo = shaded ? dark_hi * lo_of_hi : cloth_dark_lo;
      const float dark = SoftThreshold(sum, dark_hi, dark_lo - dark_hi);
      // In a cell in deep shade the colour of pixels about as dark as the cell is JPEG's
      // and the noise's: they are ball only by their darkness.
      if (shaded && lit[x] < kFullShade * cloth_sum && sum < kShadeColourFloor * lit[x])
        q[x] = dark;
      else
        q[x] = std::max(q[x], dark);
    }
  }
}

// Ball-ness of pixels much brighter than the cloth added to `ballness` (over `roi`):
// PoolBallOptions::bright_fraction_srgb.
void AddBrightness(const cv::Mat& bgr, const cv::Rect& roi, const cv::Vec3f& cloth, double fraction,
                   cv::Mat* ballness) {
  constexpr double kSoft = 0.05;  // half the soft band, a share of the cloth's brightness
  const float cloth_sum = cloth[0] + cloth[1] + cloth[2];
  const float bright_lo = static_cast<float>((fraction - kSoft) * cloth_sum);
  const float bright_hi = static_cast<float>((fraction + kSoft) * cloth_sum);
  for (int y = 0; y < roi.height; ++y) {
    const cv::Vec3b* p = bgr.ptr<cv::Vec3b>(y + roi.y) + roi.x;
    float* q = ballness->ptr<float>(y);
    for (int x = 0; x < roi.width; ++x) {
      const float sum = static_cast<float>(p[x][0]) + p[x][1] + p[x][2];
      if (sum <= bright_lo) continue;
      q[x] = std::max(q[x], SoftThreshold(sum, bright_lo, bright_hi - bright_lo));
    }
  }
}

// The ball-ness by colour of every pixel in `roi` (0 = cloth, 1 = ball), soft around the
// thresholds so that sub-pixel fitting sees a continuous image (a shadow on the cloth is
// dark, never coloured; AddDarkness adds the dark balls). The colour angle to the cloth is
// taken in light (PoolBallOptions::pixel_encoding), where shading and the light's strength
// scale a colour without turning it: an sRGB-encoded shade of a colour is another colour,
// and a ball's shaded side came closer to the cloth's. The chromaticity test stays on the
// values as encoded, where its noise allowance was set. The twenty sets rendered sRGB:
// balls over 10 mm 150 + 181 -> 130 + 162, separated balls named 3,048 + 3,096 -> 3,055 +
// 3,097, located 4,747 + 4,736 -> 4,758 + 4,750, false balls 21 + 12 -> 16 + 16 (the
// chromaticity in light as well: 140 + 165 over 10 mm, 23 + 30 false balls).
cv::Mat BallnessMap(const cv::Mat& bgr, const cv::Rect& roi, const cv::Vec3f& cloth,
                    const PoolBallOptions& o) {
  cv::Mat out(roi.size(), CV_32FC1);
  const double lo = (o.ball_angle_deg - o.ball_angle_soft_deg) * kPi / 180;
  const double hi = (o.ball_angle_deg + o.ball_angle_soft_deg) * kPi / 180;
  const float cos_lo = static_cast<float>(std::cos(lo)), cos_hi = static_cast<float>(std::cos(hi));
  const bool in_light = o.pixel_encoding == PixelEncoding::kSrgb;
  const std::array<float, 256>& light_of = SrgbLightTable();
  const cv::Vec3f angle_cloth = ColourInLight(cloth, o.pixel_encoding);
  const float angle_cloth_norm = static_cast<float>(cv::norm(angle_cloth));
  const float cloth_sum = cloth[0] + cloth[1] + cloth[2];
  const float cloth_inv_i = 3.f / std::max(1.f, cloth_sum);
  const float cloth_cx = (cloth[2] - 0.5f * (cloth[1] + cloth[0])) * cloth_inv_i;
  const float cloth_cy = 0.8660254f * (cloth[1] - cloth[0]) * cloth_inv_i;
  constexpr double kChromaSoft = 0.08;
  const float chroma_lo2 = static_cast<float>(std::pow(o.ball_chroma_distance - kChromaSoft, 2));
  const float chroma_hi2 = static_cast<float>(std::pow(o.ball_chroma_distance + kChromaSoft, 2));
  // Chromaticity is noise over intensity: below chroma_full_sum the distance it must reach
  // grows as the pixel darkens, and below chroma_min_sum it is mostly noise (the dark
  // test takes over). A dark green 6 on green cloth is 0.35-0.5 of the cloth's brightness
  // and far from its chromaticity; with a hard cut at 0.45 the far 6 of benchmark frame
  // 49 broke into fragments too small for a ball.
  const float chroma_full_sum = static_cast<float>(0.45 * cloth_sum);
  const float chroma_min_sum = static_cast<float>(0.25 * cloth_sum);
  for (int y = 0; y < roi.height; ++y) {
    const cv::Vec3b* p = bgr.ptr<cv::Vec3b>(y + roi.y) + roi.x;
    float* q = out.ptr<float>(y);
    for (int x = 0; x < roi.width; ++x) {
      const float b = p[x][0], g = p[x][1], r = p[x][2];
      const float lb = in_light ? light_of[p[x][0]] : b, lg = in_light ? light_of[p[x][1]] : g,
                  lr = in_light ? light_of[p[x][2]] : r;
      const float n = std::sqrt(lb * lb + lg * lg + lr * lr);
      const float c = n > 0 ? (lb * angle_cloth[0] + lg * angle_cloth[1] + lr * angle_cloth[2]) /
                                  (n * angle_cloth_norm)
                            : 0;
      float colour;
      if (c >= cos_lo) {
        colour = 0;
      } else if (c <= cos_hi) {
        colour = 1;
      } else {
        colour = static_cast<float>(SmoothStep((std::acos(c) - lo) / (hi - lo)));
      }
      const float sum = b + g + r;
      // Chromaticity (opponent chroma over intensity) far from the cloth's: a ball of
      // nearly the cloth's hue (the green 6 on green cloth) is more saturated and darker,
      // which the angle in RGB barely sees; the light's strength and the shadows on the
      // cloth leave chromaticity alone.
      if (colour < 1 && sum > chroma_min_sum) {
        const float inv_i = 3.f / sum;
        const float cx = (r - 0.5f * (g + b)) * inv_i - cloth_cx;
        const float cy = 0.8660254f * (g - b) * inv_i - cloth_cy;
        const float noise_scale = sum < chroma_full_sum ? chroma_full_sum / sum : 1.f;
        const float d2 = (cx * cx + cy * cy) / (noise_scale * noise_scale);
        if (d2 >= chroma_hi2) {
          colour = 1;
        } else if (d2 > chroma_lo2) {
          colour = std::max(
              colour,
              static_cast<float>(SmoothStep((std::sqrt(d2) - o.ball_chroma_distance + kChromaSoft) /
                                            (2 * kChromaSoft))));
        }
      }
      q[x] = colour;
    }
  }
  return out;
}

// The cloth's brightness (B + G + R) as lit next to the cushions, per pixel of `roi`: a
// band of cloth's level where it is under `cloth_sum`, a cushion face's where it is under
// `dark_sum`, `cloth_sum` elsewhere; empty when no cell is darker. A lamp not over the
// table's middle leaves a cushion's face, and a band of cloth along it, in the cushion's
// shadow: dark, they read as ball (a row of false 8s along the far cushion). The cloth in
// bands along each cushion (kShadeBins bands out to kShadeReach ball radii from its nose)
// and each cushion's face are cut into cells kShadeCellLength radii long; a cell's level
// is the median brightness of its pixels of the cloth's colour (`colour_ballness` under
// 0.5), which a ball or two frozen on the cushion do not move. Sampled at every other
// pixel of every other row (a frame's time stays about as it was).
constexpr double kShadeReach = 2;
constexpr int kShadeBins = 8;
constexpr double kShadeCellLength = 8;
cv::Mat CushionShade(const cv::Mat& bgr, const cv::Rect& roi, const cv::Mat& colour_ballness,
                     const PlanarPose& pose, const cv::Matx33d& K, const PoolTableProfile& profile,
                     float cloth_sum, float dark_sum) {
  const double L = profile.length_mm, W = profile.width_mm, r = profile.ball_radius_mm;
  const double h = profile.cushion_height_mm;
  const double reach = kShadeReach * r;
  const cv::Vec3d camera = CameraCentre(pose);
  // Cushions 0: y = 0, 1: x = L, 2: y = W, 3: x = 0. A table point `along` cushion `c`
  // and `depth` in from its nose, at height z.
  const auto at = [&](int c, double along, double depth, double z) {
    switch (c) {
      case 0:
        return cv::Vec3d(along, depth, z);
      case 1:
        return cv::Vec3d(L - depth, along, z);
      case 2:
        return cv::Vec3d(along, W - depth, z);
      default:
        return cv::Vec3d(depth, along, z);
    }
  };
  const auto length_of = [&](int c) { return c % 2 == 0 ? L : W; };
  // A cushion's face is seen from the table's side of it only.
  const auto face_seen = [&](int c) {
    const double inside = c == 0   ? camera[1]
                          : c == 1 ? L - camera[0]
                          : c == 2 ? W - camera[1]
                                   : camera[0];
    return inside > 0 && camera[2] > h;
  };
  const auto quad = [&](const std::array<cv::Vec3d, 4>& corners) {
    std::array<cv::Point, 4> q;
    for (int k = 0; k < 4; ++k) {
      const cv::Point2d m = ProjectIdeal(pose, K, corners[k]);
      q[k] = cv::Point(cvRound((m.x - 0.5 - roi.x) * 16), cvRound((m.y - 0.5 - roi.y) * 16));
    }
    return q;
  };
  // Where to sample: each band and seen face painted (fillConvexPoly takes in the pixels
  // its edges touch, so a sample's cell is then taken from its ray).
  thread_local cv::Mat near;
  near.create(roi.size(), CV_8UC1);
  near.setTo(0);
  for (int c = 0; c < 4; ++c) {
    const double length = length_of(c);
    auto q =
        quad({at(c, 0, 0, 0), at(c, length, 0, 0), at(c, length, reach, 0), at(c, 0, reach, 0)});
    cv::fillConvexPoly(near, q.data(), 4, cv::Scalar(255), cv::LINE_8, 4);
    if (!face_seen(c)) continue;
    q = quad({at(c, 0, 0, 0), at(c, length, 0, 0), at(c, length, 0, h), at(c, 0, 0, h)});
    cv::fillConvexPoly(near, q.data(), 4, cv::Scalar(255), cv::LINE_8, 4);
  }
  const double cell_mm = kShadeCellLength * r;
  int segments[4], offsets[5] = {0};
  for (int c = 0; c < 4; ++c) {
    segments[c] = std::max(1, static_cast<int>(std::ceil(length_of(c) / cell_mm)));
    offsets[c + 1] = offsets[c] + segments[c];
  }
  const int bins = kShadeBins + 1;  // the bands, then the face
  const int total = offsets[4] * bins;
  const auto along_cell = [&](int c, double along) {
    return offsets[c] +
           std::clamp(static_cast<int>(along / length_of(c) * segments[c]), 0, segments[c] - 1);
  };
  // Every other pixel of every other row, put in its cell by its ray through the pixel's
  // centre: on the cloth, the band of the nearest cushion; else the face it crosses
  // between the cloth and the cushion's top.
  const cv::Matx33d M = pose.R.t() * K.inv();
  std::vector<std::vector<float>> sums(total);
  std::vector<int> counts(total, 0);
  for (int y = 0; y < roi.height; y += 2) {
    const uchar* in = near.ptr<uchar>(y);
    const cv::Vec3b* p = bgr.ptr<cv::Vec3b>(y + roi.y) + roi.x;
    const float* col = colour_ballness.ptr<float>(y);
    for (int x = 0; x < roi.width; x += 2) {
      if (!in[x]) continue;
      const cv::Vec3d d = M * cv::Vec3d(x + roi.x + 0.5, y + roi.y + 0.5, 1);
      if (d[2] >= 0) continue;
      const double t0 = -camera[2] / d[2];
      const double X = camera[0] + t0 * d[0], Y = camera[1] + t0 * d[1];
      int index = -1;
      if (X >= 0 && Y >= 0 && X <= L && Y <= W) {
        const double to[4] = {Y, L - X, W - Y, X};
        const int c = static_cast<int>(std::min_element(to, to + 4) - to);
        if (to[c] >= reach) continue;
        index =
            along_cell(c, c % 2 == 0 ? X : Y) * bins + static_cast<int>(to[c] / reach * kShadeBins);
      } else {
        const double th = (h - camera[2]) / d[2];
        const double Xh = camera[0] + th * d[0], Yh = camera[1] + th * d[1];
        if (Xh < 0 || Yh < 0 || Xh > L || Yh > W) continue;
        const bool beyond[4] = {(Y < 0), (X > L), (Y > W), (X < 0)};
        if (beyond[0] + beyond[1] + beyond[2] + beyond[3] != 1) continue;  // a corner
        const int c = static_cast<int>(std::find(beyond, beyond + 4, true) - beyond);
        const double tm = (0.5 * h - camera[2]) / d[2];
        index = along_cell(c, c % 2 == 0 ? camera[0] + tm * d[0] : camera[1] + tm * d[1]) * bins +
                kShadeBins;
      }
      ++counts[index];
      if (col[x] < 0.5f) sums[index].push_back(static_cast<float>(p[x][0] + p[x][1] + p[x][2]));
    }
  }
  // The cells darker than the cloth, brightest first: where two meet, the darker one is
  // painted last and holds their shared pixels. Of the faces only those that would read as
  // dark themselves (under `dark_sum`): before a lit face (0.4-0.9 of the cloth) a dark
  // ball keeps its top (a 6 frozen on the far cushion went 9 -> 20 mm off when lit faces
  // were taken in).
  std::vector<std::pair<float, int>> dark_cells;
  for (int i = 0; i < total; ++i) {
    auto& v = sums[i];
    if (v.size() < 5 || v.size() < 0.3 * counts[i]) continue;
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    const bool face = i % bins == kShadeBins;
    if (v[v.size() / 2] < (face ? dark_sum : cloth_sum))
      dark_cells.emplace_back(v[v.size() / 2], i);
  }
  if (dark_cells.empty()) return cv::Mat();
  std::sort(dark_cells.begin(), dark_cells.end(), std::greater<>());
  cv::Mat shade(roi.size(), CV_32FC1, cv::Scalar(cloth_sum));
  for (const auto& [level, i] : dark_cells) {
    const int c = static_cast<int>(std::upper_bound(offsets, offsets + 5, i / bins) - offsets) - 1;
    const int j = i / bins - offsets[c], bin = i % bins;
    const double a0 = length_of(c) * j / segments[c], a1 = length_of(c) * (j + 1) / segments[c];
    std::array<cv::Point, 4> q;
    if (bin < kShadeBins) {
      const double d0 = reach * bin / kShadeBins, d1 = reach * (bin + 1) / kShadeBins;
      q = quad({at(c, a0, d0, 0), at(c, a1, d0, 0), at(c, a1, d1, 0), at(c, a0, d1, 0)});
    } else {
      q = quad({at(c, a0, 0, 0), at(c, a1, 0, 0), at(c, a1, 0, h), at(c, a0, 0, h)});
    }
    cv::fillConvexPoly(shade, q.data(), 4, cv::Scalar(level), cv::LINE_8, 4);
  }
  return shade;
}

// Ball-ness of the pixels that the pocket mask leaves out: neither ball nor cloth.
constexpr float kMaskedOut = -1;

// Compass search: from `xy`, step along +-X and +-Y while `score` improves, halving the
// step down to 0.02 mm, never farther than `max_move` from the start. After a move the
// step straight back is not tried: it is where the search came from, already worse.
template <typename Score>
cv::Point2d CompassSearch(cv::Point2d xy, double first_step, double max_move, const Score& score) {
  double best = score(xy);
  const cv::Point2d start = xy;
  const cv::Point2d dirs[4] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
  int back = -1;  // the direction back to where the last move came from
  for (double step = first_step; step > 0.02;) {
    bool moved = false;
    for (int k = 0; k < 4; ++k) {
      if (k == back) continue;
      const cv::Point2d cand = xy + dirs[k] * step;
      if (cv::norm(cand - start) > max_move) continue;
      const double s = score(cand);
      if (s > best + 1e-9) {
        best = s;
        xy = cand;
        moved = true;
        back = k ^ 1;
        break;
      }
    }
    if (!moved) {
      step *= 0.5;
      back = -1;
    }
  }
  return xy;
}

// Evaluates the silhouette of a ball at a table position against the ball-ness map.
class SilhouetteScorer {
 public:
  SilhouetteScorer(const cv::Mat& ballness, const cv::Rect& roi, const cv::Mat& claimed,
                   const cv::Matx33d& K, const PlanarPose& pose, const PoolTableProfile& profile)
      : ballness_(ballness),
        roi_(roi),
        claimed_(claimed),
        K_(K),
        K_inv_(K.inv()),
        pose_(pose),
        camera_(CameraCentre(pose)),
        radius_(profile.ball_radius_mm),
        length_(profile.length_mm),
        width_(profile.width_mm),
        cushion_height_(profile.cushion_height_mm) {
    // The ray through pixel (u, v) in the table frame is ray0 + u ray_u + v ray_v.
    const cv::Matx33d M = pose_.R.t() * K_inv_;
    ray_u_ = {M(0, 0), M(1, 0), M(2, 0)};
    ray_v_ = {M(0, 1), M(1, 1), M(2, 1)};
    ray0_ = {M(0, 2), M(1, 2), M(2, 2)};
  }

  cv::Vec3d Ray(double u, double v) const { return ray0_ + u * ray_u_ + v * ray_v_; }

  // Score() and Fit() over the dark zone under the ball as well: right for a ball-ness by
  // colour alone, in which a shadow stays cloth.
  void CountShadowZone() { count_shadow_zone_ = true; }
  // Pixels of the dark zone under the ball that lie outside its silhouette and are ball by
  // colour in `colour` (over the roi) at `level` or more count as ball outside it (a ball
  // in front of this one), not as the ball's own shadow.
  void CountColouredBelow(const cv::Mat* colour, double level) {
    colour_below_ = colour;
    colour_below_level_ = level;
  }

  // A ball against a cushion is partly hidden behind it: is the sphere point seen through
  // pixel (u, v) below the cushion top and the ray over the cushion when it gets there?
  bool HiddenByCushion(const cv::Vec3d& centre, double u, double v) const {
    cv::Vec3d d = Ray(u, v);
    d /= std::sqrt(d.dot(d));
    const cv::Vec3d oc = centre - camera_;
    const double b = oc.dot(d);
    const double disc = b * b - (oc.dot(oc) - radius_ * radius_);
    if (disc < 0) return false;
    const double t_hit = b - std::sqrt(disc);
    const double z_hit = camera_[2] + t_hit * d[2];
    if (z_hit >= cushion_height_ || d[2] >= 0) return false;
    return !OverPlayingSurface(d, cushion_height_);
  }
  // The lower part of a ball and the cloth just in front of it are dark both on the ball
  // (unlit underside) and off it (contact shadow, ambient occlusion): no edge to fit.
  // True for a pixel whose ray passes the ball's centre lower than 0.4 radius below it.
  bool InShadowZone(const cv::Vec3d& centre, double u, double v) const {
    // camera_z + t d_z < centre_z - 0.4 r with t = (centre - camera).d / d.d, multiplied
    // out by d.d > 0 (no division: the fits call this for every pixel of their boxes).
    const cv::Vec3d d = Ray(u, v);
    return (centre - camera_).dot(d) * d[2] < (centre[2] - 0.4 * radius_ - camera_[2]) * d.dot(d);
  }
  // Is pixel (u, v) a cushion's face seen beyond the cloth: does its ray pass the cushion
  // top's height over the playing surface and meet the cloth's height outside it?
  bool OverCushionFace(double u, double v) const {
    const cv::Vec3d d = Ray(u, v);
    if (d[2] >= 0) return false;
    return OverPlayingSurface(d, cushion_height_) && !OverPlayingSurface(d, 0);
  }
  bool NearCushion(const cv::Point2d& xy) const {
    return xy.x < 2 * radius_ || xy.y < 2 * radius_ || xy.x > length_ - 2 * radius_ ||
           xy.y > width_ - 2 * radius_;
  }

  // Bounding box (image pixels) of the silhouette, a little grown.
  cv::Rect Box(const cv::Vec3d& centre) const {
    const cv::Vec3d c = pose_.R * centre + pose_.t;
    const cv::Point2d m = ProjectIdeal(pose_, K_, centre);
    const double r_px = 1.35 * K_(0, 0) * radius_ / std::max(1e-9, cv::norm(c)) + 2.5;
    return cv::Rect(static_cast<int>(std::floor(m.x - r_px)),
                    static_cast<int>(std::floor(m.y - r_px)), static_cast<int>(2 * r_px + 2),
                    static_cast<int>(2 * r_px + 2)) &
           roi_;
  }

  // Correlation over the box between the silhouette (+1 inside, -1 outside) and the
  // ball-ness (+1 ball, -1 cloth), leaving out pixels of other balls (`claimed`), pixels
  // that a cushion hides and the dark zone under the ball. Ball pixels outside the
  // silhouette count against it as much as cloth inside it, so the fit is held from
  // every side.
  // `visible`: the silhouette's area (pixels) that the other balls leave to it.
  double Score(const cv::Point2d& xy, double* mean_ballness = nullptr,
               double* visible = nullptr) const {
    const cv::Vec3d centre(xy.x, xy.y, radius_);
    const cv::Matx33d Q = SphereSilhouetteConic(pose_, K_, centre, radius_);
    const cv::Rect box = Box(centre);
    const bool near_cushion = NearCushion(xy);
    // The compass search calls this tens of times per ball. The terms of the ray and of
    // the conic's gradient that depend on the column alone are taken once per call, the
    // row's once per row; each sum is formed in the same order as Ray() and Coverage()
    // form it, so every value is bit for bit theirs.
    thread_local std::vector<cv::Vec3d> ray_at_column;    // ray0_ + u ray_u_
    thread_local std::vector<cv::Vec3d> conic_at_column;  // (Q00 u, Q10 u, Q20 u)
    ray_at_column.resize(std::max(0, box.width));
    conic_at_column.resize(std::max(0, box.width));
    for (int i = 0; i < box.width; ++i) {
      const double u = box.x + i;
      ray_at_column[i] = ray0_ + u * ray_u_;
      conic_at_column[i] = {Q(0, 0) * u, Q(1, 0) * u, Q(2, 0) * u};
    }
    const cv::Vec3d to_centre = centre - camera_;
    const double shadow_level = centre[2] - 0.4 * radius_ - camera_[2];
    double score = 0, cov_sum = 0, ball_sum = 0;
    for (int v = box.y; v < box.y + box.height; ++v) {
      const float* b = ballness_.ptr<float>(v - roi_.y);
      const float* cl = claimed_.empty() ? nullptr : claimed_.ptr<float>(v - roi_.y);
      const cv::Vec3d ray_row = static_cast<double>(v) * ray_v_;
      const double qv0 = Q(0, 1) * v, qv1 = Q(1, 1) * v, qv2 = Q(2, 1) * v;
      for (int u = box.x; u < box.x + box.width; ++u) {
        const double w = cl ? 1.0 - cl[u - roi_.x] : 1.0;
        if (w <= 0) continue;
        const double bn = b[u - roi_.x];
        if (bn < 0) continue;  // kMaskedOut: a pocket
        const int i = u - box.x;
        bool in_shadow_zone = false;
        if (!count_shadow_zone_) {  // InShadowZone(centre, u, v)
          const cv::Vec3d d = ray_at_column[i] + ray_row;
          in_shadow_zone = to_centre.dot(d) * d[2] < shadow_level * d.dot(d);
          // Of the zone, only pixels ball by colour count (CountColouredBelow).
          if (in_shadow_zone &&
              (colour_below_ == nullptr ||
               colour_below_->at<float>(v - roi_.y, u - roi_.x) < colour_below_level_))
            continue;
        }
        // Coverage(Q, u, v)
        const cv::Vec3d& c = conic_at_column[i];
        const double qx = c[0] + qv0 + Q(0, 2);
        const double qy = c[1] + qv1 + Q(1, 2);
        const double qz = c[2] + qv2 + Q(2, 2);
        const double cov = CoverageFromGradient(qx, qy, qz, u, v);
        if (in_shadow_zone) {  // a ball pixel the silhouette leaves out, or none
          if (cov < 0.5) score += w * (2 * cov - 1);
          continue;
        }
        if (near_cushion && cov > 0 && HiddenByCushion(centre, u, v)) continue;
        score += w * (2 * cov - 1) * (2 * bn - 1);
        cov_sum += cov * w;
        ball_sum += cov * w * bn;
      }
    }
    if (mean_ballness) *mean_ballness = cov_sum > 0 ? ball_sum / cov_sum : 0;
    if (visible) *visible = cov_sum;
    return score;
  }

  // Signed distance (pixels, first order) of pixel (u, v) inside the conic's outline.
  static double InsideDistance(const cv::Matx33d& Q, double u, double v) {
    const double qx = Q(0, 0) * u + Q(0, 1) * v + Q(0, 2);
    const double qy = Q(1, 0) * u + Q(1, 1) * v + Q(1, 2);
    const double qz = Q(2, 0) * u + Q(2, 1) * v + Q(2, 2);
    const double grad = 2 * std::sqrt(qx * qx + qy * qy);
    return grad > 0 ? (u * qx + v * qy + qz) / grad : -1e9;
  }

  // Fraction of pixel (u, v) inside the conic's silhouette (signed distance to the
  // boundary, first order).
  static double Coverage(const cv::Matx33d& Q, double u, double v) {
    const double qx = Q(0, 0) * u + Q(0, 1) * v + Q(0, 2);
    const double qy = Q(1, 0) * u + Q(1, 1) * v + Q(1, 2);
    const double qz = Q(2, 0) * u + Q(2, 1) * v + Q(2, 2);
    return CoverageFromGradient(qx, qy, qz, u, v);
  }
  // Coverage with Q (u, v, 1) given as (qx, qy, qz).
  static double CoverageFromGradient(double qx, double qy, double qz, double u, double v) {
    const double g = u * qx + v * qy + qz;
    const double grad2 = qx * qx + qy * qy;  // (half the gradient's length)^2
    if (grad2 <= 0) return 0;
    // Most pixels of a box lie wholly inside or outside: |g| >= grad / 2 tells them
    // without the root and the division.
    if (g * g >= grad2) return g > 0 ? 1.0 : 0.0;
    return std::clamp(0.5 + g / (2 * std::sqrt(grad2)), 0.0, 1.0);
  }

  // Compass search for the best table position, starting at `xy`.
  cv::Point2d Fit(cv::Point2d xy, double first_step_mm) const {
    return CompassSearch(xy, first_step_mm, 1e9, [this](const cv::Point2d& p) { return Score(p); });
  }

 private:
  // Does the ray from the camera along `d` (downwards) meet height `z` over the playing
  // surface, (0, 0)-(length, width)?
  bool OverPlayingSurface(const cv::Vec3d& d, double z) const {
    const double t = (z - camera_[2]) / d[2];
    const double x = camera_[0] + t * d[0], y = camera_[1] + t * d[1];
    return x >= 0 && y >= 0 && x <= length_ && y <= width_;
  }

  const cv::Mat& ballness_;
  cv::Rect roi_;
  const cv::Mat& claimed_;
  bool count_shadow_zone_ = false;
  const cv::Mat* colour_below_ = nullptr;
  double colour_below_level_ = 1;
  cv::Matx33d K_, K_inv_;
  PlanarPose pose_;
  cv::Vec3d camera_;
  double radius_, length_, width_, cushion_height_;
  cv::Vec3d ray0_, ray_u_, ray_v_;
};

// Fewest of the 48 outline points a rim fit needs.
constexpr int kMinRimPoints = 10;
// Fewest rim points, seen again from where a rim fit ended, for that fit to be kept. The
// fit itself moves only on kMinRimPoints or more; from its new position a touching ball
// can cover more of the outline's scans (seed 37's frame 22: a 6 in front of the 9, moved
// from 4.9 px off to 2.5 px, then had 8 rim points and was thrown away at 10).
constexpr int kMinRimPointsToKeep = 8;

// Fits a ball's outline to the steepest fall of its colour distance from the cloth.
class EdgeFitter {
 public:
  EdgeFitter(const cv::Mat& gx, const cv::Mat& gy, const cv::Rect& area, const cv::Mat& claimed,
             const cv::Rect& roi, const SilhouetteScorer& scorer, const cv::Matx33d& K,
             const PlanarPose& pose, double radius)
      : gx_(gx),
        gy_(gy),
        area_(area),
        claimed_(claimed),
        roi_(roi),
        scorer_(scorer),
        K_(K),
        pose_(pose),
        radius_(radius),
        camera_(CameraCentre(pose)) {}

  // For a ball darker than the cloth, the outline next to its own shadow on the cloth has
  // no edge to speak of (dark against dark): those outline points are left out.
  void SkipShadowedOutline(bool skip) { skip_shadowed_ = skip; }
  // Edge points on the far side with a pixel under `level` in `brightness` 0.5-2 px beyond
  // them are taken on the outward fall of the luma (its gradients luma_gx, luma_gy) when it
  // has a qualifying peak no farther out. All maps over the fitter's area.
  struct ShadedOutside {
    cv::Mat brightness, luma_gx, luma_gy;
    double level = 0;
    // Every edge point is moved to the luma's outermost qualifying fall when that lies
    // this near it (PoolBallOptions::edge_luma_snap_px; 0: never).
    double luma_snap_px = 0;
  };
  // How much farther out than its reach a rim scan that starts inside the ball goes on
  // looking for the cloth, on the outline's far side (0: not at all).
  void SetOutwardReach(double px) { outward_reach_px_ = px; }
  // The levels of a rim fit in the distance map (RimPoints).
  struct RimLevels {
    double outside = 0;    // the cloth's level just outside the ball
    double threshold = 0;  // the ball's overall half-way level
    // A point's own step may lower its level down to a fifth of the ball's step (not to
    // the noise of the cloth).
    double Floor() const { return outside + 0.4 * (threshold - outside); }
    // Whether a thin outer band under the level is taken as the step (a dark ball).
    bool thin_outer_band = false;
  };
  // Rim points only on the outline's far side: a ball darker than the cloth has its own
  // shadow, as dark as it, joined to its near side (a camera looking steeply down sees it
  // beside the whole lower half), so only the far rim is against clean cloth. With the
  // near side in, seed 11's frame 0 8 stayed 4-5 px down in its shadow (17 mm off).
  void FarSideOnly(bool far_only) { far_only_ = far_only; }
  // The other balls' image centres and apparent radii (x, y, radius): a scan going outwards
  // stops short of them, since a fit that is off by a pixel or two does not cover all of
  // a touching ball's pixels, and a scan that crosses them finds no cloth of this ball's.
  void SetNeighbours(std::vector<cv::Vec3d> neighbours) { neighbours_ = std::move(neighbours); }
  bool NearNeighbour(double x, double y) const {
    for (const cv::Vec3d& n : neighbours_)
      if (std::hypot(x - n[0], y - n[1]) < kNeighbourMargin * n[2]) return true;
    return false;
  }

  // Calls visit(u, v, nx, ny, far_side) for each usable point of the outline of a ball at
  // `xy` (ideal pixels, outward unit normal; `far_side`: the cloth seen just beyond the
  // outline there lies behind the ball, away from its shadow): not in the dark lower
  // part, not beside the ball's own shadow when so asked, not on another ball, not hidden
  // by a cushion.
  template <typename Visit>
  void ForEachOutlinePoint(const cv::Point2d& xy, const Visit& visit) const {
    const cv::Vec3d centre(xy.x, xy.y, radius_);
    const cv::Vec3d c = pose_.R * centre + pose_.t;  // camera frame
    const double c2 = c.dot(c);
    // The sphere's contour generator: a circle around c * (1 - r^2/|c|^2).
    const cv::Vec3d circle_centre = c * (1 - radius_ * radius_ / c2);
    const double rho = radius_ * std::sqrt(std::max(0.0, 1 - radius_ * radius_ / c2));
    cv::Vec3d e1 = c.cross(cv::Vec3d(0, 0, 1));
    if (cv::norm(e1) < 1e-9) e1 = c.cross(cv::Vec3d(0, 1, 0));
    e1 /= cv::norm(e1);
    cv::Vec3d e2 = c.cross(e1);
    e2 /= cv::norm(e2);
    const cv::Matx33d Q = SphereSilhouetteConic(pose_, K_, centre, radius_);
    const cv::Matx33d to_table = pose_.R.t();
    constexpr int kPoints = 48;
    // The compass searches visit tens of positions per ball: the 48 directions' cosines
    // and sines are taken once (the same values as computed in place).
    static const std::array<std::pair<double, double>, kPoints> kDirections = [] {
      std::array<std::pair<double, double>, kPoints> out;
      for (int k = 0; k < kPoints; ++k) {
        const double a = 2 * 3.14159265358979 * k / kPoints;
        out[k] = {std::cos(a), std::sin(a)};
      }
      return out;
    }();
    for (int k = 0; k < kPoints; ++k) {
      const auto& [cos_a, sin_a] = kDirections[k];
      const cv::Vec3d point = circle_centre + rho * (cos_a * e1 + sin_a * e2);
      // Height of the tangent point on the table: skip the dark lower part.
      const cv::Vec3d on_table = to_table * (point - pose_.t);
      if (on_table[2] < radius_ - 0.4 * radius_) continue;
      // Where the ray grazing the ball here meets the cloth: in the ball's shadow (lamps
      // above the table: within about a radius of the contact point)?
      // And does it meet the cloth beyond the ball, seen from the camera (the outline's
      // far side, where the shadow is not)?
      bool shadowed = false, far_side = false;
      const cv::Vec3d d = on_table - camera_;
      if (d[2] < 0) {
        const double t = -camera_[2] / d[2];
        const double sx = camera_[0] + t * d[0] - xy.x, sy = camera_[1] + t * d[1] - xy.y;
        shadowed = sx * sx + sy * sy < kShadowReach * kShadowReach * radius_ * radius_;
        far_side = sx * (xy.x - camera_[0]) + sy * (xy.y - camera_[1]) > 0;
      }
      if (skip_shadowed_ && shadowed) continue;
      const cv::Vec3d m = K_ * point;
      const double u = m[0] / m[2], v = m[1] / m[2];
      if (u < area_.x + 1 || v < area_.y + 1 || u > area_.x + area_.width - 2 ||
          v > area_.y + area_.height - 2)
        continue;
      const int iu = static_cast<int>(u), iv = static_cast<int>(v);
      if (!roi_.contains({iu, iv}) || claimed_.at<float>(iv - roi_.y, iu - roi_.x) > 0.01) continue;
      if (scorer_.NearCushion(xy) && scorer_.HiddenByCushion(centre, u, v)) continue;
      // Outward normal of the outline: the conic's gradient points inside.
      const double qx = Q(0, 0) * u + Q(0, 1) * v + Q(0, 2);
      const double qy = Q(1, 0) * u + Q(1, 1) * v + Q(1, 2);
      const double norm = std::hypot(qx, qy);
      if (norm <= 0) continue;
      visit(u, v, -qx / norm, -qy / norm, far_side);
    }
  }

  // Mean outward fall of the distance across the outline of a ball at `xy`.
  double Score(const cv::Point2d& xy, int* used = nullptr) const {
    double sum = 0;
    int n = 0;
    ForEachOutlinePoint(xy, [&](double u, double v, double nx, double ny, bool) {
      sum += -(Sample(gx_, u, v) * nx + Sample(gy_, u, v) * ny);
      ++n;
    });
    if (used) *used = n;
    return n >= 6 ? sum / n : -1e9;
  }

  // Rim points: along each outline point's normal, from the cloth outside inwards, the
  // first place where `distance` (over `area_`) reaches the point's threshold (sub-pixel).
  // The outermost step is the rim; the ball's own inner edges (a highlight, a lit cap) lie
  // beyond it and are never reached. Points whose scan meets another ball are left out.
  // A point's threshold is half-way up its own step (cloth 1.5-3 px outside the outline,
  // ball 1 px to half the reach inside) when that is lower than the ball's overall
  // half-way level, but never below the levels' floor: the green 6's lit cap is much
  // nearer the cloth than its dark lower half, and at the level of the whole ball its top
  // rim was only met inside the cap, which moved the ball towards the camera.
  std::vector<cv::Point2d> RimPoints(const cv::Point2d& xy, const cv::Mat& distance,
                                     const RimLevels& levels, double reach_px) const {
    const double threshold = levels.threshold, floor_level = levels.Floor();
    std::vector<cv::Point2d> rim;
    const auto inside_area = [this](double x, double y) {
      return x >= area_.x && y >= area_.y && x <= area_.x + area_.width - 2 &&
             y <= area_.y + area_.height - 2;
    };
    ForEachOutlinePoint(xy, [&](double u, double v, double nx, double ny, bool far_side) {
      std::vector<double> in, out;
      for (double s = 1.5; s <= 3.01; s += 0.5)
        if (inside_area(u + s * nx, v + s * ny))
          out.push_back(Sample(distance, u + s * nx, v + s * ny));
      for (double s = -1; s >= -std::max(1.5, 0.5 * reach_px); s -= 0.5)
        if (inside_area(u + s * nx, v + s * ny))
          in.push_back(Sample(distance, u + s * nx, v + s * ny));
      double level = threshold;
      if (!in.empty() && !out.empty()) {
        std::nth_element(in.begin(), in.begin() + in.size() / 2, in.end());
        std::nth_element(out.begin(), out.begin() + out.size() / 2, out.end());
        const double i = in[in.size() / 2], o = out[out.size() / 2];
        if (i > o) level = std::max(floor_level, std::min(threshold, o + 0.5 * (i - o)));
      }
      constexpr double kStep = 0.25;
      // Usable sample `s` px out along the normal: in the area, not on another ball.
      const auto usable = [&](double s) {
        const double x = u + s * nx, y = v + s * ny;
        if (!inside_area(x, y)) return false;
        const int ix = static_cast<int>(x), iy = static_cast<int>(y);
        return roi_.contains({ix, iy}) && claimed_.at<float>(iy - roi_.y, ix - roi_.x) <= 0.01;
      };
      double start = reach_px;
      if (outward_reach_px_ > 0 && far_side && usable(start) &&
          Sample(distance, u + start * nx, v + start * ny) >= level) {
        // The outline lies inside the ball here, farther than the reach: on the far side
        // the cloth beyond the ball is clean (no shadow of its own), so the scan goes on
        // outwards to the cloth and starts from there (a dark ball that the edge pass
        // pulled down into its shadow is brought back by its far rim).
        for (start += kStep; start <= reach_px + outward_reach_px_; start += kStep) {
          if (!usable(start) || NearNeighbour(u + start * nx, v + start * ny)) return;
          if (Sample(distance, u + start * nx, v + start * ny) < level) break;
        }
        if (start > reach_px + outward_reach_px_) return;
      }
      // A thin outer band under the level, then a lighter one inside it (a black ball's
      // dark top rim before its highlight: blur keeps the band below the ball's half-way
      // level, and the rim was met under the highlight, 3-4 px inside): the step is to
      // that band, so the level is half-way from the cloth to its peak (2 px past where
      // the scan first reaches the floor). Only for a dark ball (RimLevels): a coloured
      // ball's outer band is its own colour, blurred with the cloth.
      double below = -1;
      for (double s = start; levels.thin_outer_band && s >= -reach_px; s -= kStep) {
        if (!usable(s)) break;
        const double d = Sample(distance, u + s * nx, v + s * ny);
        if (d >= level) break;
        if (below >= 0 && below < floor_level && d >= floor_level) {
          double peak = d;
          for (double t = s - kStep; t >= std::max(-reach_px, s - 2.0) && usable(t); t -= kStep)
            peak = std::max(peak, Sample(distance, u + t * nx, v + t * ny));
          if (peak < level) level = levels.outside + 0.5 * (peak - levels.outside);
          break;
        }
        below = d;
      }
      double previous = -1;
      for (double s = start; s >= -reach_px; s -= kStep) {
        const double x = u + s * nx, y = v + s * ny;
        if (!usable(s)) return;
        const double d = Sample(distance, x, y);
        if (d >= level) {
          if (previous < 0) return;  // already over it outside: no cloth to start from
          const double f = (level - previous) / std::max(1e-9, d - previous);
          const double at = s + kStep * (1 - f);
          if (!far_only_ || far_side) rim.emplace_back(u + at * nx, v + at * ny);
          return;
        }
        previous = d;
      }
    });
    return rim;
  }

  // Fits the sphere's outline to rim points (least squares on the signed pixel distance,
  // with points more than kRimHuberPx off given a constant pull), the rim found again from
  // each new position.
  cv::Point2d FitToRim(cv::Point2d xy, const cv::Mat& distance, const RimLevels& levels,
                       double reach_px, int* used = nullptr) const {
    for (int round = 0; round < 3; ++round) {
      const std::vector<cv::Point2d> rim = RimPoints(xy, distance, levels, reach_px);
      if (used) *used = static_cast<int>(rim.size());
      if (static_cast<int>(rim.size()) < kMinRimPoints) return xy;
      const cv::Point2d start = xy;
      xy = CompassSearch(xy, 0.1 * radius_, radius_, [&](const cv::Point2d& p) {
        return -OutlineHuberCost(
            SphereSilhouetteConic(pose_, K_, cv::Vec3d(p.x, p.y, radius_), radius_), rim);
      });
      if (cv::norm(xy - start) < 0.05 * radius_) break;
    }
    return xy;
  }

  // Edge points of a ball at `xy`: along each outline normal (reach_px either side), the
  // outermost local maximum of the outward fall that reaches half the largest fall on that
  // normal and whose outer side (1.5 px beyond) is below `cloth_level` in `distance`:
  // a ball's outline is its outermost edge, its inner edges (a highlight, the border of a
  // lit cap) lie inside it, and an edge with no cloth beyond it (a cushion face seen
  // behind the ball, another ball) is not its outline against the cloth. Scans that meet
  // another ball's pixels are left out.
  std::vector<cv::Point2d> EdgePoints(const cv::Point2d& xy, double reach_px,
                                      const cv::Mat& distance, double cloth_level,
                                      const ShadedOutside* shaded) const {
    std::vector<cv::Point2d> points;
    // A pixel in from the area's border: the Sobel falls there see its reflected border.
    const auto inside_area = [this](double x, double y) {
      return x >= area_.x + 1 && y >= area_.y + 1 && x <= area_.x + area_.width - 3 &&
             y <= area_.y + area_.height - 3;
    };
    constexpr double kStep = 0.25;
    std::vector<double> falls;
    // The outermost qualifying peak of the outward fall along the normal at (u, v) in the
    // gradients (gx, gy): its offset along the normal, or false when there is none.
    const auto outermost_edge = [&](const cv::Mat& gx, const cv::Mat& gy, double u, double v,
                                    double nx, double ny, double* at_out) {
      falls.clear();
      for (double s = reach_px; s >= -reach_px; s -= kStep) {
        const double x = u + s * nx, y = v + s * ny;
        if (!inside_area(x, y)) return false;
        const int ix = static_cast<int>(x), iy = static_cast<int>(y);
        if (!roi_.contains({ix, iy}) || claimed_.at<float>(iy - roi_.y, ix - roi_.x) > 0.01)
          return false;
        falls.push_back(-(Sample(gx, x, y) * nx + Sample(gy, x, y) * ny));
      }
      const double peak = *std::max_element(falls.begin(), falls.end());
      if (peak <= 0) return false;
      for (size_t k = 1; k + 1 < falls.size(); ++k) {
        const double f = falls[k];
        if (f < 0.5 * peak || f < falls[k - 1] || f < falls[k + 1]) continue;
        // Sub-pixel: the vertex of the parabola through the three samples.
        const double den = falls[k - 1] - 2 * f + falls[k + 1];
        const double shift = den < 0 ? 0.5 * (falls[k - 1] - falls[k + 1]) / den : 0;
        const double at = reach_px - kStep * (k + shift);
        const double ox = u + (at + 1.5) * nx, oy = v + (at + 1.5) * ny;
        if (!inside_area(ox, oy) || Sample(distance, ox, oy) > cloth_level) continue;
        *at_out = at;
        return true;
      }
      return false;
    };
    ForEachOutlinePoint(xy, [&](double u, double v, double nx, double ny, bool far_side) {
      double at = 0;
      if (!outermost_edge(gx_, gy_, u, v, nx, ny, &at)) return;
      if (shaded == nullptr) {
        points.emplace_back(u + at * nx, v + at * ny);
        return;
      }
      // Against a dark outside on the far side, the luma's edge when it lies no farther
      // out; else, for a ball brighter than the cloth in luma, when it lies this near.
      bool dark_outside = false;
      if (far_side) {
        double darkest = std::numeric_limits<double>::max();
        for (double t = 0.5; t <= 2.0; t += 0.5) {
          const double x = u + (at + t) * nx, y = v + (at + t) * ny;
          if (inside_area(x, y)) darkest = std::min(darkest, Sample(shaded->brightness, x, y));
        }
        dark_outside = darkest < shaded->level;
      }
      double luma_at = 0;
      if ((dark_outside || shaded->luma_snap_px > 0) &&
          outermost_edge(shaded->luma_gx, shaded->luma_gy, u, v, nx, ny, &luma_at)) {
        if (dark_outside && luma_at <= at + kStep)
          at = luma_at;
        else if (std::abs(luma_at - at) <= shaded->luma_snap_px)
          at = luma_at;
      }
      points.emplace_back(u + at * nx, v + at * ny);
    });
    return points;
  }

  // Fits the sphere's outline to its edge points (as FitToRim, the points found again from
  // each new position), with the start position counting as `prior_points` points on its
  // outline (a quadratic pull on the image distance from it). With `shaded`, far-side
  // points against a dark outside are taken on the luma (ShadedOutside).
  cv::Point2d FitToEdgePoints(cv::Point2d xy, const cv::Mat& distance, double cloth_level,
                              double reach_px, double prior_points,
                              const ShadedOutside* shaded) const {
    const cv::Point2d origin = ProjectIdeal(pose_, K_, {xy.x, xy.y, radius_});
    for (int round = 0; round < 3; ++round) {
      const std::vector<cv::Point2d> points =
          EdgePoints(xy, reach_px, distance, cloth_level, shaded);
      if (static_cast<int>(points.size()) < kMinRimPoints) return xy;
      const cv::Point2d start = xy;
      xy = CompassSearch(xy, 0.1 * radius_, radius_, [&](const cv::Point2d& p) {
        const cv::Vec3d centre(p.x, p.y, radius_);
        const cv::Matx33d Q = SphereSilhouetteConic(pose_, K_, centre, radius_);
        const cv::Point2d moved = ProjectIdeal(pose_, K_, centre) - origin;
        return -(0.5 * prior_points * moved.dot(moved) + OutlineHuberCost(Q, points));
      });
      if (cv::norm(xy - start) < 0.05 * radius_) break;
    }
    return xy;
  }

  // The silhouette fit leans along the line of sight (JPEG's smeared colour grows a
  // bright ball's blob upwards; a dark ball's shadow joins its blob below), so the outline
  // is first scanned along the line of sight, then refined in both directions.
  cv::Point2d Fit(cv::Point2d xy, const cv::Vec3d& camera) const {
    int used = 0;
    Score(xy, &used);
    if (used < 6) return xy;
    cv::Point2d sight(xy.x - camera[0], xy.y - camera[1]);
    const double length = cv::norm(sight);
    if (length > 1e-6) {
      sight *= 1.0 / length;
      cv::Point2d best = xy;
      double best_score = Score(xy);
      for (int k = -8; k <= 8; ++k) {
        if (k == 0) continue;
        const cv::Point2d p = xy + sight * (0.1 * k * radius_);
        const double s = Score(p);
        if (s > best_score) {
          best_score = s;
          best = p;
        }
      }
      xy = best;
    }
    return CompassSearch(xy, 0.1 * radius_, 0.5 * radius_,
                         [this](const cv::Point2d& p) { return Score(p); });
  }

 private:
  double Sample(const cv::Mat& m, double u, double v) const {
    const double x = u - area_.x, y = v - area_.y;
    const int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
    const double fx = x - x0, fy = y - y0;
    return (1 - fy) * ((1 - fx) * m.at<float>(y0, x0) + fx * m.at<float>(y0, x0 + 1)) +
           fy * ((1 - fx) * m.at<float>(y0 + 1, x0) + fx * m.at<float>(y0 + 1, x0 + 1));
  }

  const cv::Mat& gx_;
  const cv::Mat& gy_;
  cv::Rect area_;
  const cv::Mat& claimed_;
  cv::Rect roi_;
  const SilhouetteScorer& scorer_;
  cv::Matx33d K_;
  PlanarPose pose_;
  double radius_;
  cv::Vec3d camera_;
  bool skip_shadowed_ = false;
  double outward_reach_px_ = 0;
  bool far_only_ = false;
  std::vector<cv::Vec3d> neighbours_;
  static constexpr double kNeighbourMargin = 1.3;  // apparent radii
  static constexpr double kShadowReach = 1.3;      // radii
  static constexpr double kRimHuberPx = 1.0;

  // Huber cost (kRimHuberPx) of points' distances to a sphere's projected outline Q: the
  // rim fit's and the edge-point fit's objective.
  static double OutlineHuberCost(const cv::Matx33d& Q, const std::vector<cv::Point2d>& points) {
    double cost = 0;
    for (const auto& q : points) {
      const double e = std::abs(SilhouetteScorer::InsideDistance(Q, q.x, q.y));
      cost += e < kRimHuberPx ? 0.5 * e * e : kRimHuberPx * (e - 0.5 * kRimHuberPx);
    }
    return cost;
  }
};

// The level of a ball's rim step in `distance` (over `area`) for a ball at `xy`: half-way
// from the median just outside its outline (1.5-3.5 px out; `outside_level`) to the median
// inside it (at least 1 px in), leaving out other balls' pixels and the dark zone under
// it. 0 when either side has too few pixels.
double RimThreshold(const cv::Mat& distance, const cv::Rect& area, const cv::Mat& claimed,
                    const cv::Rect& roi, const SilhouetteScorer& scorer, const PlanarPose& pose,
                    const cv::Matx33d& K, const cv::Point2d& xy, double radius,
                    double* outside_level = nullptr) {
  const cv::Vec3d centre(xy.x, xy.y, radius);
  const cv::Matx33d Q = SphereSilhouetteConic(pose, K, centre, radius);
  const cv::Rect box = scorer.Box(centre);
  std::vector<float> inside, outside;
  for (int v = box.y; v < box.y + box.height; ++v)
    for (int u = box.x; u < box.x + box.width; ++u) {
      if (!area.contains({u, v}) || claimed.at<float>(v - roi.y, u - roi.x) > 0.01) continue;
      if (scorer.InShadowZone(centre, u, v)) continue;
      const double depth = SilhouetteScorer::InsideDistance(Q, u, v);
      const float d = distance.at<float>(v - area.y, u - area.x);
      if (depth >= 1) {
        inside.push_back(d);
      } else if (depth <= -1.5 && depth >= -3.5) {
        outside.push_back(d);
      }
    }
  constexpr size_t kMinPixels = 8;
  if (inside.size() < kMinPixels || outside.size() < kMinPixels) return 0;
  std::nth_element(inside.begin(), inside.begin() + inside.size() / 2, inside.end());
  std::nth_element(outside.begin(), outside.begin() + outside.size() / 2, outside.end());
  const double in = inside[inside.size() / 2], out = outside[outside.size() / 2];
  if (outside_level) *outside_level = out;
  return in > out ? out + 0.5 * (in - out) : 0;
}

// Reference chroma (intensity-normalised opponent colour) of each ball colour.
struct ColourRef {
  double chroma_x, chroma_y;
  double saturation;  // |chroma|
  double blue_share;  // BlueShare of the colour
};

// Blue over the larger of red and green: about 0.1 for the yellow of the 1 and the 9,
// about 0.95 for their white, and in between, in proportion, for a mix of the two.
double BlueShare(const cv::Vec3b& bgr) {
  return bgr[0] / std::max(1.0, static_cast<double>(std::max(bgr[1], bgr[2])));
}

// Fewest of the 48 outline points an edge fit needs after leaving out the shadowed ones.
constexpr int kMinOutlinePoints = 16;

// Colour is read this far (pixels) inside a ball's outline.
constexpr double kInteriorPx = 1.0;
// PoolLuma of a pixel in float, for the per-pixel loops.
inline float PixelLuma(const cv::Vec3b& p) { return 0.114f * p[0] + 0.587f * p[1] + 0.299f * p[2]; }
// PoolBallOptions::edge_luma_snap_px: a ball is brighter than the cloth in luma when its
// median is over this many times the cloth's (by their albedos the cue, 1, 9 and 5 are
// 1.45-2.4 times the benchmark's green cloth, the red 3 0.9, the 2 and 4 0.6), and the snap reaches
// at most this share of its apparent radius (on a 9-ft table's 3-5 px balls a whole pixel found
// other edges: 24 -> 27 balls over 10 mm on seed 7's set, 26 with the share).
constexpr double kBrighterLuma = 1.15;
constexpr double kLumaSnapRadii = 0.15;
// PoolBallOptions::near_half_dark_share: the near half is the silhouette's pixels more than
// this many apparent radii from its centre towards the camera, and is judged on at least
// this many of them.
constexpr double kNearHalfFrom = 0.18;
constexpr size_t kMinNearHalfPixels = 5;
// AddBallsOfTheClothsHue (PoolBallOptions::cloth_hue_ball_dark_share): a highlight is a
// blob of pixels this many times as bright as the cloth (B + G + R; the cloth and the
// shade along a cushion hold none) and at most this share of a ball's apparent area (not
// a white ball's lit top).
constexpr double kClothHueHighlight = 1.3;
constexpr double kClothHueMaxHighlight = 0.5;
// Its ball is seen already when, in the disc of one apparent radius around it, this share
// of a ball's area is ball by colour, or this share ball at all (by colour or darkness).
constexpr double kClothHueBallShare = 0.35;
constexpr double kClothHueSeenShare = 0.5;
// Otherwise the darker pixels within this many apparent radii of it are its ball's: the
// highlight lies within about half a radius of the centre, towards the lamps, and a wider
// reach takes in the shadow under the ball (1.4: 59 + 62 balls over 10 mm on the twenty
// sRGB sets, 1.0: 55 + 64, 1.2: 57 + 58; without the rule 53 + 64).
constexpr double kClothHueReach = 1.2;
// A ball's body for whether it is darker than the cloth (RefineOutlines): its coloured
// pixels and its grey ones under this share of the cloth's brightness, when they are at
// least this share of its pixels. Over the twenty benchmark sets rendered sRGB, balls over
// 10 mm 94 + 124 -> 87 + 117 (false balls 16 + 12 -> 14 + 10); linear 50 + 74 -> 51 + 73.
// With every grey pixel under the cloth's brightness in the body, a cue ball's shaded
// half was its body (linear: 52 + 78, seven cue balls over 10 mm more).
constexpr float kBodyGreyMax = 0.5f;
// PoolBallOptions::edge_interior_level: a ball's interior is its pixels this far inside
// its outline (pixels), read on a ball of at least kMinInteriorRadiusPx apparent radius.
constexpr double kInteriorDepthPx = 1;
constexpr double kMinInteriorRadiusPx = 4;
constexpr double kMinBodyShare = 0.25;
// PoolBallOptions::darker_edge_pass_srgb: a ball is of the cloth's hue when the median
// hue of its coloured pixels is within this of the cloth's (30 and 60 measured the same).
constexpr double kClothLikeHueGapDeg = 45;

// The median of `values` (not empty), which are reordered.
float MedianOf(std::vector<float>* values) {
  auto middle = values->begin() + values->size() / 2;
  std::nth_element(values->begin(), middle, values->end());
  return *middle;
}

// Whether a ball is of the cloth's hue or of none (PoolBallOptions::darker_edge_pass_srgb):
// the median gap between `hues` (degrees, of its coloured pixels; reordered) and the
// cloth's is under kClothLikeHueGapDeg, or they are too few of its `ball_pixels` to say
// (a grey or black ball).
bool OfClothHueOrNone(std::vector<float>* hues, size_t ball_pixels, const cv::Vec3f& cloth) {
  if (hues->size() < 5 || hues->size() < kMinBodyShare * ball_pixels) return true;
  double cloth_hue, unused_saturation, unused_intensity;
  HueSaturation(cloth, &cloth_hue, &unused_saturation, &unused_intensity);
  for (float& h : *hues) h = static_cast<float>(HueGapDeg(h, cloth_hue));
  return MedianOf(hues) < kClothLikeHueGapDeg;
}

}  // namespace

absl::Status PoolBallOptions::Validate() const {
  if (!(ball_angle_deg > 0 && ball_angle_deg < 45))
    return absl::InvalidArgumentError("ball_angle_deg must be in (0, 45)");
  if (!(ball_angle_soft_deg > 0 && ball_angle_soft_deg < ball_angle_deg))
    return absl::InvalidArgumentError("ball_angle_soft_deg must be in (0, ball_angle_deg)");
  if (!(ball_chroma_distance > 0.1 && ball_chroma_distance < 2))
    return absl::InvalidArgumentError("ball_chroma_distance must be in (0.1, 2)");
  if (!(cloth_hue_ball_dark_share == 0 ||
        (cloth_hue_ball_dark_share > dark_fraction + 0.1 && cloth_hue_ball_dark_share < 1)))
    return absl::InvalidArgumentError(absl::StrCat(
        "cloth_hue_ball_dark_share must be 0 (off) or above dark_fraction + 0.1 and under 1 "
        "(a share of the cloth's brightness), got ",
        cloth_hue_ball_dark_share));
  if (!(bright_fraction_srgb == 0 || (bright_fraction_srgb >= 1.2 && bright_fraction_srgb <= 4)))
    return absl::InvalidArgumentError(absl::StrCat(
        "bright_fraction_srgb must be 0 (off) or in [1.2, 4] (a multiple of the cloth's "
        "brightness; nearer 1 the lit cloth itself reads as ball), got ",
        bright_fraction_srgb));
  if (!(dark_fraction > 0.05 && dark_fraction < 0.9))
    return absl::InvalidArgumentError("dark_fraction must be in (0.05, 0.9)");
  if (!(cushion_shade_dark_share >= 0 && cushion_shade_dark_share <= 1))
    return absl::InvalidArgumentError(
        "cushion_shade_dark_share must be in [0, 1] (a share of the cloth's level by the "
        "cushions; 0: off)");
  if (!(min_area_fraction > 0 && min_area_fraction <= 1))
    return absl::InvalidArgumentError("min_area_fraction must be in (0, 1]");
  if (!(stick_opening_radius >= 0 && stick_opening_radius < 1))
    return absl::InvalidArgumentError(absl::StrCat(
        "stick_opening_radius must be in [0, 1) ball radii (a stick is thinner than a ball), got ",
        stick_opening_radius));
  if (!(seed_merge_distance > 0 && seed_merge_distance <= 2))
    return absl::InvalidArgumentError(absl::StrCat(
        "seed_merge_distance must be in (0, 2] ball radii (two balls are at least 2 apart), "
        "got ",
        seed_merge_distance));
  if (!(stick_bridge_length > 0))
    return absl::InvalidArgumentError(absl::StrCat(
        "stick_bridge_length must be positive (ball radii the stick's line is followed past "
        "each strip over the cloth), got ",
        stick_bridge_length));
  if (!(min_stick_elongation >= 1))
    return absl::InvalidArgumentError(
        absl::StrCat("min_stick_elongation must be at least 1 (length over mean width), got ",
                     min_stick_elongation));
  if (!(min_stick_length >= 2))
    return absl::InvalidArgumentError(
        absl::StrCat("min_stick_length must be at least 2 ball radii (one ball's width), got ",
                     min_stick_length));
  if (!(min_fit_ballness > 0 && min_fit_ballness < 1))
    return absl::InvalidArgumentError("min_fit_ballness must be in (0, 1)");
  if (!(one_white_share > 0 && one_white_share < cue_white_share && cue_white_share < 1))
    return absl::InvalidArgumentError("need 0 < one_white_share < cue_white_share < 1");
  if (!(white_outward_weight >= 0 && white_outward_weight <= 2))
    return absl::InvalidArgumentError(
        absl::StrCat("white_outward_weight must be in [0, 2], got ", white_outward_weight));
  if (!(white_outward_of_one >= -1 && white_outward_of_one <= 1))
    return absl::InvalidArgumentError(
        absl::StrCat("white_outward_of_one must be in [-1, 1], got ", white_outward_of_one));
  if (!(five_orange_share > 0 && five_orange_share < 0.5))
    return absl::InvalidArgumentError("five_orange_share must be in (0, 0.5)");
  if (!(line_of_sight_pair_deg >= 0 && line_of_sight_pair_deg < 90))
    return absl::InvalidArgumentError(absl::StrCat(
        "line_of_sight_pair_deg must be in [0, 90) (degrees between a touching pair's line "
        "and the line of sight; 0 turns the rule off), got ",
        line_of_sight_pair_deg));
  if (!(white_balance_min_cast >= 0 && white_balance_min_cast < 1))
    return absl::InvalidArgumentError(absl::StrCat(
        "white_balance_min_cast must be in [0, 1) (a share of a channel's gain; 0 turns the "
        "white balance off), got ",
        white_balance_min_cast));
  if (!(moved_number_weight > 0 && moved_number_weight <= 1))
    return absl::InvalidArgumentError(absl::StrCat(
        "moved_number_weight must be in (0, 1] (a factor on a moved ball's number scores), got ",
        moved_number_weight));
  if (!(max_black_share_srgb >= 0 && max_black_share_srgb <= 1))
    return absl::InvalidArgumentError(
        absl::StrCat("max_black_share_srgb must be in [0, 1] (a share of a ball's votes), got ",
                     max_black_share_srgb));
  if (!(unnamed_score >= 0 && unnamed_score < 1))
    return absl::InvalidArgumentError(absl::StrCat(
        "unnamed_score must be in [0, 1) (a number's share of the votes), got ", unnamed_score));
  if (!(rim_outward_reach >= 0 && rim_outward_reach <= 2))
    return absl::InvalidArgumentError("rim_outward_reach must be in [0, 2]");
  if (!(edge_point_reach >= 0 && edge_point_reach <= 2))
    return absl::InvalidArgumentError("edge_point_reach must be in [0, 2]");
  if (!(near_half_dark_share >= 0 && near_half_dark_share <= 1))
    return absl::InvalidArgumentError("near_half_dark_share must be in [0, 1]");
  if (!(rim_full_colour_saturation >= 0 && rim_full_colour_saturation <= 1))
    return absl::InvalidArgumentError("rim_full_colour_saturation must be in [0, 1]");
  if (!(straight_rim_silhouette_share >= 0 && straight_rim_silhouette_share < 1))
    return absl::InvalidArgumentError(
        "straight_rim_silhouette_share must be in [0, 1) (0: the rim fit alone; at 1 the rim "
        "fit would not count)");
  if (!(min_fit_ballness_by_colour >= 0 && min_fit_ballness_by_colour <= min_fit_ballness))
    return absl::InvalidArgumentError(
        "min_fit_ballness_by_colour must be in [0, min_fit_ballness] (0: off)");
  if (!(colour_below_ballness >= 0 && colour_below_ballness <= 1))
    return absl::InvalidArgumentError(
        "colour_below_ballness must be in [0, 1] (a ball-ness by colour; 0: off)");
  if (!(colour_below_front_ballness >= 0 && colour_below_front_ballness <= 1))
    return absl::InvalidArgumentError(
        "colour_below_front_ballness must be in [0, 1] (a ball-ness by colour; 0: off)");
  if (!(same_ball_colour_ballness >= 0 && same_ball_colour_ballness <= 1))
    return absl::InvalidArgumentError(
        "same_ball_colour_ballness must be in [0, 1] (a ball-ness by colour; 0: off)");
  if (!(edge_interior_level > 0 && edge_interior_level <= 1))
    return absl::InvalidArgumentError(
        "edge_interior_level must be in (0, 1] (a quantile of a ball's interior; 1: off)");
  if (!(edge_point_prior >= 0 && edge_point_prior <= 100))
    return absl::InvalidArgumentError("edge_point_prior must be in [0, 100]");
  if (!(edge_max_ballness_drop > 0 && edge_max_ballness_drop <= 1))
    return absl::InvalidArgumentError("edge_max_ballness_drop must be in (0, 1]");
  if (!(edge_shade_brightness >= 0 && edge_shade_brightness <= 1))
    return absl::InvalidArgumentError("edge_shade_brightness must be in [0, 1]");
  if (!(edge_luma_snap_px >= 0 && edge_luma_snap_px <= 3))
    return absl::InvalidArgumentError("edge_luma_snap_px must be in [0, 3] pixels");
  if (!(dark_reflection_brightness >= 0 && dark_reflection_brightness < 1))
    return absl::InvalidArgumentError(
        "dark_reflection_brightness must be in [0, 1) (a share of the lit cloth's brightness)");
  if (!(dark_reflection_chroma_srgb >= 0 && dark_reflection_chroma_srgb < 1))
    return absl::InvalidArgumentError(absl::StrCat(
        "dark_reflection_chroma_srgb must be in [0, 1) (a share of the lit cloth's colour), got ",
        dark_reflection_chroma_srgb));
  if (!(vote_min_colour_share >= 0 && vote_min_colour_share <= 1))
    return absl::InvalidArgumentError(
        absl::StrCat("vote_min_colour_share must be in [0, 1] (a share of a colour's chroma), got ",
                     vote_min_colour_share));
  if (!(dark_reflection_hue_deg >= 0 && dark_reflection_hue_deg <= 180))
    return absl::InvalidArgumentError("dark_reflection_hue_deg must be in [0, 180] degrees");
  if (!(split_hidden_min_visible >= 0 && split_hidden_min_visible <= 1))
    return absl::InvalidArgumentError("split_hidden_min_visible must be in [0, 1]");
  if (!(split_hidden_min_ballness > 0.5 && split_hidden_min_ballness <= 1))
    return absl::InvalidArgumentError("split_hidden_min_ballness must be in (0.5, 1]");
  if (!(split_hidden_min_radius_px >= 0))
    return absl::InvalidArgumentError("split_hidden_min_radius_px must be >= 0");
  if (!(split_hidden_min_unexplained >= 0 && split_hidden_min_unexplained < 1))
    return absl::InvalidArgumentError(
        "split_hidden_min_unexplained must be in [0, 1) (a share of a ball's area)");
  return absl::OkStatus();
}

cv::Matx33d SphereSilhouetteConic(const PlanarPose& pose, const cv::Matx33d& K,
                                  const cv::Vec3d& centre, double radius) {
  const cv::Vec3d c = pose.R * centre + pose.t;
  const cv::Matx33d cone = c * c.t() - (c.dot(c) - radius * radius) * cv::Matx33d::eye();
  const cv::Matx33d Kinv = K.inv();
  return Kinv.t() * cone * Kinv;
}

std::array<double, 10> PoolNumberScores(const PoolVotes& votes, const PoolBallOptions& o,
                                        double white_outward) {
  std::array<double, 10> s{};
  double total = 0;
  for (double v : votes) total += v;
  if (total <= 0) return s;
  // Yellow votes of a ball with a real share of orange ones are an orange 5 faded by
  // mixing (options.five_orange_share): they count for the 5, not for the 1/9 group.
  const double yellow_orange = votes[1] + votes[5];
  const double orange_share = yellow_orange > 0 ? votes[5] / yellow_orange : 0;
  const double faded = std::clamp(orange_share / o.five_orange_share - 1, 0.0, 1.0);
  const double yellow = votes[1] * (1 - faded);
  for (int k = 2; k <= 8; ++k) s[k] = votes[k] / total;
  s[5] = (votes[5] + votes[1] * faded) / total;
  // The 3 and the 7 share the red votes (split by saturation in DetectPoolBalls): a red
  // ball is never ruled out as either, so that when two red balls both look like one of
  // them, the less likely number still goes to one of them rather than to neither.
  const double red = votes[3] + votes[7];
  s[3] = (0.3 * red + 0.7 * votes[3]) / total;
  s[7] = (0.3 * red + 0.7 * votes[7]) / total;
  // Seed eq. 4.3: the cue, the 1 and the 9 are the white+yellow balls; the white share
  // of their white+yellow votes tells them apart (over cue_white_share: cue, under
  // one_white_share: 1, else 9). The cue's score keeps growing up to all white, so that a
  // 9 showing mostly its white caps does not tie with the cue.
  const double group = (votes[0] + yellow) / total;
  const double w = votes[0] + yellow > 0 ? votes[0] / (votes[0] + yellow) : 0;
  const double mid = (o.cue_white_share + o.one_white_share) / 2;
  const double half = (o.cue_white_share - o.one_white_share) / 2;
  s[0] = group * std::clamp((w - mid) / (1 - mid), 0.0, 1.0);
  // In an sRGB picture neither the cue ball nor the green 6 has black: their shaded sides
  // are lifted to grey and dark green (options.max_black_share_srgb). An 8 whose number
  // disc faces the camera is as white as a cue ball besides its black, and on green cloth
  // its few dark pixels tinted by the cloth read as the 6's.
  if (o.pixel_encoding == PixelEncoding::kSrgb && o.max_black_share_srgb > 0) {
    const double black_share = votes[8] / total, most = o.max_black_share_srgb;
    const double not_black = std::clamp((most - black_share) / (0.5 * most), 0.0, 1.0);
    s[0] *= not_black;
    s[6] *= not_black;
  }
  // Between the 1 and the 9, white at the outline counts as more of the 9's white caps.
  const double w19 =
      std::clamp(w + o.white_outward_weight * (white_outward - o.white_outward_of_one), 0.0, 1.0);
  s[1] = group * std::clamp((mid - w19) / half, 0.0, 1.0);
  // The 9 shows anything from its stripe alone to mostly white, depending on how it
  // lies: never ruled out, preferred from the middle band up, and less likely only towards
  // all white (the cue's). A score peaked at the middle made a yellow 1 whose highlight
  // reads as white (share 0.38) a better 9 than the real 9 beside it (share 0.75), which
  // was then left unnamed: with each number used once, the whiter of two yellow balls
  // must stay the better 9.
  const double rise = std::clamp(1 - (mid - w19) / (1.5 * half), 0.0, 1.0);
  const double fall = std::clamp((1 - w) / (1 - o.cue_white_share), 0.0, 1.0);
  s[9] = group * (0.35 + 0.65 * rise * fall);
  return s;
}

namespace {
// A cloth within this hue of the red 3 (burgundy) votes red inside a ball's outline.
constexpr double kRedClothHueGapDeg = 45;
// The two calibrated red colours' cues: saturation and log brightness over the cloth.
struct RedCues {
  double sat[2], log_bright[2];  // [0] the 3, [1] the 7; log_bright NaN when unusable
  // How far each cue may go, in quarters of the gap (SaturationZ, BrightnessZ): the one that
  // decides up to the whole gap, the other up to half of it, where it only tips a ball
  // that the first leaves near the middle. In a linear picture saturation decides:
  // brightness depends on how each ball sits in the light (a 3 away from the lamps is as
  // dark as a 7 under one). In an sRGB picture, read in light, brightness decides: JPEG's
  // colour smear, undone by the decoding, takes a small 3's saturation down to the 7's
  // (over the twenty sets rendered sRGB, the 3s' 5th percentile 2.32 against the 7s' 95th
  // 2.43), while its brightness over the cloth around it stays clear of theirs (1st
  // percentile 1.40 against 99th 1.58). Linear, saturation 1.47 against 1.57 and brightness
  // 0.92 against 1.09. With saturation deciding, 9 separated 3s and 7s of the twenty sets
  // rendered sRGB were misnamed (none is now), and the 9-ft set named 3 balls fewer.
  double sat_cap = 4, bright_cap = 2;
};
// In light for kSrgb (the profile's colours decoded).
RedCues RedCuesOf(const PoolTableProfile& profile, PixelEncoding encoding) {
  const auto values = [encoding](const cv::Vec3b& v) {
    return ColourInLight(cv::Vec3f(v[0], v[1], v[2]), encoding);
  };
  RedCues c;
  if (encoding == PixelEncoding::kSrgb) {
    c.sat_cap = 2;
    c.bright_cap = 4;
  }
  const cv::Vec3f pc = values(profile.cloth_bgr);
  const double cloth = std::max(0.1, (pc[0] + pc[1] + pc[2]) / 3.0);
  for (int k = 0; k < 2; ++k) {
    double hue, intensity;
    HueSaturation(values(profile.ball_bgr[k == 0 ? 3 : 7]), &hue, &c.sat[k], &intensity);
    c.log_bright[k] = intensity > 0 ? std::log(intensity / cloth) : std::nan("");
  }
  return c;
}
// Each cue as a signed distance in quarters of the gap between the two calibrated colours
// (positive: towards the 3), capped as RedCues says; 0 when the colours do not differ in
// it.
double SaturationZ(double saturation_delta, const RedCues& c) {
  if (std::abs(c.sat[0] - c.sat[1]) <= 0.05) return 0;
  return std::clamp(saturation_delta / ((c.sat[0] - c.sat[1]) / 4), -c.sat_cap, c.sat_cap);
}
double BrightnessZ(double log_brightness_delta, const RedCues& c) {
  if (!(std::abs(c.log_bright[0] - c.log_bright[1]) > 0.1)) return 0;
  return std::clamp(log_brightness_delta / ((c.log_bright[0] - c.log_bright[1]) / 4), -c.bright_cap,
                    c.bright_cap);
}
}  // namespace

double PoolRedShareOfThree(double saturation, double brightness, const PoolTableProfile& profile,
                           PixelEncoding encoding) {
  const RedCues c = RedCuesOf(profile, encoding);
  double z = SaturationZ(saturation - (c.sat[0] + c.sat[1]) / 2, c);
  if (brightness > 0)
    z += BrightnessZ(std::log(brightness) - (c.log_bright[0] + c.log_bright[1]) / 2, c);
  return 1 / (1 + std::exp(-z));
}

double PoolRedPairShareOfThree(double saturation_a, double brightness_a, double saturation_b,
                               double brightness_b, const PoolTableProfile& profile,
                               PixelEncoding encoding) {
  const RedCues c = RedCuesOf(profile, encoding);
  double z = SaturationZ(saturation_a - saturation_b, c);
  if (brightness_a > 0 && brightness_b > 0)
    z += BrightnessZ(std::log(brightness_a / brightness_b), c);
  return 1 / (1 + std::exp(-z));
}

std::vector<int> AssignPoolNumbers(const std::vector<std::array<double, 10>>& scores,
                                   double unnamed_score) {
  // Dynamic programme over balls and the set of numbers used so far.
  const int n = static_cast<int>(scores.size());
  const int states = 1 << kPoolBallCount;
  std::vector<std::vector<double>> best(n + 1, std::vector<double>(states, -1e18));
  std::vector<std::vector<int>> choice(n + 1, std::vector<int>(states, -1));
  best[0][0] = 0;
  for (int i = 0; i < n; ++i)
    for (int used = 0; used < states; ++used) {
      if (best[i][used] <= -1e17) continue;
      if (best[i][used] + unnamed_score > best[i + 1][used]) {
        best[i + 1][used] = best[i][used] + unnamed_score;
        choice[i + 1][used] = -1;
      }
      for (int k = 0; k < kPoolBallCount; ++k) {
        if (used & (1 << k)) continue;
        const int next = used | (1 << k);
        const double v = best[i][used] + scores[i][k];
        if (v > best[i + 1][next]) {
          best[i + 1][next] = v;
          choice[i + 1][next] = k;
        }
      }
    }
  int used = static_cast<int>(std::max_element(best[n].begin(), best[n].end()) - best[n].begin());
  std::vector<int> numbers(n, -1);
  for (int i = n; i > 0; --i) {
    numbers[i - 1] = choice[i][used];
    if (numbers[i - 1] >= 0) used &= ~(1 << numbers[i - 1]);
  }
  return numbers;
}

namespace {
// SplitHiddenBalls: the farther ball of a pair is not kept when more than this share of
// the pixels it alone explains lie over a cushion's face. Over the twenty benchmark sets
// 13 of 45 splits have over a tenth there, 12 of them 0.19 or more; 0.1-0.2 give the same
// balls, 0.3 keeps five of them (two of the wrong pairs among them).
constexpr double kMaxHiddenCrescentOnFace = 0.15;
// How far a ball's blob reaches outside its silhouette: the lens blur and JPEG's halved
// colour resolution (seed 7's frame 15: a 5 of 5.5 px radius has a blob of 7 px). At 1 px
// (UnexplainedByOneBall) the twenty sRGB sets had 159 + 188 balls over 10 mm, at 2 px 147
// + 178, at 1.5 px 150 + 181; the wider the halo, the less of a real pair's crescent
// counts (seed 19's frame 42 pair: 0.46 of a ball outside at 1.5 px, the limit 0.4).
constexpr double kBallHaloPx = 1.5;

// StickPixels: a strip shorter than kBentStripMaxLength ball radii whose pixels lie
// farther than kMaxStripBend times its mean half-width from its line (the 90th
// percentile) is bent, and not a stick.
constexpr double kBentStripMaxLength = 6;
constexpr double kMaxStripBend = 1.5;

// The line through a strip's pixels (Huber; cv::fitLine's direction and point) and the
// 90th percentile of their distances from it.
double StripLine(const std::vector<cv::Point>& points, cv::Vec4f* line) {
  cv::fitLine(points, *line, cv::DIST_HUBER, 0, 0.01, 0.01);
  const cv::Vec4f& l = *line;
  std::vector<float> offsets;
  for (const cv::Point& p : points)
    offsets.push_back(static_cast<float>(std::abs((p.x - l[2]) * l[1] - (p.y - l[3]) * l[0])));
  std::nth_element(offsets.begin(), offsets.begin() + offsets.size() * 9 / 10, offsets.end());
  return offsets[offsets.size() * 9 / 10];
}

// The cue stick's pixels in `mask` (ROI at `roi`; PoolBallOptions::stick_opening_radius):
// long strips thinner than a ball. A ball's apparent radius changes with the image row, so
// the opening runs in bands of rows, each with the disc of its middle row.
cv::Mat StickPixels(const cv::Mat& mask, const cv::Rect& roi, const PlanarPose& pose,
                    const cv::Matx33d& K, double r, double table_length, double table_width,
                    double cushion_height, const PoolBallOptions& options) {
  cv::Mat stick = cv::Mat::zeros(mask.size(), CV_8UC1);
  if (options.stick_opening_radius <= 0) return stick;
  const auto radius_at = [&](const cv::Point2d& pixel) {
    cv::Point2d xy;
    return BackProjectToPlane(pose, K, pixel, r, &xy) ? ApparentRadiusPx(pose, K, xy, r) : 0.0;
  };
  cv::Mat opened = cv::Mat::zeros(mask.size(), CV_8UC1);
  constexpr int kBand = 24;
  for (int y0 = 0; y0 < mask.rows; y0 += kBand) {
    const int y1 = std::min(mask.rows, y0 + kBand);
    const double r_px = radius_at({roi.x + roi.width / 2.0, roi.y + (y0 + y1) / 2.0});
    if (r_px <= 0) {
      mask.rowRange(y0, y1).copyTo(opened.rowRange(y0, y1));  // nothing removed
      continue;
    }
    const int k = std::max(1, static_cast<int>(std::lround(options.stick_opening_radius * r_px)));
    const int lo = std::max(0, y0 - 2 * k - 1), hi = std::min(mask.rows, y1 + 2 * k + 1);
    cv::Mat band;
    cv::morphologyEx(mask.rowRange(lo, hi), band, cv::MORPH_OPEN,
                     cv::getStructuringElement(cv::MORPH_ELLIPSE, {2 * k + 1, 2 * k + 1}));
    band.rowRange(y0 - lo, y1 - lo).copyTo(opened.rowRange(y0, y1));
  }
  // Not the cushions' faces seen beyond the cloth (between the cloth's outline and the
  // cushion noses' at their top): in the shade of the cushions' lips they are long dark
  // strips too, and a ball against one is thin where the strip leaves it.
  const auto outline = [&](double z) {
    cv::Mat inside = cv::Mat::zeros(mask.size(), CV_8UC1);
    cv::fillConvexPoly(inside, TableOutlinePx(pose, K, table_length, table_width, z, roi.tl()),
                       cv::Scalar(255));
    return inside;
  };
  const cv::Mat cloth_outline = outline(0);
  const cv::Mat faces = outline(cushion_height) & ~cloth_outline;
  const cv::Mat thin_anywhere = mask & ~opened;
  const cv::Mat thin = thin_anywhere & ~faces;
  // Label images are kept per thread: fresh ones were faulted in anew every frame.
  thread_local cv::Mat labels;
  cv::Mat stats, centroids;
  const int n = ConnectedComponentsWithStats(thin, 8, &labels, &stats, &centroids);
  std::vector<uchar> is_stick(n, 0);
  std::vector<double> strip_radius(n, 0);
  // A stick strip's line and the 90th percentile of its pixels' distances from it.
  std::vector<cv::Vec4f> strip_line(n);
  std::vector<double> strip_spread(n, 0);
  std::vector<std::vector<cv::Point>> points(n);
  std::vector<int> on_faces(n, 0);
  for (int y = 0; y < labels.rows; ++y) {
    const int* l = labels.ptr<int>(y);
    const uchar* f = faces.ptr<uchar>(y);
    for (int x = 0; x < labels.cols; ++x)
      if (l[x] > 0) {
        points[l[x]].emplace_back(x, y);
        on_faces[l[x]] += f[x] != 0;
      }
  }
  for (int i = 1; i < n; ++i) {
    if (points[i].size() < 5) continue;
    const double r_px =
        radius_at({centroids.at<double>(i, 0) + roi.x, centroids.at<double>(i, 1) + roi.y});
    if (r_px <= 0) continue;
    strip_radius[i] = r_px;
    const cv::RotatedRect box = cv::minAreaRect(points[i]);
    const double extent = std::max(box.size.width, box.size.height);
    // Long, thin on average (a strip, not a wide patch of shadow), much longer than wide
    // (not what the opening leaves of a ragged ball: seed 7's frame 48 left a green 6
    // beside the 2 as a strip 3.4 radii long and 1.2 wide), and mostly off the faces (a
    // stick crosses them; a strip mostly on them is their shade).
    const double area = static_cast<double>(points[i].size());
    is_stick[i] = extent >= options.min_stick_length * r_px &&
                  area <= 2 * options.stick_opening_radius * r_px * extent &&
                  area * options.min_stick_elongation <= extent * extent &&
                  2 * on_faces[i] < static_cast<int>(points[i].size());
    if (!is_stick[i]) continue;
    strip_spread[i] = StripLine(points[i], &strip_line[i]);
    // A short strip must also be straight: a stick is, but what the opening leaves of a
    // dark ball's lower half joined to a neighbour's shadow is a bent crescent (seed 47's
    // frame 2: a separated green 6 taken out as a stick, 4.5 radii long, its pixels up to
    // 1.75 of its mean half-width from its line). The short strips that the ten cue-stick
    // sets add are within 1.31; long ones, the stick joined to its shadow or to a
    // cushion's shade, bend more and are left to the tests above.
    if (extent < kBentStripMaxLength * r_px &&
        strip_spread[i] > kMaxStripBend * 0.5 * area / extent)
      is_stick[i] = 0;
  }
  // A stick is straight: the thin pixels along each stick strip's line are the stick as
  // well, where the strip was cut (over the faces, past a ball, at its tip): beyond the
  // cloth all of them, over the cloth those within options.stick_bridge_length of the
  // strip's ends (the object ball lies on the line beyond the cue ball).
  for (int i = 1; i < n; ++i) {
    if (!is_stick[i]) continue;
    const cv::Vec4f& line = strip_line[i];
    const double half_width = strip_spread[i] + 1.5;
    const auto off_line = [&](const cv::Point& p) {
      return std::abs((p.x - line[2]) * line[1] - (p.y - line[3]) * line[0]);
    };
    const auto along = [&](const cv::Point& p) {
      return (p.x - line[2]) * line[0] + (p.y - line[3]) * line[1];
    };
    double first = 1e18, last = -1e18;
    for (const cv::Point& p : points[i]) {
      const double t = along(p);
      first = std::min(first, t);
      last = std::max(last, t);
    }
    const double bridge = options.stick_bridge_length * strip_radius[i];
    for (int y = 0; y < thin_anywhere.rows; ++y) {
      const uchar* t = thin_anywhere.ptr<uchar>(y);
      uchar* s = stick.ptr<uchar>(y);
      const uchar* c = cloth_outline.ptr<uchar>(y);
      for (int x = 0; x < thin_anywhere.cols; ++x)
        if (t[x] && off_line({x, y}) <= half_width) {
          const double a = along({x, y});
          if (!c[x] || (a >= first - bridge && a <= last + bridge)) s[x] = 255;
        }
    }
  }
  return stick;
}

// Per-channel gains that give `seen` the chromaticity of `reference` (BGR), keeping the
// sum of its channels.
cv::Vec3f ChromaticityGains(const cv::Vec3f& seen, const cv::Vec3f& reference) {
  const double seen_sum = std::max(1e-6f, seen[0] + seen[1] + seen[2]);
  const double reference_sum = std::max(1e-6f, reference[0] + reference[1] + reference[2]);
  cv::Vec3f gains;
  for (int c = 0; c < 3; ++c)
    gains[c] =
        static_cast<float>((reference[c] / reference_sum) / std::max(1e-3, seen[c] / seen_sum));
  return gains;
}

// True when the gains read from the balls' white and from the cloth both say the light is
// coloured (a channel's gain off 1 by more than `min_cast` on the white, and by more than
// 1.33 times that on the cloth, whose colour is known less well) and say the same colour:
// their logarithms within 37 degrees (cosine 0.8). Gains outside [0.5, 2] are no light's
// colour but a misreading (another cloth than the profile's, no white ball in view).
bool LightCastsAgree(const cv::Vec3f& white_gains, const cv::Vec3f& cloth_gains, double min_cast) {
  cv::Vec3d a, b;
  double cast_a = 0, cast_b = 0;
  for (int c = 0; c < 3; ++c) {
    if (!(white_gains[c] > 0.5f && white_gains[c] < 2.0f)) return false;
    if (!(cloth_gains[c] > 0.5f && cloth_gains[c] < 2.0f)) return false;
    a[c] = std::log(white_gains[c]);
    b[c] = std::log(cloth_gains[c]);
    cast_a = std::max(cast_a, std::abs(white_gains[c] - 1.0));
    cast_b = std::max(cast_b, std::abs(cloth_gains[c] - 1.0));
  }
  if (cast_a <= min_cast || cast_b <= 1.33 * min_cast) return false;
  return a.dot(b) > 0.8 * cv::norm(a) * cv::norm(b);
}

// A ball's white pixels are its light's colour when they are at least this share of its
// pixels (the cue's are 25-100%: its lower part is shaded, its highlight clipped; the 9's
// 20-50%; a coloured ball's highlight fringe 0-25%), at least this many, and their median
// saturation is under kMaxWhiteSaturation (the cue's: 0.05 under a neutral light, 0.3
// under warm lamps half corrected; the 9's white, mixed with its yellow at the stripe's
// edges, up to 0.5). Of those balls, the one with the most white, and the purest, gives
// the light's colour (white share times 1 - saturation): a 9 showing as much white as the
// cue has it mixed with yellow, and a blue ball's highlight under warm light is as
// neutral as the cue but small.
constexpr double kMinWhiteShare = 0.2;
constexpr size_t kMinWhitePixels = 10;
constexpr double kMaxWhiteSaturation = 0.4;

// Median chromaticity (opponent chroma over intensity) of a ball's lit pixels. Dark pixels
// (under 0.45 of the cloth's brightness: a shadow, the 8) have no chromaticity to speak of
// and are left out.
class LitChromaMedian {
 public:
  explicit LitChromaMedian(float cloth_sum) : min_sum_(0.45f * cloth_sum) {}
  void Add(const cv::Vec3b& p) {
    const float sum = static_cast<float>(p[0] + p[1] + p[2]);
    if (sum < min_sum_) return;
    cx_.push_back((p[2] - 0.5f * (p[1] + p[0])) * 3 / sum);
    cy_.push_back(0.8660254f * (p[1] - p[0]) * 3 / sum);
  }
  // False when fewer than `min_pixels` were lit.
  bool Median(size_t min_pixels, cv::Point2d* chroma) {
    if (cx_.size() < min_pixels) return false;
    std::nth_element(cx_.begin(), cx_.begin() + cx_.size() / 2, cx_.end());
    std::nth_element(cy_.begin(), cy_.begin() + cy_.size() / 2, cy_.end());
    *chroma = {cx_[cx_.size() / 2], cy_[cy_.size() / 2]};
    return true;
  }

 private:
  float min_sum_;
  std::vector<float> cx_, cy_;
};

// The chromaticity (LitChromaMedian) of the ball pixels within half a ball's apparent radius
// of where a ball at table position `xy` projects: the colour a seed started on. False for a
// position not given (NaN) or with fewer than 6 lit ball pixels. `ballness` covers `roi`.
bool SeedColour(const cv::Mat& bgr, const cv::Mat& ballness, const cv::Rect& roi,
                const PlanarPose& pose, const cv::Matx33d& K, const cv::Point2d& xy, double r,
                float cloth_sum, cv::Point2d* chroma) {
  if (!std::isfinite(xy.x) || !std::isfinite(xy.y)) return false;
  const cv::Point2d at = ProjectIdeal(pose, K, {xy.x, xy.y, r});
  const double reach = 0.5 * ApparentRadiusPx(pose, K, xy, r);
  LitChromaMedian lit(cloth_sum);
  for (int v = cvFloor(at.y - reach); v <= cvCeil(at.y + reach); ++v)
    for (int u = cvFloor(at.x - reach); u <= cvCeil(at.x + reach); ++u) {
      if (!roi.contains({u, v}) || std::hypot(u - at.x, v - at.y) > reach) continue;
      if (ballness.at<float>(v - roi.y, u - roi.x) < 0.5f) continue;
      lit.Add(bgr.at<cv::Vec3b>(v, u));
    }
  return lit.Median(6, chroma);
}

// One pass of the ball finder over a picture (DetectPoolBallsOnce): its stages, in the order
// Run() calls them, and what they share: the picture as read, the search region and its
// ball-ness maps, the seeds as the stages fit them, and the silhouettes that the other balls
// claim. One object per pass; it keeps references to its arguments. Not thread-safe.
class BallFinder {
 public:
  BallFinder(const cv::Mat& image, const cv::Matx33d& K, const PlanarPose& pose,
             const PoolTableProfile& profile, const cv::Vec3b& cloth_bgr,
             const PoolBallOptions& options)
      : image_(image),
        K_(K),
        pose_(pose),
        profile_(profile),
        options_(options),
        L_(profile.length_mm),
        W_(profile.width_mm),
        r_(profile.ball_radius_mm),
        cloth_(cloth_bgr[0], cloth_bgr[1], cloth_bgr[2]),
        cloth_intensity_((cloth_[0] + cloth_[1] + cloth_[2]) / 3),
        cloth_sum_(cloth_[0] + cloth_[1] + cloth_[2]),
        camera_(CameraCentre(pose)),
        labels_(BlobLabelBuffer()) {}

  // The balls of the picture, whose pixels are valid (the ideal image's) inside `valid`
  // only; `ball_size_ratio` as DetectPoolBalls'.
  std::vector<PoolDetectedBall> Run(const cv::Rect& valid, double* ball_size_ratio) {
    if (ball_size_ratio) *ball_size_ratio = 0;
    if (!FindBallPixels(valid)) return {};
    SeedBlobs(ball_size_ratio);
    FitSilhouettes();
    SplitHiddenBalls();
    RefineOutlines();
    ResolveOverlaps();
    KeepBalls();
    TellRedPairApart();
    return NameBalls();
  }

 private:
  // The blob labels' buffer, kept per thread (as StickPixels' labels).
  static cv::Mat& BlobLabelBuffer() {
    thread_local cv::Mat labels;
    return labels;
  }

  // The picture read through a light blur, the search region and its ball-ness, the ball
  // pixels without the cue stick's (mask_); false when no pixel of the table can be read.
  bool FindBallPixels(const cv::Rect& valid);
  // PoolBallOptions::cloth_hue_ball_dark_share: the darker pixels of blobs that are too
  // little ball by colour to be a ball, yet hold some, added to `ballness`.
  void AddBallsOfTheClothsHue(const cv::Mat& shade, cv::Mat* ballness) const;
  // One seed per expected ball of each blob (touching balls split at distance maxima),
  // and the fragments of a small ball taken together.
  void SeedBlobs(double* ball_size_ratio);
  // Each seed's silhouette fitted, nearest first, then again with all others claimed;
  // two seeds of one ball merged.
  void FitSilhouettes();
  // Whether seed i (seeds_ sorted nearest first) is the nearest of two or more seeds whose
  // balls' centres project into the same blob.
  bool FrontOfBlob(size_t i) const;
  // The blob (labels_) under image pixel `pixel`; 0 off every blob or outside the roi.
  int BlobAt(const cv::Point2d& pixel) const {
    const cv::Point at(cvRound(pixel.x) - roi_.x, cvRound(pixel.y) - roi_.y);
    return at.inside(cv::Rect(0, 0, roi_.width, roi_.height)) ? labels_.at<int>(at) : 0;
  }
  // The blob under the centre of the ball at table position `xy`.
  int BlobOfBall(const cv::Point2d& xy) const {
    return BlobAt(ProjectIdeal(pose_, K_, {xy.x, xy.y, r_}));
  }
  // A blob of two balls, one behind the other, with one seed: fitted as two.
  void SplitHiddenBalls();
  // The pixels of blob `label` (labels_) more than kBallHaloPx outside the silhouette of
  // one ball fitted to it from seed i, over a ball's area
  // (PoolBallOptions::split_hidden_min_unexplained).
  double UnexplainedByOneBall(size_t i, int label);
  // Each fit moved onto its outline: the edge, the edge points, the rim.
  void RefineOutlines();
  // Fits closer than two balls can be: dropped or moved out of each other.
  void ResolveOverlaps();
  // The fits that are balls, with their colour votes (balls_).
  void KeepBalls();
  // Two red balls are the 3 and the 7: told apart by their differences.
  void TellRedPairApart();
  // Overlapping balls moved apart, and each ball's number.
  std::vector<PoolDetectedBall> NameBalls();

  // `map` (over roi_) where balls can be: outside the playing volume no ball can be, 0.
  // The pockets are masked out at the cloth and at the cushion top; seen from low on the
  // table's long axis, a ball in front of a side pocket lies partly over that mask. Those
  // pixels say nothing about the ball (they are not cloth): kMaskedOut, left out of the
  // fits (a 7 beside a side pocket with a third of its silhouette masked was rejected as
  // half cloth, benchmark frame 53), as are the cue stick's.
  cv::Mat InPlayingVolume(const cv::Mat& map) const {
    cv::Mat out(map.size(), CV_32FC1);
    for (int y = 0; y < map.rows; ++y) {
      const float* in = map.ptr<float>(y);
      const uchar* volume = playing_volume_.ptr<uchar>(y);
      const uchar* open = region_.ptr<uchar>(y);  // the volume without the pockets
      const uchar* on_stick = stick_.empty() ? nullptr : stick_.ptr<uchar>(y);
      float* o = out.ptr<float>(y);
      for (int x = 0; x < map.cols; ++x)
        o[x] = on_stick && on_stick[x] ? kMaskedOut
               : !volume[x]            ? 0.f
               : !open[x]              ? kMaskedOut
                                       : in[x];
    }
    return out;
  }
  // The image direction (unit, or zero) from the centre of a ball at table position `xy`
  // to its top and far side.
  cv::Point2d FarSideDirectionPx(const cv::Point2d& xy) const {
    cv::Point2d away(xy.x - camera_[0], xy.y - camera_[1]);
    away /= std::max(1e-9, cv::norm(away));
    const cv::Point2d up =
        ProjectIdeal(pose_, K_, {xy.x + r_ * away.x, xy.y + r_ * away.y, 2 * r_}) -
        ProjectIdeal(pose_, K_, {xy.x, xy.y, r_});
    const double length = cv::norm(up);
    return length > 0 ? up / length : cv::Point2d(0, 0);
  }
  // Distance from the camera to the centre of a ball at table position `xy`.
  double FromCamera(const cv::Point2d& xy) const {
    return cv::norm(cv::Vec3d(xy.x, xy.y, r_) - camera_);
  }
  void ClearClaimed() {
    for (const cv::Rect& box : claimed_boxes_)
      for (int v = box.y; v < box.y + box.height; ++v)
        std::fill_n(claimed_.ptr<float>(v - roi_.y) + (box.x - roi_.x), box.width, 0.f);
    claimed_boxes_.clear();
  }
  // Paints the silhouettes of the balls at positions[j], j < count and j != skip, into
  // claimed_ (cleared first).
  void Claim(const std::vector<cv::Point2d>& positions, size_t skip, size_t count) {
    ClearClaimed();
    for (size_t j = 0; j < count; ++j) {
      if (j == skip) continue;
      const cv::Vec3d centre(positions[j].x, positions[j].y, r_);
      const cv::Matx33d Q = SphereSilhouetteConic(pose_, K_, centre, r_);
      SilhouetteScorer scorer(ballness_in_region_, roi_, claimed_, K_, pose_, profile_);
      const cv::Rect box = scorer.Box(centre);
      claimed_boxes_.push_back(box);
      for (int v = box.y; v < box.y + box.height; ++v)
        for (int u = box.x; u < box.x + box.width; ++u) {
          float& c = claimed_.at<float>(v - roi_.y, u - roi_.x);
          c = std::max(c, static_cast<float>(SilhouetteScorer::Coverage(Q, u, v)));
        }
    }
  }
  // Ball-ness by colour alone (a shadow stays cloth) where balls can be, made the first
  // time a rim fit or the final check needs it from the map FindBallPixels read.
  const cv::Mat& ByColourAlone() {
    if (colour_ballness_.empty()) colour_ballness_ = InPlayingVolume(colour_only_);
    return colour_ballness_;
  }

  const cv::Mat& image_;  // as given: the colour votes read it
  const cv::Matx33d& K_;
  const PlanarPose& pose_;
  const PoolTableProfile& profile_;
  const PoolBallOptions& options_;
  const double L_, W_, r_;  // the table's length and width, the balls' radius (mm)
  const cv::Vec3f cloth_;
  const double cloth_intensity_;
  const float cloth_sum_;
  const cv::Vec3d camera_;  // the camera's centre in the table frame
  cv::Mat bgr_;             // the picture through a light blur: the outlines read it
  cv::Rect image_rect_;     // where bgr_ is as the whole picture's blur gives it
  cv::Rect roi_;            // where balls can be seen; the maps below are over it
  cv::Mat region_;          // the playing volume without the pockets
  cv::Mat playing_volume_;
  cv::Mat mask_;                    // ball pixels
  cv::Mat stick_;                   // the cue stick's pixels (StickPixels)
  cv::Mat ballness_in_region_;      // InPlayingVolume of the ball-ness
  cv::Mat& labels_;                 // the blobs of mask_
  std::vector<cv::Point2d> seeds_;  // table positions, refined by each stage in turn
  // Blobs with the area of more balls than their distance maxima gave seeds for.
  std::vector<int> under_split_;
  cv::Mat claimed_;  // the silhouettes of the balls other than the one being fitted
  // The boxes (image pixels) painted in claimed_ since it was last cleared: Claim() runs
  // a few times for every ball, and clearing the whole map each time was 3% of a frame.
  std::vector<cv::Rect> claimed_boxes_;
  std::vector<int> hidden_behind_;  // per seed: the nearer ball's index, -1 (SplitHiddenBalls)
  cv::Mat colour_only_;             // the ball-ness by colour alone over roi_
  cv::Mat colour_ballness_;         // ByColourAlone
  std::vector<char> moved_;         // per seed: moved out of a neighbour (ResolveOverlaps)
  std::vector<PoolDetectedBall> balls_;
  std::vector<char> balls_moved_;  // per ball: placed by the overlap rule
  double cloth_hue_ = 0;           // for the dark reflection votes
  double cloth_saturation_ = 0;    // for dark_reflection_chroma_srgb
};

bool BallFinder::FindBallPixels(const cv::Rect& valid) {
  // JPEG rings around sharp colour edges (and halves the colour resolution); a light
  // blur removes the ringing that would make the cloth next to a ball look like ball.
  // Its buffer is kept per thread: allocated afresh for every frame, it and the frame's
  // other large buffers were given back to the kernel and faulted in again each time
  // (112,000 page faults over the pool benchmark's 60 frames, 67,000 with this). Nothing
  // keeps a reference to it (bgr_) past the pass.
  if (valid.area() <= 0) return false;
  thread_local cv::Mat blurred;
  const cv::Rect whole(0, 0, image_.cols, image_.rows);
  // The pixels that are read: those the blur gives exactly as on the whole picture (its
  // radius inside `valid`, except along the picture's own border).
  image_rect_ = valid;
  if (valid != whole) {
    // OpenCV blurs a part of a picture by another path than a whole one (it differs by a
    // grey level in a few pixels in a hundred); a copy of the part is blurred like a whole.
    blurred.create(image_.size(), image_.type());
    cv::Mat out = blurred(valid);
    cv::GaussianBlur(image_(valid).clone(), out, cv::Size(0, 0), kOutlineBlurSigma);
    const int d = kOutlineBlurRadius;
    const int x0 = valid.x > 0 ? valid.x + d : 0, y0 = valid.y > 0 ? valid.y + d : 0;
    const int x1 = valid.br().x < whole.width ? valid.br().x - d : whole.width;
    const int y1 = valid.br().y < whole.height ? valid.br().y - d : whole.height;
    image_rect_ = cv::Rect(x0, y0, std::max(0, x1 - x0), std::max(0, y1 - y0));
  } else {
    cv::GaussianBlur(image_, blurred, cv::Size(0, 0), kOutlineBlurSigma);
  }
  bgr_ = blurred;
  // Where balls can be seen: the playing surface from the cloth up to a ball's height,
  // without the pockets.
  std::vector<cv::Point> hull;
  roi_ = BallSearchRect(pose_, K_, L_, W_, r_, image_.size(), &hull) & image_rect_;
  if (roi_.area() <= 0) return false;
  region_ = cv::Mat::zeros(roi_.size(), CV_8UC1);
  std::vector<cv::Point> shifted;
  for (const auto& p : hull) shifted.push_back(p - roi_.tl());
  cv::fillConvexPoly(region_, shifted, cv::Scalar(255));
  playing_volume_ = region_.clone();
  const cv::Point2d pockets[6] = {{0, 0}, {L_, 0}, {L_, W_}, {0, W_}, {L_ / 2, 0}, {L_ / 2, W_}};
  for (int k = 0; k < 6; ++k) {
    const double radius = (k < 4 ? profile_.corner_pocket_mm : profile_.side_pocket_mm) / 2;
    for (double z : {0.0, profile_.cushion_height_mm}) {
      std::vector<cv::Point> disc;
      for (int a = 0; a < 24; ++a) {
        const double t = 2 * kPi * a / 24;
        const cv::Point2d q = ProjectIdeal(
            pose_, K_,
            {pockets[k].x + radius * std::cos(t), pockets[k].y + radius * std::sin(t), z});
        disc.emplace_back(cvRound(q.x) - roi_.x, cvRound(q.y) - roi_.y);
      }
      cv::fillConvexPoly(region_, disc, cv::Scalar(0));
    }
  }
  // Ball-ness by colour (kept for ByColourAlone), then of dark pixels against the cloth as
  // lit by the cushions.
  colour_only_ = BallnessMap(bgr_, roi_, cloth_, options_);
  const cv::Mat shade =
      options_.cushion_shade_dark_share > 0
          ? CushionShade(bgr_, roi_, colour_only_, pose_, K_, profile_, cloth_sum_,
                         static_cast<float>((options_.dark_fraction + 0.1) * cloth_sum_))
          : cv::Mat();
  cv::Mat ballness = colour_only_.clone();
  AddDarkness(bgr_, roi_, cloth_, options_, shade, &ballness);
  if (options_.pixel_encoding == PixelEncoding::kSrgb && options_.bright_fraction_srgb > 0)
    AddBrightness(bgr_, roi_, cloth_, options_.bright_fraction_srgb, &ballness);
  if (options_.cloth_hue_ball_dark_share > 0) AddBallsOfTheClothsHue(shade, &ballness);
  mask_.create(roi_.size(), CV_8UC1);
  for (int y = 0; y < roi_.height; ++y) {
    const float* b = ballness.ptr<float>(y);
    const uchar* in = region_.ptr<uchar>(y);
    uchar* m = mask_.ptr<uchar>(y);
    for (int x = 0; x < roi_.width; ++x) m[x] = b[x] > 0.5f && in[x] ? 255 : 0;
  }
  ballness_in_region_ = InPlayingVolume(ballness);
  {
    // A ball's highlight or lit cap can come close to the cloth's colour (the far dark
    // green 6 of benchmark frame 49 is a ring of ball pixels around a lit cap that
    // looks like cloth): holes in the ball mask that are enclosed by ball pixels, inside
    // the playing surface and smaller than half a ball there are ball. (The gap between
    // three touching balls, a twentieth of a ball, is filled as well; it lies outside
    // every fitted silhouette, where it weighs as little as the blur around it.) The ring
    // is taken where the pixels are ball at all (over 0.1): the lit cap's edge is partly
    // of the cloth's colour on one side, where a ring of clear ball pixels has a gap.
    thread_local cv::Mat hole_labels;  // kept per thread, as StickPixels' labels
    cv::Mat hole_stats, hole_centroids;
    const int holes = ConnectedComponentsWithStats(ballness <= 0.1, 4, &hole_labels, &hole_stats,
                                                   &hole_centroids);
    std::vector<uchar> fill(holes, 0);
    for (int h = 1; h < holes; ++h) {
      const int left = hole_stats.at<int>(h, cv::CC_STAT_LEFT);
      const int top = hole_stats.at<int>(h, cv::CC_STAT_TOP);
      if (left == 0 || top == 0 || left + hole_stats.at<int>(h, cv::CC_STAT_WIDTH) >= roi_.width ||
          top + hole_stats.at<int>(h, cv::CC_STAT_HEIGHT) >= roi_.height)
        continue;
      const cv::Point2d c(hole_centroids.at<double>(h, 0) + roi_.x,
                          hole_centroids.at<double>(h, 1) + roi_.y);
      cv::Point2d xy;
      if (!BackProjectToPlane(pose_, K_, c, r_, &xy)) continue;
      const double r_px = ApparentRadiusPx(pose_, K_, xy, r_);
      fill[h] = hole_stats.at<int>(h, cv::CC_STAT_AREA) <= 0.5 * kPi * r_px * r_px;
    }
    // Not the pockets (outside the region), which the mask leaves out as well.
    for (int y = 0; y < roi_.height; ++y) {
      const int* l = hole_labels.ptr<int>(y);
      const uchar* in = region_.ptr<uchar>(y);
      for (int x = 0; x < roi_.width; ++x)
        if (l[x] > 0 && fill[l[x]] && !in[x]) fill[l[x]] = 0;
    }
    for (int y = 0; y < roi_.height; ++y) {
      const int* l = hole_labels.ptr<int>(y);
      uchar* m = mask_.ptr<uchar>(y);
      float* b = ballness_in_region_.ptr<float>(y);
      for (int x = 0; x < roi_.width; ++x)
        if (l[x] > 0 && fill[l[x]]) {
          m[x] = 255;
          b[x] = 1;
        }
    }
  }

  // A cue stick over the cloth gives no seeds, and the fits leave its pixels out.
  stick_ = StickPixels(mask_, roi_, pose_, K_, r_, L_, W_, profile_.cushion_height_mm, options_);
  mask_.setTo(0, stick_);
  ballness_in_region_.setTo(kMaskedOut, stick_);

  return true;
}

void BallFinder::SeedBlobs(double* ball_size_ratio) {
  // Blobs -> seeds (one per expected ball; touching balls split at distance maxima).
  cv::Mat stats, centroids;
  const int n = ConnectedComponentsWithStats(mask_, 8, &labels_, &stats, &centroids);
  struct Fragment {
    cv::Point2d centroid;  // image pixels
    int area;
    double radius_px, expected;  // a ball's apparent radius and area there
  };
  std::vector<Fragment> fragments;  // blobs too small for a ball
  // Each ball-sized blob's largest inscribed circle over a ball's apparent radius there.
  std::vector<double> size_ratios;
  for (int i = 1; i < n; ++i) {
    const cv::Point2d c(centroids.at<double>(i, 0) + roi_.x, centroids.at<double>(i, 1) + roi_.y);
    cv::Point2d xy;
    if (!BackProjectToPlane(pose_, K_, c, r_, &xy)) continue;
    const cv::Vec3d cam = pose_.R * cv::Vec3d(xy.x, xy.y, r_) + pose_.t;
    const double r_px = K_(0, 0) * r_ / cv::norm(cam);
    const double expected = kPi * r_px * r_px;
    const int area = stats.at<int>(i, cv::CC_STAT_AREA);
    if (area < options_.min_area_fraction * expected) {
      fragments.push_back({c, area, r_px, expected});
      continue;
    }
    const int count = std::max(1, static_cast<int>(std::floor(area / expected + 0.35)));
    // A single ball's blob needs its distance transform only for the size ratio.
    if (count == 1 && !ball_size_ratio) {
      seeds_.push_back(xy);
      continue;
    }
    const cv::Rect box(stats.at<int>(i, cv::CC_STAT_LEFT), stats.at<int>(i, cv::CC_STAT_TOP),
                       stats.at<int>(i, cv::CC_STAT_WIDTH), stats.at<int>(i, cv::CC_STAT_HEIGHT));
    cv::Mat blob;
    cv::copyMakeBorder(labels_(box) == i, blob, 1, 1, 1, 1, cv::BORDER_CONSTANT, 0);
    cv::Mat dist;
    cv::distanceTransform(blob, dist, cv::DIST_L2, 3);
    if (ball_size_ratio) {
      double inscribed = 0;
      cv::minMaxLoc(dist, nullptr, &inscribed);
      size_ratios.push_back(inscribed / r_px);
    }
    if (count == 1) {
      seeds_.push_back(xy);
      continue;
    }
    const size_t seeds_before = seeds_.size();
    for (int k = 0; k < count; ++k) {
      double max_value;
      cv::Point max_at;
      cv::minMaxLoc(dist, nullptr, &max_value, nullptr, &max_at);
      if (max_value < 0.4 * r_px) break;
      const cv::Point2d pixel(max_at.x - 1 + box.x + roi_.x, max_at.y - 1 + box.y + roi_.y);
      if (BackProjectToPlane(pose_, K_, pixel, r_, &xy)) seeds_.push_back(xy);
      cv::circle(dist, max_at, static_cast<int>(std::ceil(1.4 * r_px)), cv::Scalar(0), -1);
    }
    if (seeds_.size() - seeds_before == 1) under_split_.push_back(i);
  }
  {
    // A small ball of nearly the cloth's colour (a far green 6 on green cloth) can break
    // into fragments each under min_area_fraction of a ball: its dark lower half, a rim
    // pixel or two beside its lit top. Fragments within a ball's diameter of the largest
    // one are taken together; the silhouette fit and its ball-ness gate then judge them.
    std::sort(fragments.begin(), fragments.end(),
              [](const Fragment& a, const Fragment& b) { return a.area > b.area; });
    std::vector<char> used(fragments.size(), 0);
    for (size_t a = 0; a < fragments.size(); ++a) {
      if (used[a] || fragments[a].area < 2) continue;
      double area = 0;
      cv::Point2d sum(0, 0);
      std::vector<size_t> group;
      for (size_t b = a; b < fragments.size(); ++b)
        if (!used[b] &&
            cv::norm(fragments[b].centroid - fragments[a].centroid) <= 2 * fragments[a].radius_px) {
          group.push_back(b);
          area += fragments[b].area;
          sum += fragments[b].area * fragments[b].centroid;
        }
      if (group.size() < 2 || area < options_.min_area_fraction * fragments[a].expected) continue;
      cv::Point2d xy;
      if (!BackProjectToPlane(pose_, K_, sum / area, r_, &xy)) continue;
      for (size_t b : group) used[b] = 1;
      seeds_.push_back(xy);
    }
  }

  if (ball_size_ratio && size_ratios.size() >= 3) {
    std::nth_element(size_ratios.begin(), size_ratios.begin() + size_ratios.size() / 2,
                     size_ratios.end());
    *ball_size_ratio = size_ratios[size_ratios.size() / 2];
  }
}

void BallFinder::FitSilhouettes() {
  // Fit each ball's silhouette, nearest balls first; a farther ball ignores pixels that a
  // nearer ball covers.
  std::sort(seeds_.begin(), seeds_.end(), [&](const cv::Point2d& a, const cv::Point2d& b) {
    return FromCamera(a) < FromCamera(b);
  });
  // Where each seed started (its blob's distance maximum, inside its own ball), for the
  // merge after the first pass.
  std::vector<cv::Point2d> origins = seeds_;
  claimed_ = cv::Mat::zeros(roi_.size(), CV_32FC1);
  // First pass: nearest first, each ball ignoring the nearer ones already fitted; second
  // pass: each ball ignoring all the others.
  const double isolated_mm = 6 * r_;  // farther apart than this, balls never share pixels
  for (int pass = 0; pass < 2; ++pass) {
    if (pass == 1) {
      // A blob lengthened by a ball's dark underside and its shadow can be split into two
      // seeds that both go to the same ball; balls are at least 2r apart, so of two seeds
      // closer than options.seed_merge_distance only the one that fits better is a ball.
      // Left in, the other would hide half of the real ball from its fit. But two seeds
      // that started on pixels of clearly different colours (SeedColour) are two balls
      // touching, and the fit of the one fitted first, with nothing claimed yet, slid onto
      // the other (benchmark seed 19's frame 2: the yellow 9 in front of the cue ball,
      // lost): the one that moved farther goes back to where it started, and the second
      // pass fits each with the other claimed.
      // Of seeds i and j, the one to put back where it started; seeds.size() for none.
      const auto seed_to_put_back = [&](size_t i, size_t j) {
        cv::Point2d chroma_i, chroma_j;
        if (cv::norm(origins[i] - origins[j]) < options_.seed_merge_distance * r_ ||
            !SeedColour(bgr_, ballness_in_region_, roi_, pose_, K_, origins[i], r_, cloth_sum_,
                        &chroma_i) ||
            !SeedColour(bgr_, ballness_in_region_, roi_, pose_, K_, origins[j], r_, cloth_sum_,
                        &chroma_j) ||
            cv::norm(chroma_i - chroma_j) <= options_.ball_chroma_distance)
          return seeds_.size();
        const size_t back =
            cv::norm(seeds_[i] - origins[i]) >= cv::norm(seeds_[j] - origins[j]) ? i : j;
        // Unless another fit nearby has that colour: the seed started on a neighbouring
        // ball's pixels (a blob of two touching balls and a shadow gives three seeds).
        const cv::Point2d& own = back == i ? chroma_i : chroma_j;
        for (size_t k = 0; k < seeds_.size(); ++k) {
          cv::Point2d chroma_k;
          if (k != back && cv::norm(seeds_[k] - origins[back]) < 2.5 * r_ &&
              SeedColour(bgr_, ballness_in_region_, roi_, pose_, K_, seeds_[k], r_, cloth_sum_,
                         &chroma_k) &&
              cv::norm(chroma_k - own) <= options_.ball_chroma_distance)
            return seeds_.size();
        }
        return back;
      };
      for (bool merged = true; merged;) {
        merged = false;
        for (size_t i = 0; i < seeds_.size() && !merged; ++i)
          for (size_t j = i + 1; j < seeds_.size() && !merged; ++j) {
            if (cv::norm(seeds_[i] - seeds_[j]) >= options_.seed_merge_distance * r_) continue;
            const size_t back = seed_to_put_back(i, j);
            if (back < seeds_.size()) {
              seeds_[back] = origins[back];
              origins[back] = {std::nan(""), std::nan("")};  // put back once only
              merged = true;
              continue;
            }
            std::vector<cv::Point2d> others;
            for (size_t k = 0; k < seeds_.size(); ++k)
              if (k != i && k != j) others.push_back(seeds_[k]);
            Claim(others, others.size(), others.size());
            SilhouetteScorer scorer(ballness_in_region_, roi_, claimed_, K_, pose_, profile_);
            const size_t drop = scorer.Score(seeds_[i]) >= scorer.Score(seeds_[j]) ? j : i;
            seeds_.erase(seeds_.begin() + static_cast<std::ptrdiff_t>(drop));
            origins.erase(origins.begin() + static_cast<std::ptrdiff_t>(drop));
            merged = true;
          }
      }
    }
    for (size_t i = 0; i < seeds_.size(); ++i) {
      if (pass == 1) {
        bool alone = true;
        for (size_t j = 0; j < seeds_.size(); ++j)
          if (j != i && cv::norm(seeds_[j] - seeds_[i]) < isolated_mm) alone = false;
        if (alone) continue;  // the first pass already saw no other ball
      }
      Claim(seeds_, i, pass == 0 ? i : seeds_.size());
      if (pass == 0) {
        // The farther balls of a blob are not fitted yet: the pixels nearer to another
        // seed of the same blob than to this one are left to it, so that a touching ball's
        // pixels do not count against this ball's silhouette (which would pull it
        // towards the pair's middle). Seeds closer than 1.5r may be one ball lengthened
        // by its shadow (merged below when closer than options.seed_merge_distance): those
        // share their pixels.
        const cv::Point2d own = ProjectIdeal(pose_, K_, {seeds_[i].x, seeds_[i].y, r_});
        // A seed on a ball has colour about it; one on the shadow that lengthens a ball's
        // blob has none (the black 8 neither: its touching balls share pixels as before).
        const auto coloured = [&](const cv::Point2d& pixel, const cv::Point2d& xy) {
          const double r_px = ApparentRadiusPx(pose_, K_, xy, r_);
          const int reach = std::max(1, cvRound(0.5 * r_px));
          const cv::Rect disc = cv::Rect(cvRound(pixel.x) - reach, cvRound(pixel.y) - reach,
                                         2 * reach + 1, 2 * reach + 1) &
                                image_rect_;
          if (disc.area() <= 0) return false;
          const cv::Mat colour = BallnessMap(bgr_, disc, cloth_, options_);
          double sum = 0;
          int count = 0;
          for (int v = 0; v < disc.height; ++v)
            for (int u = 0; u < disc.width; ++u) {
              const double du = u + disc.x - pixel.x, dv = v + disc.y - pixel.y;
              if (du * du + dv * dv > reach * reach) continue;
              sum += colour.at<float>(v, u);
              ++count;
            }
          return count > 0 && sum >= 0.5 * count;
        };
        const int blob = BlobAt(own);
        std::vector<cv::Point2d> neighbours;
        for (size_t j = 0; j < seeds_.size() && blob > 0; ++j) {
          if (j == i || cv::norm(seeds_[j] - seeds_[i]) < 1.5 * r_) continue;
          const cv::Point2d other = ProjectIdeal(pose_, K_, {seeds_[j].x, seeds_[j].y, r_});
          if (BlobAt(other) == blob && coloured(other, seeds_[j])) neighbours.push_back(other);
        }
        if (!neighbours.empty() && !coloured(own, seeds_[i])) neighbours.clear();
        if (!neighbours.empty()) {
          SilhouetteScorer boxer(ballness_in_region_, roi_, claimed_, K_, pose_, profile_);
          const cv::Rect box = boxer.Box(cv::Vec3d(seeds_[i].x, seeds_[i].y, r_));
          claimed_boxes_.push_back(box);
          for (int v = box.y; v < box.y + box.height; ++v)
            for (int u = box.x; u < box.x + box.width; ++u) {
              const cv::Point2d p(u, v);
              const double d_own = cv::norm(p - own);
              for (const cv::Point2d& n : neighbours)
                if (cv::norm(p - n) < d_own) {
                  claimed_.at<float>(v - roi_.y, u - roi_.x) = 1;
                  break;
                }
            }
        }
      }
      SilhouetteScorer scorer(ballness_in_region_, roi_, claimed_, K_, pose_, profile_);
      if (pass == 1 && options_.colour_below_ballness > 0) {
        scorer.CountColouredBelow(&ByColourAlone(), options_.colour_below_ballness);
      } else if (pass == 0 && options_.colour_below_front_ballness > 0 && FrontOfBlob(i)) {
        // The nearest ball of a blob is fitted with nothing of the blob claimed yet, and
        // is the one that slides onto the ball behind it
        // (options.colour_below_front_ballness).
        scorer.CountColouredBelow(&ByColourAlone(), options_.colour_below_front_ballness);
      }
      seeds_[i] = scorer.Fit(seeds_[i], 0.35 * r_);
    }
  }
}

bool BallFinder::FrontOfBlob(size_t i) const {
  const int blob = BlobOfBall(seeds_[i]);
  if (blob <= 0) return false;
  bool later = false;
  for (size_t j = 0; j < seeds_.size(); ++j) {
    if (j == i || BlobOfBall(seeds_[j]) != blob) continue;
    if (j < i) return false;  // a nearer seed of the blob
    later = true;
  }
  return later;
}

double BallFinder::UnexplainedByOneBall(size_t i, int label) {
  Claim(seeds_, i, seeds_.size());
  SilhouetteScorer whole(ballness_in_region_, roi_, claimed_, K_, pose_, profile_);
  whole.CountShadowZone();
  const cv::Point2d one = whole.Fit(seeds_[i], 0.35 * r_);
  const cv::Vec3d centre(one.x, one.y, r_);
  const cv::Matx33d Q = SphereSilhouetteConic(pose_, K_, centre, r_);
  const cv::Rect box = whole.Box(centre);
  // The blob reaches at most a ball beyond the one silhouette (its box's size).
  const cv::Rect reach = cv::Rect(box.x - box.width / 2 - roi_.x, box.y - box.height / 2 - roi_.y,
                                  box.width * 2, box.height * 2) &
                         cv::Rect(0, 0, roi_.width, roi_.height);
  int outside = 0;
  for (int v = reach.y; v < reach.y + reach.height; ++v) {
    const int* l = labels_.ptr<int>(v);
    for (int u = reach.x; u < reach.x + reach.width; ++u)
      if (l[u] == label &&
          SilhouetteScorer::InsideDistance(Q, u + roi_.x, v + roi_.y) < -kBallHaloPx)
        ++outside;
  }
  const double r_px = ApparentRadiusPx(pose_, K_, one, r_);
  return outside / (kPi * r_px * r_px);
}

void BallFinder::SplitHiddenBalls() {
  // A ball seen behind another one along the line of sight is mostly hidden by it: the
  // pair's blob has about two balls' area for the pose, but the farther ball shows only a
  // crescent above the nearer one, with no distance maximum of its own, and the one seed's
  // silhouette settles on the farther ball or between the two, the nearer ball's lower
  // half being in its dark zone (benchmark seed 11's frame 17: the 9 24 mm off, the 8 behind
  // it lost). Such a blob with a single seed is fitted as two balls as well: a second one
  // started touching the first where it covers the most ball pixels the first leaves, each
  // then fitted with the other's silhouette claimed and never into it. The pair is kept
  // when the second is ball (options.split_hidden_min_ballness), when each of the two
  // alone explains enough of the blob (options.split_hidden_min_visible: the pixels at
  // least a pixel outside the other's outline), and when the second is not a dark patch in
  // front of the first (its shadow).
  // For the farther ball of such a pair, the nearer one's index (-1: none).
  hidden_behind_.assign(seeds_.size(), -1);
  if (options_.split_hidden_min_visible > 0) {
    // A ball frozen on a cushion is often fitted into it, its blob lengthened by the
    // cushion's shaded face: that one is brought back later, not split.
    const double inset = 0.9 * r_;
    const auto on_table = [&](const cv::Point2d& p) {
      return p.x >= inset && p.y >= inset && p.x <= L_ - inset && p.y <= W_ - inset;
    };
    for (int label : under_split_) {
      size_t a = seeds_.size(), found = 0;
      for (size_t i = 0; i < seeds_.size(); ++i) {
        if (BlobOfBall(seeds_[i]) == label) {
          a = i;
          ++found;
        }
      }
      if (found != 1 || !on_table(seeds_[a]) ||
          ApparentRadiusPx(pose_, K_, seeds_[a], r_) < options_.split_hidden_min_radius_px)
        continue;
      if (options_.split_hidden_min_unexplained > 0 &&
          UnexplainedByOneBall(a, label) < options_.split_hidden_min_unexplained)
        continue;
      std::vector<cv::Point2d> pair = seeds_;
      const size_t b = pair.size();
      pair.push_back({});
      double best = -1, best_mean = 0;
      Claim(pair, b, b);
      const SilhouetteScorer starter(ballness_in_region_, roi_, claimed_, K_, pose_, profile_);
      for (int k = 0; k < 12; ++k) {
        const double t = k * kPi / 6;
        const cv::Point2d start = seeds_[a] + 2 * r_ * cv::Point2d(std::cos(t), std::sin(t));
        if (!on_table(start)) continue;
        double mean = 0, visible = 0;
        starter.Score(start, &mean, &visible);
        if (mean * visible > best) {
          best = mean * visible;
          best_mean = mean;
          pair[b] = start;
        }
      }
      // Where even the best start is mostly cloth there is no second ball to fit (time:
      // most single balls lengthened by their shadow end here).
      if (best < 0 || best_mean < 0.5) continue;
      // Never into the other: the second ball's fit would slide back into the first, whose
      // silhouette explains its pixels.
      const auto fit_apart = [&](size_t self, size_t other) {
        Claim(pair, self, pair.size());
        const SilhouetteScorer scorer(ballness_in_region_, roi_, claimed_, K_, pose_, profile_);
        pair[self] = CompassSearch(pair[self], 0.35 * r_, 1e9, [&](const cv::Point2d& p) {
          return cv::norm(p - pair[other]) < 2 * r_ ? -1e18 : scorer.Score(p);
        });
      };
      double second_ballness = 0, first_ballness = 0;
      for (int round = 0; round < 2; ++round) {
        fit_apart(b, a);
        fit_apart(a, b);
        Claim(pair, b, pair.size());
        SilhouetteScorer(ballness_in_region_, roi_, claimed_, K_, pose_, profile_)
            .Score(pair[b], &second_ballness);
        // Far from ball after the first round, the second does not become one (time).
        if (second_ballness < 0.5) break;
      }
      if (second_ballness < options_.split_hidden_min_ballness) continue;
      Claim(pair, a, pair.size());
      SilhouetteScorer(ballness_in_region_, roi_, claimed_, K_, pose_, profile_)
          .Score(pair[a], &first_ballness);
      // What each alone explains, the other balls claimed: its pixels at least a pixel
      // outside the other's outline, out of its dark zone. Their area over a ball's, and
      // for the second the share of their ball-ness that is lit.
      Claim(pair, a, b);
      double own_area[2], own_face[2], second_lit = 0;
      for (int k = 0; k < 2; ++k) {
        const cv::Point2d& self = pair[k == 0 ? a : b];
        const cv::Point2d& other = pair[k == 0 ? b : a];
        const cv::Vec3d centre(self.x, self.y, r_);
        const cv::Matx33d Q = SphereSilhouetteConic(pose_, K_, centre, r_);
        const cv::Matx33d Q_other = SphereSilhouetteConic(pose_, K_, {other.x, other.y, r_}, r_);
        const SilhouetteScorer boxer(ballness_in_region_, roi_, claimed_, K_, pose_, profile_);
        const cv::Rect box = boxer.Box(centre);
        double pixels = 0, ball = 0, lit = 0, face = 0;
        for (int v = box.y; v < box.y + box.height; ++v)
          for (int u = box.x; u < box.x + box.width; ++u) {
            if (SilhouetteScorer::Coverage(Q, u, v) < 0.99) continue;
            if (SilhouetteScorer::InsideDistance(Q_other, u, v) > -1) continue;
            if (claimed_.at<float>(v - roi_.y, u - roi_.x) > 0.5) continue;
            if (boxer.InShadowZone(centre, u, v)) continue;
            const float bn = ballness_in_region_.at<float>(v - roi_.y, u - roi_.x);
            if (bn < 0) continue;
            pixels += 1;
            ball += bn;
            face += boxer.OverCushionFace(u + 0.5, v + 0.5);
            const cv::Vec3b& p = bgr_.at<cv::Vec3b>(v, u);
            if (bn >= 0.5 && p[0] + p[1] + p[2] >= 0.45f * cloth_sum_) lit += 1;
          }
        const double r_self = ApparentRadiusPx(pose_, K_, self, r_);
        own_area[k] = pixels / (kPi * r_self * r_self);
        own_face[k] = pixels > 0 ? face / pixels : 0;
        if (k == 1) second_lit = ball > 0 ? lit / ball : 0;
      }
      const bool farther = FromCamera(pair[b]) > FromCamera(pair[a]);
      const bool shadow = !farther && second_lit < 0.3;
      // The farther ball's crescent over the shaded face of the far cushion is the face:
      // dark, it reads as ball and lengthens a ball near that cushion upwards, and the
      // pair was the ball's lit top with the face, behind its lower half (benchmark seeds
      // 41, 43, 47: a separated 5 pushed 2-3 px down the picture by it, 18-19 mm, and a
      // false ball above it).
      const bool face_behind = own_face[farther ? 1 : 0] > kMaxHiddenCrescentOnFace;
      if (shadow || face_behind ||
          std::min(own_area[0], own_area[1]) < options_.split_hidden_min_visible ||
          first_ballness < 0.5)
        continue;
      seeds_ = pair;
      hidden_behind_.push_back(-1);
      hidden_behind_[farther ? b : a] = static_cast<int>(farther ? a : b);
    }
  }
}

void BallFinder::AddBallsOfTheClothsHue(const cv::Mat& shade, cv::Mat* ballness) const {
  const float share = static_cast<float>(options_.cloth_hue_ball_dark_share);
  constexpr float kSoft = 0.1f;  // the darkness is soft over this share below `share`
  const float highlight_sum = static_cast<float>(kClothHueHighlight * cloth_sum_);
  cv::Mat highlight = cv::Mat::zeros(roi_.size(), CV_8UC1);
  for (int y = 0; y < roi_.height; ++y) {
    const cv::Vec3b* p = bgr_.ptr<cv::Vec3b>(y + roi_.y) + roi_.x;
    const uchar* in = region_.ptr<uchar>(y);
    uchar* h = highlight.ptr<uchar>(y);
    for (int x = 0; x < roi_.width; ++x)
      h[x] = in[x] && static_cast<float>(p[x][0]) + p[x][1] + p[x][2] >= highlight_sum ? 255 : 0;
  }
  thread_local cv::Mat labels;  // kept per thread, as StickPixels' labels
  cv::Mat stats, centroids;
  const int n = ConnectedComponentsWithStats(highlight, 8, &labels, &stats, &centroids);
  // First every highlight is judged on the map as it is, then the unseen balls are added.
  struct Unseen {
    cv::Point2d centre;  // roi pixels
    double reach;        // pixels
    cv::Rect box;        // around the disc of `reach`, inside the roi
  };
  std::vector<Unseen> unseen;
  for (int k = 1; k < n; ++k) {
    const cv::Point2d c(centroids.at<double>(k, 0), centroids.at<double>(k, 1));
    cv::Point2d xy;
    if (!BackProjectToPlane(pose_, K_, c + cv::Point2d(roi_.x, roi_.y), r_, &xy)) continue;
    const double r_px = ApparentRadiusPx(pose_, K_, xy, r_);
    const double ball_area = kPi * r_px * r_px;
    // A highlight, not a white or lit ball's whole top.
    if (stats.at<int>(k, cv::CC_STAT_AREA) > kClothHueMaxHighlight * ball_area) continue;
    const double reach = kClothHueReach * r_px;
    const cv::Rect box = cv::Rect(cvFloor(c.x - reach), cvFloor(c.y - reach), 2 * cvCeil(reach) + 2,
                                  2 * cvCeil(reach) + 2) &
                         cv::Rect(0, 0, roi_.width, roi_.height);
    // The ball this highlight is on is seen already when the disc of its apparent radius
    // around it is a good part ball, by colour or by darkness.
    int colour = 0, any = 0;
    for (int y = box.y; y < box.y + box.height; ++y)
      for (int x = box.x; x < box.x + box.width; ++x) {
        if (std::hypot(x - c.x, y - c.y) > r_px || labels.at<int>(y, x) == k) continue;
        colour += colour_only_.at<float>(y, x) > 0.5f;
        any += ballness->at<float>(y, x) > 0.5f;
      }
    if (colour < kClothHueBallShare * ball_area && any < kClothHueSeenShare * ball_area)
      unseen.push_back({c, reach, box});
  }
  for (const Unseen& u : unseen)
    for (int y = u.box.y; y < u.box.y + u.box.height; ++y) {
      const cv::Vec3b* p = bgr_.ptr<cv::Vec3b>(y + roi_.y) + roi_.x;
      const float* lit = shade.empty() ? nullptr : shade.ptr<float>(y);
      const uchar* in = region_.ptr<uchar>(y);
      float* b = ballness->ptr<float>(y);
      for (int x = u.box.x; x < u.box.x + u.box.width; ++x) {
        if (!in[x] || std::hypot(x - u.centre.x, y - u.centre.y) > u.reach) continue;
        const float level = lit ? std::min(lit[x], cloth_sum_) : cloth_sum_;
        const float fraction = (static_cast<float>(p[x][0]) + p[x][1] + p[x][2]) / level;
        b[x] = std::max(b[x], SoftThreshold(fraction, share, -kSoft));
      }
    }
}

void BallFinder::RefineOutlines() {
  // Sub-pixel pass on the edge: the ball's outline is where its colour distance from the
  // cloth around it falls fastest (for any symmetric blur, JPEG smear or shading of the
  // ball), so the silhouette's outline is moved to where that fall is steepest, on the
  // part of the outline that is not in the dark zone under the ball, not hidden by a
  // cushion and not next to another ball.
  for (size_t i = 0; i < seeds_.size(); ++i) {
    // A ball mostly hidden behind another has too little outline of its own: it keeps the
    // silhouette fit it had with the nearer ball.
    if (hidden_behind_[i] >= 0) continue;
    const cv::Point2d silhouette_xy = seeds_[i];
    Claim(seeds_, i, seeds_.size());
    SilhouetteScorer scorer(ballness_in_region_, roi_, claimed_, K_, pose_, profile_);
    const cv::Vec3d centre(seeds_[i].x, seeds_[i].y, r_);
    const cv::Matx33d Q = SphereSilhouetteConic(pose_, K_, centre, r_);
    const cv::Rect box = scorer.Box(centre);
    std::vector<cv::Vec3f> cloth_pixels;
    std::vector<float> cloth_brightness;  // of those not on a cushion's face
    std::vector<float> ball_intensities, ball_chromatic, ball_saturations, ball_lumas;
    // Brightness in light of the silhouette's near half and of the cloth around it
    // (options.near_half_dark_share): `far_dir` is the image direction of the ball's far
    // side, `near_from_px` how far from its centre against it the near half is taken.
    std::vector<float> near_half_light, cloth_light, ball_grey, ball_hues;
    const cv::Point2d centre_px = ProjectIdeal(pose_, K_, centre);
    const double radius_px = ApparentRadiusPx(pose_, K_, seeds_[i], r_);
    const double near_from_px = kNearHalfFrom * radius_px;
    const cv::Point2d far_dir = FarSideDirectionPx(seeds_[i]);
    // The interior whose level caps the edge pass's distance (options.edge_interior_level):
    // its pixels, taken in the pass below, which leaves out the same claimed and shadowed
    // ones.
    const bool cap_edge_pass =
        options_.edge_interior_level < 1 && radius_px >= kMinInteriorRadiusPx;
    std::vector<cv::Point> interior_px;
    const auto brightness_in_light = [&](const cv::Vec3b& p) {
      const cv::Vec3f l = ColourInLight(cv::Vec3f(p[0], p[1], p[2]), options_.pixel_encoding);
      return (l[0] + l[1] + l[2]) / 3;
    };
    for (int v = box.y; v < box.y + box.height; ++v)
      for (int u = box.x; u < box.x + box.width; ++u) {
        if (claimed_.at<float>(v - roi_.y, u - roi_.x) > 0.01) continue;
        if (scorer.InShadowZone(centre, u, v)) continue;
        if (cap_edge_pass && SilhouetteScorer::InsideDistance(Q, u, v) >= kInteriorDepthPx)
          interior_px.emplace_back(u, v);
        const cv::Vec3b& p = bgr_.at<cv::Vec3b>(v, u);
        const float b = ballness_in_region_.at<float>(v - roi_.y, u - roi_.x);
        const double cov = SilhouetteScorer::Coverage(Q, u, v);
        if (cov >= 0.99 && b > 0.5) {
          const float intensity = (p[0] + p[1] + p[2]) / 3.f;
          ball_intensities.push_back(intensity);
          if ((u - centre_px.x) * far_dir.x + (v - centre_px.y) * far_dir.y < -near_from_px)
            near_half_light.push_back(brightness_in_light(p));
          ball_lumas.push_back(PixelLuma(p));
          const float cx = p[2] - 0.5f * (p[1] + p[0]), cy = 0.8660254f * (p[1] - p[0]);
          if (std::hypot(cx, cy) > 0.25f * std::max(1.f, intensity)) {
            ball_chromatic.push_back(intensity);
            ball_hues.push_back(static_cast<float>(std::atan2(cy, cx) * 180 / kPi));
          } else
            ball_grey.push_back(intensity);
          ball_saturations.push_back(std::hypot(cx, cy) / std::max(15.f, intensity));
        }
        // The cloth around the ball: not a pocket, not the rail beyond the playing volume
        // (a ball frozen on a cushion would take the rail's colour for the cloth's).
        if (cov > 0 || b >= 0.5 || b < 0 || !playing_volume_.at<uchar>(v - roi_.y, u - roi_.x))
          continue;
        cloth_pixels.emplace_back(p[0], p[1], p[2]);
        if (!scorer.OverCushionFace(u + 0.5, v + 0.5)) {
          cloth_brightness.push_back((p[0] + p[1] + p[2]) / 3.f);
          cloth_light.push_back(brightness_in_light(p));
        }
      }
    if (cloth_pixels.size() < 5) continue;
    cv::Vec3f local_cloth;
    for (int k = 0; k < 3; ++k) {
      std::vector<float> c;
      for (const auto& p : cloth_pixels) c.push_back(p[k]);
      std::nth_element(c.begin(), c.begin() + c.size() / 2, c.end());
      local_cloth[k] = c[c.size() / 2];
    }
    const cv::Rect grown =
        cv::Rect(box.x - box.width / 2, box.y - box.height / 2, box.width * 2, box.height * 2) &
        image_rect_;
    const float cloth_i = std::max(15.f, (local_cloth[0] + local_cloth[1] + local_cloth[2]) / 3);
    // A dark ball is told by its median brightness (the chromaticity of near-black pixels
    // is noise and JPEG's colour smear, and the highlight of a small ball is a good part
    // of its mean), unless it has lit, coloured pixels like the green 6: for such a ball,
    // and any ball darker than the cloth, chromaticity counts only as much as the pixel's
    // brightness can carry.
    float ball_median = cloth_i;
    if (!ball_intensities.empty()) ball_median = MedianOf(&ball_intensities);
    int lit_chromatic = 0;
    for (float v : ball_chromatic) lit_chromatic += v > 0.4f * cloth_i;
    const bool dark_ball =
        ball_median < 0.5f * cloth_i && lit_chromatic < 0.15 * ball_intensities.size();
    // Darker than the cloth, not than the shaded face of the cushion seen beyond a ball by
    // the far cushion, which the cloth sample above takes in: measured against it, a green
    // 6 or a black 8 with its highlight there was not darker, and was not fitted on its far
    // rim. With the ball-ness check below for such balls: over the ten green and the ten
    // held-out benchmark sets, balls over 10 mm 55 + 89 -> 55 + 82 (separated ones 23 + 34
    // -> 22 + 29), most of the change far 6s (seed 53's frame 18: 19.4 -> 0.6 mm, seed
    // 17's frame 2: 12.3 -> 3.3 mm).
    float cloth_level = cloth_i;
    if (cloth_brightness.size() >= 5) cloth_level = std::max(15.f, MedianOf(&cloth_brightness));
    const bool dark_near_half =
        near_half_light.size() >= kMinNearHalfPixels && cloth_light.size() >= 5 &&
        MedianOf(&near_half_light) < options_.near_half_dark_share * MedianOf(&cloth_light);
    // Whether the ball is darker than the cloth is told by its body: its coloured pixels
    // and its black, without the white of its number disc, its highlight and a shaded
    // white (grey pixels over half the cloth's brightness). A 6 or an 8 whose disc faces
    // up or to the camera is half white on a small ball, and by the median of all its
    // pixels it was taken for a bright ball and its edge pass slid it into its shadow
    // (benchmark seed 7's frame 26 rendered sRGB: an 8 of median 98 against the cloth's
    // 104, body 29; 20 mm towards the camera before, 3.1 mm now). A ball with too little
    // body (the cue ball) keeps the median of all its pixels.
    float body_median = ball_median;
    {
      std::vector<float> body = ball_chromatic;
      for (float g : ball_grey)
        if (g <= kBodyGreyMax * cloth_i) body.push_back(g);
      if (body.size() >= 5 && body.size() >= kMinBodyShare * ball_intensities.size())
        body_median = MedianOf(&body);
    }
    const bool darker_than_cloth = body_median < 0.9f * cloth_level || dark_near_half;
    // The ball's colour distance from the cloth over `grown`: in full colour, or mostly in
    // chromaticity (the colour with the light's strength divided out), so that a ball as
    // bright as the cloth (the lit top of a green 6) still stands out, and a shadow on the
    // cloth does not; a dark ball (the 8) has no chromaticity to speak of and is told by
    // its darkness. Read in light (PoolBallOptions::pixel_encoding): the cloth's colour and every
    // pixel decoded, with the floor of the intensity (15 grey levels, sRGB 21 decoded: 2).
    const bool in_light = options_.pixel_encoding == PixelEncoding::kSrgb;
    const std::array<float, 256>& light_of = SrgbLightTable();
    const cv::Vec3f light_cloth = ColourInLight(local_cloth, options_.pixel_encoding);
    const float floor_i = in_light ? 2.f : 15.f;
    const float light_cloth_i =
        in_light ? std::max(floor_i, (light_cloth[0] + light_cloth[1] + light_cloth[2]) / 3)
                 : cloth_i;
    const cv::Vec3f light_cloth_chroma = light_cloth / light_cloth_i;
    cv::Mat distance(grown.size(), CV_32FC1);
    const auto fill_distance = [&](bool full_colour) {
      for (int v = 0; v < grown.height; ++v) {
        const cv::Vec3b* p = bgr_.ptr<cv::Vec3b>(v + grown.y) + grown.x;
        float* d = distance.ptr<float>(v);
        for (int u = 0; u < grown.width; ++u) {
          const cv::Vec3f q =
              in_light ? cv::Vec3f(light_of[p[u][0]], light_of[p[u][1]], light_of[p[u][2]])
                       : cv::Vec3f(p[u][0], p[u][1], p[u][2]);
          if (full_colour) {
            d[u] = static_cast<float>(cv::norm(q - light_cloth));
            continue;
          }
          const float i = std::max(floor_i, (q[0] + q[1] + q[2]) / 3);
          d[u] = static_cast<float>(
              cv::norm(q / i - light_cloth_chroma) *
                  (darker_than_cloth ? std::min(i, light_cloth_i) : light_cloth_i) +
              0.3 * std::abs(i - light_cloth_i));
        }
      }
    };
    fill_distance(dark_ball);
    cv::Mat gx, gy;
    {
      // The edge pass sees the step from the cloth to the ball's own level, not the
      // contrasts inside the ball (options.edge_interior_level).
      std::vector<float> interior;
      for (const cv::Point& q : interior_px)
        if (grown.contains(q)) interior.push_back(distance.at<float>(q.y - grown.y, q.x - grown.x));
      cv::Mat capped;  // a buffer of its own: `distance` stays whole for the fits below
      if (interior.size() >= 5) {
        const auto level =
            interior.begin() +
            std::min(interior.size() - 1,
                     static_cast<size_t>(options_.edge_interior_level * interior.size()));
        std::nth_element(interior.begin(), level, interior.end());
        cv::min(distance, *level, capped);
      }
      const cv::Mat& edge_map = capped.empty() ? distance : capped;
      cv::Sobel(edge_map, gx, CV_32F, 1, 0, 3, 1.0 / 8);
      cv::Sobel(edge_map, gy, CV_32F, 0, 1, 3, 1.0 / 8);
    }
    EdgeFitter edge(gx, gy, grown, claimed_, roi_, scorer, K_, pose_, r_);
    if (darker_than_cloth) {
      // The outline beside the ball's own shadow is left out, unless that leaves too little
      // of it (a camera looking steeply down sees the cloth beside the whole outline in
      // the shadow's penumbra).
      edge.SkipShadowedOutline(true);
      int used = 0;
      edge.Score(seeds_[i], &used);
      if (used < kMinOutlinePoints) edge.SkipShadowedOutline(false);
    }
    // A ball darker than the cloth and of the cloth's hue or of none, in an sRGB picture,
    // goes from its silhouette fit to its rim fit below (options.darker_edge_pass_srgb).
    const bool straight_to_rim = darker_than_cloth && in_light && !options_.darker_edge_pass_srgb &&
                                 OfClothHueOrNone(&ball_hues, ball_intensities.size(), local_cloth);
    if (!straight_to_rim) seeds_[i] = edge.Fit(seeds_[i], camera_);
    if (!darker_than_cloth && options_.edge_point_reach > 0) {
      // The edge pass's mean fall is drawn to where the ball's contrast is strongest; its
      // outline is where the edge is (options.edge_point_reach).
      double outside = 0;
      const double threshold =
          RimThreshold(distance, grown, claimed_, roi_, scorer, pose_, K_, seeds_[i], r_, &outside);
      if (threshold > 0) {
        const double reach_px =
            std::max(2.0, options_.edge_point_reach * ApparentRadiusPx(pose_, K_, seeds_[i], r_));
        // Brightness (as the cloth's) and luma over `grown` for the edge points against a
        // shaded background (options.edge_shade_brightness).
        EdgeFitter::ShadedOutside shaded;
        const bool luma_needed =
            options_.edge_shade_brightness > 0 || options_.edge_luma_snap_px > 0;
        if (luma_needed) {
          shaded.brightness.create(grown.size(), CV_32FC1);
          cv::Mat luma(grown.size(), CV_32FC1);
          for (int v = 0; v < grown.height; ++v) {
            const cv::Vec3b* p = bgr_.ptr<cv::Vec3b>(v + grown.y) + grown.x;
            float* b = shaded.brightness.ptr<float>(v);
            float* y = luma.ptr<float>(v);
            for (int u = 0; u < grown.width; ++u) {
              b[u] = (p[u][0] + p[u][1] + p[u][2]) / 3.f;
              y[u] = PixelLuma(p[u]);
            }
          }
          cv::Sobel(luma, shaded.luma_gx, CV_32F, 1, 0, 3, 1.0 / 8);
          cv::Sobel(luma, shaded.luma_gy, CV_32F, 0, 1, 3, 1.0 / 8);
          shaded.level = options_.edge_shade_brightness * cloth_i;
          // The luma snap only for a ball brighter than the cloth in luma: a ball darker
          // in luma (the purple 4, the blue 2) has its luma edge below it in its shadow,
          // and moved there it went 1.1-1.6 px down the picture.
          if (options_.edge_luma_snap_px > 0 && !ball_lumas.empty()) {
            std::nth_element(ball_lumas.begin(), ball_lumas.begin() + ball_lumas.size() / 2,
                             ball_lumas.end());
            if (ball_lumas[ball_lumas.size() / 2] > kBrighterLuma * PoolLuma(local_cloth))
              shaded.luma_snap_px =
                  std::min(options_.edge_luma_snap_px,
                           kLumaSnapRadii * ApparentRadiusPx(pose_, K_, seeds_[i], r_));
          }
        }
        seeds_[i] =
            edge.FitToEdgePoints(seeds_[i], distance, threshold, reach_px,
                                 options_.edge_point_prior, luma_needed ? &shaded : nullptr);
      }
    }
    {
      // The silhouette fit matches the ball-ness (a ball's colour, or its darkness);
      // outline fits that put a good part of the silhouette on the cloth were drawn by
      // another edge (options.edge_max_ballness_drop): for a ball darker than the cloth,
      // the top of the shaded face of the cushion behind it (benchmark seed 11's frame 21:
      // a green 6 on its silhouette fit 0.3 px from the truth, 1.9 px up after the edge
      // pass, 11 mm).
      double silhouette_ballness = 0, edge_ballness = 0;
      scorer.Score(silhouette_xy, &silhouette_ballness);
      scorer.Score(seeds_[i], &edge_ballness);
      // For a ball darker than the cloth only where a cushion's face is seen just beyond
      // the top of its silhouette: elsewhere the ball-ness of such a ball is partly its
      // shadow's, and a red 3 on burgundy cloth went from 8.6 to 16.5 mm when its edge
      // fit was set back on its silhouette fit.
      bool face_behind = false;
      if (darker_than_cloth) {
        const cv::Point2d c = ProjectIdeal(pose_, K_, {silhouette_xy.x, silhouette_xy.y, r_});
        const cv::Point2d up = FarSideDirectionPx(silhouette_xy);
        if (up != cv::Point2d(0, 0)) {
          const double r_px = ApparentRadiusPx(pose_, K_, silhouette_xy, r_);
          const cv::Point2d beyond = c + up * (r_px + 2);
          face_behind = scorer.OverCushionFace(beyond.x, beyond.y);
        }
      }
      if (silhouette_ballness >= 0.5 &&
          edge_ballness < silhouette_ballness - options_.edge_max_ballness_drop &&
          (!darker_than_cloth || face_behind))
        seeds_[i] = silhouette_xy;
    }
    if (darker_than_cloth) {
      // A ball darker than the cloth has brighter edges inside it than its rim (the
      // highlight on the 8, the lit cap of the 6 above its dark lower half) and the mean
      // fall above can settle on one of them, which moves the ball towards the camera.
      // Its rim is the outermost step instead: half-way from the cloth just outside to
      // the ball's median inside, met first when coming in from the cloth.
      // A grey or black ball (options.rim_full_colour_saturation) is fitted on its rim in
      // the full colour distance: its far rim is its top, lit by the lamps to nearly the
      // cloth's brightness and with no chromaticity of its own, so in the distance above
      // it barely stands out and the rim was met 1.7 px inside it (benchmark frame 5's 8).
      if (!dark_ball && !ball_saturations.empty()) {
        std::nth_element(ball_saturations.begin(),
                         ball_saturations.begin() + ball_saturations.size() / 2,
                         ball_saturations.end());
        const float cloth_cx = local_cloth[2] - 0.5f * (local_cloth[1] + local_cloth[0]);
        const float cloth_cy = 0.8660254f * (local_cloth[1] - local_cloth[0]);
        const double cloth_saturation = std::hypot(cloth_cx, cloth_cy) / cloth_i;
        if (ball_saturations[ball_saturations.size() / 2] <
            options_.rim_full_colour_saturation * cloth_saturation)
          fill_distance(true);  // the edge pass above has its gradients already
      }
      double outside = 0;
      const double threshold =
          RimThreshold(distance, grown, claimed_, roi_, scorer, pose_, K_, seeds_[i], r_, &outside);
      if (threshold > 0) {
        const double r_px = ApparentRadiusPx(pose_, K_, seeds_[i], r_);
        int used = 0;
        {
          std::vector<cv::Vec3d> neighbours;
          for (size_t j = 0; j < seeds_.size(); ++j) {
            if (j == i || cv::norm(seeds_[j] - seeds_[i]) > 4 * r_) continue;
            const cv::Vec3d other(seeds_[j].x, seeds_[j].y, r_);
            const cv::Point2d at = ProjectIdeal(pose_, K_, other);
            neighbours.emplace_back(at.x, at.y, ApparentRadiusPx(pose_, K_, seeds_[j], r_));
          }
          edge.SetNeighbours(std::move(neighbours));
        }
        edge.SetOutwardReach(options_.rim_outward_reach * r_px);
        edge.FarSideOnly(options_.rim_far_side_only);
        EdgeFitter::RimLevels levels;
        levels.outside = outside;
        levels.threshold = threshold;
        levels.thin_outer_band = dark_ball;
        const cv::Point2d on_rim =
            edge.FitToRim(seeds_[i], distance, levels, std::max(3.0, 0.6 * r_px), &used);
        // Kept when enough rim was found, unless it leaves the silhouette half cloth where
        // the edge pass's was not: the ball would then be dropped as not a ball at all
        // (on the 9-ft set two separated balls were lost that way). Under half ball is
        // still kept when it loses no more ball-ness than the edge pass may
        // (edge_max_ballness_drop) and stays a ball for the final check
        // (min_fit_ballness): a green 6 on green cloth, its lit cap of the cloth's colour,
        // is half ball on its rim, and the edge fit that is more ball has slid into its
        // shadow (seed 41's frame 50: 5 px down, 0.49 on the rim against 0.55).
        double rim_ballness = 0, edge_ballness = 0;
        if (used >= kMinRimPointsToKeep) {
          scorer.Score(on_rim, &rim_ballness);
          scorer.Score(seeds_[i], &edge_ballness);
          bool little_lost = rim_ballness >= options_.min_fit_ballness &&
                             rim_ballness >= edge_ballness - options_.edge_max_ballness_drop;
          if (!little_lost && !dark_ball && rim_ballness >= options_.min_fit_ballness) {
            // A coloured ball darker than the cloth: the ball-ness above counts its shadow
            // as ball, which favours the fit that slid into it. By colour alone, over the
            // whole silhouette (as the final check refits such a ball), the shadow is
            // cloth (seed 41's frame 43: a 6 on its rim 0.1 px from the truth, 0.46 ball
            // against the edge fit's 0.68, 2.6 px down in its shadow).
            SilhouetteScorer by_colour(ByColourAlone(), roi_, claimed_, K_, pose_, profile_);
            by_colour.CountShadowZone();
            double rim_colour = 0, edge_colour = 0;
            by_colour.Score(on_rim, &rim_colour);
            by_colour.Score(seeds_[i], &edge_colour);
            little_lost = rim_colour >= edge_colour - options_.edge_max_ballness_drop;
          }
          if (rim_ballness >= 0.5 || edge_ballness < 0.5 || little_lost) {
            // Straight from its silhouette fit, the rim fit is the second of two
            // independent measures of the ball (options.straight_rim_silhouette_share).
            seeds_[i] = straight_to_rim ? on_rim + options_.straight_rim_silhouette_share *
                                                       (silhouette_xy - on_rim)
                                        : on_rim;
          }
        }
      }
    }
  }
}

void BallFinder::ResolveOverlaps() {
  // The nearer ball's outline fits do not see the hidden one behind it (its outline there
  // is against that ball, not the cloth): it is kept out of it.
  for (size_t h = 0; h < seeds_.size(); ++h) {
    if (hidden_behind_[h] < 0) continue;
    cv::Point2d& front = seeds_[static_cast<size_t>(hidden_behind_[h])];
    const double gap = cv::norm(front - seeds_[h]);
    if (gap < 2 * r_) front = seeds_[h] + (front - seeds_[h]) * (2 * r_ / std::max(1e-6, gap));
  }
  // Two balls cannot be closer than 2r, yet two fits may end up closer than 1.6r (real
  // touching balls, each fitted within a few millimetres, stay well apart of that). Either
  // the worse fit is a ball's shaded lower half and shadow fitted as a ball of its own,
  // just beyond the seeds' merging distance (it has the other's colour, or none: it is
  // dropped; nearer to the camera than the real ball, it would take the real ball's lower
  // half from its votes: frame 13's yellow 1 was left with its highlight and read as the
  // 9), or it is a touching ball of another colour whose fit slid into its neighbour (it
  // is moved straight out to touch it: frame 58's 4, in front of the 1 on the line of
  // sight, was 21 mm into it). When the better fit is dark and has no colour of its own
  // (the 8, or a shadow fitted as a ball) and the worse one has, the dark one is moved: the
  // coloured fit is held by its colour, the dark one by shadows that lie around any
  // touching pair (seed 13's frame 46: a dark fit in the shadows between the 3 and the 4
  // pushed the 4 13.8 mm out and stood as a false ball beside the 3, 15.6 mm off; moved
  // out of the 4, it met the 3 and, of no colour of its own, was dropped).
  // Median chromaticity (opponent chroma over intensity) of a fit's lit ball pixels that
  // the other balls (painted in claimed_) leave to it; false when it has too few of them.
  const auto fit_chroma = [&](const cv::Point2d& xy, cv::Point2d* chroma) {
    const cv::Vec3d centre(xy.x, xy.y, r_);
    const cv::Matx33d Q = SphereSilhouetteConic(pose_, K_, centre, r_);
    SilhouetteScorer boxer(ballness_in_region_, roi_, claimed_, K_, pose_, profile_);
    const cv::Rect box = boxer.Box(centre);
    LitChromaMedian lit(cloth_sum_);
    for (int v = box.y; v < box.y + box.height; ++v)
      for (int u = box.x; u < box.x + box.width; ++u) {
        if (SilhouetteScorer::Coverage(Q, u, v) < 0.99) continue;
        if (claimed_.at<float>(v - roi_.y, u - roi_.x) > 0.5) continue;
        if (ballness_in_region_.at<float>(v - roi_.y, u - roi_.x) < 0.5) continue;
        lit.Add(bgr_.at<cv::Vec3b>(v, u));
      }
    constexpr size_t kMinColoured = 8;
    return lit.Median(kMinColoured, chroma);
  };
  // Whether a fit is dark: the median brightness of its ball pixels inside the outline
  // (other balls as painted in claimed_, the dark zone under it left out) is under half
  // the cloth's. A ball whose colour pixels another fit claims has no colour left, yet is
  // not dark.
  const auto fit_dark = [&](const cv::Point2d& xy) {
    const cv::Vec3d centre(xy.x, xy.y, r_);
    const cv::Matx33d Q = SphereSilhouetteConic(pose_, K_, centre, r_);
    SilhouetteScorer boxer(ballness_in_region_, roi_, claimed_, K_, pose_, profile_);
    const cv::Rect box = boxer.Box(centre);
    std::vector<float> brightness;
    for (int v = box.y; v < box.y + box.height; ++v)
      for (int u = box.x; u < box.x + box.width; ++u) {
        if (SilhouetteScorer::Coverage(Q, u, v) < 0.99) continue;
        if (claimed_.at<float>(v - roi_.y, u - roi_.x) > 0.5) continue;
        if (ballness_in_region_.at<float>(v - roi_.y, u - roi_.x) < 0.5) continue;
        if (boxer.InShadowZone(centre, u, v)) continue;
        const cv::Vec3b& p = bgr_.at<cv::Vec3b>(v, u);
        brightness.push_back((p[0] + p[1] + p[2]) / 3.f);
      }
    if (brightness.empty()) return false;
    std::nth_element(brightness.begin(), brightness.begin() + brightness.size() / 2,
                     brightness.end());
    return brightness[brightness.size() / 2] < 0.5 * cloth_intensity_;
  };
  // Each round drops a seed or moves one out of another; a moved ball may land in a third
  // one, so the rounds are capped rather than run until nothing overlaps.
  const size_t max_rounds = 2 * seeds_.size();
  // Seeds moved out of a neighbour: placed by the rule, not by their own pixels.
  moved_.assign(seeds_.size(), 0);
  bool changed = true;
  for (size_t round = 0; changed && round < max_rounds; ++round) {
    changed = false;
    for (size_t i = 0; i < seeds_.size() && !changed; ++i)
      for (size_t j = i + 1; j < seeds_.size() && !changed; ++j) {
        const cv::Point2d apart = seeds_[j] - seeds_[i];
        const double gap = cv::norm(apart);
        if (gap >= 1.6 * r_) continue;
        double fit[2];
        cv::Point2d chroma[2];
        bool coloured[2], dark[2];
        // Closer than a radius, the two are fits of one ball. The ball-ness counts the ball's
        // shadow as ball and can favour a fit that slid into it; by colour alone the shadow
        // is cloth (options.same_ball_colour_ballness).
        const bool one_ball = gap < r_ && options_.same_ball_colour_ballness > 0;
        double by_colour[2] = {0, 0};
        for (int k = 0; k < 2; ++k) {
          const size_t self = k == 0 ? i : j;
          std::vector<cv::Point2d> rest;
          for (size_t m = 0; m < seeds_.size(); ++m)
            if (m != self) rest.push_back(seeds_[m]);
          Claim(rest, rest.size(), rest.size());
          coloured[k] = fit_chroma(seeds_[self], &chroma[k]);
          // Its fit against the pixels left when only the balls other than the pair are
          // painted: each of the two may claim the pixels they share.
          rest.erase(std::remove(rest.begin(), rest.end(), seeds_[k == 0 ? j : i]), rest.end());
          Claim(rest, rest.size(), rest.size());
          SilhouetteScorer scorer(ballness_in_region_, roi_, claimed_, K_, pose_, profile_);
          scorer.Score(seeds_[self], &fit[k]);
          dark[k] = fit_dark(seeds_[self]);
          if (one_ball) {
            SilhouetteScorer colour_scorer(ByColourAlone(), roi_, claimed_, K_, pose_, profile_);
            colour_scorer.CountShadowZone();
            colour_scorer.Score(seeds_[self], &by_colour[k]);
          }
        }
        size_t worse = fit[0] >= fit[1] ? j : i;
        if (one_ball && std::max(by_colour[0], by_colour[1]) >= options_.same_ball_colour_ballness)
          worse = by_colour[0] >= by_colour[1] ? j : i;
        const size_t better = worse == i ? j : i;
        const int w = worse == i ? 0 : 1;
        const bool other_colour =
            coloured[w] && (!coloured[1 - w] ||
                            cv::norm(chroma[w] - chroma[1 - w]) > options_.ball_chroma_distance);
        if (other_colour) {
          // One of the two is moved straight out to touch the other: the dark one without
          // colour of its own, else the worse fit, or the nearer of a pair seen one behind
          // the other (options.line_of_sight_pair_deg).
          size_t mover = worse;
          if (!coloured[1 - w] && dark[1 - w]) {
            mover = better;
          } else if (options_.line_of_sight_pair_deg > 0 && gap > r_) {
            const size_t nearer = FromCamera(seeds_[i]) < FromCamera(seeds_[j]) ? i : j;
            const size_t farther = nearer == i ? j : i;
            const cv::Point2d sight(seeds_[farther].x - camera_[0], seeds_[farther].y - camera_[1]);
            const cv::Point2d behind = seeds_[farther] - seeds_[nearer];
            if (behind.dot(sight) >= std::cos(options_.line_of_sight_pair_deg * kPi / 180) *
                                         cv::norm(behind) * cv::norm(sight))
              mover = nearer;
          }
          const size_t keep = mover == i ? j : i;
          seeds_[mover] =
              seeds_[keep] + (seeds_[mover] - seeds_[keep]) * (2 * r_ / std::max(1e-6, gap));
          moved_[mover] = 1;
        } else {
          seeds_.erase(seeds_.begin() + static_cast<std::ptrdiff_t>(worse));
          moved_.erase(moved_.begin() + static_cast<std::ptrdiff_t>(worse));
        }
        changed = true;
      }
  }
}

void BallFinder::KeepBalls() {
  // Keep distinct, well-supported balls on the table.
  double unused_intensity;
  HueSaturation(cloth_, &cloth_hue_, &cloth_saturation_, &unused_intensity);
  std::vector<cv::Point2d> kept;
  for (size_t i = 0; i < seeds_.size(); ++i) {
    if (seeds_[i].x < -r_ / 2 || seeds_[i].y < -r_ / 2 || seeds_[i].x > L_ + r_ / 2 ||
        seeds_[i].y > W_ + r_ / 2)
      continue;
    // A ball's centre is at least a radius inside the cushion noses. A dark ball frozen on
    // the far cushion can be fitted beyond it, half on the dark rail (benchmark frame 46's
    // 8, 28 mm into the cushion, then rejected as half cloth): it is brought back to the
    // cushion, with a tenth of a radius to spare for the fit's own noise.
    const double inset = 0.9 * r_;
    seeds_[i].x = std::clamp(seeds_[i].x, inset, L_ - inset);
    seeds_[i].y = std::clamp(seeds_[i].y, inset, W_ - inset);
    cv::Point2d xy = seeds_[i];
    bool duplicate = false;
    for (const auto& k : kept)
      if (cv::norm(k - xy) < r_) duplicate = true;
    if (duplicate) continue;
    Claim(seeds_, i, seeds_.size());
    SilhouetteScorer scorer(ballness_in_region_, roi_, claimed_, K_, pose_, profile_);
    double mean_ballness = 0;
    scorer.Score(xy, &mean_ballness);
    bool kept_by_colour = false;
    if (!moved_[i] && mean_ballness < options_.min_fit_ballness) {
      // A small dark ball of nearly the cloth's hue (a far green 6 on green cloth) shows
      // ball only in its lower half, dark and far from the cloth's chromaticity; its lit
      // top is of the cloth's colour. The fits leave the zone under the ball out (a ball's
      // own shadow is as dark as a dark ball), so they slid up onto the cloth. By colour
      // alone a shadow stays cloth: the seed is fitted once more on that, over the whole
      // silhouette, and kept where it is then mostly ball.
      SilhouetteScorer by_colour(ByColourAlone(), roi_, claimed_, K_, pose_, profile_);
      by_colour.CountShadowZone();
      const cv::Point2d refit = by_colour.Fit(xy, 0.35 * r_);
      double colour_mean = 0;
      by_colour.Score(refit, &colour_mean);
      if (colour_mean >= options_.min_fit_ballness && cv::norm(refit - xy) < r_) {
        seeds_[i] = xy = refit;
        mean_ballness = colour_mean;
      } else if (options_.min_fit_ballness_by_colour > 0 &&
                 mean_ballness >= options_.min_fit_ballness_by_colour) {
        // A green 6 whose lit cap reads as cloth (options.min_fit_ballness_by_colour).
        double here = 0;
        by_colour.Score(xy, &here);
        kept_by_colour = here >= options_.min_fit_ballness_by_colour;
      }
    }
    // A ball moved out of its neighbour is where the rule put it: it must be half ball.
    if (!kept_by_colour && mean_ballness < (moved_[i] ? 0.5 : options_.min_fit_ballness)) continue;
    // Votes: pixels not covered by a nearer ball (by distance now: a ball split off a
    // blob behind another one was added after the others).
    {
      const double own = FromCamera(xy);
      std::vector<cv::Point2d> nearer;
      for (size_t j = 0; j < seeds_.size(); ++j)
        if (j != i && FromCamera(seeds_[j]) < own) nearer.push_back(seeds_[j]);
      Claim(nearer, nearer.size(), nearer.size());
    }
    kept.push_back(xy);
    PoolDetectedBall ball;
    ball.x_mm = xy.x;
    ball.y_mm = xy.y;
    ball.fit_score = mean_ballness;
    const cv::Vec3d centre(xy.x, xy.y, r_);
    ball.ideal_pixel = ProjectIdeal(pose_, K_, centre);
    ball.radius_px = ApparentRadiusPx(pose_, K_, xy, r_);
    // Votes over the pixels well inside the silhouette that no nearer ball covers.
    const cv::Matx33d Q = SphereSilhouetteConic(pose_, K_, centre, r_);
    const cv::Rect box = scorer.Box(centre);
    // Local light: the cloth brightness around the ball.
    const bool srgb = options_.pixel_encoding == PixelEncoding::kSrgb;
    const std::array<float, 256>& light_of = SrgbLightTable();
    std::vector<float> ring, ring_light;  // the cloth's intensity as read, and in light (sRGB)
    for (int v = box.y - box.height / 2; v < box.y + box.height * 3 / 2; v += 2)
      for (int u = box.x - box.width / 2; u < box.x + box.width * 3 / 2; u += 2) {
        if (!image_rect_.contains({u, v})) continue;
        const double d = std::hypot(u - ball.ideal_pixel.x, v - ball.ideal_pixel.y);
        if (d < 1.6 * ball.radius_px || d > 2.6 * ball.radius_px) continue;
        const cv::Vec3b& p = bgr_.at<cv::Vec3b>(v, u);
        const cv::Vec3f pf(p[0], p[1], p[2]);
        if (ColorAngleDeg(pf, cloth_) < options_.ball_angle_deg) {
          ring.push_back((pf[0] + pf[1] + pf[2]) / 3);
          if (srgb) ring_light.push_back((light_of[p[0]] + light_of[p[1]] + light_of[p[2]]) / 3);
        }
      }
    double light = 1;  // local cloth brightness / the profile's cloth brightness
    const cv::Vec3b pc = profile_.cloth_bgr;
    const double profile_cloth = (pc[0] + pc[1] + pc[2]) / 3.0;
    // The red cues of an sRGB picture are read in light: its 3's and 7's brightness over
    // the cloth, and their saturation, are the encoding's as much as the balls' (the
    // twenty sets rendered sRGB: 3,055 + 3,097 -> 3,064 + 3,104 separated balls named, the
    // 3 read as the 7 21 -> 10 times). The cloth around the ball in light for that.
    double ring_in_light = 0;
    if (ring.size() >= 5) {
      std::nth_element(ring.begin(), ring.begin() + ring.size() / 2, ring.end());
      light = ring[ring.size() / 2] / profile_cloth;
      if (srgb) {
        std::nth_element(ring_light.begin(), ring_light.begin() + ring_light.size() / 2,
                         ring_light.end());
        ring_in_light = ring_light[ring_light.size() / 2];
      }
    } else {
      light = cloth_intensity_ / profile_cloth;
      if (srgb) {
        const cv::Vec3f cloth_light = ColourInLight(cloth_, PixelEncoding::kSrgb);
        ring_in_light = (cloth_light[0] + cloth_light[1] + cloth_light[2]) / 3;
      }
    }
    const bool red_in_light = srgb && ring_in_light > 0;
    std::array<ColourRef, kPoolBallCount> refs;
    for (int k = 0; k < kPoolBallCount; ++k) {
      const cv::Vec3b& c = profile_.ball_bgr[k];
      double h, s, i;
      HueSaturation(cv::Vec3f(c[0], c[1], c[2]), &h, &s, &i);
      refs[k] = {s * std::cos(h * kPi / 180), s * std::sin(h * kPi / 180), s, BlueShare(c)};
    }
    // Pixels in the red group (the 3 and the maroon 7 differ in saturation, not hue): their
    // saturation where the camera did not clip.
    std::vector<float> red_saturation, red_brightness;
    double red_votes = 0;
    double white_rho = 0, yellow_rho = 0;
    for (int v = box.y; v < box.y + box.height; ++v)
      for (int u = box.x; u < box.x + box.width; ++u) {
        // Pixels at least a pixel inside the outline: the blur of lens, demosaicing and
        // JPEG (which halves the colour resolution) mixes the cloth into the outer ring.
        if (SilhouetteScorer::InsideDistance(Q, u, v) < kInteriorPx) continue;
        if (claimed_.at<float>(v - roi_.y, u - roi_.x) > 0.5) continue;
        // Only the ball's own colours vote: not the cloth seen where a cushion hides the
        // ball, nor cloth left inside the silhouette by a small misfit.
        if (ballness_in_region_.at<float>(v - roi_.y, u - roi_.x) < 0.5) continue;
        if (scorer.NearCushion(xy) && scorer.HiddenByCushion(centre, u, v)) continue;
        if (scorer.InShadowZone(centre, u, v)) continue;
        // The colour from the unblurred image: the light blur used for the outline would
        // mix the 9's white cap into its stripe.
        const cv::Vec3b& p = image_.at<cv::Vec3b>(v, u);
        double hue, sat, intensity;
        HueSaturation(cv::Vec3f(p[0], p[1], p[2]), &hue, &sat, &intensity);
        const double q = intensity / (profile_cloth * light);
        int vote;
        bool red_cue = false;  // the 3's and the 7's cues are read on this pixel
        if (q < 0.45 && sat < 0.6) {
          vote = 8;
        } else if (sat < 0.25) {
          vote = q < 0.55 ? 8 : 0;
        } else {
          // Nearest solid colour in the intensity-normalised chroma plane (seed eq. 4.1
          // on the chromatic part, which is independent of the light's strength). For a
          // pixel brighter than the lit cloth, the colour is the segment from grey to it
          // (options.vote_min_colour_share): such a pixel mixes a ball's colour with white
          // (its highlight, its number disc, the blur between them), and by the colour's
          // point the lit orange 5's pale pixels were nearer the maroon 7, which is less
          // saturated, than their own colour. A darker pale pixel is shade, noise or the
          // cloth mixed in, and keeps the point (else a maroon 7's shade read as the 5).
          // The 3 and the 7 are told apart by the saturation and brightness of the pixels
          // nearest a red colour's point: the pale ones would only dilute that.
          const double x = sat * std::cos(hue * kPi / 180), y = sat * std::sin(hue * kPi / 180);
          vote = 1;
          int point_vote = 1;
          double best = 1e9, best_point = 1e9;
          for (int k = 1; k <= 7; ++k) {
            const double rx = refs[k].chroma_x, ry = refs[k].chroma_y;
            const double d_point = std::hypot(x - rx, y - ry);
            if (d_point < best_point) {
              best_point = d_point;
              point_vote = k;
            }
            double d = d_point;
            if (q >= 1) {
              const double t = std::clamp((x * rx + y * ry) / std::max(1e-9, rx * rx + ry * ry),
                                          options_.vote_min_colour_share, 1.0);
              d = std::hypot(x - t * rx, y - t * ry);
            }
            if (d < best) {
              best = d;
              vote = k;
            }
          }
          red_cue = point_vote == 3 || point_vote == 7;
        }
        // A pixel of the cloth's hue is the 8 mirroring the cloth when it is dark
        // (options.dark_reflection_brightness), and in an sRGB picture, of a solid colour,
        // when it carries little colour against the cloth's: the 8's dark pixels take the
        // cloth's colour from JPEG's colour smear well above that darkness, and are told
        // from a solid ball of it (the green 6) so (options.dark_reflection_chroma_srgb).
        if (vote != 8 && HueGapDeg(hue, cloth_hue_) < options_.dark_reflection_hue_deg &&
            (q < options_.dark_reflection_brightness ||
             (srgb && vote > 1 &&
              sat * q < options_.dark_reflection_chroma_srgb * cloth_saturation_)))
          vote = 8;
        if (vote == 0 || vote == 1) {
          // White and yellow mix at the 9's stripe edges, in the highlight and in any
          // blur: the pixel's blue share (blue is what yellow lacks) says how much of it
          // is white, so a thin white cap still counts for what it is.
          const double w = std::clamp((BlueShare(p) - refs[1].blue_share) /
                                          std::max(0.05, refs[0].blue_share - refs[1].blue_share),
                                      0.0, 1.0);
          ball.votes[0] += w;
          ball.votes[1] += 1 - w;
          const double rho =
              std::hypot(u - ball.ideal_pixel.x, v - ball.ideal_pixel.y) / ball.radius_px;
          white_rho += w * rho;
          yellow_rho += (1 - w) * rho;
        } else if (vote == 3 || vote == 7) {
          red_votes += 1;
        } else {
          ball.votes[vote] += 1;
        }
        if (red_cue && vote != 8) {
          if (std::max({p[0], p[1], p[2]}) < 250 && red_in_light) {
            double light_hue, light_sat, light_intensity;
            HueSaturation(cv::Vec3f(light_of[p[0]], light_of[p[1]], light_of[p[2]]), &light_hue,
                          &light_sat, &light_intensity);
            red_saturation.push_back(static_cast<float>(light_sat));
            red_brightness.push_back(static_cast<float>(light_intensity / ring_in_light));
          } else if (std::max({p[0], p[1], p[2]}) < 250) {
            red_saturation.push_back(static_cast<float>(sat));
            red_brightness.push_back(static_cast<float>(q));
          }
        }
      }
    if (red_votes > 0) {
      // The red group goes to the 3 or the 7 by the ball's saturation (upper quartile of
      // its unclipped red pixels: shading keeps it, highlights and the cloth mixed in at
      // the edge only lower it), between the two calibrated colours.
      double t = 0.5;
      if (!red_saturation.empty()) {
        const size_t k75 = red_saturation.size() * 3 / 4;
        std::nth_element(red_saturation.begin(), red_saturation.begin() + k75,
                         red_saturation.end());
        ball.colour_saturation = red_saturation[k75];
        std::nth_element(red_brightness.begin(), red_brightness.begin() + k75,
                         red_brightness.end());
        ball.colour_brightness = red_brightness[k75];
        t = PoolRedShareOfThree(ball.colour_saturation, ball.colour_brightness, profile_,
                                options_.pixel_encoding);
      }
      ball.votes[3] += red_votes * t;
      ball.votes[7] += red_votes * (1 - t);
    }
    const double white_yellow = ball.votes[0] + ball.votes[1];
    ball.white_share = white_yellow > 0 ? ball.votes[0] / white_yellow : 0;
    if (ball.votes[0] > 0 && ball.votes[1] > 0)
      ball.white_outward = white_rho / ball.votes[0] - yellow_rho / ball.votes[1];
    balls_.push_back(ball);
    balls_moved_.push_back(moved_[i]);
  }
}

void BallFinder::TellRedPairApart() {
  // Two balls that are mostly red are the 3 and the 7 (a set has one of each): they are
  // told apart by their differences, which the picture's blur and light leave alone. Not
  // on a cloth of the red balls' hue (burgundy), whose pixels inside a ball's outline
  // also vote red: a red ball there may be a fit of cloth.
  double red_hue, unused_red_saturation, unused_red_intensity;
  const cv::Vec3b& three = profile_.ball_bgr[3];
  HueSaturation(cv::Vec3f(three[0], three[1], three[2]), &red_hue, &unused_red_saturation,
                &unused_red_intensity);
  // (index, red votes): the red votes are all the 3's and the 7's.
  std::vector<std::pair<size_t, double>> red_balls;
  for (size_t i = 0; i < balls_.size() && HueGapDeg(red_hue, cloth_hue_) >= kRedClothHueGapDeg;
       ++i) {
    const PoolDetectedBall& b = balls_[i];
    const double red = b.votes[3] + b.votes[7];
    const double others = std::accumulate(b.votes.begin(), b.votes.end(), 0.0) - red;
    if (red > 0 && red > others && b.colour_saturation > 0) red_balls.emplace_back(i, red);
  }
  if (red_balls.size() == 2) {
    PoolDetectedBall& a = balls_[red_balls[0].first];
    PoolDetectedBall& b = balls_[red_balls[1].first];
    const double t =
        PoolRedPairShareOfThree(a.colour_saturation, a.colour_brightness, b.colour_saturation,
                                b.colour_brightness, profile_, options_.pixel_encoding);
    a.votes[3] = red_balls[0].second * t;
    a.votes[7] = red_balls[0].second * (1 - t);
    b.votes[3] = red_balls[1].second * (1 - t);
    b.votes[7] = red_balls[1].second * t;
  }
}

std::vector<PoolDetectedBall> BallFinder::NameBalls() {
  if (options_.separate_overlapping_fits)
    SeparateOverlappingBalls(pose_, K_, r_, &balls_, options_.line_of_sight_pair_deg);
  std::vector<std::array<double, 10>> scores;
  for (size_t i = 0; i < balls_.size(); ++i) {
    scores.push_back(PoolNumberScores(balls_[i].votes, options_, balls_[i].white_outward));
    if (balls_moved_[i])
      for (double& v : scores.back()) v *= options_.moved_number_weight;
  }
  const std::vector<int> numbers = AssignPoolNumbers(scores, options_.unnamed_score);
  for (size_t i = 0; i < balls_.size(); ++i) {
    balls_[i].number = numbers[i];
    balls_[i].confidence = numbers[i] >= 0 ? scores[i][numbers[i]] : 0;
  }
  return balls_;
}

// One pass of DetectPoolBalls on the picture as given, whose pixels are valid (the ideal
// image's) inside `valid` only.
std::vector<PoolDetectedBall> DetectPoolBallsOnce(const cv::Mat& image, const cv::Rect& valid,
                                                  const cv::Matx33d& K, const PlanarPose& pose,
                                                  const PoolTableProfile& profile,
                                                  const cv::Vec3b& cloth_bgr,
                                                  const PoolBallOptions& options,
                                                  double* ball_size_ratio) {
  return BallFinder(image, K, pose, profile, cloth_bgr, options).Run(valid, ball_size_ratio);
}

// Per-channel gains (BGR) that bring the white seen on `balls` to the profile's cue colour
// (in chromaticity; the gains keep a white pixel's sum). The white pixels are those well
// inside a ball's outline (0.7 of its radius), unclipped, of saturation under 0.6 (the
// cue's is about 0.05, under a warm cast 0.3-0.4; the yellow of the 1 and the 9 and every
// other ball colour 1 or more) and over 1.5 times the cloth's brightness (shaded white,
// greys and the 8 are darker). The light's colour is the median of the whitest ball's
// (kMinWhiteShare and below); (1, 1, 1) when no ball qualifies.
cv::Vec3f BallWhiteGains(const cv::Mat& image, const std::vector<PoolDetectedBall>& balls,
                         const cv::Vec3b& cloth_bgr, const PoolTableProfile& profile) {
  const double cloth_intensity = (cloth_bgr[0] + cloth_bgr[1] + cloth_bgr[2]) / 3.0;
  std::array<std::vector<float>, 3> chroma;  // the whitest ball's white pixels: channel / sum
  double whitest = 0;  // the chosen ball's white share times (1 - their median saturation)
  for (const PoolDetectedBall& ball : balls) {
    const double reach = 0.7 * ball.radius_px;
    std::array<std::vector<float>, 3> own;
    std::vector<float> saturations;
    int pixels = 0;
    for (int v = cvFloor(ball.ideal_pixel.y - reach); v <= cvCeil(ball.ideal_pixel.y + reach); ++v)
      for (int u = cvFloor(ball.ideal_pixel.x - reach); u <= cvCeil(ball.ideal_pixel.x + reach);
           ++u) {
        if (u < 0 || v < 0 || u >= image.cols || v >= image.rows) continue;
        if (std::hypot(u - ball.ideal_pixel.x, v - ball.ideal_pixel.y) > reach) continue;
        ++pixels;
        const cv::Vec3b& p = image.at<cv::Vec3b>(v, u);
        if (std::max({p[0], p[1], p[2]}) >= 250) continue;
        double hue, saturation, intensity;
        HueSaturation(cv::Vec3f(p[0], p[1], p[2]), &hue, &saturation, &intensity);
        if (saturation >= 0.6 || intensity < 1.5 * cloth_intensity) continue;
        const float sum = static_cast<float>(p[0] + p[1] + p[2]);
        for (int c = 0; c < 3; ++c) own[c].push_back(p[c] / sum);
        saturations.push_back(static_cast<float>(saturation));
      }
    if (saturations.size() < kMinWhitePixels || saturations.size() < kMinWhiteShare * pixels)
      continue;
    std::nth_element(saturations.begin(), saturations.begin() + saturations.size() / 2,
                     saturations.end());
    const double median_saturation = saturations[saturations.size() / 2];
    const double whiteness = saturations.size() * (1 - median_saturation) / std::max(1, pixels);
    if (median_saturation >= kMaxWhiteSaturation || whiteness <= whitest) continue;
    whitest = whiteness;
    chroma = std::move(own);
  }
  if (chroma[0].empty()) return {1, 1, 1};
  cv::Vec3f seen;
  for (int c = 0; c < 3; ++c) {
    std::vector<float>& x = chroma[c];
    std::nth_element(x.begin(), x.begin() + x.size() / 2, x.end());
    seen[c] = x[x.size() / 2];
  }
  return ChromaticityGains(seen, profile.ball_bgr[0]);
}

}  // namespace

namespace {

// DetectPoolBalls on a picture whose pixels are valid inside `valid` only.
std::vector<PoolDetectedBall> DetectPoolBallsIn(const cv::Mat& image, const cv::Rect& valid,
                                                const cv::Matx33d& K, const PlanarPose& pose,
                                                const PoolTableProfile& profile,
                                                const cv::Vec3b& cloth_bgr,
                                                const PoolBallOptions& options,
                                                cv::Vec3f* light_gains, double* ball_size_ratio) {
  const bool balance = options.white_balance_min_cast > 0;
  const cv::Vec3f prior = balance && light_gains ? *light_gains : cv::Vec3f(1, 1, 1);
  const auto balanced_cloth = [&](const cv::Vec3f& gains) {
    return cv::Vec3b(cv::saturate_cast<uchar>(cloth_bgr[0] * gains[0]),
                     cv::saturate_cast<uchar>(cloth_bgr[1] * gains[1]),
                     cv::saturate_cast<uchar>(cloth_bgr[2] * gains[2]));
  };
  const auto balanced_image = [&](const cv::Vec3f& gains) {
    if (gains == cv::Vec3f(1, 1, 1)) return image;
    cv::Mat balanced(image.size(), image.type());
    cv::Mat part = balanced(valid);
    cv::multiply(image(valid), cv::Scalar(gains[0], gains[1], gains[2]), part);
    return balanced;
  };
  const cv::Mat seen = balanced_image(prior);
  const cv::Vec3b seen_cloth = balanced_cloth(prior);
  std::vector<PoolDetectedBall> balls =
      DetectPoolBallsOnce(seen, valid, K, pose, profile, seen_cloth, options, ball_size_ratio);
  if (!balance) return balls;
  // Two witnesses of the light's colour must agree: the white of the balls, and the cloth
  // measured on the picture against the profile's cloth colour. The white of one small
  // ball alone is off by 7-26% on 21 of the benchmark's 600 neutral frames (a 9's white
  // mixed with its yellow, a cue ball in shade), and a cloth of another shade than the
  // profile's would be taken for a cast were the cloth alone asked. With the gains of an
  // earlier frame the picture is read balanced at once, and only what is left of the cast
  // is measured.
  const cv::Vec3f residual = BallWhiteGains(seen, balls, seen_cloth, profile);
  if (!LightCastsAgree(residual, ChromaticityGains(seen_cloth, profile.cloth_bgr),
                       options.white_balance_min_cast))
    return balls;
  const cv::Vec3f gains = prior.mul(residual);
  if (light_gains) *light_gains = gains;
  return DetectPoolBallsOnce(balanced_image(gains), valid, K, pose, profile, balanced_cloth(gains),
                             options, ball_size_ratio);
}

}  // namespace

std::vector<PoolDetectedBall> DetectPoolBalls(const cv::Mat& image, const cv::Matx33d& K,
                                              const PlanarPose& pose,
                                              const PoolTableProfile& profile,
                                              const cv::Vec3b& cloth_bgr,
                                              const PoolBallOptions& options,
                                              cv::Vec3f* light_gains, double* ball_size_ratio) {
  return DetectPoolBallsIn(image, cv::Rect(0, 0, image.cols, image.rows), K, pose, profile,
                           cloth_bgr, options, light_gains, ball_size_ratio);
}

std::vector<PoolDetectedBall> DetectPoolBalls(IdealView* view, const cv::Matx33d& K,
                                              const PlanarPose& pose,
                                              const PoolTableProfile& profile,
                                              const cv::Vec3b& cloth_bgr,
                                              const PoolBallOptions& options,
                                              cv::Vec3f* light_gains, double* ball_size_ratio) {
  const double L = profile.length_mm, W = profile.width_mm, r = profile.ball_radius_mm;
  const cv::Rect search = BallSearchRect(pose, K, L, W, r, view->full().size());
  if (search.area() > 0) {
    const int margin = BallReadMarginPx(pose, K, L, W, r);
    view->Require({search.x - margin, search.y - margin, search.width + 2 * margin,
                   search.height + 2 * margin});
  }
  return DetectPoolBallsIn(view->full(), view->valid(), K, pose, profile, cloth_bgr, options,
                           light_gains, ball_size_ratio);
}

cv::Mat EmptyTableBackground(const cv::Mat& bgr, const cv::Matx33d& K, const PlanarPose& pose,
                             const PoolTableProfile& profile,
                             const std::vector<PoolDetectedBall>& balls) {
  cv::Mat out = bgr.clone();
  const double r = profile.ball_radius_mm;
  for (const auto& ball : balls) {
    const cv::Vec3d centre(ball.x_mm, ball.y_mm, r);
    const cv::Matx33d Q = SphereSilhouetteConic(pose, K, centre, r);
    const double reach = 1.5 * ball.radius_px + 3;
    const cv::Rect box =
        cv::Rect(cvFloor(ball.ideal_pixel.x - 2 * reach), cvFloor(ball.ideal_pixel.y - 2 * reach),
                 cvCeil(4 * reach) + 1, cvCeil(4 * reach) + 1) &
        cv::Rect(0, 0, bgr.cols, bgr.rows);
    if (box.area() <= 0) continue;
    cv::Mat inside = cv::Mat::zeros(box.size(), CV_8UC1);
    for (int v = 0; v < box.height; ++v)
      for (int u = 0; u < box.width; ++u)
        if (SilhouetteScorer::Coverage(Q, u + box.x, v + box.y) > 0) inside.at<uint8_t>(v, u) = 255;
    cv::dilate(inside, inside, cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(5, 5)));
    cv::Mat ring;
    cv::dilate(inside, ring, cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(7, 7)));
    ring &= ~inside;
    // Seed figure 4.10: ball regions are replaced by the mat colour around them.
    const cv::Scalar fill = cv::mean(bgr(box), ring);
    out(box).setTo(fill, inside);
  }
  return out;
}

void SeparateOverlappingBalls(const PlanarPose& pose, const cv::Matx33d& K, double radius,
                              std::vector<PoolDetectedBall>* balls, double line_of_sight_pair_deg) {
  const cv::Vec3d camera = CameraCentre(pose);
  const double cos_line_of_sight =
      line_of_sight_pair_deg > 0 ? std::cos(line_of_sight_pair_deg * kPi / 180) : 2.0;
  // Each round settles every pair once; a pushed ball may overlap a third one, so rounds
  // run until no pair overlaps by more than kTolerance (a chain of three balls, 40 mm apart
  // at a radius of 24, still overlapped by 0.4 mm after three rounds), capped.
  constexpr int kMaxRounds = 50;
  constexpr double kTolerance = 0.01;  // mm
  const double contact = 2 * radius;
  bool overlapping = true;
  for (int round = 0; overlapping && round < kMaxRounds; ++round) {
    overlapping = false;
    for (size_t i = 0; i < balls->size(); ++i)
      for (size_t j = i + 1; j < balls->size(); ++j) {
        PoolDetectedBall& a = (*balls)[i];
        PoolDetectedBall& b = (*balls)[j];
        cv::Point2d along(b.x_mm - a.x_mm, b.y_mm - a.y_mm);
        const double gap = cv::norm(along);
        // Coincident centres have no direction to separate along (the overlap rule of the
        // fits never leaves two within a radius).
        if (gap >= contact - kTolerance || gap < 1e-6) continue;
        overlapping = true;
        // Share of the overlap that a takes: half, or all of it when a is the nearer of a
        // pair seen one behind the other (b the nearer: none).
        double share_a = 0.5;
        const cv::Point2d from_camera(0.5 * (a.x_mm + b.x_mm) - camera[0],
                                      0.5 * (a.y_mm + b.y_mm) - camera[1]);
        const double along_sight = from_camera.dot(along);
        if (std::abs(along_sight) > cos_line_of_sight * cv::norm(from_camera) * gap)
          share_a = along_sight > 0 ? 1.0 : 0.0;  // a -> b points away from the camera
        along *= (contact - gap) / gap;
        a.x_mm -= share_a * along.x;
        a.y_mm -= share_a * along.y;
        b.x_mm += (1 - share_a) * along.x;
        b.y_mm += (1 - share_a) * along.y;
        for (PoolDetectedBall* ball : {&a, &b}) {
          if ((ball == &a ? share_a : 1 - share_a) == 0) continue;  // not moved
          ball->ideal_pixel = ProjectIdeal(pose, K, cv::Vec3d(ball->x_mm, ball->y_mm, radius));
          ball->radius_px = ApparentRadiusPx(pose, K, {ball->x_mm, ball->y_mm}, radius);
        }
      }
  }
}

}  // namespace texfree
