// End-to-end test of PoolService through the real texfree-server binary: a rendered
// photograph analysed against its ground truth (corners, balls, shots with paths in mm
// and in the image), bad input answered with a clear status while the server stays up
// (missing intrinsics, not a picture, no table, only part of the table, unknown
// profile), a stored profile that survives a restart and takes calibrated colours, and a
// TrackTable stream that keeps the origin by the ball arrangement from the other end.
#include <gtest/gtest.h>

#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "tests/data/pool_renderer.h"
#include "tests/data/pool_scoring.h"
#include "tests/server/server_process.h"
#include "texfree/v1/pool.grpc.pb.h"

namespace texfree {
namespace {

namespace fs = std::filesystem;
using testdata::PoolScene;
using testdata::PoolView;
using testdata::PoolViewSide;
using testing::ServerProcess;

std::string Encode(const cv::Mat& image) {
  std::vector<uchar> bytes;
  cv::imencode(".png", image, bytes);
  return std::string(bytes.begin(), bytes.end());
}

PoolScene Scene(PoolViewSide side, double elevation) {
  PoolScene scene;
  scene.balls = {{0, 300, 350}, {1, 520, 200}, {2, 700, 520}, {3, 900, 180}, {5, 200, 560},
                 {6, 450, 470}, {7, 800, 330}, {9, 620, 110}};
  scene.camera = testdata::FramedPoolCamera(scene.table, side, elevation, 60, 6, 2);
  scene.camera.k1 = -0.03;
  scene.blur_sigma = 0.5;
  scene.noise_sigma = 2;
  scene.jpeg_quality = 90;
  scene.srgb_tone = true;  // a phone's picture, as the server assumes
  return scene;
}

v1::CameraIntrinsics Intrinsics(const PoolView& view) {
  v1::CameraIntrinsics in;
  in.set_fx(view.camera_matrix(0, 0));
  in.set_fy(view.camera_matrix(1, 1));
  in.set_cx(view.camera_matrix(0, 2));
  in.set_cy(view.camera_matrix(1, 2));
  for (double d : view.distortion) in.add_distortion(d);
  in.set_width(view.image.cols);
  in.set_height(view.image.rows);
  return in;
}

v1::TableProfile BenchTable(const std::string& name = "") {
  const testdata::PoolTableSpec spec;
  v1::TableProfile t;
  t.set_name(name);
  t.set_length_mm(spec.length_mm);
  t.set_width_mm(spec.width_mm);
  t.set_ball_radius_mm(spec.ball_radius_mm);
  t.set_cushion_height_mm(spec.cushion_height_mm);
  t.set_cushion_width_mm(spec.cushion_width_mm);
  t.set_corner_pocket_mm(spec.corner_pocket_mm);
  t.set_side_pocket_mm(spec.side_pocket_mm);
  return t;
}

// A TrackTable stream's first message: the camera that took `view`, the bench table.
v1::TrackTableRequest TrackConfig(const PoolView& view) {
  v1::TrackTableRequest config;
  *config.mutable_config()->mutable_intrinsics() = Intrinsics(view);
  *config.mutable_config()->mutable_profile() = BenchTable();
  return config;
}

// A TrackTable stream's frame message holding `encoded` (normally Encode(image)).
v1::TrackTableRequest TrackFrame(std::string encoded) {
  v1::TrackTableRequest frame;
  frame.mutable_frame()->set_encoded(std::move(encoded));
  return frame;
}

class PoolServiceIntegrationTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    long_view_ = new PoolView(testdata::RenderPoolView(Scene(PoolViewSide::kLongNear, 50), 11));
    short_view_ =
        new PoolView(testdata::RenderPoolView(Scene(PoolViewSide::kShortRight, 50), 12));
  }
  static void TearDownTestSuite() {
    delete long_view_;
    delete short_view_;
  }
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("texfree-pool-it-" + std::to_string(::getpid()) + "-" + std::to_string(std::rand()));
    fs::create_directories(dir_);
    server_ = std::make_unique<ServerProcess>(TEXFREE_SERVER_BINARY, dir_.string());
    ASSERT_FALSE(server_->address().empty()) << server_->Log();
    stub_ = v1::PoolService::NewStub(server_->Channel());
  }
  void TearDown() override {
    server_.reset();
    fs::remove_all(dir_);
  }
  grpc::Status Analyze(const v1::AnalyzeTableRequest& request, v1::AnalyzeTableResponse* out) {
    grpc::ClientContext ctx;
    return stub_->AnalyzeTable(&ctx, request, out);
  }
  v1::AnalyzeTableRequest Request(const PoolView& view) {
    v1::AnalyzeTableRequest request;
    request.mutable_image()->set_encoded(Encode(view.image));
    *request.mutable_intrinsics() = Intrinsics(view);
    *request.mutable_profile() = BenchTable();
    return request;
  }

  static PoolView* long_view_;
  static PoolView* short_view_;
  fs::path dir_;
  std::unique_ptr<ServerProcess> server_;
  std::unique_ptr<v1::PoolService::Stub> stub_;
};

