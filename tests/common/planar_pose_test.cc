// Tests of planar pose recovery: PoseFromHomography / HomographyFromPose on
// exact synthetic cameras, EstimatePlanarPose with lens distortion and pixel
// noise, CameraModel checks.
#include "common/planar_pose.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <opencv2/calib3d.hpp>
#include <random>
#include <vector>

namespace texfree {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;

const cv::Matx33d kK(800, 0, 320, 0, 800, 240, 0, 0, 1);

cv::Matx33d Rotation(const cv::Vec3d &axis_angle) {
  cv::Matx33d R;
  cv::Rodrigues(axis_angle, R);
  return R;
}

// A camera looking at the plane Z = 0 from distance `distance` along its axis,
// with the optical axis tilted by `tilt_deg` about an in-plane axis at
// `azimuth_deg`, and rolled by `roll_deg`. The plane point (cx, cy, 0) is on
// the optical axis.
PlanarPose Camera(double tilt_deg, double azimuth_deg, double roll_deg, double distance,
                  const cv::Point2d &centre = {300, 200}) {
  const double az = azimuth_deg * kDeg;
  const cv::Matx33d cam_to_world =
      Rotation(cv::Vec3d(-std::sin(az), std::cos(az), 0) * tilt_deg * kDeg) *
      Rotation(cv::Vec3d(0, 0, roll_deg * kDeg));
  PlanarPose pose;
  pose.R = cam_to_world.t();
  const cv::Vec3d axis(cam_to_world(0, 2), cam_to_world(1, 2), cam_to_world(2, 2));
  const cv::Vec3d position = cv::Vec3d(centre.x, centre.y, 0) - distance * axis;
  pose.t = -(pose.R * position);
  return pose;
}

std::vector<PlanarPose> Cameras() {
  std::vector<PlanarPose> out;
  for (double tilt : {0.0, 15.0, 40.0, 70.0})
    for (double roll : {0.0, 35.0, -70.0, 170.0})
      out.push_back(Camera(tilt, roll * 0.7 + 20, roll, 900 + 10 * tilt));
  return out;
}

double RotationErrorDeg(const cv::Matx33d &a, const cv::Matx33d &b) {
  cv::Vec3d r;
  cv::Rodrigues(a.t() * b, r);
  return cv::norm(r) / kDeg;
}

double MaxAbs(const cv::Matx33d &a) {
  double m = 0;
  for (double v : a.val) m = std::max(m, std::abs(v));
  return m;
}

TEST(PlanarPoseTest, SyntheticCamerasAreValidRotations) {
  for (const PlanarPose &p : Cameras()) {
    EXPECT_LT(MaxAbs(p.R * p.R.t() - cv::Matx33d::eye()), 1e-12);
    EXPECT_NEAR(cv::determinant(p.R), 1.0, 1e-12);
    EXPECT_GT(p.t[2], 0) << "the plane origin must be in front of the camera";
  }
}

TEST(PlanarPoseTest, PoseFromHomographyRecoversPoseForAnyScale) {
  for (const PlanarPose &truth : Cameras()) {
    const cv::Matx33d Rt(truth.R(0, 0), truth.R(0, 1), truth.t[0], truth.R(1, 0), truth.R(1, 1),
                         truth.t[1], truth.R(2, 0), truth.R(2, 1), truth.t[2]);
    const cv::Matx33d H = kK * Rt;
    for (double scale : {1.0, 1e-3, 37.5, -1.0, -0.02, -250.0}) {
      auto pose = PoseFromHomography(H * scale, kK);
      ASSERT_TRUE(pose.ok()) << pose.status();
      EXPECT_LT(MaxAbs(pose->R - truth.R), 1e-6) << "scale " << scale;
      EXPECT_LT(cv::norm(pose->t - truth.t), 1e-6 * cv::norm(truth.t)) << "scale " << scale;
      EXPECT_NEAR(cv::determinant(pose->R), 1.0, 1e-9);
    }
  }
}

// Close and steeply tilted (as when tracking at 80 deg): the plane's origin is
// behind the camera while the looked-at point is in front. The sign must come
// from a visible point.
TEST(PlanarPoseTest, PoseFromHomographyWithPlaneOriginBehindCamera) {
  const cv::Point2d looked_at(900, 1200);
  const PlanarPose truth = Camera(75.0, 53.0, 30.0, 400.0, looked_at);
  const cv::Vec3d origin_in_camera = truth.t;
  ASSERT_LT(origin_in_camera[2], 0) << "test setup: the origin must be behind the camera";
  const cv::Matx33d Rt(truth.R(0, 0), truth.R(0, 1), truth.t[0], truth.R(1, 0), truth.R(1, 1),
                       truth.t[1], truth.R(2, 0), truth.R(2, 1), truth.t[2]);
  for (double scale : {1.0, -1.0, 3.0}) {
    auto pose = PoseFromHomography(kK * Rt * scale, kK, looked_at);
    ASSERT_TRUE(pose.ok()) << pose.status();
    EXPECT_LT(MaxAbs(pose->R - truth.R), 1e-6) << "scale " << scale;
    EXPECT_LT(cv::norm(pose->t - truth.t), 1e-6 * cv::norm(truth.t)) << "scale " << scale;
  }
}

TEST(PlanarPoseTest, HomographyFromPoseRoundTrip) {
  for (const PlanarPose &truth : Cameras()) {
    const cv::Matx33d H = HomographyFromPose(truth, kK);
    EXPECT_DOUBLE_EQ(H(2, 2), 1.0);
    // Projects plane points where the pinhole model does.
    for (const cv::Point2d &X :
         {cv::Point2d(0, 0), cv::Point2d(300, 200), cv::Point2d(-150, 420)}) {
      const cv::Vec3d c = truth.R * cv::Vec3d(X.x, X.y, 0) + truth.t;
      const cv::Vec3d x = kK * c;
      const cv::Point2d expected(x[0] / x[2], x[1] / x[2]);
      EXPECT_LT(cv::norm(ApplyHomography(H, X) - expected), 1e-9);
    }
    auto pose = PoseFromHomography(H, kK);
    ASSERT_TRUE(pose.ok()) << pose.status();
    EXPECT_LT(MaxAbs(pose->R - truth.R), 1e-6);
    EXPECT_LT(cv::norm(pose->t - truth.t), 1e-6 * cv::norm(truth.t));
    EXPECT_LT(MaxAbs(HomographyFromPose(*pose, kK) - H), 1e-6 * MaxAbs(H));
  }
}

// The focal length from a rectangle of known sides seen by exact synthetic cameras: found
// to 1e-6 from exact corners under tilts, azimuths and rolls; within 3% with 0.25 px of
// noise on the corners; unfixed (nullopt) for a rectangle seen square on.
TEST(PlanarPoseTest, FocalLengthFromARectangleOfKnownSides) {
  const double width = 1330, height = 700;
  const auto corners_of = [&](const PlanarPose &pose, double noise_px, std::mt19937 *rng) {
    std::normal_distribution<double> noise(0, noise_px);
    std::array<cv::Point2d, 4> corners;
    const cv::Point2d plane[4] = {{0, 0}, {width, 0}, {width, height}, {0, height}};
    for (int i = 0; i < 4; ++i) {
      const cv::Vec3d x = pose.R * cv::Vec3d(plane[i].x, plane[i].y, 0) + pose.t;
      corners[i] = {kK(0, 0) * x[0] / x[2] + kK(0, 2) + (noise_px > 0 ? noise(*rng) : 0),
                    kK(1, 1) * x[1] / x[2] + kK(1, 2) + (noise_px > 0 ? noise(*rng) : 0)};
    }
    return corners;
  };
  const cv::Point2d principal(kK(0, 2), kK(1, 2));
  std::mt19937 rng(5);
  for (double tilt : {30.0, 45.0, 60.0})
    for (double azimuth : {10.0, 35.0, 70.0})
      for (double roll : {0.0, 8.0}) {
        SCOPED_TRACE(testing::Message()
                     << "tilt " << tilt << " azimuth " << azimuth << " roll " << roll);
        const PlanarPose pose = Camera(tilt, azimuth, roll, 2500, {width / 2, height / 2});
        auto f = FocalLengthFromRectangle(corners_of(pose, 0, &rng), principal, width, height);
        ASSERT_TRUE(f.has_value());
        EXPECT_NEAR(*f / kK(0, 0), 1.0, 1e-6);
        auto noisy =
            FocalLengthFromRectangle(corners_of(pose, 0.25, &rng), principal, width, height);
        ASSERT_TRUE(noisy.has_value());
        EXPECT_NEAR(*noisy / kK(0, 0), 1.0, 0.03);
      }
  const PlanarPose square_on = Camera(0, 0, 0, 2500, {width / 2, height / 2});
  EXPECT_FALSE(FocalLengthFromRectangle(corners_of(square_on, 0, &rng), principal, width, height));
}

TEST(PlanarPoseTest, PoseFromHomographyRejectsDegenerate) {
  EXPECT_EQ(PoseFromHomography(cv::Matx33d::zeros(), kK).status().code(),
            absl::StatusCode::kInvalidArgument);
  const cv::Matx33d nan(NAN, 0, 0, 0, 1, 0, 0, 0, 1);
  EXPECT_FALSE(PoseFromHomography(nan, kK).ok());
}

TEST(PlanarPoseTest, PlausibleHomographiesAreCameraViewsOfThePage) {
  // Page points around the point on the optical axis, as a view sees them.
  std::vector<cv::Point2f> seen;
  for (int y = 100; y <= 300; y += 50)
    for (int x = 150; x <= 450; x += 75) seen.emplace_back(x, y);
  // Every camera up to 75 degrees of tilt, any roll and azimuth; H's sign does not matter.
  for (double tilt : {0.0, 15.0, 40.0, 60.0, 75.0})
    for (double roll : {0.0, 35.0, -70.0, 170.0}) {
      cv::Matx33d H = HomographyFromPose(Camera(tilt, roll * 0.7 + 20, roll, 900), kK);
      EXPECT_TRUE(MakePlausibleHomography(&H, seen)) << "tilt " << tilt << " roll " << roll;
      cv::Matx33d negated = H * -1.0;
      EXPECT_TRUE(MakePlausibleHomography(&negated, seen));
      EXPECT_GT(negated(2, 2), 0);
    }
  // A mirrored page, and one shrunk to a dot.
  cv::Matx33d mirrored(-1, 0, 640, 0, 1, 0, 0, 0, 1);
  EXPECT_FALSE(MakePlausibleHomography(&mirrored, seen));
  cv::Matx33d dot(0.01, 0, 0, 0, 0.01, 0, 0, 0, 1);
  EXPECT_FALSE(MakePlausibleHomography(&dot, seen));
  // A fit that collapsed a three-column page onto a line (singular values 0.51 and 0.002,
  // the neighbourhood pass's false match at 10,000 pages), and a page seen at 85 degrees.
  cv::Matx33d collapsed(-0.187229, 0.0428901, 75.5405, 0.460142, -0.110664, 69.8822, 8.70967e-05,
                        -1.9952e-05, 1);
  EXPECT_FALSE(MakePlausibleHomography(&collapsed, seen));
  cv::Matx33d edge_on = HomographyFromPose(Camera(85, 20, 0, 900), kK);
  EXPECT_FALSE(MakePlausibleHomography(&edge_on, seen));
}

TEST(PlanarPoseTest, ApplyHomographyDividesByW) {
  const cv::Matx33d H(2, 0, 1, 0, 3, -2, 0.5, 0, 2);
  const cv::Point2d p = ApplyHomography(H, {2, 4});
  EXPECT_DOUBLE_EQ(p.x, 5.0 / 3.0);
  EXPECT_DOUBLE_EQ(p.y, 10.0 / 3.0);
}

// The analytic Jacobian against central differences of ApplyHomography on a perspective
// homography; a pure scaling's local scale is its factor; behind the horizon there is none.
TEST(PlanarPoseTest, HomographyJacobianMatchesFiniteDifferences) {
  const cv::Matx33d H(1.2, 0.3, 40, -0.1, 0.9, 25, 4e-4, -2e-4, 1);
  for (const cv::Point2d p : {cv::Point2d(0, 0), cv::Point2d(300, 150), cv::Point2d(-80, 600)}) {
    const auto J = HomographyJacobian(H, p);
    ASSERT_TRUE(J.has_value());
    const double h = 1e-4;
    const cv::Point2d dx =
        (ApplyHomography(H, p + cv::Point2d(h, 0)) - ApplyHomography(H, p - cv::Point2d(h, 0))) /
        (2 * h);
    const cv::Point2d dy =
        (ApplyHomography(H, p + cv::Point2d(0, h)) - ApplyHomography(H, p - cv::Point2d(0, h))) /
        (2 * h);
    EXPECT_NEAR((*J)(0, 0), dx.x, 1e-7);
    EXPECT_NEAR((*J)(1, 0), dx.y, 1e-7);
    EXPECT_NEAR((*J)(0, 1), dy.x, 1e-7);
    EXPECT_NEAR((*J)(1, 1), dy.y, 1e-7);
    EXPECT_NEAR(HomographyLocalScale(H, p), std::sqrt(std::abs(dx.x * dy.y - dx.y * dy.x)), 1e-7);
  }
  EXPECT_DOUBLE_EQ(HomographyLocalScale(cv::Matx33d(2.5, 0, 7, 0, 2.5, -3, 0, 0, 1), {10, 20}),
                   2.5);
  // w = 4e-4 x - 2e-4 y + 1 <= 0 beyond the horizon.
  EXPECT_FALSE(HomographyJacobian(H, {-5000, 0}).has_value());
  EXPECT_EQ(HomographyLocalScale(H, {-5000, 0}), 0.0);
}

// A 600 x 400 grid of plane points (spacing `step`) around the looked-at point, projected
// by `truth` through `camera` and kept where they land inside its 640 x 480 image.
void VisibleGrid(const PlanarPose &truth, const CameraModel &camera, int step,
                 std::vector<cv::Point2f> *plane, std::vector<cv::Point2f> *pixels) {
  std::vector<cv::Point3f> object;
  for (int y = 0; y <= 400; y += step)
    for (int x = 0; x <= 600; x += step) object.emplace_back(x, y, 0);
  cv::Vec3d rvec;
  cv::Rodrigues(truth.R, rvec);
  std::vector<cv::Point2f> projected;
  cv::projectPoints(object, rvec, truth.t, cv::Mat(camera.K),
                    camera.distortion.empty() ? cv::Mat() : cv::Mat(camera.distortion), projected);
  plane->clear();
  pixels->clear();
  for (size_t i = 0; i < object.size(); ++i) {
    const cv::Point2f &p = projected[i];
    if (p.x < 0 || p.y < 0 || p.x > 639 || p.y > 479) continue;
    plane->emplace_back(object[i].x, object[i].y);
    pixels->push_back(p);
  }
}

// VisibleGrid with Gaussian noise of `sigma` pixels added to each pixel.
void NoisyVisibleGrid(const PlanarPose &truth, const CameraModel &camera, int step, double sigma,
                      std::mt19937 *rng, std::vector<cv::Point2f> *plane,
                      std::vector<cv::Point2f> *pixels) {
  VisibleGrid(truth, camera, step, plane, pixels);
  std::normal_distribution<double> noise(0, sigma);
  for (cv::Point2f &p : *pixels)
    p += cv::Point2f(static_cast<float>(noise(*rng)), static_cast<float>(noise(*rng)));
}

TEST(PlanarPoseTest, EstimatePlanarPoseWithDistortionAndNoise) {
  CameraModel camera;
  camera.K = kK;
  camera.distortion = {-0.2, 0.05, 0, 0, 0};
  camera.size = {640, 480};
  ASSERT_TRUE(camera.Validate().ok());
  ASSERT_TRUE(camera.has_distortion());
  std::mt19937 rng(5);
  int tested = 0;
  for (const PlanarPose &truth : Cameras()) {
    std::vector<cv::Point2f> plane, pixels;
    NoisyVisibleGrid(truth, camera, 40, 0.3, &rng, &plane, &pixels);
    if (plane.size() < 30) continue;
    ++tested;
    auto pose = EstimatePlanarPose(plane, pixels, camera);
    ASSERT_TRUE(pose.ok()) << pose.status();
    EXPECT_LT(RotationErrorDeg(pose->R, truth.R), 0.5);
    EXPECT_LT(cv::norm(pose->t - truth.t), 0.01 * cv::norm(truth.t));
  }
  EXPECT_GE(tested, 12);
}

// Refinement from a pose a few degrees and centimetres off reaches the same pose as the
// estimate from scratch: the exact one for exact pixels.
TEST(PlanarPoseTest, RefinePlanarPoseFromNearbyPoseConverges) {
  CameraModel camera;
  camera.K = kK;
  camera.size = {640, 480};
  int tested = 0;
  for (const PlanarPose &truth : Cameras()) {
    std::vector<cv::Point2f> plane, pixels;
    VisibleGrid(truth, camera, 50, &plane, &pixels);
    if (plane.size() < 20) continue;
    ++tested;
    PlanarPose initial;
    initial.R = Rotation(cv::Vec3d(0.03, -0.04, 0.05)) * truth.R;  // about 4 degrees off
    initial.t = truth.t + cv::Vec3d(20, -15, 40);
    auto pose = RefinePlanarPose(plane, pixels, camera, initial);
    ASSERT_TRUE(pose.ok()) << pose.status();
    EXPECT_LT(RotationErrorDeg(pose->R, truth.R), 0.01);
    EXPECT_LT(cv::norm(pose->t - truth.t), 1e-4 * cv::norm(truth.t));
  }
  EXPECT_GE(tested, 12);
  const std::vector<cv::Point2f> three = {{0, 0}, {100, 0}, {0, 100}};
  EXPECT_EQ(RefinePlanarPose(three, three, camera, PlanarPose{}).status().code(),
            absl::StatusCode::kInvalidArgument);
}

// Without lens distortion the refinement is written out (RefinePinholePose): on noisy
// pixels it must reach OpenCV's own Levenberg-Marquardt minimum (run to convergence).
TEST(PlanarPoseTest, PinholeRefinementReachesOpenCvsMinimumOnNoisyPixels) {
  CameraModel camera;
  camera.K = cv::Matx33d(700, 0, 330, 0, 690, 235, 0, 0, 1);  // OpenCV projects without skew
  camera.size = {640, 480};
  std::mt19937 rng(5);
  int tested = 0;
  for (const PlanarPose &truth : Cameras()) {
    std::vector<cv::Point2f> plane, pixels;
    NoisyVisibleGrid(truth, camera, 40, 0.7, &rng, &plane, &pixels);
    if (plane.size() < 20) continue;
    ++tested;
    PlanarPose initial;
    initial.R = Rotation(cv::Vec3d(-0.02, 0.03, 0.01)) * truth.R;
    initial.t = truth.t + cv::Vec3d(-10, 12, 25);
    auto pose = RefinePlanarPose(plane, pixels, camera, initial);
    ASSERT_TRUE(pose.ok()) << pose.status();
    std::vector<cv::Point3f> object;
    for (const auto &p : plane) object.emplace_back(p.x, p.y, 0.f);
    cv::Mat rvec, tvec = cv::Mat(initial.t).clone();
    cv::Rodrigues(cv::Mat(initial.R), rvec);
    cv::solvePnPRefineLM(
        object, pixels, cv::Mat(camera.K), cv::Mat(), rvec, tvec,
        cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 100, 1e-12));
    cv::Mat R_cv;
    cv::Rodrigues(rvec, R_cv);
    EXPECT_LT(RotationErrorDeg(pose->R, cv::Matx33d(R_cv)), 1e-5);
    EXPECT_LT(cv::norm(pose->t - cv::Vec3d(tvec)), 1e-6 * cv::norm(truth.t));
  }
  EXPECT_GE(tested, 12);
}

