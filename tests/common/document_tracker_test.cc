// Tests of DocumentTracker on rendered camera sequences with exact ground truth: the pose
// stays within a few pixels from a top view to a strong tilt; on-line learning carries
// LLAH matching further than the top-view index alone; learned entries stay in the
// session (the shared index is untouched, another tracker sees none) and within budget;
// a mirrored page is not drawn; two pages in one view are both followed.
#include "common/document_tracker.h"
#include "common/video_keypoints.h"

#include <gtest/gtest.h>

#include <memory>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "common/llah_retriever.h"
#include "common/word_keypoints.h"
#include "tests/data/camera_sequence.h"
#include "tests/data/camera_view.h"
#include "tests/data/page_renderer.h"

namespace texfree {
namespace {

using testdata::CameraSequenceOptions;

constexpr uint32_t kPageId = 1;

cv::Mat Gray(const cv::Mat& bgr) {
  cv::Mat gray;
  cv::cvtColor(bgr, gray, cv::COLOR_BGR2GRAY);
  return gray;
}

// The registry's index built as DocumentRegistry does: quantiser learned from the first
// page, then the pages added.
class DocumentTrackerTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    page_ = new cv::Mat(testdata::RenderTextPage(4242).image);
    const WordKeypointExtractor extractor;
    const auto reference = extractor.Extract(Gray(*page_));
    LlahOptions llah;
    LlahDescriber sampler(llah, InvariantQuantizer());
    std::vector<float> samples;
    sampler.CollectInvariants(reference.points, &samples);
    auto quantizer = InvariantQuantizer::Learn(samples, llah.k);
    ASSERT_TRUE(quantizer.ok());
    auto retriever = std::make_shared<LlahRetriever>(llah, *quantizer, 18);
    ASSERT_TRUE(retriever->AddDocument({kPageId, reference.points, page_->size(), {}, {}}).ok());
    for (uint32_t i = 0; i < 3; ++i) {
      const cv::Mat other = Gray(testdata::RenderTextPage(500 + i).image);
      ASSERT_TRUE(
          retriever->AddDocument({10 + i, extractor.Extract(other).points, other.size(), {}, {}})
              .ok());
    }
    shared_ = new std::shared_ptr<const LlahRetriever>(retriever);
  }
  static void TearDownTestSuite() {
    delete page_;
    delete shared_;
  }

  struct Step {
    TrackedDocument doc;
    bool found = false;
    double error = 1e9;
  };

  // Runs a tracker over frames; per frame the result for kPageId.
  static std::vector<Step> Run(DocumentTracker& tracker,
                               const std::vector<testdata::CameraView>& views) {
    const WordKeypointExtractor extractor;
    std::vector<Step> steps;
    for (const auto& view : views) {
      const cv::Mat gray = Gray(view.image);
      const auto result = tracker.Track(extractor.Extract(gray), gray.size(), *shared_);
      Step step;
      for (const auto& d : result.documents) {
        if (d.document != kPageId) continue;
        step.doc = d;
        step.found = d.state != TrackState::kLost;
        if (step.found)
          step.error = testdata::MeanHomographyError(d.homography, view.homography, page_->size(),
                                                     gray.size());
      }
      steps.push_back(step);
    }
    return steps;
  }

  // The close orbit of the benchmark, 0 to `end_tilt` degrees.
  static std::vector<testdata::CameraView> Orbit(double end_tilt, double step) {
    CameraSequenceOptions o;
    o.end_tilt_deg = end_tilt;
    o.step_deg = step;
    const auto frames = testdata::MakeCameraSequence(page_->size(), o, 3);
    std::vector<testdata::CameraView> views;
    for (size_t i = 0; i < frames.size(); ++i)
      views.push_back(testdata::RenderSequenceFrame(*page_, frames[i], 3, static_cast<int>(i)));
    return views;
  }

  static const std::vector<testdata::CameraView>& SteepOrbit() {
    static const auto* views = new std::vector<testdata::CameraView>(Orbit(76, 2));
    return *views;
  }

