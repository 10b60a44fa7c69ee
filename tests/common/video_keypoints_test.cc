// Tests of the fast word-keypoint paths used on video (WordKeypointExtractor::Extract with
// known text geometry, half-resolution grouping, VideoKeypointExtractor) against the
// default extraction: the known-geometry path gives exactly the default keypoints, half
// resolution gives keypoints within a small fraction of the text height of them, and the
// video extractor measures the text on schedule and again when the view changes a lot.
#include "common/video_keypoints.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
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

// The frame's own extraction as VideoKeypointExtractor measures a frame (its first text
// size from the plain median of the blobs).
WordKeypoints FrameKeypoints(const cv::Mat& gray) {
  WordKeypointOptions o;
  o.area_weighted_text_size = false;
  return WordKeypointExtractor(o).Extract(gray);
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
  const WordKeypoints fresh = FrameKeypoints(closer);
  EXPECT_TRUE(m);
  EXPECT_EQ(kp.points.size(), fresh.points.size());
  video.Reset();
  video.Extract(frame, &m);
  EXPECT_TRUE(m) << "Reset measures afresh";
}

// A stream's phase moves its measurements earlier in the cycle, so that streams started
// together measure on different frames; the cycle's length stays the same.
TEST(VideoKeypointsTest, ThePhaseShiftsTheMeasuringFrames) {
  VideoKeypointOptions o;
  o.measure_every_frames = 4;
  o.measure_phase = 5;  // taken modulo 4: one frame earlier
  VideoKeypointExtractor video(WordKeypointOptions(), o);
  const cv::Mat& frame = OrbitFrames()[3];
  std::vector<bool> measured;
  for (int i = 0; i < 9; ++i) {
    bool m = false;
    video.Extract(frame, &m);
    measured.push_back(m);
  }
  EXPECT_EQ(measured,
            std::vector<bool>({true, false, false, true, false, false, false, true, false}));
}

// The page of the orbit and its word keypoints (page pixels), cut as the frames are.
struct OrbitPage {
  cv::Mat gray;
  std::vector<cv::Point2f> keypoints;
  cv::Rect2f area;  // around the keypoints
};
const OrbitPage& Page() {
  static const auto* page = [] {
    auto* out = new OrbitPage;
    out->gray = Gray(testdata::RenderTextPage(4242).image);
    out->keypoints = WordKeypointExtractor().Extract(out->gray).points;
    const cv::Rect box = cv::boundingRect(out->keypoints);
    out->area = cv::Rect2f(box.x - 40, box.y - 40, box.width + 80, box.height + 80);
    return out;
  }();
  return *page;
}

// Views of the close orbit with their true homographies, every 10 deg (0 to 80).
const std::vector<testdata::CameraView>& OrbitViews() {
  static const auto* views = [] {
    testdata::CameraSequenceOptions o;
    o.step_deg = 10;
    const auto path = testdata::MakeCameraSequence(Page().gray.size(), o, 5);
    auto* out = new std::vector<testdata::CameraView>();
    for (size_t i = 0; i < path.size(); ++i)
      out->push_back(testdata::RenderSequenceFrame(testdata::RenderTextPage(4242).image, path[i], 5,
                                                   static_cast<int>(i)));
    return out;
  }();
  return *views;
}

// The page's word keypoints where the truth puts them in the view.
std::vector<cv::Point2f> TrueKeypoints(const testdata::CameraView& view) {
  std::vector<cv::Point2f> out;
  for (const auto& p : Page().keypoints) {
    const cv::Vec3d v = view.homography * cv::Vec3d(p.x, p.y, 1);
    if (v[2] <= 0) continue;
    const cv::Point2f q(v[0] / v[2], v[1] / v[2]);
    if (q.x >= 0 && q.y >= 0 && q.x < view.image.cols && q.y < view.image.rows) out.push_back(q);
  }
  return out;
}

PageInView TruePage(const testdata::CameraView& view) {
  PageInView page;
  page.document = 7;
  page.page_to_frame = view.homography;
  page.area = Page().area;
  return page;
}

