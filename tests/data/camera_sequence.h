// Seeded camera sequences over a page, for tracking tests and benchmarks (seed 3.1.5):
// a camera orbiting from a top view to a strong tilt around the page centre, a camera
// moving along the page, and an optional hand-like occluder lying over half the page.
// Every frame comes with its exact ground truth (CameraView: H, K, R, t).
//
// The frames are what a handheld camera records: the nominal path plus a little seeded
// hand shake (look-at point, roll and tilt jitter), lens blur, sensor noise, uneven light
// and JPEG compression, all from RenderCameraView.
#ifndef TEXFREE_TESTS_DATA_CAMERA_SEQUENCE_H_
#define TEXFREE_TESTS_DATA_CAMERA_SEQUENCE_H_

#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "tests/data/camera_view.h"

namespace texfree::testdata {

struct CameraSequenceOptions {
  enum class Motion {
    kOrbit,  // tilt from start_tilt_deg to end_tilt_deg around the look-at point
    kPan,    // fixed tilt (start_tilt_deg), look-at moving from pan_from to pan_to
  };
  Motion motion = Motion::kOrbit;
  cv::Size image_size{640, 480};
  double horizontal_fov_deg = 60;
  // Image pixels per page pixel at the image centre of a top view; the camera keeps
  // its distance (fx / scale) while orbiting.
  double scale = 0.85;
  double start_tilt_deg = 0;
  double end_tilt_deg = 80;
  double step_deg = 0.5;       // kOrbit: tilt step per frame
  int pan_frames = 120;        // kPan: number of frames
  // Page fractions (0..1) of the look-at point; (0.5, 0.5) is the page centre.
  cv::Point2d look_at{0.5, 0.5};
  cv::Point2d pan_from{0.5, 0.2};
  cv::Point2d pan_to{0.5, 0.8};
  double tilt_azimuth_deg = 90;  // 90: the camera leans towards the page bottom
  double roll_deg = 5;
  // Hand shake: standard deviations of the look-at point (page px), roll and tilt.
  double shake_px = 1.5;
  double shake_deg = 0.3;
  double blur_sigma = 0.7;
  double noise_sigma = 2.0;
  double illumination_gradient = 0.25;
  int jpeg_quality = 85;  // 0 = none
  // The sheet's curl and the lens's distortion, the same in every frame (CameraViewOptions).
  double page_curl = 0;
  double curl_azimuth_deg = 0;
  bool curl_one_sided = false;
  double radial_k1 = 0;
  // Camera shake within the exposure: each frame is smeared by up to this many pixels in a
  // random direction (from a stream of its own: the path is the same with or without).
  double max_motion_blur_px = 0;
};

struct SequenceFrame {
  CameraViewOptions options;  // what RenderCameraView renders
  double nominal_tilt_deg = 0;
};

// The camera path (no pixels yet). Deterministic for (page size, options, seed).
std::vector<SequenceFrame> MakeCameraSequence(const cv::Size& page_size,
                                              const CameraSequenceOptions& options,
                                              uint64_t seed);

// A hand-like occluder (skin tone, fingers, shading) drawn over the page's
// `side` half (0 left, 1 right, 2 top, 3 bottom), as an object lying on the page.
// Returns a copy; `covered` (optional) receives the mask of covered page pixels.
cv::Mat OccludePageHalf(const cv::Mat& page, int side, uint64_t seed,
                        cv::Mat* covered = nullptr);

// Renders frame `index` of a sequence (seed varies per frame).
CameraView RenderSequenceFrame(const cv::Mat& page, const SequenceFrame& frame, uint64_t seed,
                               int index);

}  // namespace texfree::testdata

#endif  // TEXFREE_TESTS_DATA_CAMERA_SEQUENCE_H_