PoolView* PoolServiceIntegrationTest::long_view_ = nullptr;
PoolView* PoolServiceIntegrationTest::short_view_ = nullptr;

TEST_F(PoolServiceIntegrationTest, AnalyzeMatchesTheTruthAndSuggestsShots) {
  v1::AnalyzeTableResponse response;
  const grpc::Status status = Analyze(Request(*long_view_), &response);
  ASSERT_TRUE(status.ok()) << status.error_message() << server_->Log();
  ASSERT_EQ(response.corners_size(), 4);
  std::array<cv::Point2d, 4> corners;
  for (int i = 0; i < 4; ++i) corners[i] = {response.corners(i).x(), response.corners(i).y()};
  std::vector<testdata::EstimatedPoolBall> estimated;
  for (const auto& b : response.balls()) estimated.push_back({b.number(), b.x_mm(), b.y_mm()});
  const testdata::PoolScore score = testdata::ScorePoolAnalysis(
      Scene(PoolViewSide::kLongNear, 50), *long_view_, corners, estimated);
  EXPECT_LT(score.max_corner_error_px, 1.5);
  EXPECT_EQ(score.position_errors_mm.size(), long_view_->balls.size());
  for (double e : score.position_errors_mm) EXPECT_LT(e, 12);
  EXPECT_GE(score.separated_identified, score.separated - 1);
  EXPECT_TRUE(response.long_side_view());
  // Shots: the 1 is the lowest ball; every path has as many image points as table points.
  ASSERT_GT(response.shots_size(), 0) << response.shots_note();
  for (const auto& shot : response.shots()) {
    EXPECT_EQ(shot.target_ball(), 1u);
    ASSERT_GT(shot.paths_size(), 0);
    for (const auto& path : shot.paths()) {
      EXPECT_GE(path.path_mm_size(), 2);
      EXPECT_EQ(path.path_mm_size(), path.path_px_size());
    }
    EXPECT_FALSE(shot.description().empty());
  }
  EXPECT_GT(response.overlays_size(), static_cast<int>(long_view_->balls.size()));
  EXPECT_GT(response.server_ms(), 0);
  EXPECT_EQ(response.profile().length_mm(), 1330);
}

