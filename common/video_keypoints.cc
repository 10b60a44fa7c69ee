// VideoKeypointExtractor implementation.
#include "common/video_keypoints.h"

#include "absl/strings/str_cat.h"

namespace texfree {
namespace {

WordKeypointOptions WithHalfResolution(WordKeypointOptions o, double above) {
  o.half_resolution_above_char_height = above;
  return o;
}

}  // namespace

absl::Status VideoKeypointOptions::Validate() const {
  if (measure_every_frames < 1)
    return absl::InvalidArgumentError(
        absl::StrCat("measure_every_frames must be >= 1, got ", measure_every_frames));
  if (!(remeasure_below_ratio >= 0 && remeasure_below_ratio <= 1))
    return absl::InvalidArgumentError(
        absl::StrCat("remeasure_below_ratio must be in [0, 1], got ", remeasure_below_ratio));
  if (!(half_resolution_above_char_height >= 0))
    return absl::InvalidArgumentError(
        absl::StrCat("half_resolution_above_char_height must be >= 0 (0: never), got ",
                     half_resolution_above_char_height));
  return absl::OkStatus();
}

VideoKeypointExtractor::VideoKeypointExtractor(const WordKeypointOptions& keypoints,
                                               VideoKeypointOptions options)
    : options_(options),
      measuring_(keypoints),
      reusing_(WithHalfResolution(keypoints, options.half_resolution_above_char_height)) {}

void VideoKeypointExtractor::Reset() { known_.reset(); }

WordKeypoints VideoKeypointExtractor::Measure(const cv::Mat& gray) {
  WordKeypoints result = measuring_.Extract(gray);
  frames_since_measure_ = 0;
  measured_keypoints_ = result.points.size();
  if (result.char_height > 0)
    known_ = TextGeometry{result.char_height, result.text_angle_rad};
  else
    known_.reset();
  return result;
}

WordKeypoints VideoKeypointExtractor::Extract(const cv::Mat& gray, bool* measured) {
  if (measured) *measured = true;
  if (!known_ || ++frames_since_measure_ >= options_.measure_every_frames) return Measure(gray);
  WordKeypoints result = reusing_.Extract(gray, *known_);
  if (result.points.size() < options_.remeasure_below_ratio * measured_keypoints_)
    return Measure(gray);
  if (measured) *measured = false;
  return result;
}

}  // namespace texfree
