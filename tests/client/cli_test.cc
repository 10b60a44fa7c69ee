// Tests of the texfree CLI: usage errors (exit 2), an unreachable server (exit
// 1, quickly) and the doc commands against an in-process fake DocumentService.
#include "client/cli.h"

#include <arpa/inet.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "tests/client/cli_runner.h"
#include "texfree/v1/document.grpc.pb.h"

namespace texfree::client {
namespace {

using nlohmann::json;

using Result = CliResult;

// A TCP port on which nobody listens (bound, read, then closed).
int UnusedPort() {
  int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  address.sin_port = 0;
  ::bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address));
  socklen_t length = sizeof(address);
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&address), &length);
  int port = ntohs(address.sin_port);
  ::close(fd);
  return port;
}

class TempDir {
 public:
  TempDir() {
    path_ = std::filesystem::temp_directory_path() /
            ("texfree_cli_test_" + std::to_string(::getpid()) + "_" +
             std::to_string(counter_++));
    std::filesystem::create_directories(path_);
  }
  ~TempDir() { std::filesystem::remove_all(path_); }
  std::string File(const std::string& name, const std::string& content) const {
    std::ofstream(path_ / name, std::ios::binary) << content;
    return (path_ / name).string();
  }
  std::string Path(const std::string& name) const {
    return (path_ / name).string();
  }

 private:
  static inline int counter_ = 0;
  std::filesystem::path path_;
};

std::string PngBytes(int width, int height) {
  cv::Mat image(height, width, CV_8UC3, cv::Scalar::all(255));
  std::vector<uchar> buffer;
  cv::imencode(".png", image, buffer);
  return std::string(buffer.begin(), buffer.end());
}

TEST(CliTest, UsageErrorsExitTwo) {
  EXPECT_EQ(RunTexfree({}).code, 2);
  EXPECT_EQ(RunTexfree({"doc"}).code, 2);
  EXPECT_EQ(RunTexfree({"doc", "register"}).code, 2);
  Result unknown_verb = RunTexfree({"doc", "frobnicate"});
  EXPECT_EQ(unknown_verb.code, 2);
  EXPECT_NE(unknown_verb.err.find("unknown command 'frobnicate' after 'texfree doc'"),
            std::string::npos)
      << unknown_verb.err;
  EXPECT_NE(unknown_verb.err.find("register, retrieve"), std::string::npos) << unknown_verb.err;
  // An unknown group, after a global option and its value: named, with the groups there are.
  Result unknown_group = RunTexfree({"--server", "localhost:1", "maps", "list"});
  EXPECT_EQ(unknown_group.code, 2);
  EXPECT_NE(unknown_group.err.find("unknown command 'maps' after 'texfree'"), std::string::npos)
      << unknown_group.err;
  EXPECT_NE(unknown_group.err.find("doc, track"), std::string::npos) << unknown_group.err;
  EXPECT_EQ(RunTexfree({"--no-such-flag", "doc", "list"}).code, 2);
  EXPECT_EQ(RunTexfree({"doc", "delete"}).code, 2);
  EXPECT_EQ(RunTexfree({"doc", "annotate", "x"}).code, 2);
  Result missing =
      RunTexfree({"--json", "doc", "register", "/nonexistent/page.png"});
  EXPECT_EQ(missing.code, 2);
  EXPECT_TRUE(missing.out.empty());
  EXPECT_NE(missing.err.find("/nonexistent/page.png"), std::string::npos)
      << missing.err;
}

TEST(CliTest, HelpExitsZero) {
  Result help = RunTexfree({"--help"});
  EXPECT_EQ(help.code, 0);
  EXPECT_NE(help.out.find("doc"), std::string::npos);
  EXPECT_EQ(RunTexfree({"doc", "retrieve", "--help"}).code, 0);
}

TEST(CliTest, MalformedAnnotationsFailBeforeContactingTheServer) {
  TempDir dir;
  std::string image = dir.File("page.png", PngBytes(64, 64));
  std::string annotations = dir.File(
      "a.json",
      R"([{"type": "highlight", "x": 1, "y": 2, "width": -5, "height": 3}])");
  int port = UnusedPort();
  auto start = std::chrono::steady_clock::now();
  Result result =
      RunTexfree({"--json", "--server", "127.0.0.1:" + std::to_string(port),
                  "doc", "register", image, "--annotations", annotations});
  auto elapsed = std::chrono::steady_clock::now() - start;
  EXPECT_EQ(result.code, 2);
  EXPECT_TRUE(result.out.empty());
  EXPECT_NE(result.err.find("annotations[0].width"), std::string::npos)
      << result.err;
  EXPECT_LT(elapsed, std::chrono::seconds(2));  // no connection attempt

  std::string camera =
      dir.File("camera.yml", "%YAML:1.0\n---\nimage_width: 640\n");
  result = RunTexfree({"--server", "127.0.0.1:" + std::to_string(port), "doc",
                       "retrieve", image, "--intrinsics", camera});
  EXPECT_EQ(result.code, 2);
  EXPECT_NE(result.err.find("camera_matrix"), std::string::npos) << result.err;
}

