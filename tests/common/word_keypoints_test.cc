// Tests of WordKeypointExtractor on rendered text pages with ground-truth word
// boxes: keypoints land on words, words get keypoints, and the keypoints are
// stable under uneven light, scale changes and rotation; a blank page gives
// none.
#include "common/word_keypoints.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "common/image_io.h"
#include "common/neighbor_grid.h"
#include "tests/data/camera_view.h"
#include "tests/data/page_renderer.h"

namespace texfree {
namespace {

// Rendered once per seed for the whole binary (rendering is the slow part).
const testdata::RenderedPage &Page(uint64_t seed) {
  static std::map<uint64_t, testdata::RenderedPage> *pages =
      new std::map<uint64_t, testdata::RenderedPage>();
  auto it = pages->find(seed);
  if (it == pages->end()) it = pages->emplace(seed, testdata::RenderTextPage(seed)).first;
  return it->second;
}

cv::Mat Gray(uint64_t seed) { return ToGray(Page(seed).image); }

constexpr uint64_t kSeeds[] = {1, 2};

// Fraction of `reference` points that have a `moved` point within `tolerance`,
// each moved point used once at most (greedy by distance).
double MatchedFraction(const std::vector<cv::Point2f> &reference,
                       const std::vector<cv::Point2f> &moved, double tolerance) {
  if (reference.empty()) return 0;
  NeighborGrid grid(moved);
  std::vector<char> taken(moved.size(), 0);
  std::vector<int> near;
  int matched = 0;
  for (const auto &p : reference) {
    grid.NearestTo(p, 3, -1, &near);
    for (int j : near) {
      if (taken[j]) continue;
      if (cv::norm(moved[j] - p) <= tolerance) {
        taken[j] = 1;
        ++matched;
      }
      break;
    }
  }
  return static_cast<double>(matched) / reference.size();
}

bool Inside(const cv::Rect &box, const cv::Point2f &p, float margin) {
  return p.x >= box.x - margin && p.x <= box.x + box.width + margin && p.y >= box.y - margin &&
         p.y <= box.y + box.height + margin;
}

WordKeypointExtractor Extractor(WordGrouping grouping) {
  WordKeypointOptions o;
  o.grouping = grouping;
  return WordKeypointExtractor(o);
}

TEST(WordKeypointsTest, KeypointsLieOnWordsAndWordsGetKeypoints) {
  for (WordGrouping grouping : {WordGrouping::kLineClosing, WordGrouping::kLetterGraph})
    for (uint64_t seed : kSeeds) {
      const WordKeypointExtractor extractor = Extractor(grouping);
      SCOPED_TRACE("seed " + std::to_string(seed) + " grouping " +
                   std::to_string(static_cast<int>(grouping)));
      const auto &page = Page(seed);
      const WordKeypoints kp = extractor.Extract(Gray(seed));
      ASSERT_GT(kp.points.size(), page.word_boxes.size() / 3);
      EXPECT_GT(kp.char_height, 4);
      EXPECT_LT(kp.char_height, 60);
      EXPECT_NEAR(kp.text_angle_rad, 0, 0.05) << "upright page";

      int on_word = 0;
      for (const auto &p : kp.points) {
        for (const auto &box : page.word_boxes) {
          if (Inside(box, p, 2)) {
            ++on_word;
            break;
          }
        }
      }
      EXPECT_GE(on_word, 0.85 * kp.points.size()) << on_word << "/" << kp.points.size();

      // Coverage. A fair measure must not penalise words merged into one blob
      // (short words, tight spacing, punctuation): their blob has one centroid,
      // usually inside one of the words or in the space between them. So a word
      // box counts as covered when a keypoint lies in it, or in the union box
      // of it and its neighbour on the same line when they are less than one
      // word height apart (the pair became one blob and is counted once).
      const auto &boxes = page.word_boxes;
      int covered = 0;
      for (size_t i = 0; i < boxes.size(); ++i) {
        std::vector<cv::Rect> regions = {boxes[i]};
        for (size_t j = 0; j < boxes.size(); ++j) {
          if (j == i) continue;
          const cv::Rect &a = boxes[i], &b = boxes[j];
          const int overlap_y = std::min(a.y + a.height, b.y + b.height) - std::max(a.y, b.y);
          const int gap_x = std::max(a.x, b.x) - std::min(a.x + a.width, b.x + b.width);
          if (overlap_y > 0.5 * std::min(a.height, b.height) &&
              gap_x < std::min(a.height, b.height))
            regions.push_back(a | b);
        }
        bool hit = false;
        for (const auto &r : regions) {
          for (const auto &p : kp.points) {
            if (Inside(r, p, 2)) {
              hit = true;
              break;
            }
          }
          if (hit) break;
        }
        covered += hit;
      }
      EXPECT_GE(covered, 0.75 * boxes.size()) << covered << "/" << boxes.size();
    }
}

// Wide monospace type, justified (seed 19: DejaVu Sans Mono): its letters stand 0.2-0.5
// text heights apart and its word gaps 1.1-3, most of them past the gap histogram. The
// letter graph must still cut it into words, not letters (it returned 2,056 keypoints for
// 639 words when only gaps within the histogram counted as word gaps).
TEST(WordKeypointsTest, LetterGraphCutsJustifiedMonospaceIntoWords) {
  constexpr uint64_t kMonospaceSeed = 19;
  const auto &page = Page(kMonospaceSeed);
  const WordKeypoints kp = Extractor(WordGrouping::kLetterGraph).Extract(Gray(kMonospaceSeed));
  const size_t words = page.word_boxes.size();
  EXPECT_LE(kp.points.size(), 1.1 * words)
      << kp.points.size() << " keypoints, " << words << " words";
  int once = 0;
  for (const auto &box : page.word_boxes) {
    int inside = 0;
    for (const auto &p : kp.points) inside += Inside(box, p, 1);
    once += inside == 1;
  }
  EXPECT_GE(once, 0.9 * words) << once << " of " << words << " words hold one keypoint";
}

// Two text sizes in one image (a page beside the same page at 40 %): the letter
// graph measures sizes locally, so each half gets the keypoints it gets when
// extracted alone.
TEST(WordKeypointsTest, LetterGraphHandlesTwoTextSizesInOneImage) {
  const cv::Mat big = Gray(1)(cv::Rect(0, 0, 700, 900));
  cv::Mat small_full;
  cv::resize(Gray(2), small_full, cv::Size(), 0.4, 0.4, cv::INTER_AREA);
  const cv::Mat small = small_full(cv::Rect(0, 0, 380, 540));
  cv::Mat both(900, 700 + 380, CV_8UC1, cv::Scalar(235));
  big.copyTo(both(cv::Rect(0, 0, 700, 900)));
  small.copyTo(both(cv::Rect(700, 0, 380, 540)));
  const WordKeypointExtractor extractor = Extractor(WordGrouping::kLetterGraph);
  const WordKeypoints alone_big = extractor.Extract(big);
  const WordKeypoints alone_small = extractor.Extract(small);
  ASSERT_GT(alone_big.points.size(), 40u);
  ASSERT_GT(alone_small.points.size(), 40u);
  const WordKeypoints together = extractor.Extract(both);
  std::vector<cv::Point2f> small_shifted;
  for (const auto &p : alone_small.points) small_shifted.push_back(p + cv::Point2f(700, 0));
  // Keypoints at the cut edges of the crops differ; the bulk must agree.
  EXPECT_GT(MatchedFraction(alone_big.points, together.points, 2.0), 0.8);
  EXPECT_GT(MatchedFraction(small_shifted, together.points, 1.5), 0.7);
  // One global word height (the line closing) sizes the small text wrongly:
  // this is why retrieval falls back to the letter graph.
  const WordKeypointExtractor closing = Extractor(WordGrouping::kLineClosing);
  const WordKeypoints closing_small = closing.Extract(small);
  std::vector<cv::Point2f> closing_shifted;
  for (const auto &p : closing_small.points) closing_shifted.push_back(p + cv::Point2f(700, 0));
  EXPECT_LT(MatchedFraction(closing_shifted, closing.Extract(both).points, 1.5), 0.3);
}

TEST(WordKeypointsTest, StableUnderUnevenLight) {
  const WordKeypointExtractor extractor;
  for (uint64_t seed : kSeeds) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    const cv::Mat gray = Gray(seed);
    const WordKeypoints clean = extractor.Extract(gray);
    // Smooth light: a diagonal ramp times a soft radial falloff, from 0.35
    // to 1.0.
    cv::Mat gain(gray.size(), CV_32F);
    for (int y = 0; y < gray.rows; ++y) {
      for (int x = 0; x < gray.cols; ++x) {
        const double ramp = (x / double(gray.cols) + y / double(gray.rows)) / 2;  // 0..1
        const double dx = x - 0.3 * gray.cols, dy = y - 0.3 * gray.rows;
        const double radial = std::exp(-(dx * dx + dy * dy) / (2.0 * 500 * 500));
        gain.at<float>(y, x) = static_cast<float>(0.35 + 0.65 * (0.5 * (1 - ramp) + 0.5 * radial));
      }
    }
    double lo, hi;
    cv::minMaxLoc(gain, &lo, &hi);
    ASSERT_GE(lo, 0.35 - 1e-6);
    ASSERT_LE(hi, 1.0 + 1e-6);
    ASSERT_LT(lo, 0.45) << "the light must actually be uneven";
    cv::Mat dark;
    gray.convertTo(dark, CV_32F);
    dark = dark.mul(gain);
    dark.convertTo(dark, CV_8U);
    const WordKeypoints shaded = extractor.Extract(dark);
    EXPECT_GE(MatchedFraction(clean.points, shaded.points, 0.3 * clean.char_height), 0.8);
  }
}

TEST(WordKeypointsTest, StableUnderScaleChange) {
  const WordKeypointExtractor extractor;
  for (uint64_t seed : kSeeds) {
    const cv::Mat gray = Gray(seed);
    const WordKeypoints original = extractor.Extract(gray);
    for (double scale : {0.5, 1.6}) {
      SCOPED_TRACE("seed " + std::to_string(seed) + " scale " + std::to_string(scale));
      cv::Mat resized;
      cv::resize(gray, resized, cv::Size(), scale, scale,
                 scale < 1 ? cv::INTER_AREA : cv::INTER_LINEAR);
      const WordKeypoints kp = extractor.Extract(resized);
      EXPECT_NEAR(kp.char_height / scale, original.char_height, 0.25 * original.char_height);
      // Pixel centres: x_original = (x + 0.5) / scale - 0.5.
      std::vector<cv::Point2f> back;
      for (const auto &p : kp.points)
        back.emplace_back(static_cast<float>((p.x + 0.5) / scale - 0.5),
                          static_cast<float>((p.y + 0.5) / scale - 0.5));
      EXPECT_GE(MatchedFraction(original.points, back, 0.35 * original.char_height), 0.7);
    }
  }
}

TEST(WordKeypointsTest, RotationBy90DegreesRotatesKeypoints) {
  const WordKeypointExtractor extractor;
  for (uint64_t seed : kSeeds) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    const cv::Mat gray = Gray(seed);
    const WordKeypoints original = extractor.Extract(gray);
    cv::Mat rotated;
    cv::rotate(gray, rotated, cv::ROTATE_90_CLOCKWISE);
    const WordKeypoints kp = extractor.Extract(rotated);
    EXPECT_NEAR(std::abs(kp.text_angle_rad), CV_PI / 2, 0.05);
    // Clockwise: (x, y) -> (rows - 1 - y, x); back: x = y', y = rows - 1 - x'.
    std::vector<cv::Point2f> back;
    for (const auto &p : kp.points) back.emplace_back(p.y, static_cast<float>(gray.rows - 1) - p.x);
    EXPECT_GE(MatchedFraction(original.points, back, 0.3 * original.char_height), 0.8);
  }
}