TEST(PlanarPoseTest, EstimatePlanarPoseNeedsFourPoints) {
  CameraModel camera;
  camera.K = kK;
  const std::vector<cv::Point2f> plane = {{0, 0}, {100, 0}, {0, 100}};
  const std::vector<cv::Point2f> pixels = {{300, 200}, {400, 200}, {300, 300}};
  EXPECT_EQ(EstimatePlanarPose(plane, pixels, camera).status().code(),
            absl::StatusCode::kInvalidArgument);
  // Mismatched sizes too.
  const std::vector<cv::Point2f> plane4 = {{0, 0}, {100, 0}, {0, 100}, {100, 100}};
  EXPECT_EQ(EstimatePlanarPose(plane4, pixels, camera).status().code(),
            absl::StatusCode::kInvalidArgument);
}

TEST(CameraModelTest, ValidateRejectsBadModels) {
  CameraModel ok;
  ok.K = kK;
  EXPECT_TRUE(ok.Validate().ok());
  EXPECT_FALSE(ok.has_distortion());
  ok.distortion = {0, 0, 0, 0};
  EXPECT_TRUE(ok.Validate().ok());
  EXPECT_FALSE(ok.has_distortion());

  CameraModel bad = ok;
  bad.K(0, 0) = 0;
  EXPECT_EQ(bad.Validate().code(), absl::StatusCode::kInvalidArgument);
  bad = ok;
  bad.K(1, 1) = -800;
  EXPECT_EQ(bad.Validate().code(), absl::StatusCode::kInvalidArgument);
  bad = ok;
  bad.K(0, 0) = NAN;
  EXPECT_EQ(bad.Validate().code(), absl::StatusCode::kInvalidArgument);
  bad = ok;
  bad.distortion = {-0.2, 0.05, 0.001};
  const absl::Status s = bad.Validate();
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("3"), std::string::npos) << s;
  bad.distortion = {-0.2, 0.05, 0, 0, INFINITY};
  EXPECT_EQ(bad.Validate().code(), absl::StatusCode::kInvalidArgument);
  for (size_t n : {4u, 5u, 8u, 12u, 14u}) {
    CameraModel m = ok;
    m.distortion.assign(n, 0.0);
    EXPECT_TRUE(m.Validate().ok()) << n;
  }
}