TEST(VideoKeypointsTest, RectifiedKeypointsLieOnThePageWordsWhereTheFrameSqueezesThem) {
  for (size_t i : {6, 7, 8}) {  // 60, 70, 80 deg of tilt
    SCOPED_TRACE("tilt " + std::to_string(i * 10));
    const auto& view = OrbitViews()[i];
    const cv::Mat gray = Gray(view.image);
    const std::vector<cv::Point2f> truth = TrueKeypoints(view);
    const WordKeypoints plain = FrameKeypoints(gray);
    VideoKeypointExtractor video(WordKeypointOptions{}, VideoKeypointOptions{});
    VideoFrameInfo info;
    const WordKeypoints rectified = video.Extract(gray, {TruePage(view)}, &info);
    ASSERT_EQ(info.rectified.size(), 1u) << "a page seen at a slant is rectified";
    EXPECT_TRUE(info.whole_frame) << "the first frame measures the whole frame";
    const RectifiedPage& report = info.rectified[0];
    EXPECT_EQ(report.document, 7u);
    EXPECT_NEAR(report.char_height, VideoKeypointOptions().rectified_char_height, 2.5);
    EXPECT_GT(report.keypoints, 15);
    // The keypoints that come from the rectified image, mapped back into the frame, lie
    // on the page's words where the truth puts them.
    std::vector<cv::Point2f> from_rectified;
    for (const auto& p : rectified.points)
      if (std::find(plain.points.begin(), plain.points.end(), p) == plain.points.end())
        from_rectified.push_back(p);
    ASSERT_EQ(static_cast<int>(from_rectified.size()), report.keypoints);
    const double on_words = MatchedFraction(from_rectified, truth, 1.5);
    const double plain_on_words = MatchedFraction(plain.points, truth, 1.5);
    std::printf(
        "tilt %zu: rectified %zu keypoints, %.2f on words; frame %zu, %.2f; truth "
        "found %.2f vs %.2f\n",
        i * 10, from_rectified.size(), on_words, plain.points.size(), plain_on_words,
        MatchedFraction(truth, rectified.points, 1.5), MatchedFraction(truth, plain.points, 1.5));
    EXPECT_GE(on_words, 0.6);
    EXPECT_GE(MatchedFraction(truth, rectified.points, 1.5),
              MatchedFraction(truth, plain.points, 1.5))
        << "more of the page's words are found than in the frame alone";
  }
}

// The tracking benchmark's far orbit: the whole page in view (0.32 frame px per page px at
// the centre of a top view), tilted 30-40 deg, the page's title nearest the camera. The
// page's words must be found in every frame, measuring or not, as well as the frame alone
// finds them. (A first measurement of the page taken on its title, 2-3 times its body
// text, once rectified the page at that scale, and between measurements the frame was
// reduced to the few words of that image: the page was lost every other frame.)
TEST(VideoKeypointsTest, AFarSlantedPageKeepsItsWordsInEveryFrame) {
  // The benchmark's path (seed 77, 0.5 deg a frame) and the test's own (seed 5).
  struct Path {
    uint64_t seed;
    double step_deg;
  };
  for (const Path& p : {Path{77, 0.5}, Path{5, 5}}) {
    testdata::CameraSequenceOptions o;
    o.scale = 0.32;
    o.step_deg = p.step_deg;
    const auto path = testdata::MakeCameraSequence(Page().gray.size(), o, p.seed);
    const cv::Mat page_image = testdata::RenderTextPage(4242).image;
    for (double tilt : {30.0, 33.5, 35.0, 37.5, 40.0}) {
      const size_t i = static_cast<size_t>(std::lround(tilt / p.step_deg));
      if (std::abs(i * p.step_deg - tilt) > 1e-9) continue;
      SCOPED_TRACE("seed " + std::to_string(p.seed) + ", tilt " + std::to_string(tilt));
      const auto view =
          testdata::RenderSequenceFrame(page_image, path[i], p.seed, static_cast<int>(i));
      const cv::Mat gray = Gray(view.image);
      const std::vector<cv::Point2f> truth = TrueKeypoints(view);
      ASSERT_GT(truth.size(), 100u);
      const double frame_found = MatchedFraction(truth, FrameKeypoints(gray).points, 1.5);
      VideoKeypointExtractor video(WordKeypointOptions{}, VideoKeypointOptions{});
      for (int frame = 0; frame < 3; ++frame) {
        VideoFrameInfo info;
        const WordKeypoints kp = video.Extract(gray, {TruePage(view)}, &info);
        const double found = MatchedFraction(truth, kp.points, 1.5);
        std::printf(
            "seed %d, tilt %.1f, frame %d: %zu keypoints, %.2f of the page's words (frame alone "
            "%.2f)%s\n",
            static_cast<int>(p.seed), tilt, frame, kp.points.size(), found, frame_found,
            info.rectified.empty() ? "" : ", rectified");
        EXPECT_GE(found, 0.9 * frame_found) << "frame " << frame;
      }
    }
  }
}

