// Tests of the proto conversions that place a page in an image: the tracking stream's
// ready-to-draw overlays against an exact perspective homography.
#include "server/proto_convert.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "common/planar_pose.h"

namespace texfree::server {
namespace {

// A camera looking at the page at a slant: a true perspective (h31, h32 != 0).
const cv::Matx33d kH(0.8, 0.1, 40, -0.05, 0.7, 30, 1e-4, 2e-4, 1);

cv::Point2d At(const v1::Point2& p) { return {p.x(), p.y()}; }

void ExpectMapped(const v1::Point2& got, const cv::Point2d& page) {
  const cv::Point2d want = ApplyHomography(kH, page);
  EXPECT_NEAR(got.x(), want.x, 1e-9);
  EXPECT_NEAR(got.y(), want.y, 1e-9);
}

std::vector<AnnotationRecord> EveryKind() {
  std::vector<AnnotationRecord> out(4);
  out[0].kind = AnnotationRecord::Kind::kText;
  out[0].text = "see p. 12";
  out[0].position = {120, 300};
  out[0].font_size_px = 24;
  out[0].color = Rgba{10, 20, 30, 255};
  out[1].kind = AnnotationRecord::Kind::kHighlight;
  out[1].rect = {100, 200, 400, 60};
  out[1].color = Rgba{255, 255, 0, 255};
  out[1].opacity = 0.4;
  out[2].kind = AnnotationRecord::Kind::kLink;
  out[2].rect = {50, 500, 200, 40};
  out[2].uri = "https://example.org/a";
  out[3].kind = AnnotationRecord::Kind::kMedia;
  out[3].rect = {300, 600, 320, 240};
  out[3].uri = "file:///clip.mp4";
  return out;
}

TEST(PageOverlaysTest, OutlineAndEveryAnnotationKindArePlacedByTheHomography) {
  google::protobuf::RepeatedPtrField<v1::Overlay> overlays;
  PageOverlaysToProto(kH, cv::Size(1000, 1414), EveryKind(), &overlays);
  ASSERT_EQ(overlays.size(), 5);

  const v1::Overlay& outline = overlays[0];
  EXPECT_EQ(outline.kind(), v1::Overlay::POLYGON);
  ASSERT_EQ(outline.points_size(), 4);
  ExpectMapped(outline.points(0), {0, 0});
  ExpectMapped(outline.points(1), {1000, 0});
  ExpectMapped(outline.points(2), {1000, 1414});
  ExpectMapped(outline.points(3), {0, 1414});

  const v1::Overlay& text = overlays[1];
  EXPECT_EQ(text.kind(), v1::Overlay::TEXT);
  EXPECT_EQ(text.text(), "see p. 12");
  ASSERT_EQ(text.points_size(), 2);
  ExpectMapped(text.points(0), {120, 300});
  ExpectMapped(text.points(1), {144, 300});  // one font size along the baseline
  // The font size follows the page's local scale at the anchor (about 0.7-0.8 here).
  EXPECT_GT(text.font_size_px(), 24 * 0.6);
  EXPECT_LT(text.font_size_px(), 24 * 0.9);
  EXPECT_EQ(text.color().r(), 10u);
  EXPECT_EQ(text.color().b(), 30u);

  const v1::Overlay& highlight = overlays[2];
  EXPECT_EQ(highlight.kind(), v1::Overlay::FILLED_POLYGON);
  EXPECT_DOUBLE_EQ(highlight.opacity(), 0.4);
  ASSERT_EQ(highlight.points_size(), 4);
  ExpectMapped(highlight.points(0), {100, 200});
  ExpectMapped(highlight.points(2), {500, 260});

  EXPECT_EQ(overlays[3].kind(), v1::Overlay::POLYGON);
  EXPECT_EQ(overlays[3].text(), "https://example.org/a");
  ExpectMapped(overlays[3].points(1), {250, 500});
  EXPECT_EQ(overlays[4].kind(), v1::Overlay::POLYGON);
  EXPECT_EQ(overlays[4].text(), "file:///clip.mp4");
  ExpectMapped(overlays[4].points(3), {300, 840});
}

TEST(PageOverlaysTest, WhatLiesBehindTheCameraIsLeftOut) {
  // w = 1 - x / 600: the page's right part (x >= 600) is behind the camera.
  const cv::Matx33d H(1, 0, 0, 0, 1, 0, -1.0 / 600, 0, 1);
  google::protobuf::RepeatedPtrField<v1::Overlay> overlays;
  PageOverlaysToProto(H, cv::Size(1000, 1414), EveryKind(), &overlays);
  // No outline (its right corners are behind), the text, the highlight (x 100-500) and
  // the link (x 50-250) stay; the media rectangle (x 300-620) goes.
  ASSERT_EQ(overlays.size(), 3);
  EXPECT_EQ(overlays[0].kind(), v1::Overlay::TEXT);
  EXPECT_EQ(overlays[1].kind(), v1::Overlay::FILLED_POLYGON);
  EXPECT_EQ(overlays[2].text(), "https://example.org/a");
  for (const auto& o : overlays)
    for (const auto& p : o.points()) EXPECT_TRUE(std::isfinite(At(p).x));
}

}  // namespace
}  // namespace texfree::server