  static cv::Mat* page_;
  static std::shared_ptr<const LlahRetriever>* shared_;
};

cv::Mat* DocumentTrackerTest::page_ = nullptr;
std::shared_ptr<const LlahRetriever>* DocumentTrackerTest::shared_ = nullptr;

TEST_F(DocumentTrackerTest, KeepsThePoseWithinAFewPixelsFromTopViewTo76DegreesTilt) {
  DocumentTracker tracker(TrackerOptions{});
  const auto& views = SteepOrbit();
  const auto steps = Run(tracker, views);
  ASSERT_EQ(steps.size(), views.size());
  EXPECT_EQ(steps[0].doc.state, TrackState::kInitializing) << "found by retrieval";
  EXPECT_EQ(steps[0].doc.method, "retrieval");
  for (size_t i = 0; i < steps.size(); ++i) {
    SCOPED_TRACE(testing::Message() << "frame " << i << ", tilt " << 2 * i << " deg");
    ASSERT_TRUE(steps[i].found);
    EXPECT_LE(steps[i].error, 3.0);
    EXPECT_GE(steps[i].doc.inliers, 12);
    if (i > 0) {
      EXPECT_EQ(steps[i].doc.state, TrackState::kTracking);
    }
  }
  EXPECT_GT(tracker.session_index().learned_entries(), 0u) << "tilted views were learned";
}

// As the server's stream: the tracker's prediction tells the extractor where the page
// will be, and a page seen at a slant is extracted rectified.
TEST_F(DocumentTrackerTest, WithRectifiedExtractionKeepsThePoseTo80DegreesTilt) {
  DocumentTracker tracker(TrackerOptions{});
  VideoKeypointExtractor extractor(WordKeypointOptions{}, VideoKeypointOptions{});
  const std::vector<testdata::CameraView> views = Orbit(80, 2);
  int rectified = 0;
  for (size_t i = 0; i < views.size(); ++i) {
    SCOPED_TRACE(testing::Message() << "tilt " << 2 * i << " deg");
    const cv::Mat gray = Gray(views[i].image);
    const std::vector<PageInView> predicted = tracker.PredictedPages(1);
    if (i > 0) {
      ASSERT_EQ(predicted.size(), 1u);
      EXPECT_EQ(predicted[0].document, kPageId);
      // The last pose moved on by the last motion: a few pixels from the truth.
      EXPECT_LE(testdata::MeanHomographyError(predicted[0].page_to_frame, views[i].homography,
                                              page_->size(), gray.size()),
                12.0);
    }
    VideoFrameInfo info;
    const WordKeypoints keypoints = extractor.Extract(gray, predicted, &info);
    rectified += !info.rectified.empty();
    const auto result = tracker.Track(keypoints, gray.size(), *shared_, info.whole_frame);
    ASSERT_EQ(result.documents.size(), 1u);
    const TrackedDocument& doc = result.documents[0];
    ASSERT_NE(doc.state, TrackState::kLost);
    EXPECT_LE(testdata::MeanHomographyError(doc.homography, views[i].homography, page_->size(),
                                            gray.size()),
              3.0);
  }
  EXPECT_GE(rectified, static_cast<int>(views.size()) / 3) << "the steeper half at least";
  EXPECT_TRUE(tracker.PredictedPages(1).size() == 1u);
  tracker.Reset();
  EXPECT_TRUE(tracker.PredictedPages(1).empty()) << "nothing followed, nothing predicted";
}