TEST(CliTest, UnreachableServerExitsOneQuickly) {
  std::string server = "127.0.0.1:" + std::to_string(UnusedPort());
  auto start = std::chrono::steady_clock::now();
  Result result = RunTexfree({"--json", "--server", server, "doc", "list"});
  auto elapsed = std::chrono::steady_clock::now() - start;
  EXPECT_EQ(result.code, 1);
  EXPECT_TRUE(result.out.empty());
  EXPECT_NE(result.err.find("cannot reach texfree-server at " + server),
            std::string::npos)
      << result.err;
  EXPECT_LT(elapsed, std::chrono::seconds(8));
}

// A DocumentService with canned answers.
class FakeDocumentService final : public v1::DocumentService::Service {
 public:
  grpc::Status RegisterDocument(
      grpc::ServerContext*, const v1::RegisterDocumentRequest* request,
      v1::RegisterDocumentResponse* response) override {
    last_register = *request;
    auto* document = response->mutable_document();
    document->set_document_id("doc-1");
    document->set_title(request->title());
    document->set_width(64);
    document->set_height(64);
    document->set_keypoints(42);
    for (int i = 0; i < request->annotations_size(); ++i) {
      *document->add_annotations() = request->annotations(i);
      document->mutable_annotations(i)->set_annotation_id("a" +
                                                          std::to_string(i));
    }
    response->set_server_ms(3.5);
    return grpc::Status::OK;
  }

  grpc::Status DeleteDocument(grpc::ServerContext*,
                              const v1::DeleteDocumentRequest* request,
                              v1::DeleteDocumentResponse* response) override {
    if (request->document_id() != "doc-1") {
      return grpc::Status(
          grpc::StatusCode::NOT_FOUND,
          "document '" + request->document_id() + "' does not exist");
    }
    response->set_document_id("doc-1");
    return grpc::Status::OK;
  }

  grpc::Status ListDocuments(grpc::ServerContext*,
                             const v1::ListDocumentsRequest* request,
                             v1::ListDocumentsResponse* response) override {
    // Two pages: doc-1, doc-2 then doc-3.
    if (request->page_token().empty()) {
      for (const char* id : {"doc-1", "doc-2"}) {
        auto* document = response->add_documents();
        document->set_document_id(id);
        document->set_title(std::string("title of ") + id);
      }
      response->set_next_page_token("page2");
    } else if (request->page_token() == "page2") {
      auto* document = response->add_documents();
      document->set_document_id("doc-3");
      document->set_title("title of doc-3");
    }
    response->set_total(3);
    return grpc::Status::OK;
  }

  grpc::Status RetrieveDocuments(
      grpc::ServerContext*, const v1::RetrieveDocumentsRequest* request,
      v1::RetrieveDocumentsResponse* response) override {
    last_retrieve = *request;
    auto* match = response->add_matches();
    match->set_document_id("doc-1");
    match->set_title("page");
    for (double h : {0.5, 0.0, 10.0, 0.0, 0.5, 10.0, 0.0, 0.0, 1.0}) {
      match->mutable_homography()->add_h(h);
    }
    match->set_inliers(30);
    match->set_votes(50);
    match->set_width(64);
    match->set_height(64);
    auto* mapped = match->add_annotations();
    auto* highlight = mapped->mutable_annotation()->mutable_highlight();
    highlight->mutable_rect()->set_x(8);
    highlight->mutable_rect()->set_y(8);
    highlight->mutable_rect()->set_width(48);
    highlight->mutable_rect()->set_height(48);
    highlight->mutable_color()->set_r(255);
    highlight->mutable_color()->set_a(255);
    highlight->set_opacity(1.0);
    if (request->has_intrinsics()) {
      for (int i = 0; i < 9; ++i)
        match->mutable_pose()->add_rotation(i % 4 == 0 ? 1 : 0);
      for (int i = 0; i < 3; ++i) match->mutable_pose()->add_translation(i);
    }
    response->set_server_ms(12.5);
    return grpc::Status::OK;
  }

