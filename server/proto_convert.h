// Conversions between texfree.v1 proto messages and the plain C++ types of the server,
// and absl::Status -> grpc::Status. Proto types stop here.
#pragma once

#include <optional>

#include <grpcpp/support/status.h>

#include "absl/status/statusor.h"
#include "common/image_io.h"
#include "common/planar_pose.h"
#include "server/document_registry.h"
#include "server/document_types.h"
#include "texfree/v1/common.pb.h"
#include "texfree/v1/document.pb.h"

namespace texfree::server {

// One-to-one mapping of absl status codes to gRPC codes, message kept.
grpc::Status ToGrpcStatus(const absl::Status& status);

// ToGrpcStatus after logging the failure of `method`: as an error for server faults
// (INTERNAL, DATA_LOSS, UNAVAILABLE), as information for bad requests.
grpc::Status LoggedFailure(const char* method, const absl::Status& status);

// Decodes an Image message to 8-bit gray (or BGR when `gray` is false).
absl::StatusOr<cv::Mat> ImageFromProto(const v1::Image& image, const ImageLimits& limits,
                                       bool gray = true);

// nullopt when the message is absent or all zero; INVALID_ARGUMENT when half-filled.
absl::StatusOr<std::optional<CameraModel>> CameraFromProto(const v1::CameraIntrinsics& intrinsics);

absl::StatusOr<AnnotationRecord> AnnotationFromProto(const v1::Annotation& annotation);
void AnnotationToProto(const AnnotationRecord& a, v1::Annotation* out);
void DocumentToProto(const DocumentRecord& d, v1::Document* out);
void SummaryToProto(const DocumentSummary& d, v1::Document* out);

void HomographyToProto(const cv::Matx33d& H, v1::Homography* out);
void PoseToProto(const PlanarPose& pose, v1::Pose* out);

// Places a document's annotations and outline in the query image with its homography.
void MatchToProto(const RetrievedDocument& doc, v1::DocumentMatch* out);

// One annotation placed in an image by a homography (registration pixels -> image).
void MappedAnnotationToProto(const AnnotationRecord& a, const cv::Matx33d& H,
                             v1::MappedAnnotation* out);
// The page's four corners (tl, tr, br, bl) mapped by H.
void OutlineToProto(const cv::Matx33d& H, const cv::Size& page,
                    google::protobuf::RepeatedPtrField<v1::Point2>* out);
// Ready-to-draw primitives of a page seen through H (registration pixels -> image), for
// clients that draw no perspective of their own: the outline (POLYGON, green, 2 px), then
// per annotation a highlight as a FILLED_POLYGON of its colour and opacity, a text as TEXT
// (points: the baseline's start and a point one font size along it; font size at the
// anchor), a link as a blue POLYGON and a media rectangle as an orange POLYGON, both
// carrying their URI in `text`. Annotations behind the camera (a point with w <= 0) are
// left out.
void PageOverlaysToProto(const cv::Matx33d& H, const cv::Size& page,
                         const std::vector<AnnotationRecord>& annotations,
                         google::protobuf::RepeatedPtrField<v1::Overlay>* out);

}  // namespace texfree::server
