// Tests of the LLAH building blocks: the affine invariant, the learned
// quantiser and the descriptor hashes (invariance to similarity/affine maps and
// to input order, discrimination between unrelated point sets, degenerate
// inputs).
#include "common/llah.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <set>
#include <unordered_set>
#include <vector>

namespace texfree {
namespace {

constexpr double kPi = 3.14159265358979323846;

std::vector<cv::Point2f> RandomPoints(uint32_t seed, int n, float w = 1000, float h = 1400) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> ux(0, w), uy(0, h);
  std::vector<cv::Point2f> pts(n);
  for (auto &p : pts) p = {ux(rng), uy(rng)};
  return pts;
}

// x' = A x + b.
struct Affine {
  cv::Matx22d A;
  cv::Vec2d b;
  cv::Point2f operator()(const cv::Point2f &p) const {
    return {static_cast<float>(A(0, 0) * p.x + A(0, 1) * p.y + b[0]),
            static_cast<float>(A(1, 0) * p.x + A(1, 1) * p.y + b[1])};
  }
  double det() const { return cv::determinant(A); }
};

Affine RandomSimilarity(std::mt19937 &rng) {
  std::uniform_real_distribution<double> angle(-kPi, kPi), log_scale(std::log(0.4), std::log(2.5)),
      shift(-300, 300);
  const double a = angle(rng), s = std::exp(log_scale(rng));
  return {cv::Matx22d(s * std::cos(a), -s * std::sin(a), s * std::sin(a), s * std::cos(a)),
          cv::Vec2d(shift(rng), shift(rng))};
}

// Rotation * diag(s1, s2) * rotation: anisotropy s1/s2 up to max_anisotropy,
// plus an optional reflection.
Affine RandomAffine(std::mt19937 &rng, double max_anisotropy, bool mirror = false) {
  std::uniform_real_distribution<double> angle(-kPi, kPi), scale(0.5, 2.0),
      aniso(1.0, max_anisotropy), shift(-300, 300);
  const double a = angle(rng), b = angle(rng), s = scale(rng), r = aniso(rng);
  const cv::Matx22d Ra(std::cos(a), -std::sin(a), std::sin(a), std::cos(a));
  const cv::Matx22d Rb(std::cos(b), -std::sin(b), std::sin(b), std::cos(b));
  const cv::Matx22d D(s * r, 0, 0, mirror ? -s : s);
  return {Ra * D * Rb, cv::Vec2d(shift(rng), shift(rng))};
}

std::vector<cv::Point2f> Map(const std::vector<cv::Point2f> &pts, const Affine &f) {
  std::vector<cv::Point2f> out;
  out.reserve(pts.size());
  for (const auto &p : pts) out.push_back(f(p));
  return out;
}

double Area2(const cv::Point2d &a, const cv::Point2d &b, const cv::Point2d &c) {
  return (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
}

// Wraps an angle difference into (-pi, pi].
double AngleDiff(double a, double b) {
  double d = std::fmod(a - b, 2 * kPi);
  if (d > kPi) d -= 2 * kPi;
  if (d <= -kPi) d += 2 * kPi;
  return d;
}

InvariantQuantizer LearnQuantizer(const LlahOptions &options, uint32_t seed) {
  LlahDescriber raw(options, InvariantQuantizer());
  std::vector<float> samples;
  raw.CollectInvariants(RandomPoints(seed, 300), &samples);
  auto q = InvariantQuantizer::Learn(std::move(samples), options.k);
  EXPECT_TRUE(q.ok()) << q.status();
  return q.ok() ? *q : InvariantQuantizer();
}

// Brute-force set of the n nearest neighbours of point i.
std::vector<int> NearestSet(const std::vector<cv::Point2f> &pts, int i, int n) {
  std::vector<std::pair<double, int>> d;
  for (int j = 0; j < static_cast<int>(pts.size()); ++j) {
    if (j == i) continue;
    const double dx = pts[j].x - pts[i].x, dy = pts[j].y - pts[i].y;
    d.emplace_back(dx * dx + dy * dy, j);
  }
  std::partial_sort(d.begin(), d.begin() + n, d.end());
  std::vector<int> out;
  for (int k = 0; k < n; ++k) out.push_back(d[k].second);
  std::sort(out.begin(), out.end());
  return out;
}

// Number of hashes of point i in `a` that also occur among point i's hashes in
// `b`, as multisets. The slot of a descriptor depends on where the angular
// order starts, which a rotation shifts; the multiset of a point's descriptors
// does not.
int CommonHashes(const std::vector<uint64_t> &a, const std::vector<uint64_t> &b, int i, int per) {
  std::vector<uint64_t> x(a.begin() + i * per, a.begin() + (i + 1) * per);
  std::vector<uint64_t> y(b.begin() + i * per, b.begin() + (i + 1) * per);
  std::sort(x.begin(), x.end());
  std::sort(y.begin(), y.end());
  std::vector<uint64_t> common;
  std::set_intersection(x.begin(), x.end(), y.begin(), y.end(), std::back_inserter(common));
  return static_cast<int>(common.size());
}

// ----------------------------------------------------------------
// AffineInvariant

TEST(AffineInvariantTest, MatchesDefinitionOnAreas) {
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> u(0, 1000);
  for (int t = 0; t < 1000; ++t) {
    const cv::Point2f a(u(rng), u(rng)), b(u(rng), u(rng)), c(u(rng), u(rng)), d(u(rng), u(rng));
    const double expected = std::atan2(Area2(a, c, d), Area2(a, b, c));
    EXPECT_NEAR(AffineInvariant(a, b, c, d), expected, 1e-4);
  }
}

TEST(AffineInvariantTest, UnchangedByAffineMapsWithPositiveDeterminant) {
  std::mt19937 rng(2);
  std::uniform_real_distribution<float> u(0, 1000);
  int checked = 0;
  for (int t = 0; t < 2000; ++t) {
    const cv::Point2f a(u(rng), u(rng)), b(u(rng), u(rng)), c(u(rng), u(rng)), d(u(rng), u(rng));
    // Skip near-degenerate quadruples where both areas are tiny: there the
    // invariant is ill-conditioned in any float implementation.
    if (std::max(std::abs(Area2(a, c, d)), std::abs(Area2(a, b, c))) < 2000) continue;
    const Affine f = RandomAffine(rng, 3.0);
    ASSERT_GT(f.det(), 0);
    const double before = AffineInvariant(a, b, c, d);
    const double after = AffineInvariant(f(a), f(b), f(c), f(d));
    EXPECT_NEAR(AngleDiff(after, before), 0.0, 1e-4) << "trial " << t;
    ++checked;
  }
  EXPECT_GT(checked, 1900);
}

TEST(AffineInvariantTest, MirrorShiftsByPi) {
  // Both areas change sign under a reflection: atan2(-y, -x) = atan2(y, x) +
  // pi.
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(0, 1000);
  for (int t = 0; t < 500; ++t) {
    const cv::Point2f a(u(rng), u(rng)), b(u(rng), u(rng)), c(u(rng), u(rng)), d(u(rng), u(rng));
    if (std::max(std::abs(Area2(a, c, d)), std::abs(Area2(a, b, c))) < 2000) continue;
    const Affine f = RandomAffine(rng, 2.0, /*mirror=*/true);
    ASSERT_LT(f.det(), 0);
    const double before = AffineInvariant(a, b, c, d);
    const double after = AffineInvariant(f(a), f(b), f(c), f(d));
    EXPECT_NEAR(std::abs(AngleDiff(after, before)), kPi, 1e-4);
  }
}

TEST(AffineInvariantTest, DefinedForCollinearPoints) {
  // area(a,b,c) = 0: the invariant is still finite (+-pi/2 or 0).
  const float v = AffineInvariant({0, 0}, {1, 0}, {2, 0}, {0, 1});
  EXPECT_TRUE(std::isfinite(v));
  EXPECT_NEAR(std::abs(v), kPi / 2, 1e-6);
  EXPECT_TRUE(std::isfinite(AffineInvariant({0, 0}, {0, 0}, {0, 0}, {0, 0})));
}

// ----------------------------------------------------------------
// InvariantQuantizer

// Coarser levels keep every other (every k-th) threshold: the same quantiles, fewer levels.
TEST(InvariantQuantizerTest, CoarserKeepsEveryStepThThreshold) {
  const InvariantQuantizer q({1, 2, 3, 4, 5, 6, 7});
  EXPECT_EQ(q.Coarser(4).thresholds(), (std::vector<float>{2, 4, 6}));
  EXPECT_EQ(q.Coarser(2).thresholds(), (std::vector<float>{4}));
  EXPECT_EQ(q.Coarser(4).Quantize(3.5f), 1);
  EXPECT_EQ(q.Coarser(3).thresholds(), q.thresholds()) << "3 does not divide 8 levels";
  EXPECT_EQ(q.Coarser(8).thresholds(), q.thresholds());
}

TEST(InvariantQuantizerTest, LearnSplitsSamplesIntoEqualLevels) {
  std::mt19937 rng(4);
  std::normal_distribution<float> g(0.3f, 1.1f);
  for (int k : {2, 3, 5, 8}) {
    std::vector<float> samples(20000);
    for (auto &s : samples) s = g(rng);
    auto q = InvariantQuantizer::Learn(samples, k);
    ASSERT_TRUE(q.ok()) << q.status();
    ASSERT_EQ(q->thresholds().size(), static_cast<size_t>(k - 1));
    EXPECT_EQ(q->levels(), k);
    EXPECT_TRUE(std::is_sorted(q->thresholds().begin(), q->thresholds().end()));
    // Count levels on the training samples and on fresh samples of the same
    // distribution.
    for (int pass = 0; pass < 2; ++pass) {
      if (pass == 1)
        for (auto &s : samples) s = g(rng);
      std::vector<int> count(k, 0);
      for (float s : samples) {
        const int level = q->Quantize(s);
        ASSERT_GE(level, 0);
        ASSERT_LT(level, k);
        ++count[level];
      }
      for (int l = 0; l < k; ++l) {
        EXPECT_NEAR(static_cast<double>(count[l]) / samples.size(), 1.0 / k, 0.02)
            << "k=" << k << " level " << l << " pass " << pass;
      }
    }
  }
}

TEST(InvariantQuantizerTest, LearnOnRealInvariantsIsBalanced) {
  LlahOptions options;
  LlahDescriber raw(options, InvariantQuantizer());
  std::vector<float> train, test;
  raw.CollectInvariants(RandomPoints(5, 300), &train);
  raw.CollectInvariants(RandomPoints(6, 300), &test);
  auto q = InvariantQuantizer::Learn(train, options.k);
  ASSERT_TRUE(q.ok()) << q.status();
  std::vector<int> count(options.k, 0);
  for (float s : test) ++count[q->Quantize(s)];
  for (int l = 0; l < options.k; ++l)
    EXPECT_NEAR(static_cast<double>(count[l]) / test.size(), 1.0 / options.k, 0.02) << l;
}

TEST(InvariantQuantizerTest, QuantizeIsMonotoneAndUsesUpperBound) {
  const InvariantQuantizer q({-1.f, 0.f, 2.f});
  EXPECT_EQ(q.levels(), 4);
  EXPECT_EQ(q.Quantize(-5.f), 0);
  EXPECT_EQ(q.Quantize(-1.f), 1);  // a value equal to a threshold goes above it
  EXPECT_EQ(q.Quantize(-0.5f), 1);
  EXPECT_EQ(q.Quantize(0.f), 2);
  EXPECT_EQ(q.Quantize(1.9f), 2);
  EXPECT_EQ(q.Quantize(2.f), 3);
  EXPECT_EQ(q.Quantize(100.f), 3);
  EXPECT_TRUE(InvariantQuantizer().empty());
  EXPECT_EQ(InvariantQuantizer().levels(), 1);
}

TEST(InvariantQuantizerTest, LearnRefusesTooFewSamples) {
  std::vector<float> samples(149);
  std::iota(samples.begin(), samples.end(), 0.f);
  auto q = InvariantQuantizer::Learn(samples, 3);  // needs 50 * 3
  ASSERT_FALSE(q.ok());
  EXPECT_EQ(q.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_NE(q.status().message().find("150"), std::string::npos) << q.status();
  samples.push_back(149.f);
  EXPECT_TRUE(InvariantQuantizer::Learn(samples, 3).ok());
  EXPECT_EQ(InvariantQuantizer::Learn({}, 2).status().code(),
            absl::StatusCode::kFailedPrecondition);
}

TEST(InvariantQuantizerTest, LearnRejectsFewerThanTwoLevels) {
  std::vector<float> samples(1000, 1.f);
  EXPECT_EQ(InvariantQuantizer::Learn(samples, 1).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(InvariantQuantizer::Learn(samples, 0).status().code(),
            absl::StatusCode::kInvalidArgument);
}

// ---------------------------------------------------------------- LlahOptions

TEST(LlahOptionsTest, CountsAreBinomials) {
  struct Case {
    int n, m, per_point, per_descriptor;
  };
  for (const Case &c : {Case{7, 6, 7, 15}, Case{7, 5, 21, 5}, Case{8, 6, 28, 15}, Case{6, 4, 15, 1},
                        Case{10, 5, 252, 5}, Case{10, 10, 1, 210}}) {
    LlahOptions o;
    o.n = c.n;
    o.m = c.m;
    ASSERT_TRUE(o.Validate().ok()) << o.Validate();
    EXPECT_EQ(o.DescriptorsPerPoint(), c.per_point) << c.n << "," << c.m;
    EXPECT_EQ(o.InvariantsPerDescriptor(), c.per_descriptor) << c.n << "," << c.m;
    LlahDescriber d(o, InvariantQuantizer({0.f}));
    EXPECT_EQ(d.descriptors_per_point(), c.per_point);
  }
}

TEST(LlahOptionsTest, ValidateRejectsBadValues) {
  auto with = [](int n, int m, int k) {
    LlahOptions o;
    o.n = n;
    o.m = m;
    o.k = k;
    return o.Validate();
  };
  EXPECT_TRUE(with(7, 6, 3).ok());
  EXPECT_EQ(with(7, 3, 3).code(), absl::StatusCode::kInvalidArgument);  // m < 4
  EXPECT_EQ(with(5, 6, 3).code(), absl::StatusCode::kInvalidArgument);  // m > n
  EXPECT_EQ(with(11, 6, 3).code(),
            absl::StatusCode::kInvalidArgument);                        // n too large
  EXPECT_EQ(with(7, 6, 1).code(), absl::StatusCode::kInvalidArgument);  // k < 2
  EXPECT_EQ(with(7, 6, 65).code(),
            absl::StatusCode::kInvalidArgument);  // k > 64
}

// ----------------------------------------------------------------
// LlahDescriber

class LlahDescriberTest : public ::testing::Test {
 protected:
  LlahDescriberTest() : describer_(options_, LearnQuantizer(options_, 100)) {}
  LlahOptions options_;
  LlahDescriber describer_;
};

TEST_F(LlahDescriberTest, OutputLayoutAndNonZeroHashes) {
  const auto pts = RandomPoints(7, 300);
  std::vector<uint64_t> hashes;
  describer_.Describe(pts, &hashes);
  ASSERT_EQ(hashes.size(), pts.size() * options_.DescriptorsPerPoint());
  EXPECT_EQ(std::count(hashes.begin(), hashes.end(), 0u), 0);
  // Distinct subsets of one point give (almost always) distinct descriptors.
  std::unordered_set<uint64_t> distinct(hashes.begin(), hashes.end());
  EXPECT_GT(distinct.size(), hashes.size() * 9 / 10);
}

TEST_F(LlahDescriberTest, SimilarityMapKeepsHashes) {
  std::mt19937 rng(8);
  const int per = describer_.descriptors_per_point();
  for (int trial = 0; trial < 4; ++trial) {
    const auto pts = RandomPoints(20 + trial, 300);
    const Affine f = RandomSimilarity(rng);
    const auto mapped = Map(pts, f);
    std::vector<uint64_t> a, b;
    describer_.Describe(pts, &a);
    describer_.Describe(mapped, &b);
    int same = 0;
    for (int i = 0; i < static_cast<int>(pts.size()); ++i) same += CommonHashes(a, b, i, per);
    EXPECT_GE(same, 0.97 * a.size()) << "trial " << trial << ": " << same << "/" << a.size();
  }
}

TEST_F(LlahDescriberTest, AffineMapKeepsHashesOfPointsWithStableNeighbours) {
  // An anisotropic map changes which points are nearest, which LLAH tolerates
  // through redundancy (C(n, m) subsets), not through identical hashes. The
  // invariants themselves must survive: where the n-nearest set is unchanged,
  // the hashes must be too.
  std::mt19937 rng(9);
  const int per = describer_.descriptors_per_point();
  for (int trial = 0; trial < 4; ++trial) {
    const auto pts = RandomPoints(30 + trial, 300);
    const Affine f = RandomAffine(rng, 1.5);
    const auto mapped = Map(pts, f);
    std::vector<uint64_t> a, b;
    describer_.Describe(pts, &a);
    describer_.Describe(mapped, &b);
    int stable_points = 0, same = 0;
    for (int i = 0; i < static_cast<int>(pts.size()); ++i) {
      if (NearestSet(pts, i, options_.n) != NearestSet(mapped, i, options_.n)) continue;
      ++stable_points;
      same += CommonHashes(a, b, i, per);
    }
    ASSERT_GT(stable_points, 30) << "trial " << trial;
    EXPECT_GE(same, 0.97 * stable_points * per)
        << "trial " << trial << ": " << same << "/" << stable_points * per;
  }
}

// Multi-probe: slot 0 of each descriptor is the exact hash; under point noise
// (which moves invariants across level boundaries) the probes recover many
// reference hashes the exact hashes lose, and never fewer.
TEST_F(LlahDescriberTest, ProbesRecoverHashesLostToQuantisationNoise) {
  std::mt19937 rng(12);
  std::normal_distribution<float> noise(0.f, 1.5f);  // points ~60 px apart
  const int per = describer_.descriptors_per_point();
  const auto pts = RandomPoints(40, 400);
  auto noisy = pts;
  for (auto &p : noisy) p += cv::Point2f(noise(rng), noise(rng));
  std::vector<uint64_t> reference, exact, probed;
  describer_.Describe(pts, &reference);
  describer_.Describe(noisy, &exact);
  describer_.DescribeWithProbes(noisy, 2, &probed);
  ASSERT_EQ(probed.size(), exact.size() * 4);
  const std::unordered_set<uint64_t> registered(reference.begin(), reference.end());
  int found_exact = 0, found_probed = 0;
  for (size_t i = 0; i < pts.size(); ++i) {
    for (int s = 0; s < per; ++s) {
      const uint64_t *variants = &probed[(i * per + s) * 4];
      ASSERT_EQ(variants[0], exact[i * per + s]) << "slot 0 is the exact descriptor";
      bool any = false;
      for (int v = 0; v < 4; ++v) any |= variants[v] != 0 && registered.count(variants[v]) > 0;
      found_exact += registered.count(exact[i * per + s]) > 0;
      found_probed += any;
    }
  }
  EXPECT_LT(found_exact, 0.9 * exact.size()) << "the noise must disturb some descriptors";
  EXPECT_GE(found_probed, 1.3 * found_exact)
      << found_exact << " exact, " << found_probed << " with probes, of " << exact.size();
}

TEST_F(LlahDescriberTest, InputOrderDoesNotMatter) {
  const auto pts = RandomPoints(40, 300);
  std::vector<int> perm(pts.size());
  std::iota(perm.begin(), perm.end(), 0);
  std::shuffle(perm.begin(), perm.end(), std::mt19937(41));
  std::vector<cv::Point2f> shuffled(pts.size());
  for (size_t j = 0; j < perm.size(); ++j) shuffled[j] = pts[perm[j]];  // new j = old perm[j]
  std::vector<uint64_t> a, b;
  describer_.Describe(pts, &a);
  describer_.Describe(shuffled, &b);
  const int per = describer_.descriptors_per_point();
  for (size_t j = 0; j < perm.size(); ++j) {
    for (int s = 0; s < per; ++s) {
      ASSERT_EQ(b[j * per + s], a[perm[j] * per + s]) << "point " << j << " slot " << s;
    }
  }
}

TEST(LlahDescriberDefaultsTest, DifferentPointSetsRarelyCollide) {
  // Six points have only 12 - 6 = 6 affine degrees of freedom, so the 15
  // quantised invariants of a descriptor are strongly dependent and the
  // descriptors of random point sets are far from uniform over k^15 values:
  // with the defaults (n=7, m=6, k=8) about 5% of one random set's hashes occur
  // in another (measured 5.4% here; k=3 gives ~55%). Voting and RANSAC absorb
  // that; the bound guards against a regression in entropy (e.g. a quantiser or
  // rotation-canonicalisation bug), and the ratio to the ~100% kept under a
  // similarity map is what makes retrieval work.
  LlahOptions options;
  options.n = 7;
  options.m = 6;
  options.k = 8;
  const LlahDescriber describer(options, LearnQuantizer(options, 100));
  for (uint32_t seed : {50u, 52u, 54u}) {
    std::vector<uint64_t> a, b;
    describer.Describe(RandomPoints(seed, 300), &a);
    describer.Describe(RandomPoints(seed + 1, 300), &b);
    const std::unordered_set<uint64_t> in_a(a.begin(), a.end());
    int collisions = 0;
    for (uint64_t h : b) collisions += in_a.count(h) ? 1 : 0;
    EXPECT_LT(collisions, 0.08 * b.size()) << collisions << "/" << b.size();
  }
}

TEST_F(LlahDescriberTest, TooFewNeighboursGiveZeroHashes) {
  const int per = describer_.descriptors_per_point();
  std::vector<uint64_t> hashes;
  // n + 1 points: every point has exactly n neighbours.
  auto pts = RandomPoints(60, options_.n + 1, 100, 100);
  describer_.Describe(pts, &hashes);
  ASSERT_EQ(hashes.size(), pts.size() * per);
  EXPECT_EQ(std::count(hashes.begin(), hashes.end(), 0u), 0);
  // n points: n - 1 neighbours each, no descriptor at all.
  pts.pop_back();
  hashes.assign(3, 77);
  describer_.Describe(pts, &hashes);
  ASSERT_EQ(hashes.size(), pts.size() * per);
  EXPECT_EQ(std::count(hashes.begin(), hashes.end(), 0u), static_cast<long>(hashes.size()));
  // Empty input.
  describer_.Describe({}, &hashes);
  EXPECT_TRUE(hashes.empty());
}

TEST_F(LlahDescriberTest, DescribeSubsetMatchesDescribeAndLeavesOtherSlots) {
  const auto pts = RandomPoints(70, 200);
  const int per = describer_.descriptors_per_point();
  std::vector<uint64_t> full;
  describer_.Describe(pts, &full);
  const std::vector<int> which = {0, 5, 17, 199, 100};
  std::vector<uint64_t> part(pts.size() * per, 12345);
  describer_.DescribeSubset(pts, which, &part);
  const std::set<int> chosen(which.begin(), which.end());
  for (int i = 0; i < static_cast<int>(pts.size()); ++i) {
    for (int s = 0; s < per; ++s) {
      if (chosen.count(i)) {
        EXPECT_EQ(part[i * per + s], full[i * per + s]) << i;
      } else {
        EXPECT_EQ(part[i * per + s], 12345u) << i;
      }
    }
  }
}

TEST_F(LlahDescriberTest, CollectInvariantsCountsAndRange) {
  const auto pts = RandomPoints(80, 120);
  std::vector<float> inv;
  describer_.CollectInvariants(pts, &inv);
  // C(n, 4) quadruples x 4 cyclic starts per point.
  const int per_point = 35 * 4;
  ASSERT_EQ(inv.size(), pts.size() * per_point);
  for (float v : inv) {
    ASSERT_TRUE(std::isfinite(v));
    ASSERT_LE(std::abs(v), kPi + 1e-5);
  }
  std::vector<float> few;
  describer_.CollectInvariants(RandomPoints(81, options_.n), &few);
  EXPECT_TRUE(few.empty());
}

// Registered pages keep their descriptor hashes in the database (setting
// llah.hash_version): any change to the hash function, however it is computed,
// must change that version. The fingerprints below were taken from the
// reference implementation (atan2 invariants, lexicographic canonical rotation).
// The point sets include the hard cases: points sharing a direction from their
// centre, collinear quadruples (zero areas) and invariants on the learned
// thresholds themselves (the quantiser's training points described again).
uint64_t Fingerprint(const std::vector<uint64_t> &hashes) {
  uint64_t f = 1469598103934665603ull;  // FNV-1a over the hashes in order
  for (uint64_t h : hashes) f = (f ^ h) * 1099511628211ull;
  return f;
}

TEST(LlahHashStabilityTest, HashesAreThoseStoredByEarlierVersions) {
  LlahOptions options;
  // Random points, then a regular grid (many equal angles and zero areas), then a
  // jittered grid quantised to quarter pixels (near-equal angles).
  std::vector<cv::Point2f> pts = RandomPoints(2024, 1500);
  for (int y = 0; y < 20; ++y)
    for (int x = 0; x < 20; ++x) pts.emplace_back(2000 + 30.0f * x, 40.0f * y);
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> jitter(-6, 6);
  for (int y = 0; y < 20; ++y)
    for (int x = 0; x < 20; ++x)
      pts.emplace_back(3000 + 25.0f * x + jitter(rng) * 0.25f, 30.0f * y + jitter(rng) * 0.25f);
  LlahDescriber sampler(options, InvariantQuantizer());
  std::vector<float> samples;
  sampler.CollectInvariants(pts, &samples);
  auto quantizer = InvariantQuantizer::Learn(samples, options.k);
  ASSERT_TRUE(quantizer.ok());
  const LlahDescriber describer(options, *quantizer);
  std::vector<uint64_t> hashes;
  describer.Describe(pts, &hashes);
  EXPECT_EQ(Fingerprint(hashes), 11476328182685511305ull);
  describer.DescribeWithProbes(pts, 2, &hashes);
  EXPECT_EQ(Fingerprint(hashes), 18434784175329760127ull);
}

}  // namespace
}  // namespace texfree
