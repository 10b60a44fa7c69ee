// Word segmentation benchmark: how often each word-keypoint extractor finds exactly one
// keypoint per printed word, on the sharp registration pages and on camera views of them
// (tilt up to 40 deg, scale 0.6-1.3, blur, noise, uneven light, JPEG: the retrieval
// benchmark's views). LLAH matches a photo to a page only where both were cut into the same
// words, so this is the number retrieval accuracy rests on; the renderer's word boxes are
// the ground truth.
//
//   texfree-bench-words --pages 40 --views 3 [--fonts liberation]
#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <string>
#include <vector>

#include "common/word_keypoints.h"
#include "tests/data/camera_view.h"
#include "tests/data/page_renderer.h"

namespace {

struct Counts {
  long words = 0;      // printed words fully inside the image
  long one = 0;        // ...holding exactly one keypoint
  long split = 0;      // ...holding two or more
  long keypoints = 0;  // all keypoints
  long unique = 0;     // keypoints alone in their word
  void Add(const Counts &o) {
    words += o.words;
    one += o.one;
    split += o.split;
    keypoints += o.keypoints;
    unique += o.unique;
  }
};

// Word boxes mapped by H into the image; a keypoint belongs to the word whose quadrilateral
// holds it.
Counts Score(const std::vector<cv::Rect> &boxes, const cv::Matx33d &H, const cv::Size &image,
             const std::vector<cv::Point2f> &points) {
  Counts c;
  c.keypoints = static_cast<long>(points.size());
  std::vector<int> owner(points.size(), -1), per_word;
  std::vector<std::vector<cv::Point2f>> quads;
  for (const cv::Rect &b : boxes) {
    std::vector<cv::Point2f> in{cv::Point2f(b.x, b.y), cv::Point2f(b.x + b.width, b.y),
                                cv::Point2f(b.x + b.width, b.y + b.height),
                                cv::Point2f(b.x, b.y + b.height)},
        out;
    cv::perspectiveTransform(in, out, cv::Matx33f(H));
    bool inside = true;
    for (const auto &p : out)
      inside = inside && p.x >= 2 && p.y >= 2 && p.x < image.width - 2 && p.y < image.height - 2;
    if (!inside) continue;
    quads.push_back(out);
  }
  per_word.assign(quads.size(), 0);
  for (size_t i = 0; i < points.size(); ++i)
    for (size_t w = 0; w < quads.size(); ++w)
      if (cv::pointPolygonTest(quads[w], points[i], false) >= 0) {
        owner[i] = static_cast<int>(w);
        ++per_word[w];
        break;
      }
  c.words = static_cast<long>(quads.size());
  for (int n : per_word) {
    if (n == 1) ++c.one;
    if (n >= 2) ++c.split;
  }
  for (int o : owner)
    if (o >= 0 && per_word[static_cast<size_t>(o)] == 1) ++c.unique;
  return c;
}

}  // namespace

