// VideoKeypointExtractor: word keypoints of consecutive frames of one video. The text's
// size and direction change little from one frame to the next, so they are measured
// (WordKeypointExtractor::Extract, two thresholding passes) only now and then, and the
// frames in between reuse the measurement (one pass, Extract with known geometry, about
// 4x cheaper). Large text is grouped at half resolution.
//
// Pages seen at a slant: one text height for the whole frame does not fit a page tilted
// far from the camera (its far lines are squeezed to a few pixels, its near letters are
// large). When the caller knows where a tracked page will be (PageInView, the tracker's
// prediction), the part of the frame showing the page is warped into page coordinates
// (fronto-parallel, text of one height and direction), words are cut there, and their
// centroids are mapped back into the frame. They replace the frame's own keypoints there.
#pragma once

#include <cstdint>
#include <map>
#include <opencv2/core.hpp>
#include <optional>
#include <vector>

#include "absl/status/status.h"
#include "common/word_keypoints.h"

namespace texfree {

struct VideoKeypointOptions {
  // The text is measured on one frame in this many (1: every frame, as a still image).
  int measure_every_frames = 8;
  // This stream measures that many frames earlier in the cycle (taken modulo
  // measure_every_frames): a server following many streams gives each its own phase, so
  // that their measuring frames, several times dearer than the others, do not fall on the
  // same moment when the streams start together.
  int measure_phase = 0;
  // Frames counted as already past the measurement when a stream first measures a text.
  int PhaseInCycle() const { return measure_phase % measure_every_frames; }
  // A frame that reuses the measurement and finds fewer than this share of the keypoints
  // of the last measured frame is extracted again with a fresh measurement (the camera
  // came much closer or moved away fast).
  double remeasure_below_ratio = 0.6;
  // Text taller than this many pixels is grouped into words at half resolution (see
  // WordKeypointOptions::half_resolution_above_char_height); 0: never.
  double half_resolution_above_char_height = 12;

  // Rectified extraction of predicted pages (Extract with pages). A page is rectified
  // when the frame's magnification of it (square root of the local area scale) varies by
  // more than this factor over the part in view: from about 50 deg of tilt at a close
  // distance. 0: never.
  double rectify_above_perspective = 1.8;
  // Height of the text in the rectified image, pixels: tall enough for words to be cut
  // reliably, small enough to keep the image cheap and the far part within
  // max_rectify_upsampling (on the benchmark's close orbit, seeds 77-81: 7 px held every
  // frame to 80 deg; 8 and 9 px lost one or two frames on some seeds).
  double rectified_char_height = 7;
  // The rectified image leaves out the part of the page where it would enlarge the frame
  // more than this along the squeezed direction: the frame does not resolve the text
  // there, and enlarging it invents nothing.
  double max_rectify_upsampling = 3;
  // A page is not rectified when the rectified image would enlarge the frame more than
  // this at the median magnification (small text seen from afar: enlarging blurs it, and
  // the frame's own keypoints do better).
  double max_median_upsampling = 1.2;
  // Pixel budget of a rectified image, as a multiple of the frame's pixels; the text is
  // made smaller to fit (not below rectified_min_char_height, else the page is not
  // rectified).
  double max_rectified_area = 1.0;
  double rectified_min_char_height = 5;

  absl::Status Validate() const;
};

// Where a followed page is expected in the frame (the tracker's prediction).
struct PageInView {
  uint32_t document = 0;
  // Page (registration image) pixels -> frame pixels, scaled so that w > 0 in front of
  // the camera.
  cv::Matx33d page_to_frame = cv::Matx33d::eye();
  // The page's text area, page pixels.
  cv::Rect2f area;
};

// One page's rectified extraction on one frame (for tests and traces).
struct RectifiedPage {
  uint32_t document = 0;
  // Rectified pixels -> page pixels: page = origin + u / scale.
  double scale = 0;
  cv::Point2d origin;
  cv::Matx33d to_frame = cv::Matx33d::eye();  // rectified pixels -> frame pixels
  cv::Size size;                              // of the rectified image
  cv::Size frame_size;
  double char_height = 0;  // text height in the rectified image
  // Frame pixels of the page part in view left out for being too far to rectify (empty:
  // none).
  cv::Rect unresolved;
  int keypoints = 0;  // rectified keypoints kept in the frame
  int replaced = 0;   // frame keypoints they replaced
};

// True when a frame keypoint at `frame_point` lies where `page`'s rectified image gives
// the keypoints (well inside it, its blob clear of the frame's border).
bool TakenByRectified(const RectifiedPage& page, const cv::Point2f& frame_point);

// What VideoKeypointExtractor::Extract did on one frame.
struct VideoFrameInfo {
  bool measured = false;    // the text of the frame was measured
  bool whole_frame = true;  // false: only the rectified pages were extracted
  std::vector<RectifiedPage> rectified;
};

// Not thread-safe: one per video stream, fed its frames in order.
class VideoKeypointExtractor {
 public:
  // `keypoints`: the options the pages were registered with.
  VideoKeypointExtractor(const WordKeypointOptions& keypoints, VideoKeypointOptions options);

  // gray: CV_8UC1. `measured` (optional) tells whether the text was measured on this frame.
  WordKeypoints Extract(const cv::Mat& gray, bool* measured = nullptr);
  // The same, with the pages the tracker expects in this frame: those seen at a slant are
  // extracted rectified (see the file comment). While all of them are, the rest of the
  // frame is extracted only on the frames that measure the text (one in
  // measure_every_frames), to look for other pages: the other frames return the pages'
  // keypoints alone (info->whole_frame false), with the last measured text height of the
  // frame.
  WordKeypoints Extract(const cv::Mat& gray, const std::vector<PageInView>& pages,
                        VideoFrameInfo* info = nullptr);

  // The next frame measures the text afresh (e.g. after a cut).
  void Reset();

 private:
  // What is known of a page's text in page pixels, measured on rectified images.
  struct PageText {
    std::optional<TextGeometry> known;  // char_height in page pixels
    std::vector<double> heights;        // the last few measurements of it
    size_t measured_keypoints = 0;      // per 10^4 rectified pixels, when last measured
    int frames_since_measure = 0;
  };

  WordKeypoints Measure(const cv::Mat& gray);
  // Extracts one page rectified: appends its keypoints, in frame coordinates, to
  // `points` (those well inside the rectified image; TakenByRectified says where). False
  // when the page is not seen at a slant, or not well enough to be rectified.
  // `frame_char_height`: the frame's text height, for a first guess of the page's.
  bool ExtractRectified(const cv::Mat& gray, const PageInView& page, double frame_char_height,
                        std::vector<cv::Point2f>* points, RectifiedPage* report);

  const VideoKeypointOptions options_;
  // All three have the registration's options but for the first text size, taken from the
  // plain median of the blobs (see ForVideo in the .cc).
  WordKeypointExtractor measuring_;
  WordKeypointExtractor reusing_;    // with half resolution for large text
  WordKeypointExtractor rectified_;  // full resolution
  std::optional<TextGeometry> known_;
  size_t measured_keypoints_ = 0;
  int frames_since_measure_ = 0;
  std::map<uint32_t, PageText> pages_;
};

}  // namespace texfree