// A near-frontal view of a serif page (page 75's body), as a phone held close sees it.
// With one noise and blur draw (render seed 7) the letters touch at this resolution; with
// another (42) they stand 2-4 px apart, wider than the provisional closing bridges, and
// the text measurement once took the tall letters' width (4 px) for the word height (19
// px) and cut the view into a thousand letters. Either way the text must be measured at
// the words' height and cut into about as many keypoints as there are words in view.
TEST(WordKeypointsTest, TextIsMeasuredAlikeWhetherLettersTouchOrStandApart) {
  const auto &page = Page(75);
  for (const double roll : {0.0, 90.0})
    for (const uint64_t render_seed : {7, 42}) {
      SCOPED_TRACE("roll " + std::to_string(roll) + " render seed " + std::to_string(render_seed));
      testdata::CameraViewOptions view;
      view.horizontal_fov_deg = 55.6;
      view.tilt_deg = 4;
      view.tilt_azimuth_deg = 110.5;
      view.roll_deg = roll;
      view.scale = 0.9;
      view.look_at = {350, 735};
      view.blur_sigma = 1.2;
      view.noise_sigma = 3.8;
      view.illumination_gradient = 0.43;
      const testdata::CameraView seen = testdata::RenderCameraView(page.image, view, render_seed);
      // Ground truth: the word boxes wholly in view, and their median height there.
      std::vector<float> heights;
      const cv::Rect frame(0, 0, seen.image.cols, seen.image.rows);
      for (const cv::Rect &box : page.word_boxes) {
        std::vector<cv::Point2f> corners = {box.tl(), cv::Point2f(box.br().x, box.tl().y), box.br(),
                                            cv::Point2f(box.tl().x, box.br().y)};
        cv::perspectiveTransform(corners, corners, cv::Mat(seen.homography));
        const cv::Rect seen_box = cv::boundingRect(corners);
        if ((seen_box & frame) != seen_box) continue;
        heights.push_back(static_cast<float>(box.height * view.scale));
      }
      ASSERT_GT(heights.size(), 40u);
      std::nth_element(heights.begin(), heights.begin() + heights.size() / 2, heights.end());
      const double word_height = heights[heights.size() / 2];

      const WordKeypoints kp = Extractor(WordGrouping::kLetterGraph).Extract(ToGray(seen.image));
      EXPECT_GT(kp.char_height, 0.7 * word_height) << "word height " << word_height;
      EXPECT_LT(kp.char_height, 1.4 * word_height) << "word height " << word_height;
      EXPECT_GT(kp.points.size(), 0.6 * heights.size()) << heights.size() << " words in view";
      EXPECT_LT(kp.points.size(), 1.6 * heights.size()) << heights.size() << " words in view";
    }
}

