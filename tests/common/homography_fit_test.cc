// Tests of the homography fits against a synthetic camera over a page: exact pairs, noisy
// pairs (least squares against OpenCV's), outliers (RANSAC, and PROSAC on ranked pairs) and
// degenerate input.
#include "common/homography_fit.h"

#include <gtest/gtest.h>

#include <functional>
#include <opencv2/calib3d.hpp>
#include <random>

namespace texfree {
namespace {

// A 640x480 camera (f = 800 px) looking at a 1000 x 1400 px page tilted by about 20°.
cv::Matx33d PageToView() {
  const cv::Matx33d K(800, 0, 320, 0, 800, 240, 0, 0, 1);
  cv::Matx33d R;
  cv::Rodrigues(cv::Vec3d(0.3, -0.2, 0.1), R);
  const cv::Vec3d t(-400, -600, 2200);
  const cv::Matx33d Rt(R(0, 0), R(0, 1), t[0], R(1, 0), R(1, 1), t[1], R(2, 0), R(2, 1), t[2]);
  cv::Matx33d H = K * Rt;
  return H * (1.0 / H(2, 2));
}

cv::Point2f Map(const cv::Matx33d &H, const cv::Point2f &p) {
  const cv::Vec3d q = H * cv::Vec3d(p.x, p.y, 1);
  return {static_cast<float>(q[0] / q[2]), static_cast<float>(q[1] / q[2])};
}

// Largest distance between where two homographies put the page's corners.
double CornerGap(const cv::Matx33d &A, const cv::Matx33d &B) {
  double gap = 0;
  for (const cv::Point2f c :
       {cv::Point2f(0, 0), cv::Point2f(1000, 0), cv::Point2f(1000, 1400), cv::Point2f(0, 1400)})
    gap = std::max(gap, static_cast<double>(cv::norm(Map(A, c) - Map(B, c))));
  return gap;
}

double RmsResidual(const cv::Matx33d &H, const std::vector<cv::Point2f> &src,
                   const std::vector<cv::Point2f> &dst) {
  double sum = 0;
  for (size_t i = 0; i < src.size(); ++i) {
    const cv::Point2f e = Map(H, src[i]) - dst[i];
    sum += e.dot(e);
  }
  return std::sqrt(sum / src.size());
}

// `count` page points and their views, with Gaussian noise of `sigma` px on the views.
void MakePairs(int count, double sigma, uint32_t seed, std::vector<cv::Point2f> *src,
               std::vector<cv::Point2f> *dst) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> x(100, 900), y(100, 1300);
  std::normal_distribution<float> noise(0, static_cast<float>(sigma));
  const cv::Matx33d H = PageToView();
  src->clear();
  dst->clear();
  for (int i = 0; i < count; ++i) {
    const cv::Point2f p(x(rng), y(rng));
    src->push_back(p);
    dst->push_back(Map(H, p) + cv::Point2f(noise(rng), noise(rng)));
  }
}

// `ranks` pairs ranked best first, as LLAH ranks a page's correspondences: at the ranks
// where `right(rank)` holds, the next of `true_count` true pairs (MakePairs, `seed`), while
// they last; unrelated pairs elsewhere. `truth` flags the true ones; returns their number.
int MakeRankedPairs(int ranks, int true_count, double sigma, uint32_t seed,
                    const std::function<bool(int)> &right, std::vector<cv::Point2f> *src,
                    std::vector<cv::Point2f> *dst, std::vector<bool> *truth) {
  std::vector<cv::Point2f> page, view;
  MakePairs(true_count, sigma, seed, &page, &view);
  std::mt19937 rng(seed + 1);
  std::uniform_real_distribution<float> x(0, 1000), y(0, 1400), u(0, 640), v(0, 480);
  size_t next = 0;
  for (int rank = 0; rank < ranks; ++rank) {
    const bool is_true = next < page.size() && right(rank);
    if (is_true) {
      src->push_back(page[next]);
      dst->push_back(view[next++]);
    } else {
      src->emplace_back(x(rng), y(rng));
      dst->emplace_back(u(rng), v(rng));
    }
    truth->push_back(is_true);
  }
  return static_cast<int>(next);
}

// A robust fit (`fit(H, inliers)`) of pairs whose true ones are flagged in `truth`: every
// true pair kept, at most one unrelated one (it may fall within 2 px by chance), the page's
// corners within 1.5 px, and the same answer from a second run.
void ExpectKeepsTheTruePairs(const std::function<bool(cv::Matx33d *, std::vector<char> *)> &fit,
                             const std::vector<bool> &truth) {
  cv::Matx33d H, again;
  std::vector<char> inliers;
  ASSERT_TRUE(fit(&H, &inliers));
  ASSERT_EQ(inliers.size(), truth.size());
  int true_kept = 0, false_kept = 0, true_count = 0;
  for (size_t i = 0; i < truth.size(); ++i) {
    (truth[i] ? true_kept : false_kept) += inliers[i];
    true_count += truth[i];
  }
  EXPECT_EQ(true_kept, true_count);
  EXPECT_LE(false_kept, 1);
  EXPECT_LT(CornerGap(H, PageToView()), 1.5);
  ASSERT_TRUE(fit(&again, nullptr));
  EXPECT_EQ(CornerGap(H, again), 0);
}

TEST(HomographyFitTest, ExactPairsGiveTheHomographyBack) {
  std::vector<cv::Point2f> src, dst;
  for (int count : {4, 5, 30}) {
    MakePairs(count, 0, 7, &src, &dst);
    cv::Matx33d H;
    ASSERT_TRUE(FitHomography(src, dst, &H)) << count;
    EXPECT_NEAR(H(2, 2), 1, 1e-12);
    // Float coordinates: the views carry about 1e-5 px of rounding.
    EXPECT_LT(CornerGap(H, PageToView()), 2e-3) << count;
    EXPECT_LT(RmsResidual(H, src, dst), 1e-4) << count;
  }
}

TEST(HomographyFitTest, NoisyPairsGiveTheLeastSquaresFitAsOpenCvDoes) {
  std::vector<cv::Point2f> src, dst;
  for (uint32_t seed = 1; seed <= 5; ++seed) {
    MakePairs(25, 0.7, seed, &src, &dst);
    cv::Matx33d H;
    ASSERT_TRUE(FitHomography(src, dst, &H));
    // The least-squares fit leaves no more residual than the true homography does.
    EXPECT_LE(RmsResidual(H, src, dst), RmsResidual(PageToView(), src, dst) + 1e-6);
    // And it is OpenCV's (method 0: DLT, then Levenberg-Marquardt) within a few
    // thousandths of a pixel over the whole page.
    const cv::Matx33d reference(cv::findHomography(src, dst, 0));
    EXPECT_LT(CornerGap(H, reference), 0.01) << seed;
    EXPECT_LE(RmsResidual(H, src, dst), RmsResidual(reference, src, dst) + 1e-9) << seed;
    // 0.7 px of noise on 25 points inside the page: its corners, extrapolated, within 3 px
    // of the truth (2.2 px at most over these seeds).
    EXPECT_LT(CornerGap(H, PageToView()), 3.0) << seed;
  }
}

TEST(HomographyFitTest, RansacFindsTheHomographyAmongOutliersDeterministically) {
  std::vector<cv::Point2f> src, dst;
  MakePairs(40, 0.3, 11, &src, &dst);
  std::mt19937 rng(12);
  std::uniform_real_distribution<float> x(0, 1000), y(0, 1400), u(0, 640), v(0, 480);
  for (int i = 0; i < 25; ++i) {  // 38% outliers: pairs of unrelated points
    src.emplace_back(x(rng), y(rng));
    dst.emplace_back(u(rng), v(rng));
  }
  std::vector<bool> truth(src.size(), false);
  std::fill(truth.begin(), truth.begin() + 40, true);
  ExpectKeepsTheTruePairs(
      [&](cv::Matx33d *H, std::vector<char> *inliers) {
        return FitHomographyRansac(src, dst, 2.0, 200, H, inliers);
      },
      truth);
}

TEST(HomographyFitTest, RansacDrawsTheSamplesOpenCvDraws) {
  int same_mask = 0, trials = 0;
  double worst_gap = 0;
  for (uint32_t seed = 1; seed <= 40; ++seed) {
    std::vector<cv::Point2f> src, dst;
    MakePairs(20 + seed % 17, 0.4, seed, &src, &dst);
    std::mt19937 rng(100 + seed);
    std::uniform_real_distribution<float> x(0, 1000), y(0, 1400), u(0, 640), v(0, 480);
    for (uint32_t i = 0; i < 4 + seed % 9; ++i) {
      src.emplace_back(x(rng), y(rng));
      dst.emplace_back(u(rng), v(rng));
    }
    cv::Matx33d H;
    std::vector<char> mask;
    ASSERT_TRUE(FitHomographyRansac(src, dst, 1.5, 50, &H, &mask));
    std::vector<uchar> cv_mask;
    const cv::Matx33d reference(cv::findHomography(src, dst, cv::RANSAC, 1.5, cv_mask, 50));
    ++trials;
    same_mask += std::equal(mask.begin(), mask.end(), cv_mask.begin(),
                            [](char a, uchar b) { return (a != 0) == (b != 0); });
    worst_gap = std::max(worst_gap, CornerGap(H, reference));
  }
  // The same samples, tests and generator give the same consensus, so a caller that moves
  // from cv::findHomography keeps its inliers; the refit on them differs by hundredths of a
  // pixel at most (FitHomography's least squares converge further).
  EXPECT_EQ(same_mask, trials);
  EXPECT_LT(worst_gap, 0.05);
}

// Pairs ranked best first as LLAH ranks them: most of the head are true, the tail mostly
// unrelated (60% of all pairs are outliers).
TEST(HomographyFitTest, ProsacFindsTheHomographyAmongRankedOutliersDeterministically) {
  std::vector<cv::Point2f> src, dst;
  std::vector<bool> truth;
  // Of the first 20 ranks, one in four is an outlier; after them, two in three.
  const int true_pairs = MakeRankedPairs(
      100, 40, 0.3, 21, [](int rank) { return rank < 20 ? rank % 4 != 3 : rank % 3 == 0; }, &src,
      &dst, &truth);
  ASSERT_EQ(true_pairs, 40);
  ExpectKeepsTheTruePairs(
      [&](cv::Matx33d *H, std::vector<char> *inliers) {
        return FitHomographyProsac(src, dst, 2.0, 1000, H, inliers);
      },
      truth);
}

// Few pairs with few of them right, as a candidate page's LLAH correspondences often are: 8
// right of 20, the 5th to 10th ranks wrong. PROSAC must still reach the right model within
// its budget (its growth schedule spread over the budget, not over 200,000 samples).
TEST(HomographyFitTest, ProsacFindsFewRightPairsAmongFewPairs) {
  std::vector<cv::Point2f> src, dst;
  std::vector<bool> truth;
  ASSERT_EQ(MakeRankedPairs(
                20, 8, 0.5, 41, [](int rank) { return rank % 10 < 4; }, &src, &dst, &truth),
            8);
  ExpectKeepsTheTruePairs(
      [&](cv::Matx33d *H, std::vector<char> *inliers) {
        return FitHomographyProsac(src, dst, 2.0, 1000, H, inliers);
      },
      truth);
}

// The best-ranked pairs all lie in one corner of the page, so that their minimal samples'
// homographies are exact there and several pixels off across the page. Local optimisation
// grows such a model into the whole page's consensus instead of stopping at the corner's.
TEST(HomographyFitTest, ProsacGrowsACornersModelIntoTheWholePage) {
  const cv::Matx33d H_true = PageToView();
  std::mt19937 rng(31);
  std::normal_distribution<float> noise(0, 0.5f);
  std::uniform_real_distribution<float> corner(100, 250), x(100, 900), y(100, 1300);
  std::uniform_real_distribution<float> u(0, 640), v(0, 480);
  std::vector<cv::Point2f> src, dst;
  std::vector<bool> truth;
  auto add_true = [&](const cv::Point2f &p) {
    src.push_back(p);
    dst.push_back(Map(H_true, p) + cv::Point2f(noise(rng), noise(rng)));
    truth.push_back(true);
  };
  for (int i = 0; i < 10; ++i) add_true({corner(rng), corner(rng)});
  for (int i = 0; i < 90; ++i) {
    add_true({x(rng), y(rng)});
    if (i % 3 == 0) {  // 30 unrelated pairs among them
      src.emplace_back(x(rng), y(rng));
      dst.emplace_back(u(rng), v(rng));
      truth.push_back(false);
    }
  }
  cv::Matx33d H;
  std::vector<char> inliers;
  ASSERT_TRUE(FitHomographyProsac(src, dst, 2.0, 1000, &H, &inliers));
  int true_kept = 0, false_kept = 0;
  for (size_t i = 0; i < src.size(); ++i) (truth[i] ? true_kept : false_kept) += inliers[i];
  EXPECT_GE(true_kept, 97);  // of 100; 0.5 px noise puts a few beyond 2 px
  EXPECT_LE(false_kept, 1);
  EXPECT_LT(CornerGap(H, H_true), 1.5);
}

TEST(HomographyFitTest, TooFewMismatchedOrCollinearPairsAreRefused) {
  std::vector<cv::Point2f> src, dst;
  cv::Matx33d H;
  MakePairs(3, 0, 3, &src, &dst);
  EXPECT_FALSE(FitHomography(src, dst, &H));
  EXPECT_FALSE(FitHomographyRansac(src, dst, 2, 50, &H));
  EXPECT_FALSE(FitHomographyProsac(src, dst, 2, 50, &H));
  MakePairs(10, 0, 3, &src, &dst);
  dst.pop_back();
  EXPECT_FALSE(FitHomography(src, dst, &H));
  EXPECT_FALSE(FitHomographyRansac(src, dst, 2, 50, &H));
  EXPECT_FALSE(FitHomographyProsac(src, dst, 2, 50, &H));
  // All on one line: no homography is determined.
  src.clear();
  dst.clear();
  for (int i = 0; i < 10; ++i) {
    src.emplace_back(10.f * i, 5.f * i);
    dst.emplace_back(3.f * i, 7.f * i);
  }
  EXPECT_FALSE(FitHomography(src, dst, &H));
  EXPECT_FALSE(FitHomographyRansac(src, dst, 2, 50, &H));
  EXPECT_FALSE(FitHomographyProsac(src, dst, 2, 50, &H));
}

}  // namespace
}  // namespace texfree
