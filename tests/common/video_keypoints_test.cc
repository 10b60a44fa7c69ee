// Tests of the fast word-keypoint paths used on video (WordKeypointExtractor::Extract with
// known text geometry, half-resolution grouping, VideoKeypointExtractor) against the
// default extraction: the known-geometry path gives exactly the default keypoints, half
// resolution gives keypoints within a small fraction of the text height of them, and the
// video extractor measures the text on schedule and again when the view changes a lot.
#include "common/video_keypoints.h"

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>
#include <vector>

#include "common/neighbor_grid.h"
#include "common/word_keypoints.h"
#include "tests/data/camera_sequence.h"
#include "tests/data/camera_view.h"
#include "tests/data/page_renderer.h"

namespace texfree {
namespace {

cv::Mat Gray(const cv::Mat& bgr) {
  cv::Mat gray;
  cv::cvtColor(bgr, gray, cv::COLOR_BGR2GRAY);
  return gray;
}

// Frames of the benchmark's close orbit (blur, noise, JPEG), every `step` degrees.
const std::vector<cv::Mat>& OrbitFrames() {
  static const auto* frames = [] {
    const cv::Mat page = testdata::RenderTextPage(4242).image;
    testdata::CameraSequenceOptions o;
    o.step_deg = 10;
    const auto path = testdata::MakeCameraSequence(page.size(), o, 5);
    auto* out = new std::vector<cv::Mat>();
    for (size_t i = 0; i < path.size(); ++i)
      out->push_back(
          Gray(testdata::RenderSequenceFrame(page, path[i], 5, static_cast<int>(i)).image));
    return out;
  }();
  return *frames;
}

// Share of `reference` points with a `other` point within `tolerance`.
double MatchedFraction(const std::vector<cv::Point2f>& reference,
                       const std::vector<cv::Point2f>& other, double tolerance) {
  if (reference.empty() || other.empty()) return 0;
  NeighborGrid grid(other);
  std::vector<int> nearest;
  int matched = 0;
  for (const auto& p : reference) {
    grid.NearestTo(p, 1, -1, &nearest);
    matched += !nearest.empty() && cv::norm(other[nearest[0]] - p) <= tolerance;
  }
  return static_cast<double>(matched) / reference.size();
}

TEST(VideoKeypointsTest, KnownGeometryGivesExactlyTheDefaultKeypoints) {
  const WordKeypointExtractor extractor;
  EXPECT_EQ(extractor.options().half_resolution_above_char_height, 0) << "off by default";
  std::vector<cv::Mat> images = OrbitFrames();
  images.push_back(Gray(testdata::RenderTextPage(7).image));  // a whole page, no camera
  for (size_t i = 0; i < images.size(); ++i) {
    SCOPED_TRACE("image " + std::to_string(i));
    const WordKeypoints measured = extractor.Extract(images[i]);
    ASSERT_GT(measured.char_height, 0);
    const WordKeypoints known =
        extractor.Extract(images[i], TextGeometry{measured.char_height, measured.text_angle_rad});
    EXPECT_EQ(known.char_height, measured.char_height);
    EXPECT_EQ(known.text_angle_rad, measured.text_angle_rad);
    ASSERT_EQ(known.points.size(), measured.points.size());
    for (size_t k = 0; k < known.points.size(); ++k)
      ASSERT_EQ(known.points[k], measured.points[k]) << "keypoint " << k;
  }
}

TEST(VideoKeypointsTest, HalfResolutionKeypointsLieOnTheFullResolutionOnes) {
  const WordKeypointExtractor full;
  WordKeypointOptions o;
  o.half_resolution_above_char_height = 12;
  const WordKeypointExtractor half(o);
  int tested = 0;
  for (const cv::Mat& image : OrbitFrames()) {
    const WordKeypoints measured = full.Extract(image);
    if (measured.char_height <= 12) continue;  // small text stays at full resolution
    ++tested;
    SCOPED_TRACE("text height " + std::to_string(measured.char_height));
    const WordKeypoints reduced =
        half.Extract(image, TextGeometry{measured.char_height, measured.text_angle_rad});
    // Word centroids: within a tenth of the text height (1-2 px here), nearly all of them.
    EXPECT_GE(MatchedFraction(measured.points, reduced.points, 0.1 * measured.char_height), 0.9);
    EXPECT_GE(MatchedFraction(reduced.points, measured.points, 0.1 * measured.char_height), 0.9);
  }
  EXPECT_GE(tested, 3) << "the orbit starts with large text";
}

TEST(VideoKeypointsTest, MeasuresOnScheduleAndWhenTheViewChanges) {
  VideoKeypointOptions o;
  o.measure_every_frames = 4;
  VideoKeypointExtractor video(WordKeypointOptions(), o);
  const cv::Mat& frame = OrbitFrames()[3];
  std::vector<bool> measured;
  for (int i = 0; i < 9; ++i) {
    bool m = false;
    const WordKeypoints kp = video.Extract(frame, &m);
    EXPECT_GT(kp.points.size(), 20u);
    measured.push_back(m);
  }
  EXPECT_EQ(measured,
            std::vector<bool>({true, false, false, false, true, false, false, false, true}));
  // The camera comes 3x closer: text measured for the old view finds too few words, so the
  // frame is measured again at once.
  cv::Mat closer;
  cv::resize(frame(cv::Rect(frame.cols / 3, frame.rows / 3, frame.cols / 3, frame.rows / 3)),
             closer, frame.size(), 0, 0, cv::INTER_CUBIC);
  bool m = false;
  const WordKeypoints kp = video.Extract(closer, &m);
  const WordKeypoints fresh = WordKeypointExtractor().Extract(closer);
  EXPECT_TRUE(m);
  EXPECT_EQ(kp.points.size(), fresh.points.size());
  video.Reset();
  video.Extract(frame, &m);
  EXPECT_TRUE(m) << "Reset measures afresh";
}

TEST(VideoKeypointsTest, OptionsValidate) {
  EXPECT_TRUE(VideoKeypointOptions().Validate().ok());
  VideoKeypointOptions o;
  o.measure_every_frames = 0;
  EXPECT_FALSE(o.Validate().ok());
  o = VideoKeypointOptions();
  o.remeasure_below_ratio = 1.5;
  EXPECT_FALSE(o.Validate().ok());
  WordKeypointOptions w;
  w.half_resolution_above_char_height = 3;  // below 2 * min_char_height
  EXPECT_FALSE(w.Validate().ok());
  w.half_resolution_above_char_height = -1;
  EXPECT_FALSE(w.Validate().ok());
}

}  // namespace
}  // namespace texfree
