// Conversions between the client's plain types (annotations, camera files,
// homographies) and the texfree.v1 proto messages. The only place, with
// json_output.h, where client code touches proto annotation types.
#pragma once

#include <opencv2/core/matx.hpp>

#include "client/annotation.h"
#include "client/camera_file.h"
#include "client/overlay_renderer.h"
#include "texfree/v1/common.pb.h"
#include "texfree/v1/document.pb.h"

namespace texfree::client {

v1::Color ColorToProto(const Rgba& color);
Rgba ColorFromProto(const v1::Color& color);

v1::Annotation AnnotationToProto(const PageAnnotation& annotation);
PageAnnotation AnnotationFromProto(const v1::Annotation& annotation);

v1::CameraIntrinsics IntrinsicsToProto(const CameraFile& camera);

// 9 row-major values; returns false (and leaves `out` alone) if not 9 finite
// values.
bool HomographyFromProto(const v1::Homography& homography, cv::Matx33d* out);

// A retrieved match as a page to draw (homography, page size, title,
// annotations). Returns false if the match carries no usable homography.
bool OverlayPageFromMatch(const v1::DocumentMatch& match, OverlayPage* page);

}  // namespace texfree::client
