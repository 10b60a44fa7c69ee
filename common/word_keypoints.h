// WordKeypointExtractor: keypoints of printed text pages = centroids of word
// blobs.
//
// The seed (2.3, 5.5) thresholds with a fixed filter, which fails when the
// camera is far from or close to the page. Here every size is derived from the
// image itself:
//   1. adaptive mean threshold (window from the image size) -> ink mask; uneven
//   light is
//      absorbed by the local mean;
//   2. minimum-area rectangles of the ink blobs -> a provisional size s0 and
//   the text line
//      direction (from each letter to its nearest neighbour); a closing along
//      the line joins letters, and the short side of the elongated blobs gives
//      the word height h, which is the same whether letters touch at this
//      resolution or not;
//   3. a second threshold with a window of 3 h, then a closing with a
//   line-shaped kernel of
//      gap_factor * h along the text direction: letters of a word join, words
//      and lines do not;
//   4. word blobs filtered by size relative to h; blobs cut by the image border
//   are
//      dropped since their centroids move with the frame.
#pragma once

#include <opencv2/core.hpp>
#include <vector>

#include "absl/status/status.h"

namespace texfree {

// How letters are joined into words.
enum class WordGrouping {
  // One closing along the text direction for the whole image, gap_factor * word
  // height.
  kLineClosing,
  // Letters joined pairwise on the same line when their gap is below a
  // threshold relative
  // to the local text height, the threshold split from the image's own gap
  // statistics:
  // copes with several text sizes in one image, perspective and wide
  // (monospace) letter
  // spacing, at the price of more sensitivity to blur.
  kLetterGraph,
};

struct WordKeypointOptions {
  WordGrouping grouping = WordGrouping::kLineClosing;
  // Offset below the local mean for ink, in gray levels: high enough that blur
  // and JPEG haze between words stays paper, low enough for faint text
  // (contrast 40+).
  double threshold_offset = 17.0;
  // Letters closer than gap_factor * word height along the line are one word
  // (letter gaps are ~0.13, word spaces ~0.4 word heights in common fonts).
  double gap_factor = 0.25;
  // kLetterGraph: gap threshold relative to the local glyph height when the gap
  // statistics show no clear split between letter and word spaces.
  double letter_gap_factor = 0.3;
  // Character heights outside [min_char_height, max_char_height] pixels are not
  // text.
  double min_char_height = 2.5;
  double max_char_height = 200.0;
  // Word blobs smaller than min_word_area_factor * h^2 are dots or noise.
  double min_word_area_factor = 0.35;
  // Blobs longer than max_word_length_factor * h are rules, frames or figures.
  double max_word_length_factor = 30.0;
  // Blobs with more ink than max_word_length_factor * max_word_height_factor *
  // h^2 are figures.
  double max_word_height_factor = 3.5;
  // Drop blobs touching the image border (their centroids are unstable).
  bool drop_border_blobs = true;
  // Letters apart (pass 1): when under this share of the provisional words' area lies in
  // elongated blobs and their height is below the letters' size, the letters were not
  // joined, and the text is measured again with longer bridges; that reading is kept when
  // at least min_reclosed_word_area_share of its area is elongated. Fused text measured
  // 0.85-1 on the benchmark's views, a sharp serif view with letters apart 0.46 (0.93
  // closed again).
  double min_word_area_share = 0.6;
  double min_reclosed_word_area_share = 0.8;
  // Pass 1's provisional text size: the median of the ink blobs' short sides weighted by
  // their area (true: noise and JPEG specks, which outnumber the letters of large type
  // under noise on a whole page, weigh little), or their plain median (false: a small
  // image with few letters, where a heading's few large blobs would decide).
  bool area_weighted_text_size = true;
  // Upper bound of keypoints returned (largest blobs kept).
  int max_keypoints = 20000;
  // When > 0 and the text is taller than this many pixels, words are grouped on a
  // half-resolution image (4x fewer pixels; word centroids move by about a tenth of the
  // text height at most). 0 (default): always at full resolution.
  double half_resolution_above_char_height = 0;

  absl::Status Validate() const;
};

// The text's size and direction in an image, as Extract measures them.
struct TextGeometry {
  double char_height = 0;     // pixels
  double text_angle_rad = 0;  // text line direction
};

// Ink of a CV_8UC1 image: 255 where a pixel is darker than the mean of the block x block
// window around it (replicated borders) by at least floor(offset), else 0. The same mask as
// cv::adaptiveThreshold(gray, ink, 255, ADAPTIVE_THRESH_MEAN_C, THRESH_BINARY_INV, block,
// offset), made in one vectorised pass after the box mean. `block` is odd and > 1.
cv::Mat InkMask(const cv::Mat &gray, int block, double offset);

struct WordKeypoints {
  std::vector<cv::Point2f> points;
  double char_height = 0;     // estimated character height, pixels
  double text_angle_rad = 0;  // dominant text line direction
};

// Thread-compatible: const methods may be called concurrently.
class WordKeypointExtractor {
 public:
  explicit WordKeypointExtractor(WordKeypointOptions options = {});
  // gray: CV_8UC1, dark text on light paper.
  WordKeypoints Extract(const cv::Mat &gray) const;
  // The same without measuring the text (the first of the two thresholding passes, about
  // half the work): `known` is what a recent frame of the same video measured. Gives the
  // keypoints of Extract(gray) when `known` equals what Extract(gray) would measure.
  // Returns no keypoints when known.char_height is outside [min_char_height,
  // max_char_height].
  WordKeypoints Extract(const cv::Mat &gray, const TextGeometry &known) const;
  const WordKeypointOptions &options() const { return options_; }

 private:
  // Pass 2: words of text of height h along `angle`. `ink` is the ink mask of `smooth` at
  // window 3 h when the caller has it already.
  WordKeypoints GroupWords(const cv::Mat &gray, const cv::Mat &smooth, double h, double angle,
                           cv::Mat ink) const;

  WordKeypointOptions options_;
};

}  // namespace texfree
