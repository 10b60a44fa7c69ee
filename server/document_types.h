// Plain C++ types of the document registry (no proto, no SQL): documents and annotations.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "absl/status/status.h"

namespace texfree::server {

struct Rgba {
  uint8_t r = 0, g = 0, b = 0, a = 255;
};

// Coordinates are registration-image pixels.
struct AnnotationRecord {
  enum class Kind { kText, kHighlight, kLink, kMedia };
  std::string id;  // assigned by the store
  Kind kind = Kind::kText;
  std::string text;         // kText
  cv::Point2d position;     // kText: baseline start
  double font_size_px = 0;  // kText
  cv::Rect2d rect;          // kHighlight, kLink, kMedia
  Rgba color;               // kText, kHighlight
  double opacity = 1.0;     // kHighlight
  std::string uri;          // kLink: URL; kMedia: URI (or empty with data)
  std::string mime_type;    // kMedia
  std::string data;         // kMedia inline bytes

  // Checks the fields this kind needs against the page size; the message names the field.
  absl::Status Validate(const cv::Size& page) const;
};

struct DocumentRecord {
  uint32_t index_id = 0;  // internal, dense key of the LLAH index
  std::string id;         // public id
  std::string title;
  cv::Size size;
  int64_t created_unix_ms = 0;
  int keypoint_count = 0;  // stored count (keypoints may be left unloaded)
  std::vector<cv::Point2f> keypoints;
  // Extra keypoint layers (LlahRetriever's DocumentKeypoints::extra_layers): the page cut
  // into words as a camera sees it, in registration-image pixels, layer after layer, and
  // each layer's size. Empty in pages registered without them.
  std::vector<cv::Point2f> layer_keypoints;
  std::vector<uint32_t> layer_sizes;
  // LLAH descriptor hashes of keypoints then layer_keypoints (LlahRetriever::DescribeLayers
  // layout); stored so that start-up need not recompute them. May be empty.
  std::vector<uint64_t> hashes;
  // Keypoints of the page's figures (FigureKeypointExtractor), in registration-image pixels,
  // indexed apart from the words. Empty when the page has too few (or was registered
  // before figures were indexed).
  std::vector<cv::Point2f> figure_keypoints;
  // Letters of the page's large type (LetterKeypointExtractor), in registration-image pixels,
  // indexed apart from the words. Empty when the page has too few (or was registered before
  // letters were indexed).
  std::vector<cv::Point2f> letter_keypoints;
  // Their LLAH descriptor hashes (LlahRetriever::DescribeLayers layout, one layer). May be
  // empty.
  std::vector<uint64_t> letter_hashes;
  std::vector<AnnotationRecord> annotations;
};

}  // namespace texfree::server
