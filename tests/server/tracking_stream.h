// Helpers of the tracking service tests: a rendered camera sequence over a page as JPEG
// frames with ground truth, and a client that runs one Track stream to the end.
#pragma once

#include <grpcpp/grpcpp.h>

#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "tests/data/camera_view.h"
#include "texfree/v1/tracking.grpc.pb.h"

namespace texfree::testing {

struct TrackFrame {
  std::string jpeg;
  testdata::CameraView truth;  // image, H, K, R, t
};

// `count` frames of the close orbit (tilt from 0 by `step_deg`) over `page`, JPEG 85.
std::vector<TrackFrame> RenderTrackFrames(const cv::Mat& page, int count, double step_deg,
                                          uint64_t seed);

// Intrinsics of a rendered view (no distortion).
v1::CameraIntrinsics IntrinsicsOf(const testdata::CameraView& view);

v1::TrackRequest ConfigMessage(const v1::CameraIntrinsics* intrinsics,
                               const v1::TrackOptions& options = {});
v1::TrackRequest FrameMessage(uint64_t index, const std::string& encoded);

cv::Matx33d HomographyOf(const v1::TrackedTarget& target);

struct StreamOutcome {
  grpc::Status status;
  std::vector<v1::TrackResponse> responses;
};

// Writes every message (the first should be the config), closes the client side, then
// reads every result and the final status. Paced: after each message but the first, waits
// for its result (a camera that sends the next frame when the last one is answered), so
// the server never falls behind. Not paced: writes as fast as it can while a reader
// thread collects results (a server that falls behind drops frames).
StreamOutcome RunStream(v1::TrackingService::Stub& stub,
                        const std::vector<v1::TrackRequest>& messages, bool paced = true);

}  // namespace texfree::testing
