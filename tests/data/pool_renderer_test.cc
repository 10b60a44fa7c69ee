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
