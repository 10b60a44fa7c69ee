// FigureKeypointExtractor: keypoints of a page's figures (charts, diagrams, photographs),
// where word blobs are few or none. A view of a line chart or a bar chart holds a handful of
// words (tick labels) but many well-defined points: the corners of bars and frames, the
// vertices and markers of polylines, the ends of tick marks. Those are the corners (Shi-Tomasi:
// the smaller eigenvalue of the structure tensor) of ink components too large to be text,
// which a perspective view moves as the page's homography does. LlahRetriever describes them
// like words (affine-invariant neighbourhoods), in an index of their own.
#pragma once

#include <opencv2/core.hpp>
#include <vector>

#include "absl/status/status.h"

namespace texfree {

struct FigureKeypointOptions {
  // Ink: darker than the mean of a window of ink_window_share times the image's shorter
  // side (at least 15 px) by threshold_offset grey levels (the words' InkMask; uneven light
  // moves the mean with it).
  double ink_window_share = 0.05;
  double threshold_offset = 17.0;
  // An ink component is a figure's when its bounding box is at least min_extent_px and
  // min_extent_chars times the text height (when known) long: letters, words and tick
  // labels are smaller. Body text at a phone's reading distance is 8-30 px high.
  double min_extent_px = 24.0;
  double min_extent_chars = 4.0;
  // Small or blurred text fuses into lines as large as a figure's strokes: corners within
  // text_exclusion_chars text heights of a word keypoint are the text's, not a figure's.
  double text_exclusion_chars = 3.0;
  // Corners: Gaussian smoothing, then the structure tensor over block_size x block_size;
  // a corner's smaller eigenvalue must reach min_quality times the strongest one's, and
  // min_eigenvalue (in grey levels^2 per pixel, of 8-bit images: a straight edge gives 0,
  // a right-angled corner of 100 levels' contrast several hundred). Corners are at least
  // min_distance_px apart (the stronger kept): a polyline's vertex or a marker gives one.
  double smoothing_sigma = 1.0;
  int block_size = 5;
  double min_quality = 0.02;
  double min_eigenvalue = 30.0;
  double min_distance_px = 8.0;
  // A corner is the centroid of a blob of cornerness (connected pixels above the floor),
  // weighted by the eigenvalue, where the blob is at most centroid_max_blob_px across
  // (larger ones, a cluttered photograph's, keep their local maxima). A plot's marker disc
  // or a polyline's vertex drawn a few pixels wide has several maxima around its rim, and
  // which of them is strongest changes with the view; the blob's centroid does not. A right
  // angle's centroid lies 1-1.5 px inside it, alike on the page and in a view. 0: the local
  // maxima only. Five sets of 1,000 views (with the figures' 4 levels): at 1,000 pages 4,946
  // (24 px), 4,944 (16 px), 4,941 (a blob's single maximum kept, refined), 4,938 (local
  // maxima); at 10,000 pages 4,947 (24 px) and 4,944 (16 px) against 4,942 before.
  double centroid_max_blob_px = 24.0;
  // Corners within this many pixels of the image border are cut by the frame (a line that
  // leaves the picture makes a corner there) and dropped.
  double border_margin_px = 4.0;
  // The most keypoints kept (strongest first).
  int max_keypoints = 1500;

  absl::Status Validate() const;
};

// Thread-compatible: const methods may be called concurrently.
class FigureKeypointExtractor {
 public:
  explicit FigureKeypointExtractor(FigureKeypointOptions options = {});
  // gray: CV_8UC1, dark ink on light paper. words, char_height: the word keypoints and the
  // text's height in pixels as the word extractor measured them (none and 0 when it found
  // no text). Keypoints with sub-pixel accuracy.
  std::vector<cv::Point2f> Extract(const cv::Mat &gray, const std::vector<cv::Point2f> &words,
                                   double char_height) const;
  const FigureKeypointOptions &options() const { return options_; }

 private:
  FigureKeypointOptions options_;
};

}  // namespace texfree
