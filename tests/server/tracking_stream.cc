// Tracking test helpers: rendered frames and a whole-stream client.
#include "tests/server/tracking_stream.h"

#include <opencv2/imgcodecs.hpp>
#include <thread>

#include "tests/data/camera_sequence.h"

namespace texfree::testing {

std::vector<TrackFrame> RenderTrackFrames(const cv::Mat& page, int count, double step_deg,
                                          uint64_t seed) {
  testdata::CameraSequenceOptions o;
  o.step_deg = step_deg;
  o.end_tilt_deg = step_deg * (count - 1);
  o.jpeg_quality = 0;  // encoded once, below
  const auto frames = testdata::MakeCameraSequence(page.size(), o, seed);
  std::vector<TrackFrame> out;
  for (size_t i = 0; i < frames.size() && static_cast<int>(i) < count; ++i) {
    TrackFrame f;
    f.truth = testdata::RenderSequenceFrame(page, frames[i], seed, static_cast<int>(i));
    std::vector<uchar> bytes;
    cv::imencode(".jpg", f.truth.image, bytes, {cv::IMWRITE_JPEG_QUALITY, 85});
    f.jpeg.assign(bytes.begin(), bytes.end());
    out.push_back(std::move(f));
  }
  return out;
}

v1::CameraIntrinsics IntrinsicsOf(const testdata::CameraView& view) {
  v1::CameraIntrinsics in;
  in.set_fx(view.camera_matrix(0, 0));
  in.set_fy(view.camera_matrix(1, 1));
  in.set_cx(view.camera_matrix(0, 2));
  in.set_cy(view.camera_matrix(1, 2));
  in.set_width(view.image.cols);
  in.set_height(view.image.rows);
  return in;
}

v1::TrackRequest ConfigMessage(const v1::CameraIntrinsics* intrinsics,
                               const v1::TrackOptions& options) {
  v1::TrackRequest r;
  if (intrinsics) *r.mutable_config()->mutable_intrinsics() = *intrinsics;
  *r.mutable_config()->mutable_options() = options;
  return r;
}

v1::TrackRequest FrameMessage(uint64_t index, const std::string& encoded) {
  v1::TrackRequest r;
  r.mutable_frame()->set_frame_index(index);
  r.mutable_frame()->mutable_image()->set_encoded(encoded);
  return r;
}

cv::Matx33d HomographyOf(const v1::TrackedTarget& target) {
  cv::Matx33d H = cv::Matx33d::eye();
  if (target.homography().h_size() == 9)
    for (int i = 0; i < 9; ++i) H.val[i] = target.homography().h(i);
  return H;
}

StreamOutcome RunStream(v1::TrackingService::Stub& stub,
                        const std::vector<v1::TrackRequest>& messages, bool paced) {
  StreamOutcome outcome;
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(120));
  auto stream = stub.Track(&context);
  v1::TrackResponse response;
  if (paced) {
    for (size_t i = 0; i < messages.size(); ++i) {
      if (!stream->Write(messages[i])) break;
      if (i > 0 && stream->Read(&response)) outcome.responses.push_back(response);
    }
    stream->WritesDone();
    while (stream->Read(&response)) outcome.responses.push_back(response);
  } else {
    std::thread reader([&] {
      v1::TrackResponse r;
      while (stream->Read(&r)) outcome.responses.push_back(r);
    });
    for (const auto& m : messages)
      if (!stream->Write(m)) break;
    stream->WritesDone();
    reader.join();
  }
  outcome.status = stream->Finish();
  return outcome;
}

}  // namespace texfree::testing
