// Camera sequences over a page: orbit and pan paths with correlated hand shake, and a
// hand-like occluder.
#include "tests/data/camera_sequence.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <random>

namespace texfree::testdata {
namespace {

constexpr double kPi = 3.14159265358979323846;

double Unit(std::mt19937_64& rng) { return static_cast<double>(rng() >> 11) * 0x1.0p-53; }

// Portable standard normal (Box-Muller on raw engine bits).
double Normal(std::mt19937_64& rng) {
  const double u1 = std::max(1e-300, Unit(rng)), u2 = Unit(rng);
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2 * kPi * u2);
}

// Correlated jitter: a hand drifts, it does not jump. AR(1) with stationary std `sigma`.
class Shake {
 public:
  Shake(double sigma, std::mt19937_64& rng) : sigma_(sigma), rng_(rng) {}
  double Next() {
    constexpr double kKeep = 0.85;
    value_ = kKeep * value_ + std::sqrt(1 - kKeep * kKeep) * sigma_ * Normal(rng_);
    return value_;
  }

 private:
  double sigma_;
  std::mt19937_64& rng_;
  double value_ = 0;
};

}  // namespace

std::vector<SequenceFrame> MakeCameraSequence(const cv::Size& page_size,
                                              const CameraSequenceOptions& o, uint64_t seed) {
  std::mt19937_64 rng(seed ^ 0x73657175656e6365ULL);
  Shake sx(o.shake_px, rng), sy(o.shake_px, rng), sroll(o.shake_deg, rng),
      stilt(o.shake_deg, rng);
  int count = o.pan_frames;
  if (o.motion == CameraSequenceOptions::Motion::kOrbit) {
    count = 1 + static_cast<int>(std::floor(
                    std::abs(o.end_tilt_deg - o.start_tilt_deg) / std::max(1e-6, o.step_deg) +
                    1e-9));
  }
  std::vector<SequenceFrame> frames;
  frames.reserve(static_cast<size_t>(count));
  std::mt19937_64 smear(seed ^ 0x736d656172ULL);
  const auto unit = [&smear] { return static_cast<double>(smear() >> 11) * 0x1.0p-53; };
  for (int i = 0; i < count; ++i) {
    SequenceFrame f;
    CameraViewOptions& v = f.options;
    v.image_size = o.image_size;
    v.horizontal_fov_deg = o.horizontal_fov_deg;
    v.scale = o.scale;
    v.tilt_azimuth_deg = o.tilt_azimuth_deg;
    cv::Point2d at = o.look_at;
    if (o.motion == CameraSequenceOptions::Motion::kOrbit) {
      const double dir = o.end_tilt_deg >= o.start_tilt_deg ? 1 : -1;
      f.nominal_tilt_deg = o.start_tilt_deg + dir * o.step_deg * i;
    } else {
      f.nominal_tilt_deg = o.start_tilt_deg;
      const double s = count > 1 ? static_cast<double>(i) / (count - 1) : 0;
      at = o.pan_from + s * (o.pan_to - o.pan_from);
    }
    v.tilt_deg = std::max(0.0, f.nominal_tilt_deg + stilt.Next());
    v.roll_deg = o.roll_deg + sroll.Next();
    v.look_at = {at.x * (page_size.width - 1) + sx.Next(),
                 at.y * (page_size.height - 1) + sy.Next()};
    v.blur_sigma = o.blur_sigma;
    v.noise_sigma = o.noise_sigma;
    v.illumination_gradient = o.illumination_gradient;
    v.jpeg_quality = o.jpeg_quality;
    v.page_curl = o.page_curl;
    v.curl_azimuth_deg = o.curl_azimuth_deg;
    v.curl_one_sided = o.curl_one_sided;
    v.radial_k1 = o.radial_k1;
    v.motion_blur_px = o.max_motion_blur_px * unit();
    v.motion_blur_angle_deg = 180 * unit();
    v.background = cv::Scalar(70, 95, 125);
    frames.push_back(f);
  }
  return frames;
}

cv::Mat OccludePageHalf(const cv::Mat& page, int side, uint64_t seed, cv::Mat* covered) {
  std::mt19937_64 rng(seed ^ 0x68616e64ULL);
  const int w = page.cols, h = page.rows;
  // A palm covering the half, fingers reaching a little across the middle line, built
  // in a frame where the half is the left one, then rotated to the requested side.
  const bool vertical = side >= 2;
  const int len = vertical ? h : w;   // across the split
  const int span = vertical ? w : h;  // along the split
  cv::Mat mask(vertical ? cv::Size(h, w) : cv::Size(w, h), CV_8UC1, cv::Scalar(0));
  const int edge = len / 2;
  std::vector<cv::Point> palm = {{0, 0}, {edge - len / 20, 0}, {edge, span / 3},
                                 {edge - len / 40, 2 * span / 3}, {edge - len / 15, span},
                                 {0, span}};
  cv::fillPoly(mask, std::vector<std::vector<cv::Point>>{palm}, cv::Scalar(255), cv::LINE_AA);
  const int fingers = 4;
  for (int k = 0; k < fingers; ++k) {
    const int y = span / 5 + k * span / 7 + static_cast<int>((Unit(rng) - 0.5) * span / 30);
    const int reach = edge + static_cast<int>((0.06 + 0.06 * Unit(rng)) * len);
    const int thick = std::max(3, span / 24);
    cv::line(mask, {edge - len / 10, y}, {reach, y + static_cast<int>((Unit(rng) - 0.5) * 20)},
             cv::Scalar(255), thick, cv::LINE_AA);
    cv::circle(mask, {reach, y}, thick / 2, cv::Scalar(255), -1, cv::LINE_AA);
  }
  if (vertical) cv::transpose(mask, mask);  // left half -> top half
  if (side == 1) cv::flip(mask, mask, 1);
  if (side == 3) cv::flip(mask, mask, 0);

  // Skin with soft shading (light from one side) and faint texture.
  cv::Mat shade(std::max(2, h / 60), std::max(2, w / 60), CV_32FC1);
  cv::RNG cvrng(rng());
  cvrng.fill(shade, cv::RNG::NORMAL, 0, 0.06);
  cv::resize(shade, shade, page.size(), 0, 0, cv::INTER_CUBIC);
  const cv::Vec3f skin(120.f + 30.f * static_cast<float>(Unit(rng)),
                       150.f + 30.f * static_cast<float>(Unit(rng)), 200.f + 30.f *
                       static_cast<float>(Unit(rng)));
  cv::Mat out = page.clone();
  if (out.channels() == 1) cv::cvtColor(out, out, cv::COLOR_GRAY2BGR);
  for (int y = 0; y < h; ++y) {
    const uint8_t* m = mask.ptr<uint8_t>(y);
    const float* s = shade.ptr<float>(y);
    cv::Vec3b* p = out.ptr<cv::Vec3b>(y);
    for (int x = 0; x < w; ++x) {
      if (!m[x]) continue;
      const float a = m[x] / 255.f;
      const float gain = 0.85f + 0.15f * static_cast<float>(x) / w + s[x];
      for (int c = 0; c < 3; ++c)
        p[x][c] = cv::saturate_cast<uint8_t>((1 - a) * p[x][c] + a * skin[c] * gain);
    }
  }
  if (covered) *covered = mask;
  return out;
}

CameraView RenderSequenceFrame(const cv::Mat& page, const SequenceFrame& frame, uint64_t seed,
                               int index) {
  return RenderCameraView(page, frame.options,
                          seed * 1000003ULL + static_cast<uint64_t>(index) * 7919ULL + 17);
}

}  // namespace texfree::testdata
