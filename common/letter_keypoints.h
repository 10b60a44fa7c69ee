// LetterKeypointExtractor: keypoints of large type = centroids of its letters.
//
// Word blobs are LLAH's keypoints (seed 2.3), but a close view of large type (a title, a
// heading, a poster, a slide) holds only a handful of words: too few whole neighbourhoods
// for a descriptor to match, whatever the extractor. Its letters are many and well apart
// at that size, and a letter's centroid moves with the page as a word's does. Pages are
// registered with the letters of their large type only (body text would multiply the
// index several times over for views that its words already find); a query's letters are
// every letter large enough to be cut apart reliably.
#pragma once

#include <opencv2/core.hpp>
#include <vector>

#include "absl/status/status.h"

namespace texfree {

struct LetterKeypointOptions {
  // Ink: darker than the mean of a window of ink_window_share times the image's shorter
  // side (at least 15 px) by threshold_offset grey levels (the words' InkMask; uneven
  // light moves the mean with it). The window is wide: large letters have thick strokes.
  double ink_window_share = 0.1;
  double threshold_offset = 17.0;
  // A letter's size is the larger side of its bounding box (about the same however the
  // view turns the page). A component is a letter when its size lies in
  // [min_letter_px, max_letter_share * the image's shorter side], it fills at least
  // min_fill of its box (rules and frames fill little) and is at most max_aspect times as
  // long as wide.
  double min_letter_px = 7.0;
  double max_letter_share = 0.25;
  double min_fill = 0.1;
  double max_aspect = 6.0;
  // Letters belong to type of one size with their neighbours: a letter's type size is the
  // median size of itself and those of its `size_neighbours` nearest components within
  // neighbour_reach times its own size (a heading's letters lie farther apart than the body
  // text under it lies from them; within reach an 'e' takes its heading's size, a letter
  // of the body text under it its body's). Components under min_size_ratio of their type
  // size are dots, accents and punctuation, which blur and JPEG keep or drop at random.
  int size_neighbours = 6;
  double neighbour_reach = 1.5;
  double min_size_ratio = 0.4;
  // The most keypoints kept (the largest type first).
  int max_keypoints = 3000;

  absl::Status Validate() const;
};

struct LetterKeypoints {
  std::vector<cv::Point2f> points;
  // The median type size of the letters kept (pixels), 0 when none.
  double letter_size = 0;
};

// Thread-compatible: const methods may be called concurrently.
class LetterKeypointExtractor {
 public:
  explicit LetterKeypointExtractor(LetterKeypointOptions options = {});
  // gray: CV_8UC1, dark text on light paper. Letters of type smaller than min_type_px
  // (pixels; the options' min_letter_px when smaller) are left out.
  LetterKeypoints Extract(const cv::Mat &gray, double min_type_px = 0) const;
  const LetterKeypointOptions &options() const { return options_; }

 private:
  LetterKeypointOptions options_;
};

}  // namespace texfree
