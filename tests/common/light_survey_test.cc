// Survey geometry against ground truth: view poses from references (with an outlier),
// triangulation and its 1-sigma, the whole tunnel survey with and without bundle adjustment.
#include "common/light_survey.h"

#include <random>

#include <gtest/gtest.h>

#include "tests/data/light_scene.h"

namespace texfree::survey {
namespace {

using testdata::TunnelViewPose;

std::vector<ViewInput> TunnelObservations(const testdata::LightScene& scene, double noise_px,
                                          uint64_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0, noise_px);
  std::vector<ViewInput> views;
  for (int v = 0; v < 2; ++v) {
    ViewInput view;
    view.name = v == 0 ? "left" : "right";
    for (const auto& light : scene.lights) {
      const cv::Point2d p = ProjectPoint(scene.camera, TunnelViewPose(v), light.position);
      view.lights.push_back({light.id, p + cv::Point2d(noise(rng), noise(rng)), false});
    }
    views.push_back(view);
  }
  return views;
}

double RotationErrorDeg(const cv::Matx33d& a, const cv::Matx33d& b) {
  const cv::Matx33d d = a.t() * b;
  return std::acos(std::clamp((cv::trace(d) - 1) / 2, -1.0, 1.0)) * 180 / CV_PI;
}

TEST(LightSurveyTest, PoseFromReferencesWithOutlier) {
  testdata::LightSceneOptions options;
  const auto scene = testdata::MakeTunnelScene(options);
  const CameraPose truth = TunnelViewPose(0);
  std::vector<cv::Point3d> world;
  std::vector<cv::Point2d> pixels;
  std::mt19937 rng(1);
  std::normal_distribution<double> noise(0, 0.1);
  for (const auto& [id, X] : scene.references) {
    world.push_back(X);
    pixels.push_back(ProjectPoint(scene.camera, truth, X) + cv::Point2d(noise(rng), noise(rng)));
  }
  world[2].z += 0.5;  // a mistyped reference coordinate
  auto pose = EstimateViewPose(world, pixels, scene.camera, {});
  ASSERT_TRUE(pose.ok()) << pose.status();
  EXPECT_EQ(pose->inliers.size(), 6u);
  EXPECT_EQ(std::count(pose->inliers.begin(), pose->inliers.end(), 2), 0);
  EXPECT_LT(RotationErrorDeg(pose->pose.R, truth.R), 0.03);
  EXPECT_LT(cv::norm(pose->pose.Center() - truth.Center()), 0.05);  // metres at 43 m
  EXPECT_LT(pose->rms_px, 0.3);
}

TEST(LightSurveyTest, TooFewReferences) {
  testdata::LightSceneOptions options;
  const auto scene = testdata::MakeTunnelScene(options);
  std::vector<cv::Point3d> world = {{1, 2, 3}, {2, 3, 4}, {3, 1, 2}};
  std::vector<cv::Point2d> pixels = {{10, 10}, {20, 30}, {40, 10}};
  auto pose = EstimateViewPose(world, pixels, scene.camera, {});
  EXPECT_EQ(pose.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_NE(pose.status().message().find("at least 4 reference"), std::string::npos);
}

TEST(LightSurveyTest, TriangulationExactAndItsSigma) {
  testdata::LightSceneOptions options;
  const auto scene = testdata::MakeTunnelScene(options);
  const std::vector<CameraPose> poses = {TunnelViewPose(0), TunnelViewPose(1)};
  const cv::Point3d X = scene.measured.at(11);
  std::vector<cv::Point2d> exact = {ProjectPoint(scene.camera, poses[0], X),
                                    ProjectPoint(scene.camera, poses[1], X)};
  auto point = TriangulatePoint(poses, exact, scene.camera, {});
  ASSERT_TRUE(point.ok()) << point.status();
  EXPECT_LT(cv::norm(point->position - X), 1e-6);
  // Monte Carlo with 0.3 px noise: the reported sigma matches the spread (within 30%).
  std::mt19937 rng(2);
  std::normal_distribution<double> noise(0, 0.3);
  cv::Vec3d sum_sq(0, 0, 0);
  const int trials = 300;
  for (int t = 0; t < trials; ++t) {
    std::vector<cv::Point2d> noisy = exact;
    for (auto& p : noisy) p += cv::Point2d(noise(rng), noise(rng));
    auto p = TriangulatePoint(poses, noisy, scene.camera, {});
    ASSERT_TRUE(p.ok());
    const cv::Point3d e = p->position - X;
    sum_sq += cv::Vec3d(e.x * e.x, e.y * e.y, e.z * e.z);
  }
  for (int a = 0; a < 3; ++a) {
    const double spread = std::sqrt(sum_sq[a] / trials);
    EXPECT_NEAR(point->sigma[a], spread, 0.3 * spread) << "axis " << a;
  }
  // Parallel rays are refused.
  auto same = TriangulatePoint({poses[0], poses[0]}, {exact[0], exact[0]}, scene.camera, {});
  EXPECT_EQ(same.status().code(), absl::StatusCode::kFailedPrecondition);
}

TEST(LightSurveyTest, TunnelSurveyMillimetres) {
  testdata::LightSceneOptions options;
  const auto scene = testdata::MakeTunnelScene(options);
  // 0.1 px: the centroid accuracy the burst decoder reaches on this scene.
  const auto views = TunnelObservations(scene, 0.1, 7);
  for (bool bundle : {false, true}) {
    SolveOptions solve;
    solve.bundle_adjustment = bundle;
    auto solution = SolveSurvey(scene.camera, scene.references, views, solve);
    ASSERT_TRUE(solution.ok()) << solution.status();
    ASSERT_EQ(solution->points.size(), 7u);
    double sum = 0;
    for (const auto& p : solution->points) {
      const double error = cv::norm(p.position - scene.measured.at(p.id));
      sum += error;
      EXPECT_LT(error, 0.010) << "light " << p.id;
      EXPECT_EQ(p.views, 2);
      EXPECT_GT(p.sigma[1], 0);  // depth axis (Y) is the least certain
      EXPECT_LT(p.rms_px, 0.5);
    }
    EXPECT_LT(sum / 7, 0.005) << (bundle ? "with" : "without") << " bundle adjustment";
    for (const auto& v : solution->views) {
      EXPECT_TRUE(v.posed);
      EXPECT_LT(v.reprojection_rms_px, 0.3);
    }
    EXPECT_EQ(solution->bundle_adjusted, bundle);
  }
}

TEST(LightSurveyTest, OneViewCannotBePosed) {
  testdata::LightSceneOptions options;
  const auto scene = testdata::MakeTunnelScene(options);
  auto views = TunnelObservations(scene, 0.1, 3);
  // The right view only sees three references.
  auto& lights = views[1].lights;
  lights.erase(std::remove_if(lights.begin(), lights.end(),
                              [](const LightObservation& l) { return l.id >= 4 && l.id <= 7; }),
               lights.end());
  auto solution = SolveSurvey(scene.camera, scene.references, views, {});
  EXPECT_EQ(solution.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_NE(solution.status().message().find("right"), std::string::npos);
}

}  // namespace
}  // namespace texfree::survey
