// Tests of OverlayRenderer: highlights blended inside the mapped quad only,
// outlines at the mapped page corners, text warped onto the page.
#include "client/overlay_renderer.h"

#include <gtest/gtest.h>

#include <opencv2/core.hpp>

namespace texfree::client {
namespace {

const cv::Vec3b kWhite(255, 255, 255);

// Scale 2 and translation (10, 20): registration (x, y) -> (2x + 10, 2y + 20).
const cv::Matx33d kScaleShift(2, 0, 10, 0, 2, 20, 0, 0, 1);

int ChangedPixels(const cv::Mat& image, const cv::Rect& region) {
  int changed = 0;
  for (int y = region.y; y < region.y + region.height; ++y) {
    for (int x = region.x; x < region.x + region.width; ++x) {
      if (image.at<cv::Vec3b>(y, x) != kWhite) ++changed;
    }
  }
  return changed;
}

TEST(OverlayRendererTest, HighlightIsBlendedInsideTheMappedQuadOnly) {
  cv::Mat image(200, 200, CV_8UC3, cv::Scalar::all(255));
  PageAnnotation highlight;
  highlight.kind = AnnotationKind::kHighlight;
  highlight.rect = cv::Rect2d(10, 10, 20, 20);  // -> (30, 40) .. (70, 80)
  highlight.color = Rgba{0, 0, 255, 255};       // blue
  highlight.opacity = 0.5;
  OverlayRenderer renderer;
  renderer.DrawAnnotation(image, kScaleShift, highlight);

  // Inside: white blended half-way to blue (BGR 255, 127/128, 127/128).
  for (const cv::Point& p :
       {cv::Point(50, 60), cv::Point(32, 42), cv::Point(68, 78)}) {
    cv::Vec3b pixel = image.at<cv::Vec3b>(p);
    EXPECT_EQ(pixel[0], 255) << p;
    EXPECT_NEAR(pixel[1], 127.5, 1.0) << p;
    EXPECT_NEAR(pixel[2], 127.5, 1.0) << p;
  }
  // Outside: untouched.
  EXPECT_EQ(ChangedPixels(image, cv::Rect(0, 0, 200, 38)), 0);
  EXPECT_EQ(ChangedPixels(image, cv::Rect(0, 82, 200, 118)), 0);
  EXPECT_EQ(ChangedPixels(image, cv::Rect(0, 0, 28, 200)), 0);
  EXPECT_EQ(ChangedPixels(image, cv::Rect(72, 0, 128, 200)), 0);
}

TEST(OverlayRendererTest, HighlightUnderPerspectiveStaysInsideTheQuad) {
  cv::Mat image(300, 300, CV_8UC3, cv::Scalar::all(255));
  cv::Matx33d h(1.2, 0.1, 30, 0.05, 1.1, 40, 0.0008, 0.0005, 1);
  PageAnnotation highlight;
  highlight.kind = AnnotationKind::kHighlight;
  highlight.rect = cv::Rect2d(20, 30, 100, 60);
  highlight.color = Rgba{255, 255, 0, 255};
  highlight.opacity = 0.4;
  OverlayRenderer().DrawAnnotation(image, h, highlight);
  std::vector<cv::Point2d> centre;
  ASSERT_TRUE(OverlayRenderer::MapPoints(h, {{70, 60}}, &centre));
  cv::Vec3b pixel = image.at<cv::Vec3b>(
      cv::Point(cvRound(centre[0].x), cvRound(centre[0].y)));
  EXPECT_NEAR(pixel[0], 255 * 0.6,
              1.0);  // blue channel reduced: yellow blended
  EXPECT_EQ(pixel[1], 255);
  EXPECT_EQ(pixel[2], 255);
  std::vector<cv::Point2d> outside;
  ASSERT_TRUE(OverlayRenderer::MapPoints(h, {{10, 10}, {130, 100}}, &outside));
  for (const auto& p : outside) {
    EXPECT_EQ(image.at<cv::Vec3b>(cv::Point(cvRound(p.x), cvRound(p.y))),
              kWhite);
  }
}

TEST(OverlayRendererTest, OutlineAtMappedCorners) {
  cv::Mat image(200, 200, CV_8UC3, cv::Scalar::all(255));
  OverlayPage page;
  page.homography = kScaleShift;
  page.page_size =
      cv::Size2d(50, 40);  // corners -> (10,20) (110,20) (110,100) (10,100)
  OverlayRenderer::Options options;
  options.draw_title = false;
  OverlayRenderer renderer(options);
  renderer.DrawPage(image, page, 0);
  cv::Scalar colour = OverlayRenderer::PaletteColor(0);
  cv::Vec3b expected(static_cast<uchar>(colour[0]),
                     static_cast<uchar>(colour[1]),
                     static_cast<uchar>(colour[2]));
  for (const cv::Point& p :
       {cv::Point(10, 20), cv::Point(110, 20), cv::Point(110, 100),
        cv::Point(10, 100), cv::Point(60, 20), cv::Point(110, 60),
        cv::Point(60, 100), cv::Point(10, 60)}) {
    EXPECT_EQ(image.at<cv::Vec3b>(p), expected) << p;
  }
  EXPECT_EQ(image.at<cv::Vec3b>(60, 60), kWhite);  // page interior
  EXPECT_EQ(ChangedPixels(image, cv::Rect(0, 0, 200, 16)), 0);
  EXPECT_EQ(ChangedPixels(image, cv::Rect(115, 0, 85, 200)), 0);
  EXPECT_EQ(ChangedPixels(image, cv::Rect(0, 105, 200, 95)), 0);
}

TEST(OverlayRendererTest, TextIsDrawnAroundTheMappedAnchor) {
  cv::Mat image(300, 400, CV_8UC3, cv::Scalar::all(255));
  PageAnnotation text;
  text.kind = AnnotationKind::kText;
  text.text = "Hello";
  text.position = cv::Point2d(20, 60);  // baseline start -> (50, 140)
  text.font_size_px = 20;               // -> about 40 px high in the image
  text.color = Rgba{255, 0, 0, 255};
  OverlayRenderer renderer;
  renderer.DrawAnnotation(image, kScaleShift, text);
  // Ink above the baseline, to the right of the anchor, and nowhere far away.
  EXPECT_GT(ChangedPixels(image, cv::Rect(45, 90, 200, 55)), 100);
  EXPECT_EQ(ChangedPixels(image, cv::Rect(0, 0, 400, 80)), 0);
  EXPECT_EQ(ChangedPixels(image, cv::Rect(0, 160, 400, 140)), 0);
  EXPECT_EQ(ChangedPixels(image, cv::Rect(0, 0, 40, 300)), 0);
  // Red ink somewhere: a pixel with high R and low G and B.
  bool red = false;
  for (int y = 90; y < 145 && !red; ++y) {
    for (int x = 45; x < 245 && !red; ++x) {
      cv::Vec3b p = image.at<cv::Vec3b>(y, x);
      red = p[2] > 200 && p[1] < 60 && p[0] < 60;
    }
  }
  EXPECT_TRUE(red);
}

TEST(OverlayRendererTest, LinkMediaAndDegenerateHomographiesDoNotCrash) {
  cv::Mat image(240, 320, CV_8UC3, cv::Scalar::all(255));
  PageAnnotation link;
  link.kind = AnnotationKind::kLink;
  link.rect = cv::Rect2d(10, 10, 100, 20);
  link.url = "https://example.org";
  PageAnnotation media;
  media.kind = AnnotationKind::kMedia;
  media.rect = cv::Rect2d(10, 40, 100, 60);
  media.uri = "https://example.org/a.mp4";
  media.mime_type = "video/mp4";
  OverlayPage page;
  page.page_size = cv::Size2d(150, 120);
  page.title = "page";
  page.annotations = {link, media};
  OverlayRenderer renderer;
  renderer.DrawPage(image, page, 1);
  EXPECT_GT(ChangedPixels(image, cv::Rect(0, 0, 320, 240)), 100);

  cv::Mat copy = image.clone();
  page.homography =
      cv::Matx33d(1, 0, 0, 0, 1, 0, 0, 0, -1);  // behind the camera
  renderer.DrawPage(image, page, 0);
  page.homography = cv::Matx33d(0, 0, 0, 0, 0, 0, 0, 0, 0);
  renderer.DrawPage(image, page, 0);
  page.homography = cv::Matx33d(1, 0, 1e9, 0, 1, 1e9, 0, 0, 1);  // far away
  renderer.DrawPage(image, page, 0);
  EXPECT_EQ(cv::norm(image, copy, cv::NORM_INF), 0);
}

}  // namespace
}  // namespace texfree::client
