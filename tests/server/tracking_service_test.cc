// In-process tests of TrackingService over a real gRPC server on a loopback port and a
// real DocumentRegistry: a page tracked through a short tilt sequence with pose and
// annotations against ground truth; bad frames answered with an error result while the
// stream goes on; a bad first message or bad options refused; learning private to each
// stream; stale frames dropped and reported when the server falls behind; a cancelled or
// silent stream leaves no session behind.
#include "server/tracking_service.h"

#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <opencv2/imgproc.hpp>
#include <set>
#include <thread>

#include "common/planar_pose.h"
#include "server/document_registry.h"
#include "server/document_store.h"
#include "tests/data/page_renderer.h"
#include "tests/server/tracking_stream.h"

namespace texfree::server {
namespace {

namespace fs = std::filesystem;
using texfree::testing::ConfigMessage;
using texfree::testing::FrameMessage;
using texfree::testing::HomographyOf;
using texfree::testing::RunStream;
using texfree::testing::TrackFrame;

class TrackingServiceTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    page_ = new cv::Mat(testdata::RenderTextPage(4242).image);
    frames_ = new std::vector<TrackFrame>(texfree::testing::RenderTrackFrames(*page_, 8, 2.0, 21));
  }
  static void TearDownTestSuite() {
    delete page_;
    delete frames_;
  }

  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("texfree-track-" + std::to_string(::getpid()) + "-" + std::to_string(counter_++));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    auto store = DocumentStore::Open((dir_ / "texfree.db").string());
    ASSERT_TRUE(store.ok()) << store.status();
    auto registry = DocumentRegistry::Open(std::move(*store), {});
    ASSERT_TRUE(registry.ok()) << registry.status();
    registry_ = std::move(*registry);
    cv::Mat gray;
    cv::cvtColor(*page_, gray, cv::COLOR_BGR2GRAY);
    AnnotationRecord note;
    note.kind = AnnotationRecord::Kind::kText;
    note.text = "remember";
    note.position = {120, 300};
    note.font_size_px = 30;
    auto record = registry_->Register(gray, "tracked", {note});
    ASSERT_TRUE(record.ok()) << record.status();
    document_id_ = record->id;
  }

  void TearDown() override {
    StopServer();
    registry_.reset();
    fs::remove_all(dir_);
  }

  void StartServer(TrackingServiceOptions options = {}) {
    service_ = std::make_unique<TrackingServiceImpl>(registry_.get(), options);
    grpc::ServerBuilder builder;
    int port = 0;
    builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port);
    builder.RegisterService(service_.get());
    server_ = builder.BuildAndStart();
    ASSERT_NE(server_, nullptr);
    stub_ = v1::TrackingService::NewStub(grpc::CreateChannel("127.0.0.1:" + std::to_string(port),
                                                             grpc::InsecureChannelCredentials()));
  }

  void StopServer() {
    if (server_) server_->Shutdown(std::chrono::system_clock::now() + std::chrono::seconds(2));
    server_.reset();
    service_.reset();
  }

  // Waits until no session is left (sessions end asynchronously after a cancellation).
  bool SessionsDrain(std::chrono::milliseconds limit = std::chrono::milliseconds(5000)) {
    const auto end = std::chrono::steady_clock::now() + limit;
    while (service_->active_sessions() > 0 && std::chrono::steady_clock::now() < end)
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    return service_->active_sessions() == 0;
  }

  // A config without intrinsics, then `count` frames sent back to back (the sequence's
  // frames over and over).
  static std::vector<v1::TrackRequest> Burst(int count) {
    std::vector<v1::TrackRequest> messages = {ConfigMessage(nullptr)};
    for (int i = 0; i < count; ++i)
      messages.push_back(FrameMessage(i, (*frames_)[i % frames_->size()].jpeg));
    return messages;
  }

  static cv::Mat* page_;
  static std::vector<TrackFrame>* frames_;
  static int counter_;
  fs::path dir_;
  std::unique_ptr<DocumentRegistry> registry_;
  std::string document_id_;
  std::unique_ptr<TrackingServiceImpl> service_;
  std::unique_ptr<grpc::Server> server_;
  std::unique_ptr<v1::TrackingService::Stub> stub_;
};

cv::Mat* TrackingServiceTest::page_ = nullptr;
std::vector<TrackFrame>* TrackingServiceTest::frames_ = nullptr;
int TrackingServiceTest::counter_ = 0;

