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
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace texfree::testdata {

// The font families pages are typeset in. The word-keypoint extractor and the
// LLAH quantisation were tuned on DejaVu pages only; Liberation (metric
// compatible with Times New Roman / Arial / Courier, tighter letter spacing)
// and GNU FreeFont are held out to measure whether accuracy carries over to
// fonts never used in tuning. Neither held-out set has condensed cuts, so a
// page's condensed family is set in the regular width there.
enum class FontSet {
  kDejaVu,      // Debian fonts-dejavu-core + fonts-dejavu-extra
  kLiberation,  // fonts-liberation2
  kFreeFont,    // fonts-freefont-ttf
  // Latin Modern (fonts-lmodern, OpenType CFF): the Computer Modern faces of TeX-typeset
  // papers, with hairline strokes and thin serifs that blur apart.
  kLatinModern,
  kAll,  // one of DejaVu, Liberation and FreeFont per page, chosen from the seed
};

// "dejavu", "liberation", "freefont", "latinmodern", "all".
std::string_view FontSetName(FontSet set);
absl::StatusOr<FontSet> ParseFontSet(std::string_view name);

// NOT_FOUND naming the first missing font file and the Debian package that
// provides it. RenderTextPage() requires the set to be available (it throws
// std::runtime_error with the same message otherwise).
absl::Status CheckFontSet(FontSet set);

// ParseFontSet then CheckFontSet: a command line's --fonts value, ready to render with.
absl::StatusOr<FontSet> AvailableFontSet(std::string_view name);

struct PageOptions {
  int width = 1000;  // pixels (A4 portrait ratio by default)
  int height = 1414;
  bool color = false;  // BGR output when true (coloured headings, a figure),
                       // else still 8UC3 but gray values
  // The layout (columns, sizes, words...) still comes from the seed alone, so
  // a seed gives the same kind of page in every set; line breaks differ with
  // the fonts' widths.
  FontSet fonts = FontSet::kDejaVu;
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
