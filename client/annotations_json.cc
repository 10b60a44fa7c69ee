// Annotations JSON parsing and validation (see annotations_json.h for the
// format).
#include "client/annotations_json.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

namespace texfree::client {
namespace {

using nlohmann::json;

const char* JsonTypeName(const json& value) { return value.type_name(); }

std::string Compact(const json& value) {
  std::string text = value.dump();
  if (text.size() > 40) text = text.substr(0, 37) + "...";
  return text;
}

// Context for one entry: builds error messages naming the index and field.
class Entry {
 public:
  Entry(const json& object, size_t index) : object_(object), index_(index) {}

  [[noreturn]] void Fail(const std::string& field,
                         const std::string& what) const {
    std::ostringstream message;
    message << "annotations[" << index_ << "]";
    if (!field.empty()) message << "." << field;
    message << ": " << what;
    throw AnnotationsError(message.str());
  }

  bool Has(const std::string& field) const { return object_.contains(field); }

  double Number(const std::string& field, bool required,
                double fallback) const {
    if (!Has(field)) {
      if (required) Fail(field, "missing (a number is required)");
      return fallback;
    }
    const json& value = object_.at(field);
    if (!value.is_number()) {
      Fail(field, std::string("must be a number (got ") + JsonTypeName(value) +
                      " " + Compact(value) + ")");
    }
    double number = value.get<double>();
    if (!std::isfinite(number)) Fail(field, "must be finite");
    return number;
  }

  double Positive(const std::string& field, bool required,
                  double fallback) const {
    double number = Number(field, required, fallback);
    if (!(number > 0)) {
      std::ostringstream what;
      what << "must be > 0 (got " << number << ")";
      Fail(field, what.str());
    }
    return number;
  }

  std::string String(const std::string& field, bool required) const {
    if (!Has(field)) {
      if (required) Fail(field, "missing (a non-empty string is required)");
      return {};
    }
    const json& value = object_.at(field);
    if (!value.is_string()) {
      Fail(field,
           std::string("must be a string (got ") + JsonTypeName(value) + ")");
    }
    std::string text = value.get<std::string>();
    if (required && text.empty()) Fail(field, "must not be empty");
    return text;
  }

  Rgba Color(const std::string& field, const Rgba& fallback) const {
    if (!Has(field)) return fallback;
    const json& value = object_.at(field);
    if (value.is_string()) {
      try {
        return ParseHexColor(value.get<std::string>());
      } catch (const AnnotationsError& e) {
        Fail(field, e.what());
      }
    }
    if (value.is_array() && (value.size() == 3 || value.size() == 4)) {
      uint8_t components[4] = {0, 0, 0, 255};
      for (size_t i = 0; i < value.size(); ++i) {
        const json& c = value[i];
        if (!c.is_number() || c.get<double>() < 0 || c.get<double>() > 255) {
          Fail(field, "colour components must be numbers 0..255 (got " +
                          Compact(value) + ")");
        }
        components[i] = static_cast<uint8_t>(std::lround(c.get<double>()));
      }
      return Rgba{components[0], components[1], components[2], components[3]};
    }
    Fail(field, "bad colour " + Compact(value) +
                    " (expected \"#rrggbb\", \"#rrggbbaa\" or [r, g, b])");
  }

  cv::Rect2d Rect() const {
    double x = Number("x", true, 0);
    double y = Number("y", true, 0);
    double width = Positive("width", true, 0);
    double height = Positive("height", true, 0);
    return cv::Rect2d(x, y, width, height);
  }

  void CheckKeys(const std::set<std::string>& allowed) const {
    for (const auto& item : object_.items()) {
      if (item.key() == "type" || item.key() == "annotation_id") continue;
      if (!allowed.count(item.key())) {
        std::string list;
        for (const auto& key : allowed)
          list += (list.empty() ? "" : ", ") + key;
        Fail(item.key(), "unknown field (expected one of: type, " + list + ")");
      }
    }
  }

 private:
  const json& object_;
  size_t index_;
};

std::string ReadFileBytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return {};
  return std::string(std::istreambuf_iterator<char>(in),
                     std::istreambuf_iterator<char>());
}

PageAnnotation ParseEntry(const json& object, size_t index,
                          const std::filesystem::path& base_dir) {
  Entry entry(object, index);
  if (!object.is_object()) {
    entry.Fail("", std::string("must be an object (got ") +
                       JsonTypeName(object) + ")");
  }
  std::string type = entry.String("type", true);
  PageAnnotation annotation;
  if (object.contains("annotation_id") && object["annotation_id"].is_string()) {
    annotation.annotation_id = object["annotation_id"].get<std::string>();
  }
  if (type == "text") {
    entry.CheckKeys({"text", "x", "y", "font_size", "color"});
    annotation.kind = AnnotationKind::kText;
    annotation.text = entry.String("text", true);
    annotation.position =
        cv::Point2d(entry.Number("x", true, 0), entry.Number("y", true, 0));
    annotation.font_size_px = entry.Positive("font_size", false, 24.0);
    annotation.color = entry.Color("color", Rgba{255, 0, 0, 255});
  } else if (type == "highlight") {
    entry.CheckKeys({"x", "y", "width", "height", "color", "opacity"});
    annotation.kind = AnnotationKind::kHighlight;
    annotation.rect = entry.Rect();
    annotation.color = entry.Color("color", Rgba{255, 255, 0, 255});
    annotation.opacity = entry.Number("opacity", false, 0.4);
    if (annotation.opacity < 0 || annotation.opacity > 1) {
      std::ostringstream what;
      what << "must be between 0 and 1 (got " << annotation.opacity << ")";
      entry.Fail("opacity", what.str());
    }
  } else if (type == "link") {
    entry.CheckKeys({"x", "y", "width", "height", "url"});
    annotation.kind = AnnotationKind::kLink;
    annotation.rect = entry.Rect();
    annotation.url = entry.String("url", true);
  } else if (type == "media") {
    entry.CheckKeys({"x", "y", "width", "height", "uri", "file", "mime_type"});
    annotation.kind = AnnotationKind::kMedia;
    annotation.rect = entry.Rect();
    bool has_uri = entry.Has("uri");
    bool has_file = entry.Has("file");
    if (has_uri == has_file) {
      entry.Fail(has_uri ? "file" : "uri",
                 "exactly one of \"uri\" or \"file\" is required");
    }
    std::string source_name;
    if (has_uri) {
      annotation.uri = entry.String("uri", true);
      source_name = annotation.uri;
    } else {
      std::filesystem::path file = entry.String("file", true);
      if (file.is_relative() && !base_dir.empty()) file = base_dir / file;
      std::error_code ec;
      if (!std::filesystem::is_regular_file(file, ec)) {
        entry.Fail("file", "cannot read '" + file.string() + "'");
      }
      annotation.data = ReadFileBytes(file);
      source_name = file.string();
    }
    annotation.mime_type = entry.String("mime_type", false);
    if (annotation.mime_type.empty())
      annotation.mime_type = GuessMimeType(source_name);
  } else {
    entry.Fail("type", "unknown type '" + type +
                           "' (expected text, highlight, link or media)");
  }
  return annotation;
}

int HexDigit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  return -1;
}

}  // namespace

