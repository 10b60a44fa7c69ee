// Tests of `texfree track`: local input checked before contacting the server (exit 2),
// a folder of frames streamed in name order to an in-process fake TrackingService with
// one JSON line per frame, the summary, --no-learning, and the --output video.
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "client/camera_file.h"
#include "client/cli.h"
#include "client/frame_source.h"
#include "tests/client/cli_runner.h"
#include "texfree/v1/tracking.grpc.pb.h"

namespace texfree::client {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

using Result = CliResult;

// Answers every frame with one TRACKING page whose homography is a translation by the
// frame index, remembering what it was sent.
class FakeTracking final : public v1::TrackingService::Service {
 public:
  grpc::Status Track(grpc::ServerContext*,
                     grpc::ServerReaderWriter<v1::TrackResponse, v1::TrackRequest>* stream)
      override {
    v1::TrackRequest request;
    if (!stream->Read(&request) || !request.has_config())
      return grpc::Status(grpc::StatusCode::INVALID_ARGUMENT, "config first");
    {
      std::lock_guard lock(mutex_);
      config_ = request.config();
    }
    while (stream->Read(&request)) {
      const auto& frame = request.frame();
      cv::Mat image = cv::imdecode(
          std::vector<uchar>(frame.image().encoded().begin(), frame.image().encoded().end()),
          cv::IMREAD_GRAYSCALE);
      {
        std::lock_guard lock(mutex_);
        widths_.push_back(image.cols);
        means_.push_back(image.empty() ? -1 : cv::mean(image)[0]);
        last_image_ = image;
      }
      v1::TrackResponse r;
      r.set_frame_index(frame.frame_index());
      r.set_server_ms(2.5);
      auto* t = r.add_targets();
      t->set_id("doc1");
      t->set_title("page");
      t->set_state(v1::TrackedTarget::TRACKING);
      t->set_inliers(50);
      t->set_width(100);
      t->set_height(80);
      for (double h : {1.0, 0.0, double(frame.frame_index()), 0.0, 1.0, 5.0, 0.0, 0.0, 1.0})
        t->mutable_homography()->add_h(h);
      stream->Write(r);
    }
    return grpc::Status::OK;
  }
  v1::TrackConfig config() {
    std::lock_guard lock(mutex_);
    return config_;
  }
  std::vector<double> means() {
    std::lock_guard lock(mutex_);
    return means_;
  }
  cv::Mat last_image() {
    std::lock_guard lock(mutex_);
    return last_image_;
  }

 private:
  std::mutex mutex_;
  v1::TrackConfig config_;
  std::vector<int> widths_;
  std::vector<double> means_;
  cv::Mat last_image_;
};

class TrackCommandTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("texfree-track-cli-" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_ / "frames");
    // Frames named out of creation order; gray levels 40, 80, 120 by name.
    for (int i : {2, 0, 1})
      cv::imwrite((dir_ / "frames" / ("f" + std::to_string(i) + ".png")).string(),
                  cv::Mat(120, 160, CV_8UC3, cv::Scalar::all(40 + 40 * i)));
    std::ofstream(dir_ / "frames" / "broken.png") << "not an image";
    grpc::ServerBuilder builder;
    builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port_);
    builder.RegisterService(&fake_);
    server_ = builder.BuildAndStart();
  }
  void TearDown() override {
    server_->Shutdown();
    fs::remove_all(dir_);
  }
  std::string Server() const { return "127.0.0.1:" + std::to_string(port_); }

  fs::path dir_;
  FakeTracking fake_;
  int port_ = 0;
  std::unique_ptr<grpc::Server> server_;
};

TEST_F(TrackCommandTest, LocalInputIsCheckedFirst) {
  auto r = RunTexfree({"--server", "127.0.0.1:1", "track", (dir_ / "missing").string()});
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("does not exist"), std::string::npos) << r.err;
  fs::create_directories(dir_ / "empty");
  r = RunTexfree({"--server", "127.0.0.1:1", "track", (dir_ / "empty").string()});
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("holds no image"), std::string::npos) << r.err;
  r = RunTexfree({"--server", "127.0.0.1:1", "track", (dir_ / "frames").string(), "--output", "x.png"});
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("video file"), std::string::npos) << r.err;
  r = RunTexfree({"--server", "127.0.0.1:1", "track", "cam:x"});
  EXPECT_EQ(r.code, 2);
  r = RunTexfree({"--server", "127.0.0.1:1", "track", (dir_ / "frames").string(), "--intrinsics",
           (dir_ / "missing.yml").string()});
  EXPECT_EQ(r.code, 2);
}

TEST_F(TrackCommandTest, FolderFramesGoInNameOrderWithOneJsonLinePerFrame) {
  const auto r = RunTexfree({"--server", Server(), "--json", "track", (dir_ / "frames").string(),
                      "--no-learning"});
  ASSERT_EQ(r.code, 0) << r.err;
  std::istringstream lines(r.out);
  std::string line;
  int n = 0;
  while (std::getline(lines, line)) {
    const json j = json::parse(line);
    EXPECT_EQ(j["frame"], n);
    ASSERT_EQ(j["documents"].size(), 1u);
    EXPECT_EQ(j["documents"][0]["document_id"], "doc1");
    EXPECT_EQ(j["documents"][0]["state"], "TRACKING");
    EXPECT_EQ(j["documents"][0]["inliers"], 50);
    ASSERT_EQ(j["documents"][0]["homography"].size(), 9u);
    EXPECT_EQ(j["documents"][0]["homography"][2], n);
    EXPECT_DOUBLE_EQ(j["server_ms"].get<double>(), 2.5);
    ++n;
  }
  EXPECT_EQ(n, 3);
  const auto means = fake_.means();
  ASSERT_EQ(means.size(), 3u);
  EXPECT_NEAR(means[0], 40, 2);
  EXPECT_NEAR(means[1], 80, 2);
  EXPECT_NEAR(means[2], 120, 2);
  EXPECT_EQ(fake_.config().options().update_policy(), v1::TrackOptions::NEVER);
  EXPECT_NE(r.err.find("\"summary\""), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("broken.png"), std::string::npos) << "unreadable files are reported";
}