TEST_F(TrackingServiceTest, TracksThePageWithPoseAndAnnotations) {
  StartServer();
  const auto intrinsics = texfree::testing::IntrinsicsOf(frames_->front().truth);
  std::vector<v1::TrackRequest> messages = {ConfigMessage(&intrinsics)};
  for (size_t i = 0; i < frames_->size(); ++i)
    messages.push_back(FrameMessage(100 + i, (*frames_)[i].jpeg));
  const auto outcome = RunStream(*stub_, messages);
  ASSERT_TRUE(outcome.status.ok()) << outcome.status.error_message();
  ASSERT_EQ(outcome.responses.size(), frames_->size());
  for (size_t i = 0; i < frames_->size(); ++i) {
    SCOPED_TRACE(::testing::Message() << "frame " << i);
    const v1::TrackResponse& r = outcome.responses[i];
    const testdata::CameraView& truth = (*frames_)[i].truth;
    EXPECT_EQ(r.frame_index(), 100 + i);
    EXPECT_TRUE(r.error().empty()) << r.error();
    std::set<std::string> stages;
    for (const auto& t : r.timings()) stages.insert(t.stage());
    EXPECT_EQ(stages, (std::set<std::string>{"decode", "extract", "match", "pose", "update"}));
    EXPECT_GT(r.server_ms(), 0);
    ASSERT_EQ(r.targets_size(), 1);
    const v1::TrackedTarget& t = r.targets(0);
    EXPECT_EQ(t.id(), document_id_);
    EXPECT_EQ(t.kind(), v1::TrackedTarget::DOCUMENT);
    EXPECT_EQ(t.state(), i == 0 ? v1::TrackedTarget::INITIALIZING : v1::TrackedTarget::TRACKING);
    EXPECT_LE(testdata::MeanHomographyError(HomographyOf(t), truth.homography, page_->size(),
                                            truth.image.size()),
              3.0);
    ASSERT_EQ(t.pose().rotation_size(), 9);
    cv::Matx33d R;
    for (int k = 0; k < 9; ++k) R.val[k] = t.pose().rotation(k);
    const cv::Matx33d dR = R * truth.rotation.t();
    EXPECT_LT(std::acos(std::clamp((cv::trace(dR) - 1) / 2, -1.0, 1.0)) * 180 / CV_PI, 2.0);
    EXPECT_NEAR(t.pose().translation(2), truth.translation[2], 0.03 * truth.translation[2]);
    ASSERT_EQ(t.annotations_size(), 1);
    const cv::Point2d anchor = ApplyHomography(truth.homography, {120, 300});
    EXPECT_NEAR(t.annotations(0).anchor().x(), anchor.x, 3.0);
    EXPECT_NEAR(t.annotations(0).anchor().y(), anchor.y, 3.0);
    EXPECT_EQ(t.outline_size(), 4);
  }
  EXPECT_TRUE(SessionsDrain());
}

TEST_F(TrackingServiceTest, BadFramesGetAnErrorResultAndTheStreamGoesOn) {
  StartServer();
  v1::TrackRequest raw_too_short;
  raw_too_short.mutable_frame()->set_frame_index(3);
  auto* raw = raw_too_short.mutable_frame()->mutable_image()->mutable_raw();
  raw->set_format(v1::RawImage::GRAY8);
  raw->set_width(640);
  raw->set_height(480);
  raw->set_pixels(std::string(1000, '\x80'));
  v1::TrackRequest no_image;
  no_image.mutable_frame()->set_frame_index(4);
  const std::vector<v1::TrackRequest> messages = {ConfigMessage(nullptr),
                                                  FrameMessage(1, (*frames_)[0].jpeg),
                                                  FrameMessage(2, "this is not an image"),
                                                  raw_too_short,
                                                  no_image,
                                                  ConfigMessage(nullptr),  // a second config
                                                  FrameMessage(6, (*frames_)[1].jpeg)};
  const auto outcome = RunStream(*stub_, messages);
  ASSERT_TRUE(outcome.status.ok()) << outcome.status.error_message();
  ASSERT_EQ(outcome.responses.size(), 6u);
  const auto& r = outcome.responses;
  EXPECT_TRUE(r[0].error().empty());
  EXPECT_EQ(r[0].targets_size(), 1);
  for (int i : {1, 2, 3, 4}) {
    EXPECT_FALSE(r[i].error().empty()) << "result " << i;
    EXPECT_EQ(r[i].targets_size(), 0);
  }
  EXPECT_NE(r[1].error().find("frame 2"), std::string::npos) << r[1].error();
  EXPECT_NE(r[4].error().find("config"), std::string::npos) << r[4].error();
  EXPECT_TRUE(r[5].error().empty()) << r[5].error();
  EXPECT_EQ(r[5].frame_index(), 6u);
  ASSERT_EQ(r[5].targets_size(), 1);
  EXPECT_EQ(r[5].targets(0).state(), v1::TrackedTarget::TRACKING) << "tracking survived";
  EXPECT_TRUE(SessionsDrain());
}