const char* AnnotationKindName(AnnotationKind kind) {
  switch (kind) {
    case AnnotationKind::kText:
      return "text";
    case AnnotationKind::kHighlight:
      return "highlight";
    case AnnotationKind::kLink:
      return "link";
    case AnnotationKind::kMedia:
      return "media";
  }
  return "unknown";
}

Rgba ParseHexColor(const std::string& text) {
  bool ok = (text.size() == 7 || text.size() == 9) && text[0] == '#';
  uint8_t components[4] = {0, 0, 0, 255};
  for (size_t i = 1; ok && i < text.size(); i += 2) {
    int hi = HexDigit(text[i]);
    int lo = HexDigit(text[i + 1]);
    if (hi < 0 || lo < 0) {
      ok = false;
      break;
    }
    components[(i - 1) / 2] = static_cast<uint8_t>(hi * 16 + lo);
  }
  if (!ok) {
    throw AnnotationsError(
        "bad colour \"" + text +
        "\" (expected \"#rrggbb\", \"#rrggbbaa\" or [r, g, b])");
  }
  return Rgba{components[0], components[1], components[2], components[3]};
}

std::string FormatHexColor(const Rgba& color) {
  char buffer[16];
  if (color.a == 255) {
    std::snprintf(buffer, sizeof(buffer), "#%02x%02x%02x", color.r, color.g,
                  color.b);
  } else {
    std::snprintf(buffer, sizeof(buffer), "#%02x%02x%02x%02x", color.r, color.g,
                  color.b, color.a);
  }
  return buffer;
}

std::string GuessMimeType(const std::string& name) {
  std::string path = name.substr(0, name.find_first_of("?#"));
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) {
    return static_cast<char>(std::tolower(c));
  });
  static const std::pair<const char*, const char*> kTypes[] = {
      {".png", "image/png"},        {".jpg", "image/jpeg"},
      {".jpeg", "image/jpeg"},      {".gif", "image/gif"},
      {".bmp", "image/bmp"},        {".webp", "image/webp"},
      {".tif", "image/tiff"},       {".tiff", "image/tiff"},
      {".svg", "image/svg+xml"},    {".mp4", "video/mp4"},
      {".m4v", "video/mp4"},        {".webm", "video/webm"},
      {".mov", "video/quicktime"},  {".avi", "video/x-msvideo"},
      {".mkv", "video/x-matroska"}, {".mp3", "audio/mpeg"},
      {".wav", "audio/wav"},        {".ogg", "audio/ogg"},
      {".pdf", "application/pdf"},  {".html", "text/html"},
      {".txt", "text/plain"},
  };
  for (const auto& [extension, type] : kTypes) {
    if (ext == extension) return type;
  }
  return "application/octet-stream";
}

std::vector<PageAnnotation> ParseAnnotationsJson(
    const std::string& json_text, const std::filesystem::path& base_dir) {
  json document;
  try {
    document = json::parse(json_text);
  } catch (const json::parse_error& e) {
    throw AnnotationsError(std::string("not valid JSON: ") + e.what());
  }
  const json* list = &document;
  if (document.is_object()) {
    if (!document.contains("annotations")) {
      throw AnnotationsError(
          "expected an array or an object with an \"annotations\" array");
    }
    list = &document["annotations"];
  }
  if (!list->is_array()) {
    throw AnnotationsError(std::string("annotations: must be an array (got ") +
                           list->type_name() + ")");
  }
  std::vector<PageAnnotation> annotations;
  annotations.reserve(list->size());
  for (size_t i = 0; i < list->size(); ++i) {
    annotations.push_back(ParseEntry((*list)[i], i, base_dir));
  }
  return annotations;
}

std::vector<PageAnnotation> LoadAnnotationsFile(
    const std::filesystem::path& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    throw AnnotationsError(path.string() + ": cannot read annotations file");
  }
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw AnnotationsError(path.string() + ": cannot read annotations file");
  std::string text((std::istreambuf_iterator<char>(in)),
                   std::istreambuf_iterator<char>());
  try {
    return ParseAnnotationsJson(text, path.parent_path());
  } catch (const AnnotationsError& e) {
    throw AnnotationsError(path.string() + ": " + e.what());
  }
}

}  // namespace texfree::client