int main(int argc, char **argv) {
  CLI::App app{"texfree word segmentation benchmark"};
  int pages = 40, views = 3;
  std::string dump;
  double max_tilt = 40, max_blur = -1;
  app.add_option("--max-tilt", max_tilt, "largest camera tilt, degrees");
  app.add_option("--max-blur", max_blur,
                 "largest lens blur sigma, px (default: the view generator's)");
  app.add_option("--pages", pages, "rendered pages");
  app.add_option("--views", views, "camera views per page");
  app.add_option("--dump", dump, "folder to write the first views with keypoints drawn");
  struct Named {
    std::string name;
    texfree::WordKeypointOptions options;
  };
  std::vector<Named> extractors;
  extractors.push_back({"line closing 0.25", {}});
  texfree::WordKeypointOptions graph;
  graph.grouping = texfree::WordGrouping::kLetterGraph;
  extractors.push_back({"letter graph", graph});
  texfree::WordKeypointOptions wide;
  wide.gap_factor = 0.35;
  extractors.push_back({"line closing 0.35", wide});

  bool per_page = false;
  app.add_flag("--per-page", per_page,
               "print each page's sharp counts (which pages a font set's misses come from)");
  std::string fonts = "dejavu";
  app.add_option("--fonts", fonts,
                 "font set of the pages: dejavu (the one the extractors were tuned on), "
                 "liberation, freefont, latinmodern or all (held out)");

  CLI11_PARSE(app, argc, argv);
  texfree::testdata::PageOptions page_options;
  if (auto set = texfree::testdata::AvailableFontSet(fonts); set.ok()) {
    page_options.fonts = *set;
  } else {
    std::fprintf(stderr, "--fonts: %s\n", set.status().ToString().c_str());
    return 1;
  }
  std::vector<Counts> sharp(extractors.size()), photo(extractors.size());
  std::vector<double> view_ms(extractors.size(), 0.0);
  std::mt19937_64 rng(77);
  for (int p = 0; p < pages; ++p) {
    const auto page = texfree::testdata::RenderTextPage(static_cast<uint64_t>(p), page_options);
    cv::Mat gray;
    cv::cvtColor(page.image, gray, cv::COLOR_BGR2GRAY);
    for (size_t e = 0; e < extractors.size(); ++e) {
      const auto kp = texfree::WordKeypointExtractor(extractors[e].options).Extract(gray);
      const Counts c = Score(page.word_boxes, cv::Matx33d::eye(), gray.size(), kp.points);
      sharp[e].Add(c);
      if (per_page) {
        std::printf("page %d %s: %ld/%ld words once, %ld split, %ld/%ld keypoints on one word\n",
                    p, extractors[e].name.c_str(), c.one, c.words, c.split, c.unique, c.keypoints);
      }
      if (!dump.empty() && p < 10) {
        cv::Mat vis = page.image.clone();
        for (const cv::Rect &b : page.word_boxes) cv::rectangle(vis, b, cv::Scalar(0, 180, 0), 1);
        for (const auto &pt : kp.points) cv::circle(vis, pt, 3, cv::Scalar(0, 0, 255), -1);
        cv::imwrite(dump + "/p" + std::to_string(p) + "_sharp_e" + std::to_string(e) + ".png", vis);
        std::printf("page %d extractor %zu: %ld/%ld words once, %ld split\n", p, e, c.one, c.words,
                    c.split);
      }
    }
    for (int v = 0; v < views; ++v) {
      auto options = texfree::testdata::RandomViewOptions(rng, page.image.size(), max_tilt);
      if (max_blur >= 0) options.blur_sigma = std::min(options.blur_sigma, max_blur);
      const auto view = texfree::testdata::RenderCameraView(page.image, options, rng());
      cv::Mat view_gray;
      cv::cvtColor(view.image, view_gray, cv::COLOR_BGR2GRAY);
      for (size_t e = 0; e < extractors.size(); ++e) {
        const texfree::WordKeypointExtractor extractor(extractors[e].options);
        const auto t0 = std::chrono::steady_clock::now();
        const auto kp = extractor.Extract(view_gray);
        view_ms[e] +=
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0)
                .count();
        photo[e].Add(Score(page.word_boxes, view.homography, view_gray.size(), kp.points));
        if (!dump.empty() && p < 10) {
          cv::Mat vis = view.image.clone();
          for (const auto &pt : kp.points) cv::circle(vis, pt, 3, cv::Scalar(0, 0, 255), -1);
          cv::imwrite(dump + "/p" + std::to_string(p) + "_v" + std::to_string(v) + "_e" +
                          std::to_string(e) + ".png",
                      vis);
        }
      }
    }
  }
  std::printf(
      "| extractor | sharp: words found once | split | keypoints on one word | "
      "views: words found once | split | keypoints on one word | ms per view |\n");
  std::printf("|---|---:|---:|---:|---:|---:|---:|---:|\n");
  auto pct = [](long a, long b) { return b ? 100.0 * a / b : 0.0; };
  for (size_t e = 0; e < extractors.size(); ++e) {
    const Counts &s = sharp[e], &v = photo[e];
    std::printf("| %s | %.1f%% | %.1f%% | %.1f%% | %.1f%% | %.1f%% | %.1f%% | %.2f |\n",
                extractors[e].name.c_str(), pct(s.one, s.words), pct(s.split, s.words),
                pct(s.unique, s.keypoints), pct(v.one, v.words), pct(v.split, v.words),
                pct(v.unique, v.keypoints), view_ms[e] / std::max(1, pages * views));
  }
  return 0;
}