TEST_F(TrackCommandTest, WritesTheOutputVideoAndASummary) {
  const fs::path video = dir_ / "out.mp4";
  const auto r =
      RunTexfree({"--server", Server(), "track", (dir_ / "frames").string(), "--output",
                  video.string()});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("3 frames, 100.0% tracked"), std::string::npos) << r.out;
  EXPECT_EQ(fake_.config().options().update_policy(), v1::TrackOptions::BELOW_THRESHOLD);
  cv::VideoCapture capture(video.string());
  ASSERT_TRUE(capture.isOpened());
  int frames = 0;
  cv::Mat frame;
  while (capture.read(frame)) {
    EXPECT_EQ(frame.size(), cv::Size(160, 120));
    ++frames;
  }
  EXPECT_EQ(frames, 3);
}

// --undistort: a frame through a strong barrel lens (k1 -0.3) reaches the server with its
// dots back where an ideal pinhole puts them (within a pixel), the intrinsics sent carry no
// distortion, and the input is checked: no --intrinsics, or frames of another size than
// the calibration's, fail with exit 2.
TEST_F(TrackCommandTest, UndistortSendsIdealPinholeFrames) {
  CameraFile camera;
  camera.camera_matrix = cv::Matx33d(300, 0, 159.5, 0, 300, 119.5, 0, 0, 1);
  camera.distortion = {-0.3, 0, 0, 0, 0};
  camera.image_width = 320;
  camera.image_height = 240;
  SaveCameraFile(dir_ / "cam.yml", camera);
  // Dots drawn where the lens puts ideal grid points.
  std::vector<cv::Point2d> ideal;
  cv::Mat frame(240, 320, CV_8UC3, cv::Scalar::all(255));
  for (int y = 30; y <= 210; y += 60)
    for (int x = 30; x <= 290; x += 65) {
      ideal.emplace_back(x, y);
      const double nx = (x - 159.5) / 300, ny = (y - 119.5) / 300;
      const double f = 1 - 0.3 * (nx * nx + ny * ny);
      // Drawn at its sub-pixel place (4 fractional bits).
      cv::circle(
          frame,
          cv::Point(cvRound(16 * (159.5 + 300 * nx * f)), cvRound(16 * (119.5 + 300 * ny * f))), 48,
          cv::Scalar::all(0), -1, cv::LINE_AA, 4);
    }
  fs::create_directories(dir_ / "lens");
  cv::imwrite((dir_ / "lens" / "f0.png").string(), frame);

  auto r =
      RunTexfree({"--server", Server(), "--json", "track", (dir_ / "lens").string(), "--intrinsics",
                  (dir_ / "cam.yml").string(), "--undistort", "--jpeg-quality", "100"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(fake_.config().intrinsics().distortion_size(), 0);
  EXPECT_DOUBLE_EQ(fake_.config().intrinsics().fx(), 300);
  const cv::Mat seen = fake_.last_image();
  ASSERT_EQ(seen.size(), cv::Size(320, 240));
  double worst = 0;
  for (const cv::Point2d& p : ideal) {
    double sw = 0, sx = 0, sy = 0;
    for (int y = static_cast<int>(p.y) - 7; y <= static_cast<int>(p.y) + 7; ++y)
      for (int x = static_cast<int>(p.x) - 7; x <= static_cast<int>(p.x) + 7; ++x) {
        const double w = 255.0 - seen.at<uint8_t>(y, x);
        sw += w;
        sx += w * x;
        sy += w * y;
      }
    ASSERT_GT(sw, 255) << "no dot near " << p;
    worst = std::max(worst, std::hypot(sx / sw - p.x, sy / sw - p.y));
  }
  EXPECT_LT(worst, 1.0);

  r = RunTexfree({"--server", Server(), "track", (dir_ / "lens").string(), "--undistort"});
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("--undistort needs --intrinsics"), std::string::npos) << r.err;
  r = RunTexfree({"--server", Server(), "track", (dir_ / "frames").string(), "--intrinsics",
                  (dir_ / "cam.yml").string(), "--undistort"});
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("calibrated size"), std::string::npos) << r.err;
}

TEST(FrameSourceTest, ListsImagesSortedByName) {
  const fs::path dir = fs::temp_directory_path() / ("texfree-frames-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  for (const char* name : {"b.JPG", "a.png", "c.txt", "a10.png"})
    std::ofstream(dir / name) << "x";
  const auto files = ListImageFiles(dir);
  ASSERT_EQ(files.size(), 3u);
  EXPECT_EQ(files[0].filename(), "a.png");
  EXPECT_EQ(files[1].filename(), "a10.png");
  EXPECT_EQ(files[2].filename(), "b.JPG");
  fs::remove_all(dir);
}

}  // namespace
}  // namespace texfree::client