// A blue table analysed with a profile that does not name its cloth colour (the default
// green): found, its measured cloth colour returned, and the log says how to skip the
// search.
TEST_F(PoolServiceIntegrationTest, TableOfAnotherClothColourIsFoundAndTheLogSaysSo) {
  PoolScene scene = Scene(PoolViewSide::kLongNear, 50);
  scene.table.cloth_rgb = {20, 95, 160};
  const PoolView view = testdata::RenderPoolView(scene, 13);
  v1::AnalyzeTableResponse response;
  const grpc::Status status = Analyze(Request(view), &response);
  ASSERT_TRUE(status.ok()) << status.error_message() << server_->Log();
  EXPECT_GT(response.cloth_color().b(), response.cloth_color().g() + 30);
  EXPECT_GT(response.cloth_color().b(), response.cloth_color().r() + 60);
  std::vector<testdata::EstimatedPoolBall> estimated;
  for (const auto& b : response.balls()) estimated.push_back({b.number(), b.x_mm(), b.y_mm()});
  std::array<cv::Point2d, 4> corners;
  for (int i = 0; i < 4; ++i) corners[i] = {response.corners(i).x(), response.corners(i).y()};
  const testdata::PoolScore score = testdata::ScorePoolAnalysis(scene, view, corners, estimated);
  EXPECT_LT(score.max_corner_error_px, 1.5);
  EXPECT_EQ(score.position_errors_mm.size(), view.balls.size());
  EXPECT_NE(server_->Log().find("is not the profile's colour"), std::string::npos)
      << server_->Log();
}