// Resizing keeps pixel centres: the pixel grid's centres map onto each other, and a camera's
// projection in the resized image is its projection in the original, resized.
TEST(ResizingTest, PixelScalingAndScaledIntrinsicsAgree) {
  const cv::Size from(4032, 3024), to(1344, 1008);
  const cv::Matx33d S = PixelScaling(from, to);
  const cv::Point2d first = ApplyHomography(S, {1.0, 1.0});  // centre of the 3x3 block at 0
  EXPECT_NEAR(first.x, 0, 1e-12);
  EXPECT_NEAR(first.y, 0, 1e-12);
  const cv::Point2d last = ApplyHomography(S, {4031 - 1.0, 3023 - 1.0});
  EXPECT_NEAR(last.x, 1343, 1e-9);
  EXPECT_NEAR(last.y, 1007, 1e-9);
  const cv::Matx33d back = PixelScaling(to, from) * S;
  EXPECT_LT(cv::norm(back - cv::Matx33d::eye()), 1e-12);

  const cv::Matx33d K2 = ScaledIntrinsics(kK, from, to);
  const cv::Vec3d X(0.3, -0.2, 2.0);
  const cv::Vec3d a = kK * X, b = K2 * X;
  const cv::Point2d expected = ApplyHomography(S, {a[0] / a[2], a[1] / a[2]});
  EXPECT_NEAR(b[0] / b[2], expected.x, 1e-9);
  EXPECT_NEAR(b[1] / b[2], expected.y, 1e-9);
}

