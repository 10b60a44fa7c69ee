// Parser for the annotations JSON files given to `texfree doc register
// --annotations` and `texfree doc annotate --annotations`.
//
// Format: either a bare array or an object {"annotations": [...]}. Coordinates
// are registration-image pixels. Colours are "#rrggbb", "#rrggbbaa", [r,g,b] or
// [r,g,b,a] with components 0..255.
//
//   [{"type": "text", "text": "Remember this", "x": 120, "y": 300,
//     "font_size": 24, "color": "#ff0000"},
//    {"type": "highlight", "x": 100, "y": 400, "width": 500, "height": 40,
//     "color": "#ffff00", "opacity": 0.4},
//    {"type": "link", "x": 100, "y": 500, "width": 200, "height": 30,
//     "url": "https://example.org"},
//    {"type": "media", "x": 600, "y": 100, "width": 300, "height": 200,
//     "uri": "https://example.org/a.mp4", "mime_type": "video/mp4"}]
//
// Per type:
//   text:      text (required, non-empty), x, y (baseline start, required),
//              font_size (> 0, default 24), color (default "#ff0000")
//   highlight: x, y, width, height (required, > 0), color (default "#ffff00"),
//              opacity (0..1, default 0.4)
//   link:      x, y, width, height, url (required, non-empty)
//   media:     x, y, width, height, and exactly one of uri or file (a path,
//   relative
//              to the JSON file's folder, whose bytes are sent inline);
//              mime_type (default: guessed from the uri's or file's extension)
// "annotation_id" is accepted and ignored (so `texfree --json doc show` output
// can be fed back); any other unknown key is an error, to catch typos.
#pragma once

#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "client/annotation.h"

namespace texfree::client {

// Raised for malformed annotation files; the message names the entry index and
// the field, e.g. "annotations[2].width: must be > 0 (got -5)".
class AnnotationsError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Parses JSON text. `base_dir` resolves relative media "file" paths.
std::vector<PageAnnotation> ParseAnnotationsJson(
    const std::string& json_text, const std::filesystem::path& base_dir = {});

// Reads and parses a file; errors are prefixed with the file name.
std::vector<PageAnnotation> LoadAnnotationsFile(
    const std::filesystem::path& path);

// Parses "#rrggbb", "#rrggbbaa"; throws AnnotationsError on malformed input.
Rgba ParseHexColor(const std::string& text);

// "#rrggbb" when opaque, else "#rrggbbaa".
std::string FormatHexColor(const Rgba& color);

// MIME type from a file name or URI extension; "application/octet-stream" if
// unknown.
std::string GuessMimeType(const std::string& name);

}  // namespace texfree::client
