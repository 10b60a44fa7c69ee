// VideoKeypointExtractor: word keypoints of consecutive frames of one video. The text's
// size and direction change little from one frame to the next, so they are measured
// (WordKeypointExtractor::Extract, two thresholding passes) only now and then, and the
// frames in between reuse the measurement (one pass, Extract with known geometry, about
// 4x cheaper). Large text is grouped at half resolution.
#pragma once

#include <opencv2/core.hpp>
#include <optional>

#include "absl/status/status.h"
#include "common/word_keypoints.h"

namespace texfree {

struct VideoKeypointOptions {
  // The text is measured on one frame in this many (1: every frame, as a still image).
  int measure_every_frames = 8;
  // A frame that reuses the measurement and finds fewer than this share of the keypoints
  // of the last measured frame is extracted again with a fresh measurement (the camera
  // came much closer or moved away fast).
  double remeasure_below_ratio = 0.6;
  // Text taller than this many pixels is grouped into words at half resolution (see
  // WordKeypointOptions::half_resolution_above_char_height); 0: never.
  double half_resolution_above_char_height = 12;

  absl::Status Validate() const;
};

// Not thread-safe: one per video stream, fed its frames in order.
class VideoKeypointExtractor {
 public:
  // `keypoints`: the options the pages were registered with.
  VideoKeypointExtractor(const WordKeypointOptions& keypoints, VideoKeypointOptions options);

  // gray: CV_8UC1. `measured` (optional) tells whether the text was measured on this frame.
  WordKeypoints Extract(const cv::Mat& gray, bool* measured = nullptr);

  // The next frame measures the text afresh (e.g. after a cut).
  void Reset();

 private:
  WordKeypoints Measure(const cv::Mat& gray);

  const VideoKeypointOptions options_;
  WordKeypointExtractor measuring_;  // the registration's options
  WordKeypointExtractor reusing_;    // the same, with half resolution for large text
  std::optional<TextGeometry> known_;
  size_t measured_keypoints_ = 0;
  int frames_since_measure_ = 0;
};

}  // namespace texfree