TEST(ResizingTest, WorkingSizes) {
  EXPECT_EQ(WorkingSize({640, 480}, 1280 * 960), cv::Size(640, 480));
  EXPECT_EQ(WorkingSize({4032, 3024}, 0), cv::Size(4032, 3024)) << "0: no limit";
  const cv::Size w = WorkingSize({2560, 1920}, 1280 * 960);
  EXPECT_EQ(w, cv::Size(1280, 960));
  // Whole factors: the smallest that fits, sides rounded down.
  EXPECT_EQ(WholeFactorWorkingSize({4032, 3024}, 1920 * 1440), cv::Size(1344, 1008));
  EXPECT_EQ(WholeFactorWorkingSize({3840, 2160}, 1920 * 1440), cv::Size(1920, 1080));
  EXPECT_EQ(WholeFactorWorkingSize({1920, 1080}, 1920 * 1440), cv::Size(1920, 1080));
  EXPECT_EQ(WholeFactorWorkingSize({8000, 6000}, 1920 * 1440), cv::Size(1600, 1200));
  EXPECT_EQ(WholeFactorWorkingSize({4031, 3023}, 1920 * 1440), cv::Size(1343, 1007));
  for (const cv::Size image : {cv::Size(5000, 10), cv::Size(12345, 6789), cv::Size(2881, 1921)}) {
    const cv::Size r = WholeFactorWorkingSize(image, 1920 * 1440);
    EXPECT_LE(static_cast<int64_t>(r.width) * r.height, 1920 * 1440) << image;
    EXPECT_GE(r.width, 1);
  }
}