TEST_F(PoolServiceIntegrationTest, BadInputGetsAClearErrorAndTheServerStaysUp) {
  v1::AnalyzeTableResponse response;
  // Missing intrinsics.
  v1::AnalyzeTableRequest request = Request(*long_view_);
  request.clear_intrinsics();
  grpc::Status status = Analyze(request, &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(status.error_message().find("intrinsics"), std::string::npos) << status.error_message();
  // Not a picture.
  request = Request(*long_view_);
  request.mutable_image()->set_encoded("this is not an image, just some bytes of text");
  status = Analyze(request, &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();
  // No table: the floor beside it.
  PoolScene floor = Scene(PoolViewSide::kLongNear, 40);
  floor.camera.look_at_mm = {-2500, -1500, -760};
  const PoolView floor_view = testdata::RenderPoolView(floor, 13);
  status = Analyze(Request(floor_view), &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_NE(status.error_message().find("no pool table in view"), std::string::npos)
      << status.error_message();
  // Only part of the table: zoomed in on one end.
  PoolScene partial = Scene(PoolViewSide::kLongNear, 45);
  partial.camera.horizontal_fov_deg = 30;
  partial.camera.look_at_mm = {250, 350, 0};
  const PoolView partial_view = testdata::RenderPoolView(partial, 14);
  status = Analyze(Request(partial_view), &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_NE(status.error_message().find("only part of the table"), std::string::npos)
      << status.error_message();
  // Unknown profile.
  request = Request(*long_view_);
  request.clear_profile();
  request.set_profile_name("no-such-table");
  status = Analyze(request, &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::NOT_FOUND);
  // A profile that makes no sense.
  v1::SetTableProfileRequest bad;
  *bad.mutable_profile() = BenchTable("bad");
  bad.mutable_profile()->set_width_mm(5000);
  v1::TableProfile stored;
  grpc::ClientContext ctx;
  status = stub_->SetTableProfile(&ctx, bad, &stored);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(status.error_message().find("length_mm"), std::string::npos) << status.error_message();
  // A cloth of nearly no colour: the table is found by its cloth's colour.
  v1::SetTableProfileRequest grey;
  *grey.mutable_profile() = BenchTable("grey");
  grey.mutable_profile()->mutable_cloth_color()->set_r(70);
  grey.mutable_profile()->mutable_cloth_color()->set_g(70);
  grey.mutable_profile()->mutable_cloth_color()->set_b(75);
  grpc::ClientContext grey_ctx;
  status = stub_->SetTableProfile(&grey_ctx, grey, &stored);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(status.error_message().find("nearly grey"), std::string::npos)
      << status.error_message();
  EXPECT_TRUE(server_->running());
}

TEST_F(PoolServiceIntegrationTest, StoredProfileSurvivesARestartAndTakesCalibratedColours) {
  {
    v1::SetTableProfileRequest request;
    *request.mutable_profile() = BenchTable("bar-table");
    v1::TableProfile stored;
    grpc::ClientContext ctx;
    ASSERT_TRUE(stub_->SetTableProfile(&ctx, request, &stored).ok());
    EXPECT_EQ(stored.name(), "bar-table");
  }
  EXPECT_EQ(server_->Stop(), 0);
  server_ = std::make_unique<ServerProcess>(TEXFREE_SERVER_BINARY, dir_.string());
  ASSERT_FALSE(server_->address().empty()) << server_->Log();
  stub_ = v1::PoolService::NewStub(server_->Channel());
  v1::AnalyzeTableRequest request = Request(*long_view_);
  request.clear_profile();
  request.set_profile_name("bar-table");
  request.set_skip_shots(true);
  v1::AnalyzeTableResponse response;
  const grpc::Status status = Analyze(request, &response);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_EQ(response.profile().name(), "bar-table");
  EXPECT_EQ(response.profile().width_mm(), 700);
  EXPECT_EQ(response.balls_size(), static_cast<int>(long_view_->balls.size()));
  // Calibrate: a cloth region in the middle of the table and the 2 ball.
  const cv::Point2d middle = testdata::ProjectTablePoint(*long_view_, {665, 350, 0});
  const auto& two = long_view_->balls[2];
  ASSERT_EQ(two.number, 2);
  v1::CalibrateColorsRequest calibrate;
  calibrate.set_profile_name("bar-table");
  calibrate.mutable_image()->set_encoded(Encode(long_view_->image));
  auto* cloth = calibrate.mutable_cloth_region();
  cloth->set_x(middle.x - 30);
  cloth->set_y(middle.y - 15);
  cloth->set_width(60);
  cloth->set_height(30);
  auto* ball = calibrate.add_balls();
  ball->set_number(2);
  ball->mutable_region()->set_x(two.pixel.x - 7);
  ball->mutable_region()->set_y(two.pixel.y - 7);
  ball->mutable_region()->set_width(14);
  ball->mutable_region()->set_height(14);
  v1::TableProfile calibrated;
  grpc::ClientContext ctx;
  const grpc::Status cal = stub_->CalibrateColors(&ctx, calibrate, &calibrated);
  ASSERT_TRUE(cal.ok()) << cal.error_message();
  EXPECT_GT(calibrated.cloth_color().g(), calibrated.cloth_color().r() + 30);
  const auto& blue = calibrated.ball_colors(2).color();
  EXPECT_GT(blue.b(), blue.r() + 30);
}

TEST_F(PoolServiceIntegrationTest, TrackTableKeepsTheOriginFromTheOtherEnd) {
  grpc::ClientContext ctx;
  auto stream = stub_->TrackTable(&ctx);
  ASSERT_TRUE(stream->Write(TrackConfig(*long_view_)));
  // Same camera intrinsics for both renders (same image size and field of view).
  std::vector<const PoolView*> frames = {long_view_, short_view_};
  std::vector<v1::AnalyzeTableResponse> out;
  for (const PoolView* view : frames) {
    ASSERT_TRUE(stream->Write(TrackFrame(Encode(view->image))));
    v1::AnalyzeTableResponse response;
    if (!stream->Read(&response)) {
      const grpc::Status status = stream->Finish();
      FAIL() << "stream ended: " << status.error_message() << server_->Log();
    }
    out.push_back(response);
  }
  ASSERT_TRUE(stream->Write(TrackFrame("not an image")));
  v1::AnalyzeTableResponse lost;
  ASSERT_TRUE(stream->Read(&lost));
  stream->WritesDone();
  ASSERT_TRUE(stream->Finish().ok());
  EXPECT_EQ(out[0].state(), "analysed");
  EXPECT_EQ(out[1].state(), "tracked") << out[1].message();
  EXPECT_EQ(lost.state(), "lost");
  EXPECT_FALSE(lost.message().empty());
  // The second view, from the far end, reports the balls where the first one has them
  // (each estimate within 12 mm of the truth, so within 24 mm of each other; the wrong
  // origin would put them hundreds of millimetres apart).
  for (const auto& b : out[1].balls()) {
    double best = 1e9;
    for (const auto& r : out[0].balls())
      if (r.number() == b.number()) best = std::hypot(b.x_mm() - r.x_mm(), b.y_mm() - r.y_mm());
    EXPECT_LT(best, 24) << "ball " << b.number();
  }
  // The shot computed on the first frame is drawn on the second in its own pixels.
  ASSERT_GT(out[1].shots_size(), 0);
  EXPECT_EQ(out[1].shots(0).description(), out[0].shots(0).description());
  const auto& p0 = out[0].shots(0).paths(0).path_px(0);
  const auto& p1 = out[1].shots(0).paths(0).path_px(0);
  EXPECT_GT(std::hypot(p0.x() - p1.x(), p0.y() - p1.y()), 20);
}

// A phone streams HD frames; TrackTable analyses each reduced to live_pool_pixels (640x480 by
// default: 17-19 ms a frame, where 1280x960 takes about 49) and answers in the frame's own
// pixels. AnalyzeTable analyses the same picture at full size.
TEST_F(PoolServiceIntegrationTest, TrackTableAnalysesHdFramesAtTheLiveSize) {
  PoolScene scene = Scene(PoolViewSide::kLongNear, 45);
  testdata::ScalePoolCamera(&scene, 2);
  const PoolView hd = testdata::RenderPoolView(scene, 13);
  ASSERT_EQ(hd.image.size(), cv::Size(1280, 960));
  const auto has_stage = [](const v1::AnalyzeTableResponse& r, const std::string& stage) {
    for (const auto& t : r.timings())
      if (t.stage() == stage) return true;
    return false;
  };
  const auto expect_truth = [&](const v1::AnalyzeTableResponse& r) {
    ASSERT_EQ(r.corners_size(), 4);
    for (int k = 0; k < 4; ++k)
      EXPECT_LT(std::hypot(r.corners(k).x() - hd.cloth_corners[k].x,
                           r.corners(k).y() - hd.cloth_corners[k].y),
                3.0)
          << "corner " << k << " in the HD frame's pixels";
    EXPECT_EQ(r.balls_size(), static_cast<int>(hd.balls.size()));
    for (const auto& b : r.balls()) {
      for (const auto& t : hd.balls) {
        if (t.number != b.number()) continue;
        EXPECT_LT(std::hypot(b.x_mm() - t.x_mm, b.y_mm() - t.y_mm), 12.0) << "ball " << t.number;
      }
    }
  };

  grpc::ClientContext ctx;
  auto stream = stub_->TrackTable(&ctx);
  v1::TrackTableRequest config = TrackConfig(hd);
  config.mutable_config()->set_skip_shots(true);
  ASSERT_TRUE(stream->Write(config));
  ASSERT_TRUE(stream->Write(TrackFrame(Encode(hd.image))));
  v1::AnalyzeTableResponse live;
  ASSERT_TRUE(stream->Read(&live)) << server_->Log();
  stream->WritesDone();
  ASSERT_TRUE(stream->Finish().ok());
  EXPECT_EQ(live.state(), "analysed") << live.message();
  EXPECT_TRUE(has_stage(live, "reduce")) << "a live HD frame is analysed reduced";
  expect_truth(live);

  v1::AnalyzeTableRequest request = Request(hd);
  request.set_skip_shots(true);
  v1::AnalyzeTableResponse still;
  ASSERT_TRUE(Analyze(request, &still).ok());
  EXPECT_FALSE(has_stage(still, "reduce")) << "AnalyzeTable takes 1280x960 as it is";
  expect_truth(still);
}

}  // namespace
}  // namespace texfree