TEST_F(TrackingServiceTest, FramesOfAnotherSizeThanTheIntrinsicsAreErrors) {
  StartServer();
  auto intrinsics = texfree::testing::IntrinsicsOf(frames_->front().truth);
  intrinsics.set_width(1280);
  intrinsics.set_height(960);
  const auto outcome =
      RunStream(*stub_, {ConfigMessage(&intrinsics), FrameMessage(1, (*frames_)[0].jpeg)});
  ASSERT_TRUE(outcome.status.ok());
  ASSERT_EQ(outcome.responses.size(), 1u);
  EXPECT_NE(outcome.responses[0].error().find("intrinsics are for 1280x960"), std::string::npos)
      << outcome.responses[0].error();
}

TEST_F(TrackingServiceTest, TheFirstMessageMustBeAConfigAndOptionsAreChecked) {
  StartServer();
  auto outcome = RunStream(*stub_, {FrameMessage(1, (*frames_)[0].jpeg)});
  EXPECT_EQ(outcome.status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(outcome.status.error_message().find("first message"), std::string::npos);

  v1::TrackOptions maps;
  maps.set_track_maps(true);
  outcome = RunStream(*stub_, {ConfigMessage(nullptr, maps)});
  EXPECT_EQ(outcome.status.error_code(), grpc::StatusCode::UNIMPLEMENTED);

  v1::TrackOptions huge;
  huge.set_max_learned_entries(50'000'000);
  outcome = RunStream(*stub_, {ConfigMessage(nullptr, huge)});
  EXPECT_EQ(outcome.status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(outcome.status.error_message().find("max_learned_entries"), std::string::npos);

  v1::CameraIntrinsics half;
  half.set_fx(500);
  outcome = RunStream(*stub_, {ConfigMessage(&half)});
  EXPECT_EQ(outcome.status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_TRUE(SessionsDrain());
}

TEST_F(TrackingServiceTest, EachStreamLearnsForItselfOnly) {
  StartServer();
  v1::TrackOptions every;
  every.set_update_policy(v1::TrackOptions::EVERY_FRAME);
  std::vector<v1::TrackRequest> long_stream = {ConfigMessage(nullptr, every)};
  for (size_t i = 0; i < frames_->size(); ++i)
    long_stream.push_back(FrameMessage(i, (*frames_)[i].jpeg));
  const auto first = RunStream(*stub_, long_stream);
  ASSERT_EQ(first.responses.size(), frames_->size());
  ASSERT_EQ(first.responses.back().targets_size(), 1);
  const uint32_t learned_first = first.responses.back().targets(0).learned_entries();
  EXPECT_GT(learned_first, 0u);

  // A later stream on the same last view starts from the shared index alone.
  const auto second =
      RunStream(*stub_, {ConfigMessage(nullptr, every), FrameMessage(0, frames_->back().jpeg)});
  ASSERT_EQ(second.responses.size(), 1u);
  ASSERT_EQ(second.responses[0].targets_size(), 1);
  const auto& t = second.responses[0].targets(0);
  EXPECT_EQ(t.learned_entries(), t.learned_this_frame())
      << "nothing but what this stream's own frame taught";
  EXPECT_LT(t.learned_entries(), learned_first);
}

TEST_F(TrackingServiceTest, FallingBehindDropsTheOldestFramesAndSaysSo) {
  TrackingServiceOptions options;
  options.queue_frames = 1;
  StartServer(options);
  constexpr int kFrames = 40;
  const std::vector<v1::TrackRequest> messages = Burst(kFrames);
  const auto outcome = RunStream(*stub_, messages, /*paced=*/false);
  ASSERT_TRUE(outcome.status.ok());
  std::set<uint64_t> answered, dropped;
  uint64_t last = 0;
  for (size_t i = 0; i < outcome.responses.size(); ++i) {
    const auto& r = outcome.responses[i];
    if (i > 0) {
      EXPECT_GT(r.frame_index(), last) << "results stay in order";
    }
    last = r.frame_index();
    answered.insert(r.frame_index());
    EXPECT_EQ(r.dropped_frames(), static_cast<uint32_t>(r.dropped_frame_indices_size()));
    for (uint64_t d : r.dropped_frame_indices()) dropped.insert(d);
  }
  EXPECT_EQ(answered.size() + dropped.size(), static_cast<size_t>(kFrames))
      << "every frame is answered or reported dropped";
  for (uint64_t d : dropped) EXPECT_EQ(answered.count(d), 0u);
  EXPECT_GT(dropped.size(), 0u) << "40 frames at once must overflow a 1-frame queue";
  EXPECT_EQ(answered.count(kFrames - 1), 1u) << "the newest frame is never dropped";
}

// The queue is bounded in time: frames are stale once they have waited max_frame_age_ms.
TEST_F(TrackingServiceTest, ABurstIsAnsweredInFullWhileNoFrameGetsStale) {
  TrackingServiceOptions options;
  options.max_frame_age_ms = 60'000;
  options.queue_frames = 64;
  StartServer(options);
  constexpr int kFrames = 30;
  const std::vector<v1::TrackRequest> messages = Burst(kFrames);
  const auto outcome = RunStream(*stub_, messages, /*paced=*/false);
  ASSERT_TRUE(outcome.status.ok());
  ASSERT_EQ(outcome.responses.size(), static_cast<size_t>(kFrames));
  for (const auto& r : outcome.responses) EXPECT_EQ(r.dropped_frames(), 0u);
}

TEST_F(TrackingServiceTest, StaleFramesAreDroppedWhenANewerOneWaits) {
  TrackingServiceOptions options;
  options.max_frame_age_ms = 1;  // every frame that waits at all is stale
  options.queue_frames = 64;     // so the count bound never acts
  StartServer(options);
  constexpr int kFrames = 30;
  const std::vector<v1::TrackRequest> messages = Burst(kFrames);
  const auto outcome = RunStream(*stub_, messages, /*paced=*/false);
  ASSERT_TRUE(outcome.status.ok());
  std::set<uint64_t> answered, dropped;
  for (const auto& r : outcome.responses) {
    answered.insert(r.frame_index());
    for (uint64_t d : r.dropped_frame_indices()) dropped.insert(d);
  }
  EXPECT_GT(dropped.size(), 0u) << "frames sent at once wait longer than 1 ms";
  EXPECT_EQ(answered.size() + dropped.size(), static_cast<size_t>(kFrames))
      << "every frame is answered or reported dropped";
  EXPECT_EQ(answered.count(kFrames - 1), 1u) << "the newest frame is never stale";
}

TEST_F(TrackingServiceTest, ACancelledStreamLeavesNoSessionBehind) {
  StartServer();
  grpc::ClientContext context;
  auto stream = stub_->Track(&context);
  ASSERT_TRUE(stream->Write(ConfigMessage(nullptr)));
  ASSERT_TRUE(stream->Write(FrameMessage(0, (*frames_)[0].jpeg)));
  ASSERT_TRUE(stream->Write(FrameMessage(1, (*frames_)[1].jpeg)));
  v1::TrackResponse response;
  ASSERT_TRUE(stream->Read(&response));
  EXPECT_EQ(service_->active_sessions(), 1);
  context.TryCancel();  // the client goes away mid-stream
  while (stream->Read(&response)) {
  }
  EXPECT_EQ(stream->Finish().error_code(), grpc::StatusCode::CANCELLED);
  EXPECT_TRUE(SessionsDrain()) << service_->active_sessions() << " sessions left";
}

TEST_F(TrackingServiceTest, ASilentStreamIsClosedAfterTheIdleTimeout) {
  TrackingServiceOptions options;
  options.idle_timeout = std::chrono::milliseconds(300);
  StartServer(options);
  grpc::ClientContext context;
  auto stream = stub_->Track(&context);
  ASSERT_TRUE(stream->Write(ConfigMessage(nullptr)));
  ASSERT_TRUE(stream->Write(FrameMessage(0, (*frames_)[0].jpeg)));
  v1::TrackResponse response;
  ASSERT_TRUE(stream->Read(&response));
  const auto t0 = std::chrono::steady_clock::now();
  while (stream->Read(&response)) {
  }
  const grpc::Status status = stream->Finish();
  EXPECT_FALSE(status.ok());
  EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::seconds(5));
  EXPECT_TRUE(SessionsDrain());
}

TEST_F(TrackingServiceTest, TooManyStreamsAreRefused) {
  TrackingServiceOptions options;
  options.max_sessions = 1;
  StartServer(options);
  grpc::ClientContext context;
  auto stream = stub_->Track(&context);
  ASSERT_TRUE(stream->Write(ConfigMessage(nullptr)));
  ASSERT_TRUE(stream->Write(FrameMessage(0, (*frames_)[0].jpeg)));
  v1::TrackResponse response;
  ASSERT_TRUE(stream->Read(&response));  // the first stream is live
  const auto refused = RunStream(*stub_, {ConfigMessage(nullptr)});
  EXPECT_EQ(refused.status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  stream->WritesDone();
  while (stream->Read(&response)) {
  }
  EXPECT_TRUE(stream->Finish().ok());
  EXPECT_TRUE(SessionsDrain());
}

}  // namespace
}  // namespace texfree::server
