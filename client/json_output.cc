// Proto -> JSON conversions for the texfree client output.
#include "client/json_output.h"

#include "client/annotations_json.h"
#include "client/proto_convert.h"

namespace texfree::client {

using nlohmann::json;

json HomographyToJson(const v1::Homography& homography) {
  json out = json::array();
  for (double value : homography.h()) out.push_back(value);
  return out;
}

json PoseToJson(const v1::Pose& pose) {
  json rotation = json::array();
  for (double value : pose.rotation()) rotation.push_back(value);
  json translation = json::array();
  for (double value : pose.translation()) translation.push_back(value);
  return json{{"rotation", rotation}, {"translation", translation}};
}

json PointToJson(const v1::Point2& point) {
  return json::array({point.x(), point.y()});
}

json ColorToJson(const v1::Color& color) {
  return FormatHexColor(ColorFromProto(color));
}

json AnnotationToJson(const v1::Annotation& annotation) {
  json out;
  if (!annotation.annotation_id().empty())
    out["annotation_id"] = annotation.annotation_id();
  auto put_rect = [&out](const v1::Rect& rect) {
    out["x"] = rect.x();
    out["y"] = rect.y();
    out["width"] = rect.width();
    out["height"] = rect.height();
  };
  switch (annotation.kind_case()) {
    case v1::Annotation::kText: {
      const auto& text = annotation.text();
      out["type"] = "text";
      out["text"] = text.text();
      out["x"] = text.position().x();
      out["y"] = text.position().y();
      out["font_size"] = text.font_size_px();
      if (text.has_color()) out["color"] = ColorToJson(text.color());
      break;
    }
    case v1::Annotation::kHighlight: {
      const auto& highlight = annotation.highlight();
      out["type"] = "highlight";
      put_rect(highlight.rect());
      if (highlight.has_color()) out["color"] = ColorToJson(highlight.color());
      out["opacity"] = highlight.opacity();
      break;
    }
    case v1::Annotation::kLink:
      out["type"] = "link";
      put_rect(annotation.link().rect());
      out["url"] = annotation.link().url();
      break;
    case v1::Annotation::kMedia: {
      const auto& media = annotation.media();
      out["type"] = "media";
      put_rect(media.rect());
      out["mime_type"] = media.mime_type();
      if (media.source_case() == v1::MediaAnnotation::kUri) {
        out["uri"] = media.uri();
      } else {
        out["data_bytes"] = media.data().size();
      }
      break;
    }
    case v1::Annotation::KIND_NOT_SET:
      out["type"] = "unknown";
      break;
  }
  return out;
}

json MappedAnnotationToJson(const v1::MappedAnnotation& mapped) {
  json out = AnnotationToJson(mapped.annotation());
  if (mapped.quad_size() > 0) {
    json quad = json::array();
    for (const auto& point : mapped.quad()) quad.push_back(PointToJson(point));
    out["quad"] = quad;
  }
  if (mapped.has_anchor()) out["anchor"] = PointToJson(mapped.anchor());
  if (mapped.font_size_px() > 0)
    out["mapped_font_size_px"] = mapped.font_size_px();
  return out;
}

json DocumentToJson(const v1::Document& document, bool with_annotations) {
  json out{{"document_id", document.document_id()},
           {"title", document.title()},
           {"width", document.width()},
           {"height", document.height()},
           {"keypoints", document.keypoints()},
           {"created_unix_ms", document.created_unix_ms()}};
  if (with_annotations) {
    json annotations = json::array();
    for (const auto& annotation : document.annotations()) {
      annotations.push_back(AnnotationToJson(annotation));
    }
    out["annotations"] = annotations;
  }
  return out;
}

json MatchToJson(const v1::DocumentMatch& match) {
  json out{{"document_id", match.document_id()},
           {"title", match.title()},
           {"homography", HomographyToJson(match.homography())},
           {"inliers", match.inliers()},
           {"votes", match.votes()},
           {"width", match.width()},
           {"height", match.height()}};
  json outline = json::array();
  for (const auto& point : match.outline())
    outline.push_back(PointToJson(point));
  out["outline"] = outline;
  if (match.has_pose()) out["pose"] = PoseToJson(match.pose());
  json annotations = json::array();
  for (const auto& mapped : match.annotations()) {
    annotations.push_back(MappedAnnotationToJson(mapped));
  }
  out["annotations"] = annotations;
  return out;
}

json RetrieveResponseToJson(const v1::RetrieveDocumentsResponse& response) {
  json matches = json::array();
  for (const auto& match : response.matches())
    matches.push_back(MatchToJson(match));
  json timings = json::object();
  for (const auto& timing : response.timings())
    timings[timing.stage()] = timing.ms();
  return json{{"matches", matches},
              {"server_ms", response.server_ms()},
              {"query_keypoints", response.query_keypoints()},
              {"timings", timings}};
}

}  // namespace texfree::client
