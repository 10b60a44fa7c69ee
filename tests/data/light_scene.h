// Seeded simulator of blinking-light bursts in the dark (seed ch. 3.2 and 7): a Nikon-D300-like
// camera (4288x2848, 50 mm lens, 5.5 um pixels) on a tripod shoots a burst of frames of LED
// markers 30-50 m away that blink their IDs, each LED on its own clock (drift against the
// camera, phase, idle samples between packets). Frames get lens blur, a short exposure that
// can straddle an LED transition, read and shot noise, a dim tunnel wall, distractor lamps
// (steady, randomly flickering, a regular hazard blinker, a mains beat) and JPEG. Ground truth
// (the projected light centres) is kept beside the frames.
//
// The tunnel scene uses the seed's Table 7.2 coordinates for lights 8-14 (to be measured) and
// seven reference lights 1-7 of our own on the walls and crown around them.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "absl/status/status.h"
#include "common/light_survey.h"
#include "common/planar_pose.h"

namespace texfree::testdata {

struct SimulatedLight {
  uint32_t id = 0;
  cv::Point3d position;   // world, metres
  bool reference = false;  // surveyed: used to pose the views
  double clock_ratio = 1.0;  // camera frame interval / LED sample period
  double phase = 0;          // LED sample position (within the stream) at frame 0
  int idle_samples = 2;      // LED off between packets
  double diameter_m = 0.03;  // diffuser disc facing the camera
  double brightness = 1.5;   // on level as a share of full scale (> 1 saturates the core)
};

enum class DistractorKind {
  kSteady,       // a lamp that stays on
  kFlickering,   // a failing lamp, randomly on or off each frame
  kHazardBlink,  // a regular blinker, 6 frames on, 6 off (header-like)
  kMainsBeat,    // mains flicker aliased by the frame rate: slow sinusoid
};

struct Distractor {
  DistractorKind kind = DistractorKind::kSteady;
  cv::Point3d position;
  double diameter_m = 0.06;
  double brightness = 1.2;
};

struct LightSceneOptions {
  uint64_t seed = 1;
  int frames = 100;
  // Image and focal length scale of the D300 (1 = 4288x2848). Tests use 0.25; the light
  // discs grow by 1/scale so that a light covers as many pixels as at full size.
  double scale = 1.0;
  double max_clock_drift = 0.01;  // |clock_ratio - 1| drawn uniformly up to this
  int max_idle_samples = 4;
  double exposure_fraction = 0.0625;  // 1/100 s exposure over a 0.16 s LED sample
  double blur_sigma_px = 0.9;         // lens + focus
  double read_noise = 1.5;            // 8-bit levels
  double shot_noise_gain = 0.08;      // variance per level of signal
  double background_level = 5;        // dark tunnel wall, 8-bit levels
  int jpeg_quality = 92;              // 0 = PNG (lossless)
  bool sixteen_bit = false;           // 16-bit PNG frames (no JPEG)
  bool distractors = true;

  absl::Status Validate() const;
};

struct LightScene {
  CameraModel camera;  // at options.scale
  std::vector<SimulatedLight> lights;
  std::vector<Distractor> distractors;
  std::map<uint32_t, cv::Point3d> references;  // id -> position of the reference lights
  std::map<uint32_t, cv::Point3d> measured;    // id -> true position of the others
};

// The tunnel: references 1-7, lights 8-14 of Table 7.2, clocks and phases drawn from seed.
LightScene MakeTunnelScene(const LightSceneOptions& options);

// Tripod positions left (0) and right (1) of the tunnel axis, about 43 m from the lights.
survey::CameraPose TunnelViewPose(int view);

struct LightTruth {
  uint32_t id = 0;
  cv::Point2d pixel;  // projected centre (distortion applied)
  double radius_px = 0;
};

// Renders one view's burst frame by frame (8-bit gray, or 16-bit with options.sixteen_bit).
// Deterministic for (scene, pose, options, view_seed). Not thread-safe.
class BurstRenderer {
 public:
  BurstRenderer(const LightScene& scene, const survey::CameraPose& pose,
                const LightSceneOptions& options, uint64_t view_seed);

  cv::Mat RenderFrame(int k);
  // JPEG (options.jpeg_quality > 0 and 8-bit) or PNG bytes of frame k.
  std::string EncodeFrame(int k);
  // Lights inside the image, in id order.
  const std::vector<LightTruth>& truth() const { return truth_; }

 private:
  struct Footprint {
    cv::Point origin;  // top-left pixel of the patch
    cv::Mat weight;    // CV_32F, 1 = fully covered pixel after blur
    std::vector<float> on_fraction;  // per frame, 0..1
    double brightness = 1;
  };
  LightSceneOptions options_;
  cv::Mat background_;  // CV_32F, 8-bit scale
  std::vector<Footprint> footprints_;
  std::vector<LightTruth> truth_;
  uint64_t seed_;
};

}  // namespace texfree::testdata
