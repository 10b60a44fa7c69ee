// Unit tests of the synthetic data generators: determinism, word boxes,
// layout variety, and the exactness of the camera views' ground truth.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <random>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "tests/data/camera_view.h"
#include "tests/data/page_renderer.h"

namespace texfree::testdata {
namespace {

bool SameBytes(const cv::Mat &a, const cv::Mat &b) {
  if (a.size() != b.size() || a.type() != b.type()) return false;
  cv::Mat diff;
  cv::absdiff(a, b, diff);
  return cv::countNonZero(diff.reshape(1)) == 0;
}

cv::Point2d Apply(const cv::Matx33d &h, const cv::Point2d &p) {
  const cv::Vec3d q = h * cv::Vec3d(p.x, p.y, 1);
  return {q[0] / q[2], q[1] / q[2]};
}

TEST(PageRendererTest, SameSeedGivesIdenticalBytes) {
  const RenderedPage a = RenderTextPage(42);
  const RenderedPage b = RenderTextPage(42);
  ASSERT_EQ(a.image.type(), CV_8UC3);
  EXPECT_EQ(a.image.size(), cv::Size(1000, 1414));
  EXPECT_TRUE(SameBytes(a.image, b.image));
  EXPECT_EQ(a.word_boxes, b.word_boxes);
  EXPECT_EQ(a.seed, 42u);
  // A fresh thread (empty font and word caches) gives the same bytes too.
  RenderedPage c;
  std::thread([&c] { c = RenderTextPage(42); }).join();
  EXPECT_TRUE(SameBytes(a.image, c.image));
  EXPECT_EQ(a.word_boxes, c.word_boxes);
  // Rendering other pages in between (warm caches) changes nothing.
  RenderTextPage(7);
  RenderTextPage(8, PageOptions{1000, 1414, true});
  EXPECT_TRUE(SameBytes(a.image, RenderTextPage(42).image));
}

TEST(PageRendererTest, DifferentSeedGivesDifferentPage) {
  const RenderedPage a = RenderTextPage(1);
  const RenderedPage b = RenderTextPage(2);
  EXPECT_FALSE(SameBytes(a.image, b.image));
  EXPECT_NE(a.word_boxes, b.word_boxes);
}

TEST(PageRendererTest, GrayPagesAreGrayAndColorPagesHaveColor) {
  const RenderedPage gray = RenderTextPage(5);
  std::vector<cv::Mat> ch;
  cv::split(gray.image, ch);
  EXPECT_TRUE(SameBytes(ch[0], ch[1]));
  EXPECT_TRUE(SameBytes(ch[1], ch[2]));
  int colourful = 0;
  for (uint64_t seed = 0; seed < 10; ++seed) {
    PageOptions options;
    options.color = true;
    cv::split(RenderTextPage(seed, options).image, ch);
    if (!SameBytes(ch[0], ch[2])) ++colourful;
  }
  EXPECT_GE(colourful, 8);
}

// Every word box lies inside the page, holds dark ink, and boxes barely
// overlap: the ground truth matches what was drawn.
void ExpectWordBoxesHoldInk(const RenderedPage &page) {
  const uint64_t seed = page.seed;
  const cv::Rect frame(0, 0, page.image.cols, page.image.rows);
  ASSERT_GE(page.word_boxes.size(), 40u) << "seed " << seed;
  cv::Mat gray;
  cv::cvtColor(page.image, gray, cv::COLOR_BGR2GRAY);
  double paper = 0;
  {
    std::vector<uint8_t> v(gray.begin<uint8_t>(), gray.end<uint8_t>());
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    paper = v[v.size() / 2];
  }
  int overlapping = 0;
  for (size_t i = 0; i < page.word_boxes.size(); ++i) {
    const cv::Rect &b = page.word_boxes[i];
    ASSERT_GT(b.area(), 0);
    ASSERT_EQ(b & frame, b) << "seed " << seed;
    double min_value = 255;
    cv::minMaxLoc(gray(b), &min_value);
    EXPECT_LT(min_value, paper - 80) << "seed " << seed << " box " << i;
    for (size_t j = i + 1; j < page.word_boxes.size(); ++j) {
      const cv::Rect &o = page.word_boxes[j];
      const int inter = (b & o).area();
      if (inter > 0.2 * std::min(b.area(), o.area())) ++overlapping;
    }
  }
  EXPECT_LE(overlapping, static_cast<int>(page.word_boxes.size()) / 100 + 1) << "seed " << seed;
}

int MedianBoxHeight(const RenderedPage &page) {
  std::vector<int> heights;
  for (const auto &b : page.word_boxes) heights.push_back(b.height);
  std::nth_element(heights.begin(), heights.begin() + heights.size() / 2, heights.end());
  return heights[heights.size() / 2];
}

TEST(PageRendererTest, WordBoxesAreInsideThePageHoldInkAndBarelyOverlap) {
  for (uint64_t seed = 100; seed < 120; ++seed) {
    ExpectWordBoxesHoldInk(RenderTextPage(seed));
  }
}

TEST(PageRendererTest, FontSetNamesRoundTripAndUnknownNamesAreRejected) {
  for (FontSet set : {FontSet::kDejaVu, FontSet::kLiberation, FontSet::kFreeFont,
                      FontSet::kLatinModern, FontSet::kAll}) {
    const auto parsed = ParseFontSet(FontSetName(set));
    ASSERT_TRUE(parsed.ok()) << FontSetName(set);
    EXPECT_EQ(*parsed, set);
  }
  const auto unknown = ParseFontSet("times");
  ASSERT_FALSE(unknown.ok());
  EXPECT_EQ(unknown.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(unknown.status().message().find("liberation"), std::string::npos);
  EXPECT_EQ(PageOptions().fonts, FontSet::kDejaVu);
  // A command line's value: parsed, and its fonts present (install-deps.sh installs them).
  EXPECT_EQ(AvailableFontSet("times").status().code(), absl::StatusCode::kInvalidArgument);
  const auto liberation = AvailableFontSet("liberation");
  ASSERT_TRUE(liberation.ok()) << liberation.status();
  EXPECT_EQ(*liberation, FontSet::kLiberation);
}

// The held-out font sets (never used to tune the extractor) typeset real
// text: the same seed gives the same kind of page (sizes) in other glyphs,
// with ground-truth boxes as consistent as DejaVu's.
TEST(PageRendererTest, HeldOutFontSetsRenderTextWithConsistentWordBoxes) {
  for (FontSet set : {FontSet::kLiberation, FontSet::kFreeFont, FontSet::kLatinModern}) {
    ASSERT_TRUE(CheckFontSet(set).ok()) << CheckFontSet(set);
    PageOptions options;
    options.fonts = set;
    for (uint64_t seed = 100; seed < 110; ++seed) {
      SCOPED_TRACE(std::string(FontSetName(set)) + " seed " + std::to_string(seed));
      const RenderedPage page = RenderTextPage(seed, options);
      ExpectWordBoxesHoldInk(page);
      const RenderedPage dejavu = RenderTextPage(seed);
      EXPECT_FALSE(SameBytes(page.image, dejavu.image));
      // Same body size from the seed: word heights within a third of
      // DejaVu's (the fonts' x-heights and ascenders differ a little).
      const int h = MedianBoxHeight(page), ref = MedianBoxHeight(dejavu);
      EXPECT_LT(std::abs(h - ref), ref / 3 + 2) << h << " vs " << ref;
      // Still deterministic.
      EXPECT_TRUE(SameBytes(page.image, RenderTextPage(seed, options).image));
    }
  }
}

TEST(PageRendererTest, AllFontSetsPicksEverySetFromTheSeed) {
  PageOptions all, liberation, freefont;
  all.fonts = FontSet::kAll;
  liberation.fonts = FontSet::kLiberation;
  freefont.fonts = FontSet::kFreeFont;
  int counts[3] = {0, 0, 0};
  for (uint64_t seed = 0; seed < 12; ++seed) {
    const cv::Mat page = RenderTextPage(seed, all).image;
    const bool d = SameBytes(page, RenderTextPage(seed).image);
    const bool l = SameBytes(page, RenderTextPage(seed, liberation).image);
    const bool f = SameBytes(page, RenderTextPage(seed, freefont).image);
    ASSERT_EQ(d + l + f, 1) << "seed " << seed;
    ++counts[d ? 0 : (l ? 1 : 2)];
  }
  EXPECT_GT(counts[0], 0);
  EXPECT_GT(counts[1], 0);
  EXPECT_GT(counts[2], 0);
}

TEST(PageRendererTest, LayoutsVaryBetweenSeeds) {
  std::set<int> word_heights, word_counts, left_edges;
  for (uint64_t seed = 0; seed < 30; ++seed) {
    const RenderedPage page = RenderTextPage(seed);
    std::vector<int> heights, lefts;
    for (const auto &b : page.word_boxes) {
      heights.push_back(b.height);
      lefts.push_back(b.x);
    }
    std::nth_element(heights.begin(), heights.begin() + heights.size() / 2,
                     heights.end());
    word_heights.insert(heights[heights.size() / 2]);
    word_counts.insert(static_cast<int>(page.word_boxes.size()) / 50);
    left_edges.insert(*std::min_element(lefts.begin(), lefts.end()) / 10);
  }
  EXPECT_GE(word_heights.size(), 6u);  // font sizes vary
  EXPECT_GE(word_counts.size(), 5u);   // density varies
  EXPECT_GE(left_edges.size(), 4u);    // margins vary
}

TEST(PageRendererTest, OtherSizesWork) {
  PageOptions options;
  options.width = 600;
  options.height = 800;
  const RenderedPage page = RenderTextPage(3, options);
  EXPECT_EQ(page.image.size(), cv::Size(600, 800));
  EXPECT_GT(page.word_boxes.size(), 20u);
}

TEST(PageRendererTest, BlankPageHasNoInk) {
  const cv::Mat a = RenderBlankPage(9);
  EXPECT_EQ(a.type(), CV_8UC3);
  EXPECT_EQ(a.size(), cv::Size(1000, 1414));
  double lo = 0, hi = 0;
  cv::minMaxLoc(a.reshape(1), &lo, &hi);
  EXPECT_GT(lo, 200);
  EXPECT_GT(hi - lo, 0);  // faint texture, not a flat image
  EXPECT_TRUE(SameBytes(a, RenderBlankPage(9)));
}

// A white page with black dots, for checking where a view puts page points.
cv::Mat DotPage(std::vector<cv::Point2d> *dots) {
  cv::Mat page(1414, 1000, CV_8UC3, cv::Scalar::all(255));
  for (int y = 250; y <= 1150; y += 150) {
    for (int x = 250; x <= 750; x += 125) {
      dots->emplace_back(x, y);
      cv::circle(page, cv::Point(x, y), 4, cv::Scalar::all(0), -1, cv::LINE_8);
    }
  }
  return page;
}

// Ink (255 - gray) moments over the (2 half + 1)^2 window around `q`: total weight,
// centroid and covariance.
struct InkMoments {
  double weight = 0;
  cv::Point2d mean;
  double cxx = 0, cyy = 0, cxy = 0;
};
InkMoments InkAround(const cv::Mat &gray, const cv::Point2d &q, int half) {
  double sw = 0, sx = 0, sy = 0, sxx = 0, syy = 0, sxy = 0;
  for (int y = static_cast<int>(q.y) - half; y <= static_cast<int>(q.y) + half; ++y) {
    for (int x = static_cast<int>(q.x) - half; x <= static_cast<int>(q.x) + half; ++x) {
      const double w = 255.0 - gray.at<uint8_t>(y, x);
      sw += w;
      sx += w * x;
      sy += w * y;
      sxx += w * x * x;
      syy += w * y * y;
      sxy += w * x * y;
    }
  }
  InkMoments m;
  m.weight = sw;
  if (sw <= 0) return m;
  m.mean = {sx / sw, sy / sw};
  m.cxx = sxx / sw - m.mean.x * m.mean.x;
  m.cyy = syy / sw - m.mean.y * m.mean.y;
  m.cxy = sxy / sw - m.mean.x * m.mean.y;
  return m;
}

// Ink-weighted centroid of the 25 x 25 window around `q` in `gray`; false when
// the window leaves the image or holds no dot.
bool DotCentroid(const cv::Mat &gray, const cv::Point2d &q, cv::Point2d *c) {
  if (q.x < 15 || q.y < 15 || q.x > gray.cols - 16 || q.y > gray.rows - 16) return false;
  const InkMoments m = InkAround(gray, q, 12);
  if (m.weight <= 255) return false;
  *c = m.mean;
  return true;
}

// Each dot must appear at H * p.
TEST(CameraViewTest, HomographyMapsPagePointsToWhereTheyAppear) {
  std::vector<cv::Point2d> dots;
  const cv::Mat page = DotPage(&dots);
  const struct {
    double tilt, azimuth, roll, scale;
  } poses[] = {{0, 0, 0, 1.0},
               {30, 20, 15, 0.8},
               {55, -120, 170, 1.2},
               {45, 75, -60, 0.6}};
  for (const auto &pose : poses) {
    CameraViewOptions options;
    options.tilt_deg = pose.tilt;
    options.tilt_azimuth_deg = pose.azimuth;
    options.roll_deg = pose.roll;
    options.scale = pose.scale;
    options.background = cv::Scalar::all(255);
    const CameraView view = RenderCameraView(page, options, 11);
    cv::Mat gray;
    cv::cvtColor(view.image, gray, cv::COLOR_BGR2GRAY);
    int checked = 0;
    for (const auto &dot : dots) {
      const cv::Point2d q = Apply(view.homography, dot);
      // With a flat page and an ideal lens the true projection is H.
      EXPECT_LT(cv::norm(ProjectPagePoint(view, options, page.size(), dot) - q), 1e-6);
      cv::Point2d c;
      if (!DotCentroid(gray, q, &c)) continue;
      EXPECT_NEAR(c.x, q.x, 1.0) << "tilt " << pose.tilt;
      EXPECT_NEAR(c.y, q.y, 1.0) << "tilt " << pose.tilt;
      ++checked;
    }
    EXPECT_GE(checked, 6) << "tilt " << pose.tilt;
  }
}

// A curled sheet through a distorting lens: each dot appears where
// ProjectPagePoint puts it, within a pixel, while the flat page's homography
// misses some dots by several pixels (the bend and the lens are really there).
TEST(CameraViewTest, CurledPageThroughADistortingLensPutsDotsWhereProjected) {
  std::vector<cv::Point2d> dots;
  const cv::Mat page = DotPage(&dots);
  const struct {
    double curl, curl_azimuth;
    bool one_sided;
    double k1, tilt, azimuth, scale;
  } cases[] = {{0.08, 0, false, -0.15, 25, 40, 0.5},
               {0.10, 90, true, 0.0, 35, -100, 0.45},
               {0.0, 0, false, -0.25, 20, 160, 0.5},
               {0.06, 30, true, 0.12, 10, 0, 0.55}};
  for (const auto &k : cases) {
    CameraViewOptions options;
    options.page_curl = k.curl;
    options.curl_azimuth_deg = k.curl_azimuth;
    options.curl_one_sided = k.one_sided;
    options.radial_k1 = k.k1;
    options.tilt_deg = k.tilt;
    options.tilt_azimuth_deg = k.azimuth;
    options.roll_deg = 20;
    options.scale = k.scale;
    options.background = cv::Scalar::all(255);
    const CameraView view = RenderCameraView(page, options, 11);
    cv::Mat gray;
    cv::cvtColor(view.image, gray, cv::COLOR_BGR2GRAY);
    int checked = 0;
    double worst_homography_px = 0;
    for (const auto &dot : dots) {
      const cv::Point2d q = ProjectPagePoint(view, options, page.size(), dot);
      cv::Point2d c;
      if (!DotCentroid(gray, q, &c)) continue;
      EXPECT_NEAR(c.x, q.x, 1.0) << "curl " << k.curl << " k1 " << k.k1;
      EXPECT_NEAR(c.y, q.y, 1.0) << "curl " << k.curl << " k1 " << k.k1;
      worst_homography_px =
          std::max(worst_homography_px, cv::norm(Apply(view.homography, dot) - q));
      ++checked;
    }
    EXPECT_GE(checked, 20) << "curl " << k.curl << " k1 " << k.k1;
    EXPECT_GT(worst_homography_px, 3.0) << "curl " << k.curl << " k1 " << k.k1;
    // The error measure against the truth is zero for the truth's own
    // projection only where it is a homography: the flat homography scores
    // its miss.
    EXPECT_GT(MeanProjectionError(view.homography, view, options, page.size()), 1.0);
  }
}

// Camera shake smears a dot into a streak of the asked length along the asked direction
// (the ink's second moments), and leaves it where it was (the ink's centroid).
TEST(CameraViewTest, MotionBlurSmearsAlongItsDirection) {
  cv::Mat page(1414, 1000, CV_8UC3, cv::Scalar::all(255));
  cv::circle(page, cv::Point(500, 707), 2, cv::Scalar::all(0), -1, cv::LINE_8);
  CameraViewOptions options;
  options.background = cv::Scalar::all(255);
  for (const double angle : {0.0, 30.0, 115.0}) {
    options.motion_blur_px = 12;
    options.motion_blur_angle_deg = angle;
    const CameraView view = RenderCameraView(page, options, 3);
    cv::Mat gray;
    cv::cvtColor(view.image, gray, cv::COLOR_BGR2GRAY);
    const cv::Point2d q = Apply(view.homography, {500, 707});
    const InkMoments m = InkAround(gray, q, 15);
    ASSERT_GT(m.weight, 255);
    EXPECT_NEAR(m.mean.x, q.x, 0.5);
    EXPECT_NEAR(m.mean.y, q.y, 0.5);
    const double cxx = m.cxx, cyy = m.cyy, cxy = m.cxy;
    // Principal axis and its spread: a uniform smear of length L has variance L^2 / 12.
    const double along = 0.5 * (cxx + cyy + std::hypot(cxx - cyy, 2 * cxy));
    const double across = 0.5 * (cxx + cyy - std::hypot(cxx - cyy, 2 * cxy));
    double axis = 0.5 * std::atan2(2 * cxy, cxx - cyy) * 180 / CV_PI;
    if (axis < 0) axis += 180;
    EXPECT_NEAR(axis, angle, 3.0);
    EXPECT_NEAR(std::sqrt(12 * (along - across)), 12.0, 1.5);
  }
}

TEST(CameraViewTest, PageCornersMapToThePageOutline) {
  cv::Mat page(600, 400, CV_8UC3, cv::Scalar::all(250));
  CameraViewOptions options;
  options.tilt_deg = 35;
  options.tilt_azimuth_deg = 50;
  options.roll_deg = 25;
  options.scale = 0.45;
  options.background = cv::Scalar::all(20);
  const CameraView view = RenderCameraView(page, options, 5);
  cv::Mat gray;
  cv::cvtColor(view.image, gray, cv::COLOR_BGR2GRAY);
  const cv::Point2d centre = Apply(view.homography, {199.5, 299.5});
  const cv::Point2d corners[] = {
      {-0.5, -0.5}, {399.5, -0.5}, {399.5, 599.5}, {-0.5, 599.5}};
  for (const auto &c : corners) {
    const cv::Point2d q = Apply(view.homography, c);
    ASSERT_TRUE(cv::Rect(5, 5, gray.cols - 10, gray.rows - 10).contains(q))
        << q;
    const cv::Point2d d = (centre - q) / cv::norm(centre - q);
    const cv::Point2d in = q + 3 * d, out = q - 3 * d;
    EXPECT_GT(gray.at<uint8_t>(cvRound(in.y), cvRound(in.x)), 200) << q;
    EXPECT_LT(gray.at<uint8_t>(cvRound(out.y), cvRound(out.x)), 60) << q;
  }
}

// Close and tilted so that the page origin (a corner) is behind the camera: the
// page must still be drawn around the looked-at point (it was not, when h22 < 0
// flipped w).
TEST(CameraViewTest, PageOriginBehindTheCameraStillRendersThePage) {
  cv::Mat page(1414, 1000, CV_8UC3, cv::Scalar::all(240));
  CameraViewOptions options;
  options.tilt_deg = 38;
  options.tilt_azimuth_deg = 55;  // the origin corner falls behind the camera
  options.scale = 1.3;
  options.look_at = {700, 1000};
  options.background = cv::Scalar::all(30);
  const CameraView view = RenderCameraView(page, options, 9);
  const cv::Vec3d origin_in_camera = view.translation;
  ASSERT_LT(origin_in_camera[2], 0)
      << "test setup: the origin must be behind the camera";
  const cv::Point2d centre = Apply(view.homography, options.look_at);
  EXPECT_NEAR(centre.x, 319.5, 1e-6);
  EXPECT_NEAR(centre.y, 239.5, 1e-6);
  cv::Mat gray;
  cv::cvtColor(view.image, gray, cv::COLOR_BGR2GRAY);
  EXPECT_GT(gray.at<uint8_t>(240, 320), 200);
}

TEST(CameraViewTest, UntiltedViewAtScaleOneIsAPureTranslation) {
  const RenderedPage page = RenderTextPage(17);
  CameraViewOptions options;  // default look_at: page centre
  const CameraView view = RenderCameraView(page.image, options, 3);
  const cv::Matx33d &h = view.homography;
  EXPECT_NEAR(h(0, 0), 1, 1e-9);
  EXPECT_NEAR(h(1, 1), 1, 1e-9);
  EXPECT_NEAR(h(0, 1), 0, 1e-9);
  EXPECT_NEAR(h(1, 0), 0, 1e-9);
  EXPECT_NEAR(h(2, 0), 0, 1e-12);
  EXPECT_NEAR(h(2, 1), 0, 1e-12);
  EXPECT_NEAR(h(2, 2), 1, 1e-12);
  // Page centre (499.5, 706.5) at image centre (319.5, 239.5).
  EXPECT_NEAR(h(0, 2), -180, 1e-6);
  EXPECT_NEAR(h(1, 2), -467, 1e-6);
  // With an integer shift and no degradations the image is the page crop.
  const cv::Mat crop = page.image(cv::Rect(180, 467, 640, 480));
  cv::Mat diff;
  cv::absdiff(view.image, crop, diff);
  double max_diff = 0;
  cv::minMaxLoc(diff.reshape(1), nullptr, &max_diff);
  EXPECT_LE(max_diff, 1);
  // Not mirrored: the camera looks into the page.
  EXPECT_GT(view.translation[2], 0);
}

TEST(CameraViewTest, TiltedViewDecomposesIntoRotationAndTranslation) {
  CameraViewOptions options;
  options.tilt_deg = 60;
  options.tilt_azimuth_deg = 30;
  options.roll_deg = 40;
  options.scale = 0.9;
  options.look_at = {400, 600};
  const CameraView view = ComputeCameraGeometry({1000, 1414}, options);
  const cv::Matx33d m = view.camera_matrix.inv() * view.homography;
  const cv::Vec3d m1(m(0, 0), m(1, 0), m(2, 0)), m2(m(0, 1), m(1, 1), m(2, 1)),
      m3(m(0, 2), m(1, 2), m(2, 2));
  const double lambda = 1.0 / cv::norm(m1);
  const cv::Vec3d r1 = m1 * lambda, r2 = m2 * lambda, t = m3 * lambda;
  EXPECT_NEAR(r1.dot(r2), 0, 1e-9);
  EXPECT_NEAR(cv::norm(m1), cv::norm(m2), 1e-9 * cv::norm(m1));
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(r1[i], view.rotation(i, 0), 1e-9);
    EXPECT_NEAR(r2[i], view.rotation(i, 1), 1e-9);
    EXPECT_NEAR(t[i], view.translation[i], 1e-6 * cv::norm(t));
  }
  // R is a proper rotation; the optical axis makes 60 degrees with the
  // page normal; the page is in front of the camera.
  EXPECT_NEAR(cv::determinant(view.rotation), 1, 1e-12);
  const double cos_tilt = view.rotation(2, 2);
  EXPECT_NEAR(std::acos(cos_tilt) * 180 / CV_PI, 60, 1e-9);
  const cv::Vec3d look =
      view.rotation * cv::Vec3d(400, 600, 0) + view.translation;
  EXPECT_GT(look[2], 0);
  const cv::Point2d centre = Apply(view.homography, {400, 600});
  EXPECT_NEAR(centre.x, 319.5, 1e-6);
  EXPECT_NEAR(centre.y, 239.5, 1e-6);
  // Along the tilt axis (perpendicular to the azimuth) one page pixel at the
  // centre spans `scale` image pixels.
  const double az = 30 * CV_PI / 180;
  const cv::Point2d step(-std::sin(az), std::cos(az));
  const cv::Point2d a = Apply(view.homography, cv::Point2d(400, 600) - step),
                    b = Apply(view.homography, cv::Point2d(400, 600) + step);
  EXPECT_NEAR(cv::norm(b - a) / 2, 0.9, 1e-3);
}

TEST(CameraViewTest, RenderingIsDeterministicAndDegradationsApply) {
  const RenderedPage page = RenderTextPage(21);
  std::mt19937_64 rng(99);
  CameraViewOptions options = RandomViewOptions(rng, page.image.size());
  std::mt19937_64 rng2(99);
  const CameraViewOptions again = RandomViewOptions(rng2, page.image.size());
  EXPECT_EQ(options.tilt_deg, again.tilt_deg);
  EXPECT_EQ(options.jpeg_quality, again.jpeg_quality);
  options.noise_sigma = 4;
  options.blur_sigma = 1;
  options.illumination_gradient = 0.4;
  const CameraView a = RenderCameraView(page.image, options, 5);
  const CameraView b = RenderCameraView(page.image, options, 5);
  const CameraView c = RenderCameraView(page.image, options, 6);
  EXPECT_EQ(a.image.size(), options.image_size);
  EXPECT_EQ(a.image.type(), CV_8UC3);
  EXPECT_TRUE(SameBytes(a.image, b.image));
  EXPECT_FALSE(SameBytes(a.image, c.image));  // noise and light differ
  EXPECT_EQ(a.homography, c.homography);      // geometry does not
}

TEST(CameraViewTest, RandomOptionsStayInTheirRanges) {
  std::mt19937_64 rng(1234);
  const cv::Size page(1000, 1414);
  for (int i = 0; i < 500; ++i) {
    const CameraViewOptions o = RandomViewOptions(rng, page, 40, 0.6, 1.3);
    EXPECT_GE(o.tilt_deg, 0);
    EXPECT_LE(o.tilt_deg, 40);
    EXPECT_GE(o.roll_deg, -180);
    EXPECT_LE(o.roll_deg, 180);
    EXPECT_GE(o.scale, 0.6);
    EXPECT_LE(o.scale, 1.3);
    EXPECT_GT(o.look_at.x, 0.25 * page.width);
    EXPECT_LT(o.look_at.x, 0.75 * page.width);
    EXPECT_GT(o.look_at.y, 0.25 * page.height);
    EXPECT_LT(o.look_at.y, 0.75 * page.height);
    EXPECT_LE(o.blur_sigma, 1.5);
    EXPECT_LE(o.noise_sigma, 6);
    EXPECT_LE(o.illumination_gradient, 0.5);
    EXPECT_GE(o.jpeg_quality, 60);
    EXPECT_LE(o.jpeg_quality, 95);
  }
}

TEST(CameraViewTest, GroundTruthJsonHasTheKeys) {
  CameraViewOptions options;
  options.tilt_deg = 20;
  const CameraView view = ComputeCameraGeometry({1000, 1414}, options);
  const std::string json = CameraViewGroundTruthJson(view, options);
  for (const char *key :
       {"\"homography\"", "\"camera_matrix\"", "\"rotation\"",
        "\"translation\"", "\"tilt_deg\"", "\"jpeg_quality\""}) {
    EXPECT_NE(json.find(key), std::string::npos) << key;
  }
}

}  // namespace
}  // namespace texfree::testdata