TEST(ResizingTest, CameraForImageScalesTheSameSensorAndRefusesAnotherAspect) {
  CameraModel camera;
  camera.K = kK;
  camera.distortion = {-0.1, 0.01, 0, 0, 0};
  auto as_given = CameraForImage(camera, {1234, 999});
  ASSERT_TRUE(as_given.ok());
  EXPECT_EQ(as_given->K, kK) << "size unset: the intrinsics are the picture's";

  camera.size = {640, 480};
  auto same = CameraForImage(camera, {640, 480});
  ASSERT_TRUE(same.ok());
  EXPECT_EQ(same->K, kK);
  auto larger = CameraForImage(camera, {1920, 1440});
  ASSERT_TRUE(larger.ok()) << larger.status();
  EXPECT_EQ(larger->size, cv::Size(1920, 1440));
  EXPECT_LT(cv::norm(larger->K - ScaledIntrinsics(kK, {640, 480}, {1920, 1440})), 1e-12);
  EXPECT_EQ(larger->distortion, camera.distortion) << "normalised coordinates: unchanged";

  auto wide = CameraForImage(camera, {1920, 1080});
  EXPECT_EQ(wide.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(wide.status().message().find("640x480"), std::string::npos) << wide.status();
}

}  // namespace
}  // namespace texfree