TEST(WordKeypointsTest, BlankPageGivesAlmostNoKeypoints) {
  const WordKeypointExtractor extractor;
  for (uint64_t seed : kSeeds) {
    const cv::Mat blank = ToGray(testdata::RenderBlankPage(seed));
    EXPECT_LE(extractor.Extract(blank).points.size(), 3u) << "seed " << seed;
  }
  EXPECT_TRUE(extractor.Extract(cv::Mat(200, 300, CV_8UC1, cv::Scalar(255))).points.empty());
}

// InkMask is OpenCV's adaptive mean threshold, pixel for pixel: small and large windows
// (OpenCV sums small ones in 16 bits), fractional offsets, a view's noise and uneven light.
TEST(WordKeypointsTest, InkMaskIsOpenCvsAdaptiveMeanThreshold) {
  const cv::Mat page = Gray(1);
  testdata::CameraViewOptions options;
  options.tilt_deg = 30;
  options.noise_sigma = 4;
  options.illumination_gradient = 0.4;
  const cv::Mat view = ToGray(testdata::RenderCameraView(Page(1).image, options, 3).image);
  for (const cv::Mat &gray : {page(cv::Rect(0, 0, 333, 251)), view}) {
    for (int block : {3, 7, 15, 17, 31, 61, 101}) {
      for (double offset : {0.0, 4.5, 8.0, 20.0}) {
        cv::Mat want;
        cv::adaptiveThreshold(gray, want, 255, cv::ADAPTIVE_THRESH_MEAN_C, cv::THRESH_BINARY_INV,
                              block, offset);
        const cv::Mat got = InkMask(gray, block, offset);
        ASSERT_EQ(got.size(), want.size());
        EXPECT_EQ(cv::countNonZero(got != want), 0) << "block " << block << " offset " << offset;
        EXPECT_GT(cv::countNonZero(got), 0);
      }
    }
  }
}

