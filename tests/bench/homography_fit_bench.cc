// Robust homography fitting cost (Google Benchmark): texfree's PROSAC, its RANSAC and
// OpenCV's USAC PROSAC (which LLAH verification used until round 39) on the same pairs, in
// the same run, so their ratio is what to read. Two kinds of input, as LLAH verification
// meets them: a right page's correspondences (ranked best first, 40% of them right) and a
// hopeless candidate's (unrelated pairs), 20 to 150 pairs. Run by hand:
// ./build/tests/bench/texfree-bench-homography
#include <benchmark/benchmark.h>

#include <opencv2/calib3d.hpp>
#include <random>

#include "common/homography_fit.h"

namespace texfree {
namespace {

constexpr double kThreshold = 4.0;  // px, as LLAH verification's at a 10 px text height
constexpr int kIterations = 1000;   // RetrievalOptions::ransac_iterations

struct Pairs {
  std::vector<cv::Point2f> page, view;
};

// `count` pairs ranked best first; `right` of every 10 map the page into a 640x480 view by
// a tilted camera (with 0.7 px of noise), the others are unrelated points.
Pairs MakePairs(int count, int right, uint32_t seed) {
  cv::Matx33d R;
  cv::Rodrigues(cv::Vec3d(0.35, -0.2, 0.4), R);
  const cv::Matx33d K(800, 0, 320, 0, 800, 240, 0, 0, 1);
  const cv::Vec3d t(-500, -700, 2400);
  const cv::Matx33d H =
      K * cv::Matx33d(R(0, 0), R(0, 1), t[0], R(1, 0), R(1, 1), t[1], R(2, 0), R(2, 1), t[2]);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> x(0, 1000), y(0, 1400), u(0, 640), v(0, 480);
  std::normal_distribution<float> noise(0, 0.7f);
  Pairs pairs;
  for (int i = 0; i < count; ++i) {
    const cv::Point2f p(x(rng), y(rng));
    pairs.page.push_back(p);
    if (i % 10 < right) {
      const cv::Vec3d q = H * cv::Vec3d(p.x, p.y, 1);
      pairs.view.emplace_back(static_cast<float>(q[0] / q[2]) + noise(rng),
                              static_cast<float>(q[1] / q[2]) + noise(rng));
    } else {
      pairs.view.emplace_back(u(rng), v(rng));
    }
  }
  return pairs;
}

enum class Method { kProsac, kRansac, kOpenCvUsacProsac };

template <Method method>
void BM_Fit(benchmark::State& state) {
  const int right_per_10 = static_cast<int>(state.range(1));
  const Pairs pairs = MakePairs(static_cast<int>(state.range(0)), right_per_10, 7);
  int found = 0, right = 0;
  for (auto _ : state) {
    cv::Matx33d H;
    std::vector<char> inliers;
    bool ok = false;
    if constexpr (method == Method::kProsac) {
      ok = FitHomographyProsac(pairs.page, pairs.view, kThreshold, kIterations, &H, &inliers);
    } else if constexpr (method == Method::kRansac) {
      ok = FitHomographyRansac(pairs.page, pairs.view, kThreshold, kIterations, &H, &inliers);
    } else {
      std::vector<uchar> mask;
      ok = !cv::findHomography(pairs.page, pairs.view, cv::USAC_PROSAC, kThreshold, mask,
                               kIterations, 0.995)
                .empty();
      inliers.assign(mask.begin(), mask.end());
    }
    found += ok;
    // Right: the consensus holds 90% of the right pairs and at most one other.
    int kept = 0, wrong = 0, truth = 0;
    for (size_t i = 0; ok && i < inliers.size(); ++i) {
      const bool is_right = static_cast<int>(i % 10) < right_per_10;
      truth += is_right;
      (is_right ? kept : wrong) += inliers[i] != 0;
    }
    right += ok && truth > 0 && kept * 10 >= truth * 9 && wrong <= 1;
    benchmark::DoNotOptimize(H);
  }
  // Shares of the runs that returned a homography, and the right one.
  state.counters["found"] = benchmark::Counter(found, benchmark::Counter::kAvgIterations);
  state.counters["right"] = benchmark::Counter(right, benchmark::Counter::kAvgIterations);
}

// Arguments: pairs, right pairs of every 10.
void Inputs(benchmark::internal::Benchmark* b) {
  for (int count : {20, 60, 150}) b->Args({count, 0});
  for (int count : {20, 60, 150}) b->Args({count, 4});
  b->Unit(benchmark::kMicrosecond);
}

BENCHMARK(BM_Fit<Method::kProsac>)->Apply(Inputs);
BENCHMARK(BM_Fit<Method::kRansac>)->Apply(Inputs);
BENCHMARK(BM_Fit<Method::kOpenCvUsacProsac>)->Apply(Inputs);

}  // namespace
}  // namespace texfree

BENCHMARK_MAIN();
