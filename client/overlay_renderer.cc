// OverlayRenderer: perspective drawing of pages and annotations with OpenCV.
#include "client/overlay_renderer.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <opencv2/freetype.hpp>
#include <opencv2/imgproc.hpp>

#include "common/planar_pose.h"

namespace texfree::client {
namespace {

// Coordinates beyond this are treated as degenerate (OpenCV drawing uses int).
constexpr double kMaxCoordinate = 1e6;
// Largest text height rendered before warping, in pixels.
constexpr int kMaxTextHeight = 400;
constexpr int kMinTextHeight = 8;

const Rgba kLinkColor{30, 110, 255, 255};
const Rgba kMediaColor{200, 0, 200, 255};

cv::Matx33d Translation(double tx, double ty) {
  return cv::Matx33d(1, 0, tx, 0, 1, ty, 0, 0, 1);
}

// Bounding box of points, clipped to the image; empty if outside.
cv::Rect ClippedBounds(const std::vector<cv::Point2d>& points,
                       const cv::Size& size) {
  double min_x = points[0].x, max_x = points[0].x;
  double min_y = points[0].y, max_y = points[0].y;
  for (const auto& p : points) {
    min_x = std::min(min_x, p.x);
    max_x = std::max(max_x, p.x);
    min_y = std::min(min_y, p.y);
    max_y = std::max(max_y, p.y);
  }
  int x0 = static_cast<int>(std::floor(std::max(min_x - 1, 0.0)));
  int y0 = static_cast<int>(std::floor(std::max(min_y - 1, 0.0)));
  int x1 = static_cast<int>(
      std::ceil(std::min(max_x + 2, static_cast<double>(size.width))));
  int y1 = static_cast<int>(
      std::ceil(std::min(max_y + 2, static_cast<double>(size.height))));
  if (x1 <= x0 || y1 <= y0) return {};
  return cv::Rect(x0, y0, x1 - x0, y1 - y0);
}

// image_roi = image_roi * (1 - a) + bgr * a with a = mask / 255 * opacity.
void BlendMask(cv::Mat& image_roi, const cv::Mat& mask, const cv::Scalar& bgr,
               double opacity) {
  CV_Assert(image_roi.type() == CV_8UC3 && mask.type() == CV_8UC1 &&
            image_roi.size() == mask.size());
  const float scale = static_cast<float>(opacity / 255.0);
  const float color[3] = {static_cast<float>(bgr[0]),
                          static_cast<float>(bgr[1]),
                          static_cast<float>(bgr[2])};
  for (int y = 0; y < image_roi.rows; ++y) {
    cv::Vec3b* row = image_roi.ptr<cv::Vec3b>(y);
    const uint8_t* m = mask.ptr<uint8_t>(y);
    for (int x = 0; x < image_roi.cols; ++x) {
      if (m[x] == 0) continue;
      float a = m[x] * scale;
      for (int c = 0; c < 3; ++c) {
        row[x][c] =
            cv::saturate_cast<uint8_t>(row[x][c] * (1.0f - a) + color[c] * a);
      }
    }
  }
}

// Fills the polygon of image points `mapped` (convex, anti-aliased) in `bgr`, blended at
// `opacity`; only the polygon's bounding box inside the image is touched.
void FillConvexBlended(cv::Mat& image, const std::vector<cv::Point2d>& mapped,
                       const cv::Scalar& bgr, double opacity) {
  cv::Rect roi = ClippedBounds(mapped, image.size());
  if (roi.empty()) return;
  constexpr int kShift = 4;
  std::vector<cv::Point> points;
  for (const auto& p : mapped) {
    points.emplace_back(cvRound((p.x - roi.x) * (1 << kShift)),
                        cvRound((p.y - roi.y) * (1 << kShift)));
  }
  cv::Mat mask = cv::Mat::zeros(roi.size(), CV_8UC1);
  cv::fillConvexPoly(mask, points, cv::Scalar(255), cv::LINE_AA, kShift);
  cv::Mat image_roi = image(roi);
  BlendMask(image_roi, mask, bgr, opacity);
}

std::string MediaLabel(const PageAnnotation& annotation) {
  std::string label =
      annotation.mime_type.empty() ? "media" : annotation.mime_type;
  if (!annotation.uri.empty()) {
    std::string name =
        annotation.uri.substr(0, annotation.uri.find_first_of("?#"));
    std::string file = std::filesystem::path(name).filename().string();
    label += ": " + (file.empty() ? annotation.uri : file);
  } else if (!annotation.data.empty()) {
    label +=
        " (" + std::to_string((annotation.data.size() + 1023) / 1024) + " KiB)";
  }
  return label;
}

}  // namespace

OverlayRenderer::OverlayRenderer() : OverlayRenderer(Options()) {}

OverlayRenderer::OverlayRenderer(Options options)
    : options_(std::move(options)) {
  std::error_code ec;
  if (!options_.font_path.empty() &&
      std::filesystem::is_regular_file(options_.font_path, ec)) {
    try {
      cv::Ptr<cv::freetype::FreeType2> font = cv::freetype::createFreeType2();
      font->loadFontData(options_.font_path, 0);
      font_ = font;
    } catch (const cv::Exception&) {
      font_.reset();  // fall back to the Hershey font
    }
  }
}

OverlayRenderer::~OverlayRenderer() = default;

cv::Scalar OverlayRenderer::PaletteColor(int index) {
  static const cv::Scalar kPalette[] = {
      {0, 200, 0},   {255, 128, 0}, {0, 128, 255}, {255, 0, 255},
      {0, 220, 220}, {255, 255, 0}, {128, 0, 255}, {0, 0, 255},
  };
  constexpr int kCount = sizeof(kPalette) / sizeof(kPalette[0]);
  return kPalette[((index % kCount) + kCount) % kCount];
}

bool OverlayRenderer::MapPoints(const cv::Matx33d& h,
                                const std::vector<cv::Point2d>& in,
                                std::vector<cv::Point2d>* out) {
  if (!MapPointsInFront(h, in, out)) return false;
  // Beyond this, OpenCV's fixed-point drawing overflows.
  for (const cv::Point2d& p : *out)
    if (std::abs(p.x) > kMaxCoordinate || std::abs(p.y) > kMaxCoordinate) return false;
  return true;
}

void OverlayRenderer::DrawPages(cv::Mat& image,
                                const std::vector<OverlayPage>& pages) const {
  for (size_t i = 0; i < pages.size(); ++i)
    DrawPage(image, pages[i], static_cast<int>(i));
}

void OverlayRenderer::DrawPage(cv::Mat& image, const OverlayPage& page,
                               int page_index) const {
  CV_Assert(image.type() == CV_8UC3);
  cv::Scalar color = PaletteColor(page_index);
  if (options_.draw_annotations) {
    for (const auto& annotation : page.annotations) {
      DrawAnnotation(image, page.homography, annotation);
    }
  }
  if (options_.draw_outline && page.page_size.area() > 0) {
    DrawOutline(image, page.homography, page.page_size, color);
  }
  if (options_.draw_title && !page.title.empty() && page.page_size.area() > 0) {
    double size = std::max(page.page_size.height * 0.035, 12.0);
    Rgba rgba{static_cast<uint8_t>(color[2]), static_cast<uint8_t>(color[1]),
              static_cast<uint8_t>(color[0]), 255};
    DrawWarpedText(image, page.homography, page.title,
                   cv::Point2d(0, -0.6 * size), size, rgba);
  }
}

void OverlayRenderer::DrawOutline(cv::Mat& image, const cv::Matx33d& homography,
                                  const cv::Size2d& page_size,
                                  const cv::Scalar& bgr) const {
  std::vector<cv::Point2d> corners = {{0, 0},
                                      {page_size.width, 0},
                                      {page_size.width, page_size.height},
                                      {0, page_size.height}};
  std::vector<cv::Point2d> mapped;
  if (!MapPoints(homography, corners, &mapped)) return;
  constexpr int kShift = 4;
  std::vector<cv::Point> points;
  for (const auto& p : mapped) {
    points.emplace_back(cvRound(p.x * (1 << kShift)),
                        cvRound(p.y * (1 << kShift)));
  }
  cv::polylines(image, points, true, bgr, options_.outline_thickness,
                cv::LINE_AA, kShift);
}

void OverlayRenderer::FillQuad(cv::Mat& image, const cv::Matx33d& homography,
                               const cv::Rect2d& rect, const cv::Scalar& bgr,
                               double opacity) {
  CV_Assert(image.type() == CV_8UC3);
  if (opacity <= 0 || rect.width <= 0 || rect.height <= 0) return;
  std::vector<cv::Point2d> mapped;
  if (!MapPoints(homography, RectCorners(rect), &mapped)) return;
  FillConvexBlended(image, mapped, bgr, std::min(opacity, 1.0));
}

cv::Mat OverlayRenderer::RenderTextMask(const std::string& text, int height_px,
                                        int* baseline_y, int* left_x) const {
  const int margin = std::max(2, height_px / 4);
  if (font_) {
    int baseline = 0;
    cv::Size size = font_->getTextSize(text, height_px, -1, &baseline);
    cv::Mat canvas =
        cv::Mat::zeros(size.height + baseline + 2 * margin + height_px / 2,
                       size.width + 2 * margin, CV_8UC3);
    // With bottomLeftOrigin = true, FreeType2::putText puts the baseline start
    // at `origin` (with false, OpenCV 4.6 uses origin as the top of the em
    // box).
    cv::Point origin(margin, margin + size.height + height_px / 4);
    font_->putText(canvas, text, origin, height_px, cv::Scalar::all(255), -1,
                   cv::LINE_AA, true);
    cv::Mat mask;
    cv::extractChannel(canvas, mask, 0);
    *baseline_y = origin.y;
    *left_x = origin.x;
    return mask;
  }
  const int face = cv::FONT_HERSHEY_SIMPLEX;
  const int thickness = std::max(1, height_px / 12);
  double scale = cv::getFontScaleFromHeight(face, height_px, thickness);
  int baseline = 0;
  cv::Size size = cv::getTextSize(text, face, scale, thickness, &baseline);
  cv::Mat mask = cv::Mat::zeros(size.height + baseline + 2 * margin,
                                size.width + 2 * margin, CV_8UC1);
  cv::Point origin(margin, margin + size.height);
  cv::putText(mask, text, origin, face, scale, cv::Scalar(255), thickness,
              cv::LINE_AA);
  *baseline_y = origin.y;
  *left_x = origin.x;
  return mask;
}

void OverlayRenderer::DrawWarpedText(
    cv::Mat& image, const cv::Matx33d& homography, const std::string& text,
    const cv::Point2d& origin, double font_size_px, const Rgba& color) const {
  CV_Assert(image.type() == CV_8UC3);
  if (text.empty() || !(font_size_px > 0) || color.a == 0) return;
  // Render at about the resolution the text will have in the image.
  double scale = HomographyLocalScale(homography, origin);
  if (!(scale > 0)) return;
  int height_px = static_cast<int>(std::lround(font_size_px * scale));
  height_px = std::clamp(height_px, kMinTextHeight, kMaxTextHeight);
  double render_scale =
      height_px / font_size_px;  // mask pixels per registration pixel

  int baseline_y = 0;
  int left_x = 0;
  cv::Mat mask = RenderTextMask(text, height_px, &baseline_y, &left_x);
  if (mask.empty()) return;

  // Mask pixel (u, v) -> registration point origin + ((u - left_x), (v -
  // baseline_y)) / s.
  cv::Matx33d mask_to_page(
      1.0 / render_scale, 0, origin.x - left_x / render_scale,      //
      0, 1.0 / render_scale, origin.y - baseline_y / render_scale,  //
      0, 0, 1);
  cv::Matx33d mask_to_image = homography * mask_to_page;
  std::vector<cv::Point2d> corners = {
      {0, 0},
      {static_cast<double>(mask.cols), 0},
      {static_cast<double>(mask.cols), static_cast<double>(mask.rows)},
      {0, static_cast<double>(mask.rows)}};
  std::vector<cv::Point2d> mapped;
  if (!MapPoints(mask_to_image, corners, &mapped)) return;
  cv::Rect roi = ClippedBounds(mapped, image.size());
  if (roi.empty()) return;
  cv::Mat warped;
  cv::warpPerspective(
      mask, warped, cv::Mat(Translation(-roi.x, -roi.y) * mask_to_image),
      roi.size(), cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(0));
  cv::Mat image_roi = image(roi);
  BlendMask(image_roi, warped, color.ToBgr(), color.a / 255.0);
}

void OverlayRenderer::DrawAnnotation(cv::Mat& image,
                                     const cv::Matx33d& homography,
                                     const PageAnnotation& annotation) const {
  const cv::Rect2d& rect = annotation.rect;
  switch (annotation.kind) {
    case AnnotationKind::kText:
      DrawWarpedText(image, homography, annotation.text, annotation.position,
                     annotation.font_size_px, annotation.color);
      return;
    case AnnotationKind::kHighlight:
      FillQuad(image, homography, rect, annotation.color.ToBgr(),
               annotation.opacity * annotation.color.a / 255.0);
      return;
    case AnnotationKind::kLink:
    case AnnotationKind::kMedia: {
      if (rect.width <= 0 || rect.height <= 0) return;
      const bool link = annotation.kind == AnnotationKind::kLink;
      const Rgba& color = link ? kLinkColor : kMediaColor;
      FillQuad(image, homography, rect, color.ToBgr(), link ? 0.12 : 0.08);
      const std::vector<cv::Point2d> corners = RectCorners(rect);
      std::vector<cv::Point2d> mapped;
      if (MapPoints(homography, corners, &mapped)) {
        constexpr int kShift = 4;
        std::vector<cv::Point> points;
        for (const auto& p : mapped) {
          points.emplace_back(cvRound(p.x * (1 << kShift)),
                              cvRound(p.y * (1 << kShift)));
        }
        double scale = HomographyLocalScale(homography, (corners[0] + corners[2]) * 0.5);
        int thickness =
            std::clamp(static_cast<int>(std::lround(2 * scale)), 1, 4);
        cv::polylines(image, points, true, color.ToBgr(), thickness,
                      cv::LINE_AA, kShift);
      }
      if (!link) {
        // A "play" triangle in the middle of the box.
        double side = std::min(rect.width, rect.height) * 0.3;
        cv::Point2d centre(rect.x + rect.width / 2, rect.y + rect.height / 2);
        std::vector<cv::Point2d> triangle = {
            centre + cv::Point2d(-side / 2, -side / 2),
            centre + cv::Point2d(side / 2, 0),
            centre + cv::Point2d(-side / 2, side / 2)};
        if (MapPoints(homography, triangle, &mapped))
          FillConvexBlended(image, mapped, color.ToBgr(), 0.6);
      }
      // Label: the URL (link) or the media type and name, fitted into the box.
      std::string label = link ? annotation.url : MediaLabel(annotation);
      if (label.empty()) return;
      double size = std::min(rect.height * (link ? 0.6 : 0.15), 48.0);
      double pad = std::max(2.0, size * 0.25);
      // Shrink to the box width (text width grows linearly with its height).
      int probe_baseline = 0;
      double probe_width = 0;
      if (font_) {
        probe_width = font_->getTextSize(label, 100, -1, &probe_baseline).width;
      } else {
        probe_width = cv::getTextSize(label, cv::FONT_HERSHEY_SIMPLEX,
                                      cv::getFontScaleFromHeight(
                                          cv::FONT_HERSHEY_SIMPLEX, 100),
                                      1, &probe_baseline)
                          .width;
      }
      if (probe_width > 0) {
        size = std::min(size, (rect.width - 2 * pad) * 100.0 / probe_width);
      }
      size = std::max(size, 6.0);
      cv::Point2d origin =
          link ? cv::Point2d(rect.x + pad,
                             rect.y + rect.height / 2 + size * 0.35)
               : cv::Point2d(rect.x + pad, rect.y + pad + size);
      DrawWarpedText(image, homography, label, origin, size, color);
      return;
    }
  }
}

}  // namespace texfree::client
