// texfree.v1 protos -> nlohmann::json for the client's --json output.
// Homographies are flat arrays of 9 numbers (row-major), poses {"rotation":
// [9], "translation": [3]}, points [u, v]; annotations use the same keys as the
// annotations JSON input files.
#pragma once

#include <nlohmann/json.hpp>

#include "texfree/v1/common.pb.h"
#include "texfree/v1/document.pb.h"

namespace texfree::client {

nlohmann::json HomographyToJson(const v1::Homography& homography);
nlohmann::json PoseToJson(const v1::Pose& pose);
nlohmann::json PointToJson(const v1::Point2& point);
// "#rrggbb" or "#rrggbbaa".
nlohmann::json ColorToJson(const v1::Color& color);
// {"annotation_id", "type", ...fields of the annotations file format}. Inline
// media bytes are not printed: "data_bytes" gives their size.
nlohmann::json AnnotationToJson(const v1::Annotation& annotation);
// The annotation plus "quad" [[u,v]x4], "anchor" [u,v] and
// "mapped_font_size_px".
nlohmann::json MappedAnnotationToJson(const v1::MappedAnnotation& mapped);
// document_id, title, width, height, keypoints, created_unix_ms and, when
// `with_annotations`, "annotations".
nlohmann::json DocumentToJson(const v1::Document& document,
                              bool with_annotations);
// document_id, title, homography, inliers, votes, width, height, outline,
// pose (when present), annotations.
nlohmann::json MatchToJson(const v1::DocumentMatch& match);
// {"matches": [...], "server_ms", "query_keypoints", "timings": {stage: ms}}.
nlohmann::json RetrieveResponseToJson(
    const v1::RetrieveDocumentsResponse& response);

}  // namespace texfree::client
