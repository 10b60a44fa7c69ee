// `texfree pool ...` end to end: the CLI against the real texfree-server binary on a
// rendered table photograph (the JSON contract of SPEC.md, --overlay and --topview files),
// and local mistakes (no --intrinsics, a malformed TABLE.json) refused with exit 2 before
// the server is contacted.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "client/cli.h"
#include "tests/client/cli_runner.h"
#include "tests/data/pool_renderer.h"
#include "tests/server/server_process.h"

namespace texfree::client {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

using Result = CliResult;

class PoolCliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("texfree-pool-cli-" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    testdata::PoolScene scene;
    scene.balls = {{0, 300, 350}, {1, 520, 200}, {2, 700, 520}, {3, 900, 180}, {9, 620, 110}};
    scene.camera = testdata::FramedPoolCamera(scene.table, testdata::PoolViewSide::kLongNear, 50,
                                              60, 5, 2);
    scene.srgb_tone = true;  // a phone's picture, as the server assumes
    view_ = testdata::RenderPoolView(scene, 21);
    image_ = (dir_ / "table.png").string();
    cv::imwrite(image_, view_.image);
    camera_ = (dir_ / "camera.yml").string();
    cv::FileStorage fs(camera_, cv::FileStorage::WRITE);
    fs << "camera_matrix" << cv::Mat(view_.camera_matrix);
    fs << "distortion_coefficients" << cv::Mat(view_.distortion).reshape(1, 1);
    fs << "image_width" << view_.image.cols << "image_height" << view_.image.rows;
    fs.release();
    table_ = (dir_ / "table.json").string();
    std::ofstream(table_) << R"({"length_mm": 1330, "width_mm": 700, "ball_radius_mm": 24,
                                 "cushion_height_mm": 37, "cushion_width_mm": 42,
                                 "corner_pocket_mm": 100, "side_pocket_mm": 110})";
  }
  void TearDown() override { fs::remove_all(dir_); }

  fs::path dir_;
  testdata::PoolView view_;
  std::string image_, camera_, table_;
};

TEST_F(PoolCliTest, AnalyzePrintsTheContractAndWritesOverlayAndTopView) {
  fs::create_directories(dir_ / "data");
  testing::ServerProcess server(TEXFREE_SERVER_BINARY, (dir_ / "data").string());
  ASSERT_FALSE(server.address().empty()) << server.Log();
  const std::string overlay = (dir_ / "overlay.png").string();
  const std::string topview = (dir_ / "top.png").string();
  Result r = RunTexfree({"--json", "--server", server.address(), "pool", "analyze", image_,
                         "--intrinsics", camera_, "--table", table_, "--overlay", overlay,
                         "--topview", topview});
  ASSERT_EQ(r.code, 0) << r.err;
  const json out = json::parse(r.out);
  ASSERT_EQ(out["corners"].size(), 4u);
  for (const auto& c : out["corners"]) EXPECT_EQ(c.size(), 2u);
  ASSERT_EQ(out["balls"].size(), view_.balls.size());
  for (const auto& b : out["balls"])
    for (const char* key : {"number", "u", "v", "x_mm", "y_mm"}) EXPECT_TRUE(b.contains(key)) << key;
  ASSERT_GT(out["shots"].size(), 0u) << out.dump();
  for (const auto& s : out["shots"]) {
    EXPECT_TRUE(s["type"] == "pocket" || s["type"] == "safety");
    EXPECT_EQ(s["target_ball"], 1);
    EXPECT_GE(s["path"].size(), 2u);
    EXPECT_EQ(s["path"][0].size(), 2u);
  }
  EXPECT_GT(out["server_ms"].get<double>(), 0);
  EXPECT_FALSE(out.contains("profile_note")) << out["profile_note"];
  EXPECT_LT(out["rectangle_inconsistency"].get<double>(), 0.018);
  EXPECT_GT(out["ball_size_ratio"].get<double>(), 0.7);
  EXPECT_LT(out["ball_size_ratio"].get<double>(), 1.45);

  // Without --table the server takes the default 9-ft profile: the answer says the profile
  // is not this table's, in text and in JSON.
  r = RunTexfree(
      {"--server", server.address(), "pool", "analyze", image_, "--intrinsics", camera_});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("note: the table's outline fits a rectangle of the profile's 2540 x 1270 "
                       "mm table"),
            std::string::npos)
      << r.out;
  r = RunTexfree(
      {"--json", "--server", server.address(), "pool", "analyze", image_, "--intrinsics", camera_});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(json::parse(r.out).value("profile_note", "").find("table.json"), std::string::npos)
      << r.out;

  const cv::Mat drawn = cv::imread(overlay), original = cv::imread(image_);
  ASSERT_EQ(drawn.size(), original.size());
  EXPECT_GT(cv::norm(drawn, original, cv::NORM_L1), 1000);  // something was drawn
  EXPECT_FALSE(cv::imread(topview).empty());
}

TEST_F(PoolCliTest, LocalMistakesExitTwoWithoutTheServer) {
  // Nobody listens on port 9: a contacted server would give exit 1.
  Result r = RunTexfree({"--server", "127.0.0.1:9", "pool", "analyze", image_});
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("intrinsics"), std::string::npos) << r.err;
  const std::string bad = (dir_ / "bad.json").string();
  std::ofstream(bad) << R"({"length_mm": "long", "width_mm": 700})";
  r = RunTexfree({"--server", "127.0.0.1:9", "pool", "analyze", image_, "--intrinsics", camera_,
                  "--table", bad});
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("length_mm"), std::string::npos) << r.err;
  r = RunTexfree({"--server", "127.0.0.1:9", "pool", "analyze", image_, "--intrinsics", camera_,
                  "--overlay", (dir_ / "out.xyz").string()});
  EXPECT_EQ(r.code, 2);
}

}  // namespace
}  // namespace texfree::client
