// FigureCornerExtractor: keypoints of the parts of a page that are not words — the bends
// of a plot's lines, the corners of its bars and frames, the ends of rules and axes.
//
// A view of a chart or a table holds few words, too few for LLAH's neighbourhoods of
// words. Their strokes have corners, though, and a corner of a straight-edged stroke is a
// point of the page that any perspective maps to the corresponding corner: the bend of a
// polyline, a bar's top corner, the junction of a bar and its axis. They are found on the
// outlines of the ink's large components (the outer boundary of every component, also
// inside a frame), simplified to polygons at a tolerance of a fraction of the text height;
// a vertex that turns the outline by at least min_turn_deg is a corner, and the corners a
// stroke's two sides give at one bend (or its two cap corners at one end) are merged into
// one point. Letters, words and lines of text (components of the text's thickness along
// its direction, and whatever lies near a word keypoint) are left to the word extractor,
// and outline vertices near the image border are the frame's, not the page's.
#pragma once

#include <opencv2/core.hpp>
#include <vector>

#include "absl/status/status.h"

namespace texfree {

struct FigureCornerOptions {
  // Offset below the local mean for ink, in gray levels (as WordKeypointOptions).
  double threshold_offset = 17.0;
  // The adaptive threshold's window, in text heights: a filled bar narrower than half of
  // it is ink throughout.
  double window = 15.0;
  // Components whose longest side (minimum-area rectangle) is under this many text
  // heights are letters, words or dots.
  double min_extent = 6.0;
  // Components along the text direction (within 20 degrees) whose short side is between
  // these many text heights are words or lines of text, not strokes: rules are thinner.
  double min_text_thickness = 0.45;
  double max_text_thickness = 1.8;
  // Outline polygon tolerance, in text heights.
  double polygon_tolerance = 0.2;
  // A polygon vertex is a corner when the outline turns by at least this much there, and
  // both of its edges are at least min_edge text heights long.
  double min_edge = 0.8;
  double min_turn_deg = 25.0;
  // Corners closer than this many text heights are one (the two sides of a stroke).
  double merge_radius = 1.0;
  // Corners closer to a word keypoint than this many text heights, or this many times the
  // word's distance to its nearest word when that is at most 4 text heights (a word of a
  // text block, not a figure's lone label; text seen close in a steep view is larger than
  // the median), are not returned: in a block of text every point is within about three
  // text heights of a word's centre, and blobs of text merged by blur or a steep view have
  // corners that no page repeats.
  double word_clearance = 3.0;
  // Corners closer than this many text heights to the image border are not returned.
  double border_margin = 0.5;
  // Marker dots on plot lines (and crossings of lines) are keypoints too: where the ink is
  // at least this many times as thick as its strokes' median (0: none, the default: in
  // steep views a plot's lines thicken towards the camera, and the distance transform's
  // maxima then line them). 1.6 finds the dots of a frontal chart.
  double marker_thickness = 0;
  // Without text in the image, the text height is taken as this many stroke widths (the
  // thinnest large component's ink, which the threshold widens by a pixel or two): plot
  // lines and rules of 1.5-2 px on a page whose text is 12-14 px high measure 3-4 px.
  double height_per_stroke = 4.0;
  // At most this many corners (the sharpest kept).
  int max_corners = 400;

  absl::Status Validate() const;
};

struct FigureCorners {
  std::vector<cv::Point2f> points;
  // The text height the corners were found at: the given one, or the one derived from the
  // strokes (0 when there were none).
  double char_height = 0;
};

// Thread-compatible: const methods may be called concurrently.
class FigureCornerExtractor {
 public:
  explicit FigureCornerExtractor(FigureCornerOptions options = {});
  // gray: CV_8UC1, dark ink on light paper. char_height and text_angle_rad: the text's, as
  // WordKeypointExtractor measured it (char_height <= 0: no text found; the height is then
  // derived from the strokes).
  // `words`: the image's word keypoints; no corner is returned within word_clearance text
  // heights of one (text, even merged by blur or perspective, is the words' to describe).
  FigureCorners Extract(const cv::Mat &gray, double char_height, double text_angle_rad,
                        const std::vector<cv::Point2f> &words = {}) const;
  const FigureCornerOptions &options() const { return options_; }

 private:
  FigureCornerOptions options_;
};

}  // namespace texfree
