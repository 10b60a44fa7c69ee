// Tests of EstimateTextPerspective: keypoints of a synthetic text page seen by a tilted
// pinhole camera are rectified to an affine image of the page; views close to fronto-parallel
// and too few keypoints are left alone.
#include "common/text_perspective.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "tests/data/camera_view.h"

namespace texfree {
namespace {

// Word centres of a page in columns of lines, with random word lengths, paragraph gaps and
// jitter (page pixels).
std::vector<cv::Point2f> PageWords(uint64_t seed, const cv::Size &page) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0, 1);
  std::vector<cv::Point2f> words;
  const double line = 28;
  for (double y = 80; y < page.height - 80; y += line) {
    if (unit(rng) < 0.08) continue;  // paragraph gap
    double x = 80 + (unit(rng) < 0.15 ? 40 : 0);
    while (true) {
      const double w = 30 + 90 * unit(rng);
      if (x + w > page.width - 80) break;
      words.emplace_back(static_cast<float>(x + w / 2), static_cast<float>(y + 2 * unit(rng)));
      x += w + 14;
    }
  }
  return words;
}

struct ProjectedView {
  std::vector<cv::Point2f> image;  // keypoints inside the image
  std::vector<cv::Point2f> page;   // their page positions
  cv::Matx33d camera_matrix;
};

ProjectedView Project(const std::vector<cv::Point2f> &words, const cv::Size &page_size,
                      double tilt_deg, double azimuth_deg, double scale) {
  testdata::CameraViewOptions o;
  o.tilt_deg = tilt_deg;
  o.tilt_azimuth_deg = azimuth_deg;
  o.roll_deg = 20;
  o.scale = scale;
  const testdata::CameraView view = testdata::ComputeCameraGeometry(page_size, o);
  ProjectedView out;
  out.camera_matrix = view.camera_matrix;
  for (const cv::Point2f &w : words) {
    const cv::Vec3d p = view.homography * cv::Vec3d(w.x, w.y, 1);
    const cv::Point2f q(static_cast<float>(p[0] / p[2]), static_cast<float>(p[1] / p[2]));
    if (q.x < 0 || q.y < 0 || q.x >= o.image_size.width || q.y >= o.image_size.height) continue;
    out.image.push_back(q);
    out.page.push_back(w);
  }
  return out;
}

// The least-squares affine map from -> to: x (3x2) minimising |A x - b| with the rows of A
// = (from, 1) and of b = to.
struct AffineFit {
  cv::Mat A, b, x;
};
AffineFit FitAffine(const std::vector<cv::Point2f> &from, const std::vector<cv::Point2f> &to) {
  AffineFit f;
  f.A.create(static_cast<int>(from.size()), 3, CV_64F);
  f.b.create(static_cast<int>(from.size()), 2, CV_64F);
  for (int i = 0; i < f.A.rows; ++i) {
    f.A.at<double>(i, 0) = from[i].x;
    f.A.at<double>(i, 1) = from[i].y;
    f.A.at<double>(i, 2) = 1;
    f.b.at<double>(i, 0) = to[i].x;
    f.b.at<double>(i, 1) = to[i].y;
  }
  cv::solve(f.A, f.b, f.x, cv::DECOMP_SVD);
  return f;
}

// How far `from` -> `to` is from affine: RMS residual of the least-squares affine map,
// relative to the RMS spread of `to`.
double AffineResidual(const std::vector<cv::Point2f> &from, const std::vector<cv::Point2f> &to) {
  const AffineFit f = FitAffine(from, to);
  const cv::Mat &b = f.b;
  const cv::Mat r = f.A * f.x - b;
  cv::Scalar mean = cv::mean(b);
  double spread = 0;
  for (int i = 0; i < b.rows; ++i)
    spread += std::pow(b.at<double>(i, 0) - mean[0], 2) + std::pow(b.at<double>(i, 1) - mean[1], 2);
  return std::sqrt(cv::norm(r, cv::NORM_L2SQR) / spread);
}

