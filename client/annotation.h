// Plain (proto-free) annotation types shared by the annotations JSON parser,
// the overlay renderer and the proto conversions of the texfree client.
#pragma once

#include <cstdint>
#include <opencv2/core/types.hpp>
#include <string>

namespace texfree::client {

// 8-bit RGBA colour; a = 255 is opaque.
struct Rgba {
  uint8_t r = 0;
  uint8_t g = 0;
  uint8_t b = 0;
  uint8_t a = 255;

  // OpenCV colour for BGR images (alpha dropped).
  cv::Scalar ToBgr() const { return cv::Scalar(b, g, r); }
  bool operator==(const Rgba& o) const {
    return r == o.r && g == o.g && b == o.b && a == o.a;
  }
};

enum class AnnotationKind { kText, kHighlight, kLink, kMedia };

// Returns "text", "highlight", "link" or "media".
const char* AnnotationKindName(AnnotationKind kind);

// One annotation of a registered page. Coordinates are registration-image
// pixels. Which fields are meaningful depends on `kind`:
//   kText:      text, position (baseline start), font_size_px, color
//   kHighlight: rect, color, opacity (0..1)
//   kLink:      rect, url
//   kMedia:     rect, mime_type, and either uri or data (inline bytes)
struct PageAnnotation {
  AnnotationKind kind = AnnotationKind::kText;
  std::string
      annotation_id;  // assigned by the server; empty before registration

  std::string text;
  cv::Point2d position;
  double font_size_px = 24.0;

  cv::Rect2d rect;
  Rgba color;
  double opacity = 0.4;

  std::string url;

  std::string mime_type;
  std::string uri;
  std::string data;  // inline media bytes (when uri is empty)
};

}  // namespace texfree::client