  v1::RegisterDocumentRequest last_register;
  v1::RetrieveDocumentsRequest last_retrieve;
};

class CliServerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    grpc::ServerBuilder builder;
    int port = 0;
    builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(),
                             &port);
    builder.RegisterService(&service_);
    server_ = builder.BuildAndStart();
    ASSERT_NE(server_, nullptr);
    address_ = "127.0.0.1:" + std::to_string(port);
  }
  void TearDown() override { server_->Shutdown(); }

  Result RunJson(std::vector<std::string> args) {
    args.insert(args.begin(), {"--json", "--server", address_});
    return RunTexfree(args);
  }

  FakeDocumentService service_;
  std::unique_ptr<grpc::Server> server_;
  std::string address_;
  TempDir dir_;
};

TEST_F(CliServerTest, RegisterSendsEncodedBytesTitleAndAnnotations) {
  std::string bytes = PngBytes(64, 64);
  std::string image = dir_.File("my_page.png", bytes);
  std::string annotations = dir_.File(
      "a.json",
      R"({"annotations": [{"type": "text", "text": "hi", "x": 1, "y": 20}]})");
  Result result =
      RunJson({"doc", "register", image, "--annotations", annotations});
  ASSERT_EQ(result.code, 0) << result.err;
  json out = json::parse(result.out);  // exactly one JSON document
  EXPECT_EQ(out["document_id"], "doc-1");
  EXPECT_EQ(out["keypoints"], 42);
  EXPECT_EQ(out["title"], "my_page");
  EXPECT_EQ(out["annotation_count"], 1);
  EXPECT_EQ(service_.last_register.image().encoded(), bytes);
  EXPECT_EQ(service_.last_register.title(), "my_page");
  ASSERT_EQ(service_.last_register.annotations_size(), 1);
  EXPECT_EQ(service_.last_register.annotations(0).text().text(), "hi");

  result = RunJson({"doc", "register", image, "--title", "Custom"});
  ASSERT_EQ(result.code, 0) << result.err;
  EXPECT_EQ(json::parse(result.out)["title"], "Custom");
}

TEST_F(CliServerTest, RetrieveOutputsMatchesAndDrawsTheOverlay) {
  std::string image = dir_.File("query.png", PngBytes(64, 64));
  std::string camera = dir_.Path("camera.yml");
  {
    cv::FileStorage fs(camera, cv::FileStorage::WRITE);
    fs << "image_width" << 64 << "image_height" << 64;
    fs << "camera_matrix"
       << cv::Mat(cv::Matx33d(100, 0, 32, 0, 100, 32, 0, 0, 1));
    fs << "distortion_coefficients"
       << cv::Mat(cv::Matx<double, 1, 5>(0, 0, 0, 0, 0));
  }
  std::string overlay = dir_.Path("overlay.png");
  Result result = RunJson(
      {"doc", "retrieve", image, "--intrinsics", camera, "--overlay", overlay});
  ASSERT_EQ(result.code, 0) << result.err;
  json out = json::parse(result.out);
  ASSERT_EQ(out["matches"].size(), 1u);
  const json& match = out["matches"][0];
  EXPECT_EQ(match["document_id"], "doc-1");
  EXPECT_EQ(match["inliers"], 30);
  ASSERT_EQ(match["homography"].size(), 9u);
  EXPECT_DOUBLE_EQ(match["homography"][2].get<double>(), 10.0);
  EXPECT_EQ(match["pose"]["rotation"].size(), 9u);
  EXPECT_DOUBLE_EQ(out["server_ms"].get<double>(), 12.5);
  EXPECT_DOUBLE_EQ(service_.last_retrieve.intrinsics().fx(), 100);
  EXPECT_EQ(service_.last_retrieve.intrinsics().distortion_size(), 5);

  // Highlight (8..56) maps to (14..38): opaque red in the middle, white far
  // outside.
  cv::Mat drawn = cv::imread(overlay, cv::IMREAD_COLOR);
  ASSERT_FALSE(drawn.empty());
  EXPECT_EQ(drawn.at<cv::Vec3b>(26, 26), cv::Vec3b(0, 0, 255));
  EXPECT_EQ(drawn.at<cv::Vec3b>(60, 60), cv::Vec3b(255, 255, 255));
}

