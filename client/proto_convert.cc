// Plain client types <-> texfree.v1 protos.
#include "client/proto_convert.h"

#include <algorithm>
#include <cmath>

namespace texfree::client {
namespace {

uint8_t Clamp8(uint32_t value) {
  return static_cast<uint8_t>(std::min<uint32_t>(value, 255));
}

v1::Rect RectToProto(const cv::Rect2d& rect) {
  v1::Rect out;
  out.set_x(rect.x);
  out.set_y(rect.y);
  out.set_width(rect.width);
  out.set_height(rect.height);
  return out;
}

cv::Rect2d RectFromProto(const v1::Rect& rect) {
  return cv::Rect2d(rect.x(), rect.y(), rect.width(), rect.height());
}

}  // namespace

v1::Color ColorToProto(const Rgba& color) {
  v1::Color out;
  out.set_r(color.r);
  out.set_g(color.g);
  out.set_b(color.b);
  out.set_a(color.a);
  return out;
}

Rgba ColorFromProto(const v1::Color& color) {
  return Rgba{Clamp8(color.r()), Clamp8(color.g()), Clamp8(color.b()),
              Clamp8(color.a())};
}

v1::Annotation AnnotationToProto(const PageAnnotation& annotation) {
  v1::Annotation out;
  out.set_annotation_id(annotation.annotation_id);
  switch (annotation.kind) {
    case AnnotationKind::kText: {
      auto* text = out.mutable_text();
      text->set_text(annotation.text);
      text->mutable_position()->set_x(annotation.position.x);
      text->mutable_position()->set_y(annotation.position.y);
      text->set_font_size_px(annotation.font_size_px);
      *text->mutable_color() = ColorToProto(annotation.color);
      break;
    }
    case AnnotationKind::kHighlight: {
      auto* highlight = out.mutable_highlight();
      *highlight->mutable_rect() = RectToProto(annotation.rect);
      *highlight->mutable_color() = ColorToProto(annotation.color);
      highlight->set_opacity(annotation.opacity);
      break;
    }
    case AnnotationKind::kLink: {
      auto* link = out.mutable_link();
      *link->mutable_rect() = RectToProto(annotation.rect);
      link->set_url(annotation.url);
      break;
    }
    case AnnotationKind::kMedia: {
      auto* media = out.mutable_media();
      *media->mutable_rect() = RectToProto(annotation.rect);
      media->set_mime_type(annotation.mime_type);
      if (!annotation.uri.empty()) {
        media->set_uri(annotation.uri);
      } else {
        media->set_data(annotation.data);
      }
      break;
    }
  }
  return out;
}

PageAnnotation AnnotationFromProto(const v1::Annotation& annotation) {
  PageAnnotation out;
  out.annotation_id = annotation.annotation_id();
  switch (annotation.kind_case()) {
    case v1::Annotation::kText:
      out.kind = AnnotationKind::kText;
      out.text = annotation.text().text();
      out.position = cv::Point2d(annotation.text().position().x(),
                                 annotation.text().position().y());
      out.font_size_px = annotation.text().font_size_px();
      out.color = annotation.text().has_color()
                      ? ColorFromProto(annotation.text().color())
                      : Rgba{255, 0, 0, 255};
      break;
    case v1::Annotation::kHighlight:
      out.kind = AnnotationKind::kHighlight;
      out.rect = RectFromProto(annotation.highlight().rect());
      out.color = annotation.highlight().has_color()
                      ? ColorFromProto(annotation.highlight().color())
                      : Rgba{255, 255, 0, 255};
      out.opacity = annotation.highlight().opacity();
      break;
    case v1::Annotation::kLink:
      out.kind = AnnotationKind::kLink;
      out.rect = RectFromProto(annotation.link().rect());
      out.url = annotation.link().url();
      break;
    case v1::Annotation::kMedia:
      out.kind = AnnotationKind::kMedia;
      out.rect = RectFromProto(annotation.media().rect());
      out.mime_type = annotation.media().mime_type();
      out.uri = annotation.media().uri();
      out.data = annotation.media().data();
      break;
    case v1::Annotation::KIND_NOT_SET:
      // Nothing to draw: an empty text annotation is skipped by the renderer.
      out.kind = AnnotationKind::kText;
      break;
  }
  return out;
}

v1::CameraIntrinsics IntrinsicsToProto(const CameraFile& camera) {
  v1::CameraIntrinsics out;
  out.set_fx(camera.fx());
  out.set_fy(camera.fy());
  out.set_cx(camera.cx());
  out.set_cy(camera.cy());
  for (double d : camera.distortion) out.add_distortion(d);
  out.set_width(static_cast<uint32_t>(camera.image_width));
  out.set_height(static_cast<uint32_t>(camera.image_height));
  return out;
}

bool HomographyFromProto(const v1::Homography& homography, cv::Matx33d* out) {
  if (homography.h_size() != 9) return false;
  cv::Matx33d h;
  for (int i = 0; i < 9; ++i) {
    if (!std::isfinite(homography.h(i))) return false;
    h.val[i] = homography.h(i);
  }
  *out = h;
  return true;
}

bool OverlayPageFromMatch(const v1::DocumentMatch& match, OverlayPage* page) {
  if (!HomographyFromProto(match.homography(), &page->homography)) return false;
  page->page_size = cv::Size2d(match.width(), match.height());
  page->title = match.title().empty() ? match.document_id() : match.title();
  page->annotations.clear();
  for (const auto& mapped : match.annotations()) {
    page->annotations.push_back(AnnotationFromProto(mapped.annotation()));
  }
  return true;
}

}  // namespace texfree::client
