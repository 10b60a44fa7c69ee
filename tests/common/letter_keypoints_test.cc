// LetterKeypointExtractor: letters of large type rendered with a real font (DejaVu through
// FreeType), against the letter count of the text and a perspective view of it.
#include "common/letter_keypoints.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <opencv2/freetype.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <string>

#include "common/planar_pose.h"

namespace texfree {
namespace {

constexpr const char *kBoldFont = "/usr/share/fonts/truetype/dejavu/DejaVuSans-Bold.ttf";
constexpr const char *kSerifFont = "/usr/share/fonts/truetype/dejavu/DejaVuSerif.ttf";

struct Line {
  std::string text;
  const char *font;
  int height;  // FreeType pixel height
  cv::Point origin;
};

cv::Mat Typeset(const std::vector<Line> &lines, cv::Size size) {
  cv::Mat page(size, CV_8UC3, cv::Scalar(238, 238, 238));
  for (const Line &l : lines) {
    auto ft = cv::freetype::createFreeType2();
    ft->loadFontData(l.font, 0);
    ft->putText(page, l.text, l.origin, l.height, cv::Scalar(30, 30, 30), -1, cv::LINE_AA, true);
  }
  cv::Mat gray;
  cv::cvtColor(page, gray, cv::COLOR_BGR2GRAY);
  return gray;
}

// Letters without a separate dot or accent: one component each in DejaVu Sans Bold.
const std::vector<Line> kHeading = {
    {"Reader Number Motor", kBoldFont, 56, {40, 90}},
    {"Harbour Stream Vector", kBoldFont, 56, {40, 180}},
};

int Letters(const std::vector<Line> &lines) {
  int n = 0;
  for (const Line &l : lines)
    n += static_cast<int>(
        std::count_if(l.text.begin(), l.text.end(), [](char c) { return c != ' '; }));
  return n;
}

TEST(LetterKeypointExtractorTest, CutsLargeTypeIntoItsLetters) {
  const cv::Mat gray = Typeset(kHeading, {900, 240});
  const LetterKeypoints letters = LetterKeypointExtractor().Extract(gray);
  // 'b', 'g' and the others are one component each; none are joined at this size.
  EXPECT_EQ(static_cast<int>(letters.points.size()), Letters(kHeading));
  // The type size is the letters' box (cap and x-height letters alike): 30-60 px here.
  EXPECT_GT(letters.letter_size, 30);
  EXPECT_LT(letters.letter_size, 60);
}

TEST(LetterKeypointExtractorTest, LettersMoveWithThePageUnderPerspectiveBlurAndNoise) {
  const cv::Mat gray = Typeset(kHeading, {900, 240});
  const LetterKeypointExtractor extractor;
  const LetterKeypoints page = extractor.Extract(gray);
  // A camera 25 degrees off the normal, seeing the heading at 0.7 of its size.
  const std::vector<cv::Point2f> from{{0, 0}, {900, 0}, {900, 240}, {0, 240}};
  const std::vector<cv::Point2f> to{{40, 60}, {610, 20}, {630, 230}, {50, 200}};
  const cv::Matx33d H = cv::getPerspectiveTransform(from, to);
  cv::Mat view;
  cv::warpPerspective(gray, view, cv::Mat(H), {680, 260}, cv::INTER_LINEAR, cv::BORDER_CONSTANT,
                      cv::Scalar(238));
  cv::GaussianBlur(view, view, {0, 0}, 1.0);
  cv::Mat noise(view.size(), CV_16SC1);
  cv::randn(noise, 0, 4);
  view.convertTo(view, CV_16SC1);
  view += noise;
  view.convertTo(view, CV_8UC1);
  const LetterKeypoints seen = extractor.Extract(view);
  int found = 0;
  double worst = 0;
  for (const cv::Point2f &p : page.points) {
    const cv::Point2d q = ApplyHomography(H, cv::Point2d(p.x, p.y));
    double best = 1e9;
    for (const cv::Point2f &s : seen.points)
      best = std::min(best, std::hypot(s.x - q.x, s.y - q.y));
    if (best < 1.5) {
      ++found;
      worst = std::max(worst, best);
    }
  }
  // A letter's centroid is an area's mean: perspective moves it from the projected centroid
  // by well under a pixel at this size.
  EXPECT_GE(found, static_cast<int>(0.9 * page.points.size()))
      << found << " of " << page.points.size();
  EXPECT_LE(seen.points.size(), page.points.size() + 2);  // noise makes no letters
}

TEST(LetterKeypointExtractorTest, SmallTypeIsLeftOutBelowTheTypeSizeAsked) {
  std::vector<Line> lines = kHeading;
  for (int i = 0; i < 4; ++i)
    lines.push_back({"the quick brown fox jumps over the lazy dog and then some more words",
                     kSerifFont,
                     15,
                     {40, 240 + 22 * i}});
  const cv::Mat gray = Typeset(lines, {900, 340});
  const LetterKeypointExtractor extractor;
  const LetterKeypoints all = extractor.Extract(gray);
  const LetterKeypoints large = extractor.Extract(gray, 30);
  EXPECT_EQ(static_cast<int>(large.points.size()), Letters(kHeading));
  for (const cv::Point2f &p : large.points) EXPECT_LT(p.y, 200) << "a body letter at " << p;
  // The body's letters are cut too when no size is asked (most of its 200-odd letters: a few
  // touch at 15 px).
  EXPECT_GT(all.points.size(), large.points.size() + 150);
}

TEST(LetterKeypointExtractorTest, PlainPaperAndTinyImagesHaveNoLetters) {
  const LetterKeypointExtractor extractor;
  cv::Mat paper(480, 640, CV_8UC1, cv::Scalar(230));
  cv::Mat noise(paper.size(), CV_8UC1);
  cv::randn(noise, 0, 3);
  paper += noise;
  EXPECT_TRUE(extractor.Extract(paper).points.empty());
  EXPECT_TRUE(extractor.Extract(cv::Mat(8, 8, CV_8UC1, cv::Scalar(0))).points.empty());
  EXPECT_TRUE(extractor.Extract(cv::Mat()).points.empty());
}

TEST(LetterKeypointExtractorTest, ValidateNamesTheBadOption) {
  LetterKeypointOptions o;
  EXPECT_TRUE(o.Validate().ok());
  o.min_letter_px = 1;
  EXPECT_NE(o.Validate().message().find("min_letter_px"), std::string::npos);
  o = {};
  o.max_letter_share = 0;
  EXPECT_NE(o.Validate().message().find("max_letter_share"), std::string::npos);
  o = {};
  o.min_size_ratio = 1;
  EXPECT_NE(o.Validate().message().find("min_size_ratio"), std::string::npos);
  o = {};
  o.max_keypoints = 0;
  EXPECT_NE(o.Validate().message().find("max_keypoints"), std::string::npos);
}

}  // namespace
}  // namespace texfree