// A small view of a page's top, a heading over a few lines of body text (as a far camera's
// first rectified crop of a page): the plain median of the blobs measures the body text,
// which is what the page's words are cut by; the area-weighted size, made for whole pages
// under noise, lets the heading's few large words decide.
TEST(WordKeypointsTest, PlainMedianMeasuresTheBodyTextUnderAHeading) {
  const cv::Mat page = Gray(4242);
  const double body = WordKeypointExtractor().Extract(page).char_height;
  ASSERT_GT(body, 0);
  cv::Mat crop;
  cv::resize(page(cv::Rect(0, 0, page.cols, page.cols / 2)), crop, cv::Size(), 0.25, 0.25,
             cv::INTER_AREA);
  WordKeypointOptions plain;
  plain.area_weighted_text_size = false;
  const double measured = WordKeypointExtractor(plain).Extract(crop).char_height;
  const double weighted = WordKeypointExtractor().Extract(crop).char_height;
  std::printf("body %.1f px -> %.1f at 0.25; plain median %.1f, area-weighted %.1f\n", body,
              body * 0.25, measured, weighted);
  EXPECT_NEAR(measured, body * 0.25, 0.35 * body * 0.25);
}

TEST(WordKeypointsTest, OptionsValidate) {
  EXPECT_TRUE(WordKeypointOptions().Validate().ok());
  WordKeypointOptions o;
  o.gap_factor = 0;
  EXPECT_FALSE(o.Validate().ok());
  o = WordKeypointOptions();
  o.threshold_offset = -1;
  EXPECT_FALSE(o.Validate().ok());
  o = WordKeypointOptions();
  o.max_char_height = o.min_char_height;
  EXPECT_FALSE(o.Validate().ok());
  o = WordKeypointOptions();
  o.letter_gap_factor = 0;
  EXPECT_FALSE(o.Validate().ok());
  o = WordKeypointOptions();
  o.max_keypoints = 0;
  EXPECT_FALSE(o.Validate().ok());
  o = WordKeypointOptions();
  o.min_reclosed_word_area_share = o.min_word_area_share - 0.1;
  EXPECT_FALSE(o.Validate().ok());
}

TEST(WordKeypointsTest, MaxKeypointsKeepsTheLargestBlobs) {
  WordKeypointOptions o;
  o.max_keypoints = 25;
  const WordKeypoints kp = WordKeypointExtractor(o).Extract(Gray(1));
  EXPECT_EQ(kp.points.size(), 25u);
}

}  // namespace
}  // namespace texfree
