// Unit tests of the pool renderer: determinism, and ground truth that agrees with the
// picture (each ball's centre pixel shows the ball, the cloth corners the cloth's edge).
#include "tests/data/pool_renderer.h"

#include <gtest/gtest.h>

#include <opencv2/core.hpp>
#include <random>

namespace texfree::testdata {
namespace {

PoolScene SmallScene() {
  PoolScene scene;
  scene.balls = {{0, 300, 350}, {3, 700, 200}, {8, 1000, 500}, {9, 500, 560}};
  scene.camera = FramedPoolCamera(scene.table, PoolViewSide::kLongNear, 55, 60, 0, 0, 0.04,
                                  cv::Size(320, 240));
  return scene;
}

TEST(PoolRenderer, SameSeedSameImage) {
  const PoolScene scene = SmallScene();
  const PoolView a = RenderPoolView(scene, 3), b = RenderPoolView(scene, 3);
  EXPECT_EQ(cv::norm(a.image, b.image, cv::NORM_L1), 0);
  const PoolView c = RenderPoolView(scene, 4);  // other noise
  EXPECT_GT(cv::norm(a.image, c.image, cv::NORM_L1), 0);
}

TEST(PoolRenderer, GroundTruthAgreesWithThePicture) {
  PoolScene scene = SmallScene();
  scene.blur_sigma = scene.noise_sigma = 0;
  scene.jpeg_quality = 0;
  const PoolView view = RenderPoolView(scene, 5);
  const cv::Vec3d cloth = scene.table.cloth_rgb;
  for (const auto& ball : view.balls) {
    const cv::Vec3b& p = view.image.at<cv::Vec3b>(cvRound(ball.pixel.y), cvRound(ball.pixel.x));
    const cv::Vec3d rgb(p[2], p[1], p[0]);
    // Not the cloth's colour: the ball is at its projected centre.
    const double cosine = rgb.dot(cloth) / (cv::norm(rgb) * cv::norm(cloth) + 1e-9);
    EXPECT_LT(cosine, std::cos(15 * CV_PI / 180)) << "ball " << ball.number;
    EXPECT_TRUE(ball.separated) << "ball " << ball.number;
    EXPECT_GT(ball.visible_pixels, 10);
  }
  // The playing-surface corners lie inside the cushion outline, and both project where
  // the camera looks (a convex quadrilateral in the image).
  for (int i = 0; i < 4; ++i) {
    EXPECT_GT(view.cloth_corners[i].x, 0);
    EXPECT_LT(view.cloth_corners[i].x, 320);
  }
  EXPECT_LT(view.cushion_corners[0].x, view.cloth_corners[0].x);
  EXPECT_GT(view.cushion_corners[0].y, view.cloth_corners[0].y);
}

// A cue stick aimed through the cue ball is drawn where it projects, over the cloth, and
// shades the cloth where it hides a lamp; the balls' truth counts only what it leaves in
// view.
TEST(PoolRenderer, CueStickIsDrawnWhereItProjectsAndCastsAShadow) {
  PoolScene scene = SmallScene();
  scene.blur_sigma = scene.noise_sigma = 0;
  scene.jpeg_quality = 0;
  const PoolView plain = RenderPoolView(scene, 5);
  std::mt19937_64 rng(3);
  scene.cue_stick = AimedCueStick(rng, scene.table, scene.balls);
  const PoolCueStick& stick = *scene.cue_stick;
  // Aimed through the cue ball (at 300, 350): its axis passes over the ball's centre.
  const cv::Vec3d axis = stick.toward_butt;
  EXPECT_NEAR(cv::norm(axis), 1, 1e-9);
  EXPECT_GT(axis[2], std::sin(3 * CV_PI / 180));  // rising towards the butt
  // Seen from above, the cue ball's centre lies on the stick's line ahead of the tip, at
  // the tip's height.
  const cv::Point2d to_cue(300 - stick.tip_mm[0], 350 - stick.tip_mm[1]);
  const cv::Point2d ahead(-axis[0], -axis[1]);
  EXPECT_LT(std::abs(to_cue.cross(ahead)) / cv::norm(ahead), 1.0);
  EXPECT_GT(to_cue.dot(ahead) / cv::norm(ahead), scene.table.ball_radius_mm);
  EXPECT_NEAR(stick.tip_mm[2], scene.table.ball_radius_mm, 1e-9);
  const PoolView with = RenderPoolView(scene, 5);
  // The shaft 300 mm from the tip is drawn: maple, where the cloth was.
  const cv::Point2d shaft = ProjectTablePoint(with, stick.tip_mm + 300 * axis);
  const cv::Vec3b& seen = with.image.at<cv::Vec3b>(cvRound(shaft.y), cvRound(shaft.x));
  const cv::Vec3b& before = plain.image.at<cv::Vec3b>(cvRound(shaft.y), cvRound(shaft.x));
  EXPECT_GT(seen[2], seen[1]) << "red over green: wood, not cloth";
  EXPECT_LT(before[2], before[1]) << "green cloth without the stick";
  // Its shadow: where the shaft hides the nearer lamp (two lamps 900 mm over the long
  // axis, at a third and two thirds of the length), the cloth is darker.
  const cv::Vec3d mid = stick.tip_mm + 150 * axis;
  const double L = scene.table.length_mm, W = scene.table.width_mm;
  const cv::Vec3d lamp(std::abs(mid[0] - L / 3) < std::abs(mid[0] - 2 * L / 3) ? L / 3 : 2 * L / 3,
                       W / 2, 900);
  const cv::Vec3d shadow = lamp + (mid - lamp) * (lamp[2] / (lamp[2] - mid[2]));
  const cv::Point2d at = ProjectTablePoint(with, {shadow[0], shadow[1], 0});
  const auto brightness = [&](const PoolView& v) {
    const cv::Vec3b& p = v.image.at<cv::Vec3b>(cvRound(at.y), cvRound(at.x));
    return p[0] + p[1] + p[2];
  };
  ASSERT_GT(cv::norm(at - ProjectTablePoint(with, mid)), 3) << "the shadow is behind the stick";
  EXPECT_LT(brightness(with), 0.85 * brightness(plain));
  // The balls' truth is unchanged where the stick does not pass.
  ASSERT_EQ(with.balls.size(), plain.balls.size());
  for (size_t i = 0; i < with.balls.size(); ++i) {
    EXPECT_EQ(with.balls[i].pixel, plain.balls[i].pixel);
    EXPECT_LE(with.balls[i].visible_pixels, plain.balls[i].visible_pixels);
  }
}

TEST(PoolRenderer, RandomLayoutsDoNotOverlap) {
  std::mt19937_64 rng(9);
  const PoolTableSpec table;
  for (int i = 0; i < 20; ++i) {
    const auto balls = RandomPoolLayout(rng, table, 10, true);
    ASSERT_GE(balls.size(), 9u);
    for (size_t a = 0; a < balls.size(); ++a)
      for (size_t b = a + 1; b < balls.size(); ++b)
        EXPECT_GE(std::hypot(balls[a].x_mm - balls[b].x_mm, balls[a].y_mm - balls[b].y_mm),
                  2 * table.ball_radius_mm);
  }
}

}  // namespace
}  // namespace texfree::testdata