TEST_F(DocumentTrackerTest, LearningCarriesLlahMatchingFurtherThanTheTopViewIndex) {
  // Without prediction every pose comes from LLAH, as in the seed's experiment.
  TrackerOptions learn;
  learn.predict = false;
  // The seed's plain LLAH: retrieval's perspective rectification alone carries a top-view
  // index to about 60 degrees, which is not what this test measures.
  learn.retrieval.rectify_perspective = false;
  TrackerOptions plain = learn;
  plain.update_policy = UpdatePolicy::kNever;
  DocumentTracker with(learn), without(plain);
  const auto a = Run(with, SteepOrbit());
  const auto b = Run(without, SteepOrbit());
  auto correct_until = [](const std::vector<Step>& steps) {
    size_t i = 0;
    while (i < steps.size() && steps[i].found && steps[i].error <= 3.0) ++i;
    return i;
  };
  const size_t learned_reach = correct_until(a), plain_reach = correct_until(b);
  EXPECT_GE(learned_reach, plain_reach + 8)
      << "learning should add at least 16 degrees: " << 2 * learned_reach << " vs "
      << 2 * plain_reach;
  EXPECT_GE(2 * learned_reach, 50u);
  EXPECT_EQ(without.session_index().learned_entries(), 0u);
}

TEST_F(DocumentTrackerTest, LearnedEntriesNeverReachTheSharedIndexOrAnotherSession) {
  const size_t shared_entries = (*shared_)->entries();
  TrackerOptions every;
  every.update_policy = UpdatePolicy::kEveryFrame;
  DocumentTracker first(every), second(every);
  const auto& views = SteepOrbit();
  const std::vector<testdata::CameraView> some(views.begin(), views.begin() + 20);
  Run(first, some);
  EXPECT_GT(first.session_index().learned_entries(), 0u);
  EXPECT_EQ((*shared_)->entries(), shared_entries) << "the shared index is read-only";
  EXPECT_EQ(second.session_index().learned_entries(), 0u);
  // The second session starts from the top-view index: on its first frame it learns only
  // what that frame teaches, independent of the first session's history.
  const auto one = Run(second, {views.front()});
  ASSERT_TRUE(one[0].found);
  EXPECT_EQ(second.session_index().learned_entries(), one[0].doc.learned_entries);
  EXPECT_LT(second.session_index().learned_entries(), first.session_index().learned_entries());
}

TEST_F(DocumentTrackerTest, LearnedEntriesStayWithinTheBudget) {
  TrackerOptions options;
  options.update_policy = UpdatePolicy::kEveryFrame;
  options.session.max_learned_entries = 300;
  DocumentTracker tracker(options);
  const auto& views = SteepOrbit();
  const WordKeypointExtractor extractor;
  for (size_t i = 0; i < 16; ++i) {
    const cv::Mat gray = Gray(views[i].image);
    tracker.Track(extractor.Extract(gray), gray.size(), *shared_);
    ASSERT_LE(tracker.session_index().learned_entries(), 300u);
  }
  EXPECT_GT(tracker.session_index().learned_entries(), 100u);
}

TEST_F(DocumentTrackerTest, AMirroredPageIsNotDrawn) {
  DocumentTracker tracker(TrackerOptions{});
  const auto& views = SteepOrbit();
  std::vector<testdata::CameraView> frames(views.begin(), views.begin() + 4);
  testdata::CameraView mirrored = views[4];
  mirrored.image = cv::Mat();  // a buffer of its own: the views are shared between tests
  cv::flip(views[4].image, mirrored.image, 1);
  frames.push_back(mirrored);
  frames.push_back(views[4]);
  const auto steps = Run(tracker, frames);
  for (int i = 0; i < 4; ++i) EXPECT_TRUE(steps[i].found);
  EXPECT_FALSE(steps[4].found) << "a mirror image of the page has no valid pose";
  EXPECT_EQ(steps[4].doc.state, TrackState::kLost);
  EXPECT_TRUE(steps[5].found) << "the page is found again";
  EXPECT_LE(steps[5].error, 3.0);
}

