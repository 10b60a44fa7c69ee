// LLAH describing cost (Google Benchmark): the descriptors of every word keypoint
// of a rendered page, exact (registration, tracking) and with multi-probe
// (retrieval queries). Run by hand: ./build/tests/bench/texfree-bench-llah
#include <benchmark/benchmark.h>

#include <opencv2/imgproc.hpp>

#include "common/llah.h"
#include "common/word_keypoints.h"
#include "tests/data/page_renderer.h"

namespace texfree {
namespace {

struct Page {
  std::vector<cv::Point2f> keypoints;
  LlahDescriber describer{LlahOptions(), InvariantQuantizer()};
};

const Page& RenderedPage() {
  static const Page* page = [] {
    cv::Mat gray;
    cv::cvtColor(testdata::RenderTextPage(4242).image, gray, cv::COLOR_BGR2GRAY);
    auto* p = new Page;
    p->keypoints = WordKeypointExtractor().Extract(gray).points;
    const LlahOptions options;
    std::vector<float> samples;
    LlahDescriber(options, InvariantQuantizer()).CollectInvariants(p->keypoints, &samples);
    p->describer = LlahDescriber(options, *InvariantQuantizer::Learn(samples, options.k));
    return p;
  }();
  return *page;
}

void BM_Describe(benchmark::State& state) {
  const Page& page = RenderedPage();
  std::vector<uint64_t> hashes;
  for (auto _ : state) {
    page.describer.DescribeWithProbes(page.keypoints, static_cast<int>(state.range(0)), &hashes);
    benchmark::DoNotOptimize(hashes.data());
  }
  state.counters["keypoints"] = static_cast<double>(page.keypoints.size());
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(page.keypoints.size()));
}
BENCHMARK(BM_Describe)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace texfree

BENCHMARK_MAIN();
