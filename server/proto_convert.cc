// Proto <-> plain type conversions.
#include "server/proto_convert.h"

#include <cmath>

#include <spdlog/spdlog.h>

#include "absl/strings/str_cat.h"

namespace texfree::server {
namespace {

absl::StatusOr<Rgba> ColorFromProto(const v1::Color& c, bool has, const char* field) {
  if (!has) return Rgba{255, 0, 0, 255};
  if (c.r() > 255 || c.g() > 255 || c.b() > 255 || c.a() > 255)
    return absl::InvalidArgumentError(absl::StrCat(field, " components must be in 0..255"));
  // An all-zero colour message means "opaque black" rather than "invisible".
  const uint32_t a = (c.r() | c.g() | c.b() | c.a()) == 0 ? 255 : c.a();
  return Rgba{static_cast<uint8_t>(c.r()), static_cast<uint8_t>(c.g()),
              static_cast<uint8_t>(c.b()), static_cast<uint8_t>(a)};
}

void ColorToProto(const Rgba& c, v1::Color* out) {
  out->set_r(c.r);
  out->set_g(c.g);
  out->set_b(c.b);
  out->set_a(c.a);
}

cv::Rect2d RectFromProto(const v1::Rect& r) { return {r.x(), r.y(), r.width(), r.height()}; }

void RectToProto(const cv::Rect2d& r, v1::Rect* out) {
  out->set_x(r.x);
  out->set_y(r.y);
  out->set_width(r.width);
  out->set_height(r.height);
}

void PointToProto(const cv::Point2d& p, v1::Point2* out) {
  out->set_x(p.x);
  out->set_y(p.y);
}

}  // namespace

grpc::Status LoggedFailure(const char* method, const absl::Status& status) {
  if (status.code() == absl::StatusCode::kInternal || status.code() == absl::StatusCode::kDataLoss ||
      status.code() == absl::StatusCode::kUnavailable) {
    spdlog::error("{}: {}", method, status.ToString());
  } else {
    spdlog::info("{}: {}", method, status.ToString());
  }
  return ToGrpcStatus(status);
}

grpc::Status ToGrpcStatus(const absl::Status& status) {
  if (status.ok()) return grpc::Status::OK;
  // absl::StatusCode values are the canonical gRPC codes.
  return grpc::Status(static_cast<grpc::StatusCode>(status.code()), std::string(status.message()));
}

absl::StatusOr<cv::Mat> ImageFromProto(const v1::Image& image, const ImageLimits& limits,
                                       bool gray) {
  switch (image.data_case()) {
    case v1::Image::kEncoded:
      return DecodeImage(image.encoded(), limits, gray);
    case v1::Image::kRaw: {
      const v1::RawImage& raw = image.raw();
      RawPixelFormat format;
      if (raw.format() == v1::RawImage::GRAY8) {
        format = RawPixelFormat::kGray8;
      } else if (raw.format() == v1::RawImage::BGR8) {
        format = RawPixelFormat::kBgr8;
      } else {
        return absl::InvalidArgumentError("raw image needs format GRAY8 or BGR8");
      }
      if (raw.width() > 1u << 20 || raw.height() > 1u << 20)
        return absl::InvalidArgumentError("raw image width/height out of range");
      auto mat = ImageFromRaw(raw.pixels(), format, static_cast<int>(raw.width()),
                              static_cast<int>(raw.height()), static_cast<int>(raw.stride()),
                              limits);
      if (!mat.ok() || !gray) return mat;
      return ToGray(*mat);
    }
    case v1::Image::DATA_NOT_SET:
      break;
  }
  return absl::InvalidArgumentError("no image: set image.encoded (JPEG/PNG/BMP/TIFF) or image.raw");
}

absl::StatusOr<std::optional<CameraModel>> CameraFromProto(const v1::CameraIntrinsics& in) {
  if (in.fx() == 0 && in.fy() == 0 && in.cx() == 0 && in.cy() == 0) return std::nullopt;
  CameraModel camera;
  camera.K = cv::Matx33d(in.fx(), 0, in.cx(), 0, in.fy(), in.cy(), 0, 0, 1);
  camera.distortion.assign(in.distortion().begin(), in.distortion().end());
  camera.size = cv::Size(static_cast<int>(in.width()), static_cast<int>(in.height()));
  if (absl::Status s = camera.Validate(); !s.ok())
    return absl::InvalidArgumentError(absl::StrCat("intrinsics: ", s.message()));
  return std::optional<CameraModel>(camera);
}

absl::StatusOr<AnnotationRecord> AnnotationFromProto(const v1::Annotation& in) {
  AnnotationRecord a;
  switch (in.kind_case()) {
    case v1::Annotation::kText: {
      const auto& t = in.text();
      a.kind = AnnotationRecord::Kind::kText;
      a.text = t.text();
      a.position = {t.position().x(), t.position().y()};
      a.font_size_px = t.font_size_px();
      auto c = ColorFromProto(t.color(), t.has_color(), "text color");
      if (!c.ok()) return c.status();
      a.color = *c;
      break;
    }
    case v1::Annotation::kHighlight: {
      const auto& h = in.highlight();
      a.kind = AnnotationRecord::Kind::kHighlight;
      a.rect = RectFromProto(h.rect());
      a.opacity = h.opacity();
      auto c = ColorFromProto(h.color(), h.has_color(), "highlight color");
      if (!c.ok()) return c.status();
      a.color = *c;
      break;
    }
    case v1::Annotation::kLink:
      a.kind = AnnotationRecord::Kind::kLink;
      a.rect = RectFromProto(in.link().rect());
      a.uri = in.link().url();
      break;
    case v1::Annotation::kMedia: {
      const auto& m = in.media();
      a.kind = AnnotationRecord::Kind::kMedia;
      a.rect = RectFromProto(m.rect());
      a.mime_type = m.mime_type();
      if (m.source_case() == v1::MediaAnnotation::kUri) a.uri = m.uri();
      if (m.source_case() == v1::MediaAnnotation::kData) a.data = m.data();
      break;
    }
    case v1::Annotation::KIND_NOT_SET:
      return absl::InvalidArgumentError(
          "annotation has no kind: set one of text, highlight, link or media");
  }
  return a;
}

void AnnotationToProto(const AnnotationRecord& a, v1::Annotation* out) {
  out->set_annotation_id(a.id);
  switch (a.kind) {
    case AnnotationRecord::Kind::kText: {
      auto* t = out->mutable_text();
      t->set_text(a.text);
      PointToProto(a.position, t->mutable_position());
      t->set_font_size_px(a.font_size_px);
      ColorToProto(a.color, t->mutable_color());
      break;
    }
    case AnnotationRecord::Kind::kHighlight: {
      auto* h = out->mutable_highlight();
      RectToProto(a.rect, h->mutable_rect());
      ColorToProto(a.color, h->mutable_color());
      h->set_opacity(a.opacity);
      break;
    }
    case AnnotationRecord::Kind::kLink:
      RectToProto(a.rect, out->mutable_link()->mutable_rect());
      out->mutable_link()->set_url(a.uri);
      break;
    case AnnotationRecord::Kind::kMedia: {
      auto* m = out->mutable_media();
      RectToProto(a.rect, m->mutable_rect());
      m->set_mime_type(a.mime_type);
      if (!a.data.empty()) {
        m->set_data(a.data);
      } else {
        m->set_uri(a.uri);
      }
      break;
    }
  }
}

void SummaryToProto(const DocumentSummary& d, v1::Document* out) {
  out->set_document_id(d.id);
  out->set_title(d.title);
  out->set_width(d.size.width);
  out->set_height(d.size.height);
  out->set_keypoints(d.keypoints);
  out->set_created_unix_ms(d.created_unix_ms);
}

void DocumentToProto(const DocumentRecord& d, v1::Document* out) {
  out->set_document_id(d.id);
  out->set_title(d.title);
  out->set_width(d.size.width);
  out->set_height(d.size.height);
  out->set_keypoints(static_cast<uint32_t>(d.keypoint_count));
  out->set_created_unix_ms(d.created_unix_ms);
  for (const auto& a : d.annotations) AnnotationToProto(a, out->add_annotations());
}

void HomographyToProto(const cv::Matx33d& H, v1::Homography* out) {
  out->clear_h();
  for (int i = 0; i < 9; ++i) out->add_h(H.val[i]);
}

void PoseToProto(const PlanarPose& pose, v1::Pose* out) {
  out->clear_rotation();
  out->clear_translation();
  for (int i = 0; i < 9; ++i) out->add_rotation(pose.R.val[i]);
  for (int i = 0; i < 3; ++i) out->add_translation(pose.t[i]);
}

namespace {
v1::Overlay* AddOverlay(v1::Overlay::Kind kind, const std::vector<cv::Point2d>& points,
                        const Rgba& colour, google::protobuf::RepeatedPtrField<v1::Overlay>* out) {
  v1::Overlay* o = out->Add();
  o->set_kind(kind);
  for (const cv::Point2d& p : points) PointToProto(p, o->add_points());
  ColorToProto(colour, o->mutable_color());
  o->set_opacity(1.0);
  o->set_thickness(2.0);
  return o;
}
}  // namespace

void MappedAnnotationToProto(const AnnotationRecord& a, const cv::Matx33d& H,
                             v1::MappedAnnotation* m) {
  AnnotationToProto(a, m->mutable_annotation());
  if (a.kind == AnnotationRecord::Kind::kText) {
    PointToProto(ApplyHomography(H, a.position), m->mutable_anchor());
    m->set_font_size_px(a.font_size_px * HomographyLocalScale(H, a.position));
    // Text box: baseline start, one font size up, a rough advance of 0.6 em per byte.
    const double len = 0.6 * a.font_size_px * a.text.size();
    const cv::Point2d p = a.position;
    for (const cv::Point2d& c :
         {p + cv::Point2d(0, -a.font_size_px), p + cv::Point2d(len, -a.font_size_px),
          p + cv::Point2d(len, 0.25 * a.font_size_px), p + cv::Point2d(0, 0.25 * a.font_size_px)})
      PointToProto(ApplyHomography(H, c), m->add_quad());
  } else {
    for (const cv::Point2d& c : RectCorners(a.rect))
      PointToProto(ApplyHomography(H, c), m->add_quad());
    PointToProto(ApplyHomography(H, a.rect.tl()), m->mutable_anchor());
  }
}

void OutlineToProto(const cv::Matx33d& H, const cv::Size& page,
                    google::protobuf::RepeatedPtrField<v1::Point2>* out) {
  for (const cv::Point2d& c : RectCorners(cv::Rect2d(0, 0, page.width, page.height)))
    PointToProto(ApplyHomography(H, c), out->Add());
}

void PageOverlaysToProto(const cv::Matx33d& H, const cv::Size& page,
                         const std::vector<AnnotationRecord>& annotations,
                         google::protobuf::RepeatedPtrField<v1::Overlay>* out) {
  std::vector<cv::Point2d> mapped;
  if (MapPointsInFront(H, RectCorners(cv::Rect2d(0, 0, page.width, page.height)), &mapped))
    AddOverlay(v1::Overlay::POLYGON, mapped, Rgba{0, 200, 0, 255}, out);
  for (const AnnotationRecord& a : annotations) {
    switch (a.kind) {
      case AnnotationRecord::Kind::kText: {
        const cv::Point2d p = a.position;
        if (!MapPointsInFront(H, {p, p + cv::Point2d(a.font_size_px, 0)}, &mapped)) break;
        v1::Overlay* o = AddOverlay(v1::Overlay::TEXT, mapped, a.color, out);
        o->set_text(a.text);
        o->set_font_size_px(a.font_size_px * HomographyLocalScale(H, p));
        o->set_opacity(a.color.a / 255.0);
        break;
      }
      case AnnotationRecord::Kind::kHighlight: {
        if (!MapPointsInFront(H, RectCorners(a.rect), &mapped)) break;
        AddOverlay(v1::Overlay::FILLED_POLYGON, mapped, a.color, out)->set_opacity(a.opacity);
        break;
      }
      case AnnotationRecord::Kind::kLink:
      case AnnotationRecord::Kind::kMedia: {
        if (!MapPointsInFront(H, RectCorners(a.rect), &mapped)) break;
        const bool link = a.kind == AnnotationRecord::Kind::kLink;
        AddOverlay(v1::Overlay::POLYGON, mapped,
                   link ? Rgba{0, 90, 255, 255} : Rgba{255, 140, 0, 255}, out)
            ->set_text(a.uri);
        break;
      }
    }
  }
}

void MatchToProto(const RetrievedDocument& doc, v1::DocumentMatch* out) {
  const cv::Matx33d& H = doc.homography;
  out->set_document_id(doc.document.id);
  out->set_title(doc.document.title);
  out->set_width(doc.document.size.width);
  out->set_height(doc.document.size.height);
  HomographyToProto(H, out->mutable_homography());
  if (doc.pose) PoseToProto(*doc.pose, out->mutable_pose());
  out->set_inliers(doc.inliers);
  out->set_votes(doc.votes);
  OutlineToProto(H, doc.document.size, out->mutable_outline());
  for (const AnnotationRecord& a : doc.annotations)
    MappedAnnotationToProto(a, H, out->add_annotations());
}

}  // namespace texfree::server