TEST(VideoKeypointsTest, APageSeenFromAboveIsNotRectified) {
  const auto& view = OrbitViews()[0];
  const cv::Mat gray = Gray(view.image);
  VideoKeypointExtractor video(WordKeypointOptions{}, VideoKeypointOptions{});
  VideoFrameInfo info;
  const WordKeypoints kp = video.Extract(gray, {TruePage(view)}, &info);
  EXPECT_TRUE(info.rectified.empty());
  EXPECT_TRUE(info.whole_frame);
  EXPECT_EQ(kp.points, FrameKeypoints(gray).points);
}

TEST(VideoKeypointsTest, BetweenMeasurementsOnlyTheSlantedPageIsExtracted) {
  VideoKeypointOptions o;
  o.measure_every_frames = 4;
  VideoKeypointExtractor video(WordKeypointOptions(), o);
  const auto& view = OrbitViews()[7];
  const cv::Mat gray = Gray(view.image);
  const std::vector<cv::Point2f> truth = TrueKeypoints(view);
  cv::Matx33d to_page;
  ASSERT_NE(cv::invert(view.homography, to_page), 0);
  std::vector<bool> whole;
  double whole_found = 0;
  for (int i = 0; i < 9; ++i) {
    VideoFrameInfo info;
    const WordKeypoints kp = video.Extract(gray, {TruePage(view)}, &info);
    whole.push_back(info.whole_frame);
    ASSERT_EQ(info.rectified.size(), 1u);
    const double found = MatchedFraction(truth, kp.points, 1.5);
    if (info.whole_frame) {
      whole_found = found;
      continue;
    }
    EXPECT_GT(kp.char_height, 0) << "the frame's last measured text height";
    EXPECT_GE(found, 0.8 * whole_found) << "the page's words are found as on a whole frame";
    int on_page = 0;
    for (const auto& p : kp.points) {
      const cv::Vec3d v = to_page * cv::Vec3d(p.x, p.y, 1);
      on_page += Page().area.contains(cv::Point2f(v[0] / v[2], v[1] / v[2]));
    }
    EXPECT_GE(on_page, 0.9 * kp.points.size()) << "keypoints of the page only";
  }
  EXPECT_EQ(whole, std::vector<bool>({true, false, false, false, true, false, false, false, true}));
  // No page expected: the whole frame.
  VideoFrameInfo info;
  video.Extract(gray, {}, &info);
  EXPECT_TRUE(info.whole_frame);
  EXPECT_TRUE(info.rectified.empty());
}

TEST(VideoKeypointsTest, AnotherPageSeenFromAboveKeepsTheWholeFrame) {
  const auto& view = OrbitViews()[7];
  const cv::Mat gray = Gray(view.image);
  PageInView flat;  // a second page, seen from above in the frame's lower half
  flat.document = 8;
  flat.page_to_frame = cv::Matx33d(0.3, 0, 100, 0, 0.3, 250, 0, 0, 1);
  flat.area = cv::Rect2f(0, 0, 1000, 600);
  VideoKeypointExtractor video(WordKeypointOptions{}, VideoKeypointOptions{});
  for (int i = 0; i < 4; ++i) {
    VideoFrameInfo info;
    video.Extract(gray, {TruePage(view), flat}, &info);
    ASSERT_EQ(info.rectified.size(), 1u);
    EXPECT_EQ(info.rectified[0].document, 7u);
    EXPECT_TRUE(info.whole_frame) << "the flat page's keypoints come from the frame";
  }
}

TEST(VideoKeypointsTest, OptionsValidate) {
  EXPECT_TRUE(VideoKeypointOptions().Validate().ok());
  VideoKeypointOptions o;
  o.measure_every_frames = 0;
  EXPECT_FALSE(o.Validate().ok());
  o = VideoKeypointOptions();
  o.measure_phase = -1;
  EXPECT_FALSE(o.Validate().ok());
  o = VideoKeypointOptions();
  o.remeasure_below_ratio = 1.5;
  EXPECT_FALSE(o.Validate().ok());
  WordKeypointOptions w;
  w.half_resolution_above_char_height = 3;  // below 2 * min_char_height
  EXPECT_FALSE(w.Validate().ok());
  w.half_resolution_above_char_height = -1;
  EXPECT_FALSE(w.Validate().ok());
  o = VideoKeypointOptions();
  o.rectify_above_perspective = 0.5;
  EXPECT_FALSE(o.Validate().ok());
  o = VideoKeypointOptions();
  o.rectified_char_height = 3;  // below rectified_min_char_height
  EXPECT_FALSE(o.Validate().ok());
  o = VideoKeypointOptions();
  o.max_rectify_upsampling = 0.5;
  EXPECT_FALSE(o.Validate().ok());
}

}  // namespace
}  // namespace texfree
