// Seeded, deterministic synthetic document pages for tests and benchmarks.
//
// RenderTextPage() typesets a page of English-looking text with a layout that
// varies per seed (columns, fonts, sizes, headings, figures, tables, headers,
// page numbers) and returns the image with one ground-truth box per word.
// RenderBlankPage() returns plain paper without any text.
#ifndef TEXFREE_TESTS_DATA_PAGE_RENDERER_H_
#define TEXFREE_TESTS_DATA_PAGE_RENDERER_H_

#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

namespace texfree::testdata {

struct PageOptions {
  int width = 1000;  // pixels (A4 portrait ratio by default)
  int height = 1414;
  bool color = false;  // BGR output when true (coloured headings, a figure),
                       // else still 8UC3 but gray values
};

struct RenderedPage {
  cv::Mat image;                     // CV_8UC3, white paper, dark text
  std::vector<cv::Rect> word_boxes;  // ground truth: one box per rendered
                                     // word, page pixels
  uint64_t seed = 0;
};

// Deterministic for a seed: the same seed gives byte-identical pages (for a
// given FreeType/OpenCV build). Thread-safe.
RenderedPage RenderTextPage(uint64_t seed, const PageOptions& options = {});

// A page with no text at all (plain paper, faint texture): for "too few
// keypoints" tests.
cv::Mat RenderBlankPage(uint64_t seed, const PageOptions& options = {});

}  // namespace texfree::testdata

#endif  // TEXFREE_TESTS_DATA_PAGE_RENDERER_H_
