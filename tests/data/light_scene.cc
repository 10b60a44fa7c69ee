// Blinking-light burst simulator: tunnel scene, LED clocks, per-frame rendering.
#include "tests/data/light_scene.h"

#include <algorithm>
#include <cmath>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "absl/strings/str_cat.h"
#include "common/light_codec.h"

namespace texfree::testdata {
namespace {

constexpr int kD300Width = 4288;
constexpr int kD300Height = 2848;
constexpr double kFocalLengthMm = 50.0;
constexpr double kPixelPitchMm = 0.0055;

// Reference lights 1-7 (ours): on both walls at several depths, low and high, and the crown,
// so that no four are coplanar.
const cv::Point3d kReferences[] = {
    {42.55, 70.20, 11.30}, {42.40, 73.10, 15.60}, {45.90, 74.30, 18.40}, {52.20, 86.10, 19.10},
    {57.60, 84.20, 15.20}, {57.45, 88.00, 11.50}, {50.10, 78.40, 19.80}};
// Seed Table 7.2, lights 8-14 (ground truth, metres).
const cv::Point3d kTable72[] = {{42.622, 76.178, 11.072}, {42.623, 80.724, 11.163},
                                {42.369, 80.822, 14.689}, {48.976, 80.907, 19.286},
                                {57.540, 80.969, 14.687}, {57.317, 80.966, 11.046},
                                {57.339, 76.470, 11.089}};

cv::Matx33d LookAt(const cv::Point3d& eye, const cv::Point3d& target) {
  const cv::Vec3d forward = cv::normalize(cv::Vec3d(target - eye));
  const cv::Vec3d up(0, 0, 1);  // world Z is up
  const cv::Vec3d right = cv::normalize(forward.cross(up));
  const cv::Vec3d down = forward.cross(right);
  // Rows: camera x (right), y (down), z (forward) in world coordinates.
  return cv::Matx33d(right[0], right[1], right[2], down[0], down[1], down[2], forward[0], forward[1],
                     forward[2]);
}

}  // namespace

absl::Status LightSceneOptions::Validate() const {
  if (frames < 1) return absl::InvalidArgumentError("frames must be >= 1");
  if (!(scale > 0.05 && scale <= 1)) return absl::InvalidArgumentError("scale must be in (0.05, 1]");
  if (!(max_clock_drift >= 0 && max_clock_drift < 0.05))
    return absl::InvalidArgumentError("max_clock_drift must be in [0, 0.05)");
  if (max_idle_samples < 0) return absl::InvalidArgumentError("max_idle_samples must be >= 0");
  if (!(exposure_fraction > 0 && exposure_fraction < 1))
    return absl::InvalidArgumentError("exposure_fraction must be in (0, 1)");
  if (jpeg_quality < 0 || jpeg_quality > 100)
    return absl::InvalidArgumentError("jpeg_quality must be in [0, 100]");
  return absl::OkStatus();
}

LightScene MakeTunnelScene(const LightSceneOptions& options) {
  LightScene scene;
  const double s = options.scale;
  const double f = kFocalLengthMm / kPixelPitchMm * s;
  scene.camera.size = cv::Size(static_cast<int>(std::lround(kD300Width * s)),
                               static_cast<int>(std::lround(kD300Height * s)));
  scene.camera.K = cv::Matx33d(f, 0, (scene.camera.size.width - 1) / 2.0 + 9.5 * s, 0, f,
                               (scene.camera.size.height - 1) / 2.0 - 6.0 * s, 0, 0, 1);
  scene.camera.distortion = {-0.045, 0.11, 0.0004, -0.0003, 0.0};
  cv::RNG rng(options.seed);
  auto add = [&](uint32_t id, const cv::Point3d& p, bool reference) {
    SimulatedLight light;
    light.id = id;
    light.position = p;
    light.reference = reference;
    light.clock_ratio = 1.0 + rng.uniform(-options.max_clock_drift, options.max_clock_drift);
    light.idle_samples = options.max_idle_samples > 0 ? rng.uniform(0, options.max_idle_samples + 1) : 0;
    light.phase = rng.uniform(0.0, static_cast<double>(lights::kPacketSamples + light.idle_samples));
    light.diameter_m = 0.02 / s;
    light.brightness = rng.uniform(0.7, 2.0);
    scene.lights.push_back(light);
    (reference ? scene.references : scene.measured)[id] = p;
  };
  for (int i = 0; i < 7; ++i) add(i + 1, kReferences[i], true);
  for (int i = 0; i < 7; ++i) add(i + 8, kTable72[i], false);
  if (options.distractors) {
    scene.distractors.push_back({DistractorKind::kSteady, {45.2, 84.5, 12.3}, 0.08 / s, 1.4});
    scene.distractors.push_back({DistractorKind::kFlickering, {55.1, 74.0, 16.4}, 0.05 / s, 1.2});
    scene.distractors.push_back({DistractorKind::kHazardBlink, {48.3, 82.0, 11.3}, 0.05 / s, 1.3});
    scene.distractors.push_back({DistractorKind::kMainsBeat, {52.6, 77.2, 18.2}, 0.06 / s, 1.0});
  }
  return scene;
}

survey::CameraPose TunnelViewPose(int view) {
  const cv::Point3d target = view == 0 ? cv::Point3d(50.4, 79.0, 15.0) : cv::Point3d(49.2, 79.0, 15.0);
  const cv::Point3d eye = view == 0 ? cv::Point3d(45.8, 36.2, 12.4) : cv::Point3d(54.3, 36.0, 12.7);
  survey::CameraPose pose;
  pose.R = LookAt(eye, target);
  pose.t = -(pose.R * cv::Vec3d(eye.x, eye.y, eye.z));
  return pose;
}

BurstRenderer::BurstRenderer(const LightScene& scene, const survey::CameraPose& pose,
                             const LightSceneOptions& options, uint64_t view_seed)
    : options_(options), seed_(view_seed) {
  const cv::Size size = scene.camera.size;
  cv::RNG rng(view_seed * 7919 + options.seed);
  // Dim tunnel wall: a smooth random field around the background level, with vignetting.
  cv::Mat coarse(8, 12, CV_32F);
  rng.fill(coarse, cv::RNG::UNIFORM, 0.4, 1.6);
  cv::resize(coarse, background_, size, 0, 0, cv::INTER_CUBIC);
  background_ *= options.background_level;

  const double fx = scene.camera.K(0, 0);
  auto make_footprint = [&](const cv::Point3d& X, double diameter_m, double brightness,
                            LightTruth* truth) -> bool {
    const cv::Vec3d c = pose.R * cv::Vec3d(X.x, X.y, X.z) + pose.t;
    if (c[2] <= 1) return false;
    const cv::Point2d center = survey::ProjectPoint(scene.camera, pose, X);
    const double radius = 0.5 * diameter_m * fx / c[2];
    const int half = static_cast<int>(std::ceil(radius + 4 * options.blur_sigma_px + 2));
    const cv::Point origin(static_cast<int>(std::floor(center.x)) - half,
                           static_cast<int>(std::floor(center.y)) - half);
    const cv::Rect patch(origin, cv::Size(2 * half + 2, 2 * half + 2));
    if ((patch & cv::Rect(cv::Point(0, 0), size)) != patch) return false;
    Footprint fp;
    fp.origin = origin;
    fp.brightness = brightness;
    fp.weight = cv::Mat::zeros(patch.size(), CV_32F);
    constexpr int kSub = 8;  // supersampling of the disc edge
    for (int y = 0; y < patch.height; ++y) {
      for (int x = 0; x < patch.width; ++x) {
        int inside = 0;
        for (int sy = 0; sy < kSub; ++sy) {
          for (int sx = 0; sx < kSub; ++sx) {
            const double px = origin.x + x - 0.5 + (sx + 0.5) / kSub - center.x;
            const double py = origin.y + y - 0.5 + (sy + 0.5) / kSub - center.y;
            inside += px * px + py * py <= radius * radius;
          }
        }
        fp.weight.at<float>(y, x) = static_cast<float>(inside) / (kSub * kSub);
      }
    }
    if (options.blur_sigma_px > 0) {
      cv::GaussianBlur(fp.weight, fp.weight, cv::Size(), options.blur_sigma_px);
    }
    footprints_.push_back(std::move(fp));
    if (truth) {
      truth->pixel = center;
      truth->radius_px = radius;
    }
    return true;
  };

  const int frames = options.frames;
  for (const SimulatedLight& light : scene.lights) {
    LightTruth truth;
    truth.id = light.id;
    if (!make_footprint(light.position, light.diameter_m, light.brightness, &truth)) continue;
    truth_.push_back(truth);
    // On-fraction of the exposure window [s, s + e] in LED samples, s = phase + k * ratio.
    const int needed = static_cast<int>(std::ceil(light.phase + (frames + 1) * light.clock_ratio)) + 2;
    const std::vector<uint8_t> stream =
        *lights::EncodeLightStream(light.id, light.idle_samples, 0, needed);
    auto& on = footprints_.back().on_fraction;
    for (int k = 0; k < frames; ++k) {
      const double start = light.phase + k * light.clock_ratio;
      const double end = start + options.exposure_fraction;
      double lit = 0;
      for (int j = static_cast<int>(std::floor(start)); j < end; ++j) {
        const double overlap = std::min<double>(end, j + 1) - std::max<double>(start, j);
        if (overlap > 0 && stream[j]) lit += overlap;
      }
      on.push_back(static_cast<float>(lit / options.exposure_fraction));
    }
  }
  for (const Distractor& d : scene.distractors) {
    if (!make_footprint(d.position, d.diameter_m, d.brightness, nullptr)) continue;
    auto& on = footprints_.back().on_fraction;
    const double beat_phase = rng.uniform(0.0, 2 * CV_PI);
    const int blink_offset = rng.uniform(0, 12);
    for (int k = 0; k < frames; ++k) {
      switch (d.kind) {
        case DistractorKind::kSteady:
          on.push_back(1.f);
          break;
        case DistractorKind::kFlickering:
          on.push_back(rng.uniform(0, 2) ? static_cast<float>(rng.uniform(0.6, 1.0)) : 0.f);
          break;
        case DistractorKind::kHazardBlink:
          on.push_back((k + blink_offset) % 12 < 6 ? 1.f : 0.f);
          break;
        case DistractorKind::kMainsBeat:
          on.push_back(static_cast<float>(0.5 + 0.5 * std::sin(2 * CV_PI * 0.07 * k + beat_phase)));
          break;
      }
    }
  }
  std::sort(truth_.begin(), truth_.end(),
            [](const LightTruth& a, const LightTruth& b) { return a.id < b.id; });
}

cv::Mat BurstRenderer::RenderFrame(int k) {
  cv::RNG rng(seed_ * 1000003 + static_cast<uint64_t>(k) * 7 + options_.seed);
  cv::Mat image(background_.size(), CV_32F);
  rng.fill(image, cv::RNG::NORMAL, 0.0, options_.read_noise);
  image += background_;
  for (const Footprint& fp : footprints_) {
    const float level = static_cast<float>(255.0 * fp.brightness * fp.on_fraction[k]);
    if (level <= 0) continue;
    cv::Mat roi = image(cv::Rect(fp.origin, fp.weight.size()));
    for (int y = 0; y < roi.rows; ++y) {
      float* dst = roi.ptr<float>(y);
      const float* w = fp.weight.ptr<float>(y);
      for (int x = 0; x < roi.cols; ++x) {
        const float signal = level * w[x];
        if (signal <= 0) continue;
        const double shot = std::sqrt(options_.shot_noise_gain * signal);
        dst[x] += signal + static_cast<float>(rng.gaussian(shot));
      }
    }
  }
  cv::Mat out;
  if (options_.sixteen_bit) {
    image.convertTo(out, CV_16U, 257.0);
  } else {
    image.convertTo(out, CV_8U);
  }
  return out;
}

std::string BurstRenderer::EncodeFrame(int k) {
  const cv::Mat frame = RenderFrame(k);
  std::vector<uchar> bytes;
  if (options_.jpeg_quality > 0 && !options_.sixteen_bit) {
    cv::imencode(".jpg", frame, bytes, {cv::IMWRITE_JPEG_QUALITY, options_.jpeg_quality});
  } else {
    cv::imencode(".png", frame, bytes, {cv::IMWRITE_PNG_COMPRESSION, 1});
  }
  return std::string(bytes.begin(), bytes.end());
}

}  // namespace texfree::testdata
