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
#include <opencv2/videoio.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "client/cli.h"
#include "tests/client/cli_runner.h"
#include "client/frame_source.h"
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

 private:
  std::mutex mutex_;
  v1::TrackConfig config_;
  std::vector<int> widths_;
  std::vector<double> means_;
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