TEST(TextPerspectiveTest, SteepViewsBecomeAlmostAffine) {
  const cv::Size page(1000, 1414);
  const auto words = PageWords(3, page);
  for (double azimuth : {0.0, 70.0, 160.0, 250.0}) {
    for (double tilt : {30.0, 40.0}) {
      const ProjectedView view = Project(words, page, tilt, azimuth, 0.8);
      ASSERT_GT(view.image.size(), 100u);
      const auto P = EstimateTextPerspective(view.image);
      ASSERT_TRUE(P.has_value()) << "tilt " << tilt << " azimuth " << azimuth;
      const double before = AffineResidual(view.page, view.image);
      const double after = AffineResidual(view.page, ApplyPerspective(*P, view.image));
      // The projective part is what moves LLAH's invariants; most of it must be gone.
      EXPECT_LT(after, 0.3 * before)
          << "tilt " << tilt << " azimuth " << azimuth << ": " << before << " -> " << after;
    }
  }
}

// Smaller over larger singular value of the least-squares affine map from -> to: 1 for a
// similarity, cos(tilt) for a page foreshortened by a tilt.
double Anisotropy(const std::vector<cv::Point2f> &from, const std::vector<cv::Point2f> &to) {
  cv::Mat w;
  cv::SVD::compute(FitAffine(from, to).x.rowRange(0, 2), w);
  return w.at<double>(1) / w.at<double>(0);
}

// With the focal length the rectified keypoints are close to a similarity image of the page,
// so LLAH's nearest neighbours are the page's; without it they stay squeezed by cos(tilt).
TEST(TextPerspectiveTest, FocalLengthAlsoUndoesTheForeshortening) {
  const cv::Size page(1000, 1414);
  const auto words = PageWords(7, page);
  for (double azimuth : {0.0, 70.0, 160.0, 250.0}) {
    const ProjectedView view = Project(words, page, 40, azimuth, 0.8);
    ASSERT_GT(view.image.size(), 100u);
    TextPerspectiveOptions o;
    const auto affine = EstimateTextPerspective(view.image, o);
    o.focal_px = view.camera_matrix(0, 0);
    o.principal_point = {view.camera_matrix(0, 2), view.camera_matrix(1, 2)};
    const auto metric = EstimateTextPerspective(view.image, o);
    ASSERT_TRUE(affine.has_value() && metric.has_value()) << "azimuth " << azimuth;
    const double squeezed = Anisotropy(view.page, ApplyPerspective(*affine, view.image));
    const double restored = Anisotropy(view.page, ApplyPerspective(*metric, view.image));
    EXPECT_LT(squeezed, 0.85) << "azimuth " << azimuth;
    EXPECT_GT(restored, 0.93) << "azimuth " << azimuth << ": affine only " << squeezed;
    // Still an affine image of the page: the projective part stays removed.
    EXPECT_LT(AffineResidual(view.page, ApplyPerspective(*metric, view.image)),
              0.3 * AffineResidual(view.page, view.image))
        << "azimuth " << azimuth;
  }
}

TEST(TextPerspectiveTest, FrontoParallelViewIsLeftAlone) {
  const cv::Size page(1000, 1414);
  const ProjectedView view = Project(PageWords(5, page), page, 0, 0, 0.8);
  EXPECT_FALSE(EstimateTextPerspective(view.image).has_value());
}

TEST(TextPerspectiveTest, TooFewKeypointsGiveNoEstimate) {
  const cv::Size page(1000, 1414);
  ProjectedView view = Project(PageWords(5, page), page, 35, 0, 0.8);
  view.image.resize(12);
  EXPECT_FALSE(EstimateTextPerspective(view.image).has_value());
}

TEST(TextPerspectiveTest, OptionsValidateExplainsWhatIsWrong) {
  TextPerspectiveOptions o;
  EXPECT_TRUE(o.Validate().ok());
  o.max_depth_ratio = 1.0;
  EXPECT_FALSE(o.Validate().ok());
  o = {};
  o.neighbour = 0;
  EXPECT_NE(o.Validate().message().find("neighbour"), absl::string_view::npos);
}

}  // namespace
}  // namespace texfree
