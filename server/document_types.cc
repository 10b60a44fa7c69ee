// Annotation validation.
#include "server/document_types.h"

#include <cmath>

#include "absl/strings/str_cat.h"

namespace texfree::server {
namespace {

constexpr size_t kMaxTextBytes = 4096;
constexpr size_t kMaxUriBytes = 4096;
constexpr size_t kMaxMediaBytes = 16 << 20;

absl::Status CheckRect(const cv::Rect2d& r, const cv::Size& page, const char* kind) {
  if (!std::isfinite(r.x) || !std::isfinite(r.y) || !std::isfinite(r.width) ||
      !std::isfinite(r.height))
    return absl::InvalidArgumentError(absl::StrCat(kind, " rectangle has a non-finite value"));
  if (r.width <= 0 || r.height <= 0)
    return absl::InvalidArgumentError(absl::StrCat(kind, " rectangle needs a positive width and height, got ",
                                                   r.width, "x", r.height));
  // Annotations may reach past the page edge (margins), but not far from it.
  if (r.x + r.width < -page.width || r.y + r.height < -page.height || r.x > 2.0 * page.width ||
      r.y > 2.0 * page.height)
    return absl::InvalidArgumentError(absl::StrCat(
        kind, " rectangle (", r.x, ", ", r.y, ", ", r.width, "x", r.height,
        ") lies far outside the ", page.width, "x", page.height, " page"));
  return absl::OkStatus();
}

}  // namespace

absl::Status AnnotationRecord::Validate(const cv::Size& page) const {
  switch (kind) {
    case Kind::kText:
      if (text.empty()) return absl::InvalidArgumentError("text annotation has no text");
      if (text.size() > kMaxTextBytes)
        return absl::InvalidArgumentError(absl::StrCat("text annotation is over ", kMaxTextBytes, " bytes"));
      if (!std::isfinite(position.x) || !std::isfinite(position.y) ||
          position.x < -page.width || position.y < -page.height ||
          position.x > 2.0 * page.width || position.y > 2.0 * page.height)
        return absl::InvalidArgumentError("text annotation position lies outside the page");
      if (!(font_size_px > 0) || font_size_px > 2.0 * std::max(page.width, page.height))
        return absl::InvalidArgumentError(absl::StrCat(
            "text annotation font_size_px must be positive and at most twice the page size, got ",
            font_size_px));
      return absl::OkStatus();
    case Kind::kHighlight:
      if (!(opacity >= 0 && opacity <= 1))
        return absl::InvalidArgumentError(absl::StrCat("highlight opacity must be in [0, 1], got ", opacity));
      return CheckRect(rect, page, "highlight");
    case Kind::kLink:
      if (uri.empty()) return absl::InvalidArgumentError("link annotation has no url");
      if (uri.size() > kMaxUriBytes) return absl::InvalidArgumentError("link url is too long");
      return CheckRect(rect, page, "link");
    case Kind::kMedia:
      if (uri.empty() && data.empty())
        return absl::InvalidArgumentError("media annotation needs a uri or inline data");
      if (uri.size() > kMaxUriBytes) return absl::InvalidArgumentError("media uri is too long");
      if (data.size() > kMaxMediaBytes)
        return absl::InvalidArgumentError(absl::StrCat("media data is over ", kMaxMediaBytes >> 20, " MiB"));
      return CheckRect(rect, page, "media");
  }
  return absl::InvalidArgumentError("annotation has an unknown kind");
}

}  // namespace texfree::server