// --undistort: the picture the server gets is the ideal pinhole's (a dot drawn through a
// k1 -0.15 lens 5.5 px from where an ideal lens puts it arrives within 0.6 px of the ideal
// place), with the intrinsics sent without distortion; it needs --intrinsics (exit 2).
TEST_F(CliServerTest, RetrieveUndistortsThePictureWhenAsked) {
  cv::Mat picture(200, 200, CV_8UC3, cv::Scalar::all(255));
  const cv::Point2d ideal(25, 25);
  const double nx = (ideal.x - 99.5) / 150, ny = (ideal.y - 99.5) / 150;
  const double f = 1 - 0.15 * (nx * nx + ny * ny);
  // Drawn at its sub-pixel place (4 fractional bits).
  cv::circle(picture,
             cv::Point(cvRound(16 * (99.5 + 150 * nx * f)), cvRound(16 * (99.5 + 150 * ny * f))),
             32, cv::Scalar::all(0), -1, cv::LINE_AA, 4);
  std::vector<uchar> png;
  cv::imencode(".png", picture, png);
  const std::string image = dir_.File("lens.png", std::string(png.begin(), png.end()));
  const std::string camera = dir_.Path("lens.yml");
  {
    cv::FileStorage fs(camera, cv::FileStorage::WRITE);
    fs << "image_width" << 200 << "image_height" << 200;
    fs << "camera_matrix" << cv::Mat(cv::Matx33d(150, 0, 99.5, 0, 150, 99.5, 0, 0, 1));
    fs << "distortion_coefficients" << cv::Mat(cv::Matx<double, 1, 5>(-0.15, 0, 0, 0, 0));
  }
  Result result = RunJson({"doc", "retrieve", image, "--intrinsics", camera, "--undistort"});
  ASSERT_EQ(result.code, 0) << result.err;
  EXPECT_EQ(service_.last_retrieve.intrinsics().distortion_size(), 0);
  EXPECT_DOUBLE_EQ(service_.last_retrieve.intrinsics().fx(), 150);
  const std::string& sent = service_.last_retrieve.image().encoded();
  const cv::Mat seen =
      cv::imdecode(std::vector<uchar>(sent.begin(), sent.end()), cv::IMREAD_GRAYSCALE);
  ASSERT_EQ(seen.size(), cv::Size(200, 200));
  double sw = 0, sx = 0, sy = 0;
  for (int y = 12; y <= 38; ++y)
    for (int x = 12; x <= 38; ++x) {
      const double w = 255.0 - seen.at<uint8_t>(y, x);
      sw += w;
      sx += w * x;
      sy += w * y;
    }
  ASSERT_GT(sw, 255);
  EXPECT_NEAR(sx / sw, ideal.x, 0.6);
  EXPECT_NEAR(sy / sw, ideal.y, 0.6);

  result = RunJson({"doc", "retrieve", image, "--undistort"});
  EXPECT_EQ(result.code, 2);
  EXPECT_NE(result.err.find("--undistort needs --intrinsics"), std::string::npos) << result.err;
}

TEST_F(CliServerTest, ListFollowsPageTokens) {
  Result result = RunJson({"doc", "list"});
  ASSERT_EQ(result.code, 0) << result.err;
  json out = json::parse(result.out);
  ASSERT_EQ(out["documents"].size(), 3u);
  EXPECT_EQ(out["documents"][2]["document_id"], "doc-3");
  EXPECT_EQ(out["documents"][0]["title"], "title of doc-1");

  result = RunTexfree({"--server", address_, "doc", "list"});
  ASSERT_EQ(result.code, 0);
  EXPECT_NE(result.out.find("doc-3"), std::string::npos);
}

TEST_F(CliServerTest, DeleteAndServerErrors) {
  Result result = RunJson({"doc", "delete", "doc-1"});
  ASSERT_EQ(result.code, 0) << result.err;
  EXPECT_EQ(json::parse(result.out),
            (json{{"deleted", "doc-1"}, {"server_ms", 0.0}}));

  result = RunJson({"doc", "delete", "x"});
  EXPECT_EQ(result.code, 1);
  EXPECT_TRUE(result.out.empty());
  EXPECT_NE(result.err.find("error: NOT_FOUND: document 'x' does not exist"),
            std::string::npos)
      << result.err;

  // The fake does not implement GetDocument.
  result = RunJson({"doc", "show", "doc-1"});
  EXPECT_EQ(result.code, 1);
  EXPECT_NE(result.err.find("UNIMPLEMENTED"), std::string::npos) << result.err;
}

}  // namespace
}  // namespace texfree::client
