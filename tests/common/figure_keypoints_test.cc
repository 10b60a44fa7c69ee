// FigureCornerExtractor: a plot's bends, a bar's corners and marker dots found where a
// known perspective puts them, words left alone, options validated.
#include "common/figure_keypoints.h"

#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/imgproc.hpp>
#include <random>

#include "common/planar_pose.h"

namespace texfree {
namespace {

// A 1000 x 700 "page": a polyline with sharp bends, three filled bars on an axis, and a
// row of letter-sized blobs (words) at text height 12.
struct Chart {
  cv::Mat image;
  std::vector<cv::Point2f> bends;        // the polyline's inner vertices
  std::vector<cv::Point2f> bar_corners;  // the bars' top corners
  std::vector<cv::Point2f> markers;      // marker dots on straight stretches
};

Chart DrawChart() {
  Chart c;
  c.image = cv::Mat(700, 1000, CV_8UC1, cv::Scalar(245));
  const std::vector<cv::Point> line{{100, 300}, {220, 120}, {340, 280}, {460, 100},
                                    {580, 260}, {700, 90},  {820, 250}};
  cv::polylines(c.image, line, false, cv::Scalar(30), 3, cv::LINE_AA);
  for (size_t i = 1; i + 1 < line.size(); ++i) c.bends.emplace_back(line[i]);
  // Markers half-way along three segments.
  for (size_t i : {0, 2, 4}) {
    const cv::Point2f m = (cv::Point2f(line[i]) + cv::Point2f(line[i + 1])) * 0.5f;
    cv::circle(c.image, cv::Point(std::lround(m.x), std::lround(m.y)), 7, cv::Scalar(30), -1,
               cv::LINE_AA);
    c.markers.push_back(m);
  }
  cv::line(c.image, {100, 600}, {900, 600}, cv::Scalar(20), 3, cv::LINE_AA);
  const int tops[] = {420, 360, 480};
  for (int b = 0; b < 3; ++b) {
    const int x = 200 + 220 * b;
    cv::rectangle(c.image, cv::Rect(x, tops[b], 80, 600 - tops[b]), cv::Scalar(60), cv::FILLED);
    c.bar_corners.emplace_back(x, tops[b]);
    c.bar_corners.emplace_back(x + 79, tops[b]);
  }
  // Words: 5 x 12 px letters in groups, on two lines.
  for (int row = 0; row < 2; ++row)
    for (int w = 0; w < 8; ++w)
      for (int l = 0; l < 4; ++l)
        cv::rectangle(c.image, cv::Rect(120 + 100 * w + 8 * l, 640 + 24 * row, 6, 12),
                      cv::Scalar(25), cv::FILLED);
  return c;
}

// How many `truth` points (mapped by H) have a detected point within `tol` pixels.
int Found(const std::vector<cv::Point2f> &detected, const std::vector<cv::Point2f> &truth,
          const cv::Matx33d &H, double tol) {
  int found = 0;
  for (const cv::Point2f &t : truth) {
    const cv::Point2d p = ApplyHomography(H, cv::Point2d(t));
    for (const cv::Point2f &d : detected)
      if (std::hypot(d.x - p.x, d.y - p.y) <= tol) {
        ++found;
        break;
      }
  }
  return found;
}

TEST(FigureCornerExtractorTest, FindsBendsBarCornersAndMarkersOnTheFlatPage) {
  const Chart c = DrawChart();
  FigureCornerOptions with_markers;
  with_markers.marker_thickness = 1.6;
  const FigureCorners corners = FigureCornerExtractor(with_markers).Extract(c.image, 12, 0);
  const cv::Matx33d I = cv::Matx33d::eye();
  EXPECT_EQ(Found(corners.points, c.bends, I, 4), static_cast<int>(c.bends.size()));
  EXPECT_EQ(Found(corners.points, c.bar_corners, I, 4), static_cast<int>(c.bar_corners.size()));
  EXPECT_EQ(Found(corners.points, c.markers, I, 3), static_cast<int>(c.markers.size()));
  // Nothing on the words (y >= 630).
  for (const cv::Point2f &p : corners.points) EXPECT_LT(p.y, 630) << p;
  EXPECT_DOUBLE_EQ(corners.char_height, 12);
}

TEST(FigureCornerExtractorTest, CornersFollowAPerspectiveViewBlurredAndNoisy) {
  const Chart c = DrawChart();
  // A tilted view at 0.6 of the page's scale: the page's corners to a quadrilateral.
  const std::vector<cv::Point2f> page{{0, 0}, {1000, 0}, {1000, 700}, {0, 700}};
  const std::vector<cv::Point2f> view{{40, 60}, {600, 20}, {630, 450}, {20, 400}};
  const cv::Matx33d H(cv::getPerspectiveTransform(page, view));
  cv::Mat seen;
  cv::warpPerspective(c.image, seen, cv::Mat(H), cv::Size(640, 480), cv::INTER_AREA,
                      cv::BORDER_CONSTANT, cv::Scalar(200));
  cv::GaussianBlur(seen, seen, cv::Size(), 0.8);
  cv::Mat noise(seen.size(), CV_16S);
  cv::randn(noise, 0, 3);
  seen.convertTo(seen, CV_16S);
  seen += noise;
  seen.convertTo(seen, CV_8U);
  const FigureCorners corners = FigureCornerExtractor().Extract(seen, 7.5, -0.07);
  // Within 0.4 text heights of where the perspective puts them.
  EXPECT_GE(Found(corners.points, c.bends, H, 3), static_cast<int>(c.bends.size()) - 1);
  EXPECT_GE(Found(corners.points, c.bar_corners, H, 2.5),
            static_cast<int>(c.bar_corners.size()) - 1);
  // No corner at the view's border, where the page meets the desk.
  for (const cv::Point2f &p : corners.points) {
    EXPECT_GE(p.x, 2);
    EXPECT_GE(p.y, 2);
  }
}

TEST(FigureCornerExtractorTest, WithoutTextTheStrokesGiveTheHeight) {
  const Chart c = DrawChart();
  cv::Mat plot = c.image(cv::Rect(0, 0, 1000, 620)).clone();
  const FigureCorners corners = FigureCornerExtractor().Extract(plot, 0, 0);
  // 3 px strokes, whose ink measures 5-7 px: within a factor of two of the 12-18 px text
  // that such strokes go with.
  EXPECT_GT(corners.char_height, 8);
  EXPECT_LT(corners.char_height, 36);
  EXPECT_EQ(Found(corners.points, c.bends, cv::Matx33d::eye(), 4),
            static_cast<int>(c.bends.size()));
  // A blank picture has none, and no height.
  const FigureCorners none =
      FigureCornerExtractor().Extract(cv::Mat(480, 640, CV_8UC1, cv::Scalar(230)), 0, 0);
  EXPECT_TRUE(none.points.empty());
  EXPECT_EQ(none.char_height, 0);
}

TEST(FigureCornerExtractorTest, OptionsAreValidated) {
  EXPECT_TRUE(FigureCornerOptions().Validate().ok());
  FigureCornerOptions o;
  o.min_turn_deg = 0;
  EXPECT_FALSE(o.Validate().ok());
  o = {};
  o.window = 1;
  EXPECT_FALSE(o.Validate().ok());
  o = {};
  o.min_text_thickness = 2;
  o.max_text_thickness = 1;
  EXPECT_FALSE(o.Validate().ok());
  o = {};
  o.marker_thickness = 0.5;
  EXPECT_FALSE(o.Validate().ok());
  o.marker_thickness = 0;
  EXPECT_TRUE(o.Validate().ok());
}

}  // namespace
}  // namespace texfree