TEST_F(DocumentTrackerTest, FollowsTwoPagesInOneView) {
  // Two registered pages side by side on a desk, seen from above.
  // Registered as id 10; its type size is close to the tracked page's, as two pages of
  // one document would be.
  const cv::Mat other = testdata::RenderTextPage(500).image;
  const int gap = 60;
  cv::Mat desk(page_->rows, page_->cols + gap + other.cols, CV_8UC3, cv::Scalar(90, 110, 140));
  page_->copyTo(desk(cv::Rect(0, 0, page_->cols, page_->rows)));
  other.copyTo(desk(cv::Rect(page_->cols + gap, 0, other.cols, other.rows)));
  testdata::CameraViewOptions o;
  o.scale = 0.3;
  o.tilt_deg = 10;
  o.roll_deg = 4;
  o.image_size = {800, 600};
  o.blur_sigma = 0.5;
  o.noise_sigma = 2;
  o.jpeg_quality = 90;
  DocumentTracker tracker(TrackerOptions{});
  const WordKeypointExtractor extractor;
  for (int frame = 0; frame < 3; ++frame) {
    o.look_at = {desk.cols / 2.0 + 10 * frame, desk.rows / 2.0};
    const auto view = testdata::RenderCameraView(desk, o, 40 + frame);
    const cv::Mat gray = Gray(view.image);
    const auto result = tracker.Track(extractor.Extract(gray), gray.size(), *shared_);
    int found = 0;
    for (const auto& d : result.documents) {
      if (d.state == TrackState::kLost) continue;
      cv::Matx33d offset = cv::Matx33d::eye();
      if (d.document == 10) {
        offset(0, 2) = page_->cols + gap;
      } else {
        ASSERT_EQ(d.document, kPageId);
      }
      const double error = testdata::MeanHomographyError(d.homography, view.homography * offset,
                                                         page_->size(), gray.size());
      EXPECT_LE(error, 3.0) << "page " << d.document << " frame " << frame;
      ++found;
    }
    EXPECT_EQ(found, 2) << "frame " << frame;
  }
}

// While a page is followed, retrieval of further pages runs every retrieval_interval
// frames, at the stream's phase of that cycle (streams started together spread it out).
TEST_F(DocumentTrackerTest, RetrievalRunsOnTheStreamsPhaseOfItsCycle) {
  const auto& views = SteepOrbit();
  ASSERT_GE(views.size(), 24u);
  const WordKeypointExtractor extractor;
  for (int phase : {0, 3, 13}) {
    SCOPED_TRACE(testing::Message() << "phase " << phase);
    TrackerOptions o;
    o.retrieval_interval = 10;
    o.retrieval_phase = phase;
    DocumentTracker tracker(o);
    std::vector<int> retrieved;
    for (int i = 0; i < 24; ++i) {
      const cv::Mat gray = Gray(views[i].image);
      const auto result = tracker.Track(extractor.Extract(gray), gray.size(), *shared_);
      ASSERT_FALSE(result.documents.empty());
      ASSERT_NE(result.documents[0].state, TrackState::kLost) << "frame " << i;
      if (result.retrieved) retrieved.push_back(i);
    }
    // Found on frame 0, then every 10 frames from phase (mod 10) frames earlier.
    const int first = 10 - phase % 10;
    EXPECT_EQ(retrieved, std::vector<int>({0, first, first + 10}));
  }
}

TEST(TrackerOptionsTest, ValidateNamesTheProblem) {
  TrackerOptions o;
  EXPECT_TRUE(o.Validate().ok());
  o.min_inliers = 3;
  EXPECT_NE(o.Validate().message().find("min_inliers"), std::string::npos);
  o = {};
  o.llah_interval = 0;
  EXPECT_NE(o.Validate().message().find("llah_interval"), std::string::npos);
  o = {};
  o.session.max_learned_entries = 50'000'000;
  EXPECT_FALSE(o.Validate().ok());
  o = {};
  o.max_documents = 0;
  EXPECT_NE(o.Validate().message().find("max_documents"), std::string::npos);
  o = {};
  o.retrieval_phase = -2;
  EXPECT_NE(o.Validate().message().find("retrieval_phase"), std::string::npos);
}

TEST(TrackerTest, NothingRegisteredGivesNoDocuments) {
  DocumentTracker tracker(TrackerOptions{});
  WordKeypoints frame;
  frame.points = {{10, 10}, {20, 20}};
  EXPECT_TRUE(tracker.Track(frame, {640, 480}, nullptr).documents.empty());
}

}  // namespace
}  // namespace texfree
