// End-to-end test of DocumentService through the real texfree-server binary: register
// rendered pages with annotations, retrieve them from camera views (homography and pose
// against ground truth), several pages in one view, bad input answered with the right
// status, deletion, and a restart that keeps what remains.
#include <gtest/gtest.h>

#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <string>
#include <vector>

#include "common/planar_pose.h"
#include "tests/data/camera_view.h"
#include "tests/data/page_renderer.h"
#include "tests/server/server_process.h"
#include "texfree/v1/document.grpc.pb.h"

namespace texfree {
namespace {

namespace fs = std::filesystem;
using testing::ServerProcess;

std::string ServerBinary() { return TEXFREE_SERVER_BINARY; }

std::string Encode(const cv::Mat& image, const std::string& ext = ".png") {
  std::vector<uchar> bytes;
  cv::imencode(ext, image, bytes);
  return std::string(bytes.begin(), bytes.end());
}

cv::Matx33d FromProto(const v1::Homography& h) {
  cv::Matx33d H;
  for (int i = 0; i < 9; ++i) H.val[i] = h.h(i);
  return H;
}

struct Page {
  uint64_t seed;
  cv::Mat image;
  std::string id;
};

testdata::CameraViewOptions View(double tilt, double azimuth, double roll, double scale) {
  testdata::CameraViewOptions o;
  o.tilt_deg = tilt;
  o.tilt_azimuth_deg = azimuth;
  o.roll_deg = roll;
  o.scale = scale;
  o.blur_sigma = 0.6;
  o.noise_sigma = 2.0;
  o.illumination_gradient = 0.3;
  o.jpeg_quality = 85;
  return o;
}

class DocumentServiceIntegrationTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("texfree-it-" + std::to_string(::getpid()) + "-" + std::to_string(std::rand()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::unique_ptr<ServerProcess> Start() {
    auto server = std::make_unique<ServerProcess>(ServerBinary(), dir_.string());
    EXPECT_FALSE(server->address().empty()) << server->Log();
    return server;
  }

  fs::path dir_;
};

v1::RetrieveDocumentsResponse Retrieve(v1::DocumentService::Stub& stub, const cv::Mat& image,
                                       const cv::Matx33d* K = nullptr) {
  grpc::ClientContext ctx;
  v1::RetrieveDocumentsRequest req;
  req.mutable_image()->set_encoded(Encode(image, ".jpg"));
  if (K) {
    auto* in = req.mutable_intrinsics();
    in->set_fx((*K)(0, 0));
    in->set_fy((*K)(1, 1));
    in->set_cx((*K)(0, 2));
    in->set_cy((*K)(1, 2));
    in->set_width(image.cols);
    in->set_height(image.rows);
  }
  v1::RetrieveDocumentsResponse res;
  const grpc::Status s = stub.RetrieveDocuments(&ctx, req, &res);
  EXPECT_TRUE(s.ok()) << s.error_message();
  return res;
}

grpc::Status Register(v1::DocumentService::Stub& stub, const cv::Mat& image,
                      const std::string& title, std::vector<v1::Annotation> annotations,
                      v1::RegisterDocumentResponse* res) {
  grpc::ClientContext ctx;
  v1::RegisterDocumentRequest req;
  req.mutable_image()->set_encoded(Encode(image));
  req.set_title(title);
  for (auto& a : annotations) *req.add_annotations() = a;
  return stub.RegisterDocument(&ctx, req, res);
}

v1::Annotation Highlight(double x, double y, double w, double h, double opacity) {
  v1::Annotation a;
  auto* hl = a.mutable_highlight();
  hl->mutable_rect()->set_x(x);
  hl->mutable_rect()->set_y(y);
  hl->mutable_rect()->set_width(w);
  hl->mutable_rect()->set_height(h);
  hl->mutable_color()->set_r(255);
  hl->mutable_color()->set_g(255);
  hl->mutable_color()->set_a(255);
  hl->set_opacity(opacity);
  return a;
}

v1::Annotation Note(const std::string& text, double x, double y) {
  v1::Annotation a;
  a.mutable_text()->set_text(text);
  a.mutable_text()->mutable_position()->set_x(x);
  a.mutable_text()->mutable_position()->set_y(y);
  a.mutable_text()->set_font_size_px(28);
  return a;
}

TEST_F(DocumentServiceIntegrationTest, RegisterRetrieveDeleteRestart) {
  auto server = Start();
  ASSERT_FALSE(server->address().empty());
  auto stub = v1::DocumentService::NewStub(server->Channel());

  // Register four pages with different layouts, with annotations on the first.
  std::vector<Page> pages;
  for (uint64_t seed : {501u, 503u, 504u, 505u}) {
    Page p{seed, testdata::RenderTextPage(seed).image, ""};
    v1::RegisterDocumentResponse res;
    std::vector<v1::Annotation> notes;
    if (seed == 501) notes = {Highlight(100, 200, 400, 60, 0.4), Note("check this", 120, 400)};
    const grpc::Status s = Register(*stub, p.image, "page " + std::to_string(seed), notes, &res);
    ASSERT_TRUE(s.ok()) << s.error_message() << "\n" << server->Log();
    EXPECT_GT(res.document().keypoints(), 100u);
    EXPECT_EQ(res.document().annotations_size(), static_cast<int>(notes.size()));
    p.id = res.document().document_id();
    pages.push_back(p);
  }

  // Camera views: each page is found first, homography within a few pixels, pose with
  // intrinsics close to the camera's true rotation.
  const std::vector<testdata::CameraViewOptions> views = {View(0, 0, 0, 0.8), View(8, 30, 15, 0.9),
                                                          View(12, 200, -30, 0.8)};
  for (const Page& p : pages) {
    for (size_t v = 0; v < views.size(); ++v) {
      auto view = testdata::RenderCameraView(p.image, views[v], p.seed * 10 + v);
      auto res = Retrieve(*stub, view.image, &view.camera_matrix);
      EXPECT_GE(res.matches_size(), 1) << "page " << p.seed << " view " << v;
      if (res.matches_size() == 0) continue;
      const auto& m = res.matches(0);
      EXPECT_EQ(m.document_id(), p.id) << "page " << p.seed << " view " << v;
      EXPECT_LT(testdata::MeanHomographyError(FromProto(m.homography()), view.homography,
                                              p.image.size(), view.image.size()),
                3.0)
          << "page " << p.seed << " view " << v;
      EXPECT_GE(m.inliers(), 12u) << "page " << p.seed << " view " << v;
      ASSERT_EQ(m.pose().rotation_size(), 9);
      cv::Matx33d R;
      for (int i = 0; i < 9; ++i) R.val[i] = m.pose().rotation(i);
      const cv::Matx33d dR = R * view.rotation.t();
      const double angle_deg =
          std::acos(std::clamp((cv::trace(dR) - 1.0) / 2.0, -1.0, 1.0)) * 180.0 / CV_PI;
      EXPECT_LT(angle_deg, 2.0) << "page " << p.seed << " view " << v;
      EXPECT_GT(res.server_ms(), 0.0);
      if (p.seed == 501) {
        ASSERT_EQ(m.annotations_size(), 2);
        ASSERT_EQ(m.annotations(0).quad_size(), 4);
        const cv::Point2d expected = ApplyHomography(view.homography, {100, 200});
        EXPECT_NEAR(m.annotations(0).quad(0).x(), expected.x, 4.0);
        EXPECT_NEAR(m.annotations(0).quad(0).y(), expected.y, 4.0);
      }
    }
  }

  // Two pages in one picture: both are returned, each with its own homography.
  {
    cv::Mat canvas(1150, 1560, CV_8UC3, cv::Scalar(70, 80, 90));
    const cv::Matx33d Ha(0.75, 0, 20, 0, 0.75, 30, 0, 0, 1),
        Hb(0.74, -0.04, 790, 0.04, 0.74, 20, 0, 0, 1);
    cv::Mat a, b;  // anti-aliasing before the downscale, as a lens would
    cv::GaussianBlur(pages[1].image, a, cv::Size(), 0.6);
    cv::GaussianBlur(pages[2].image, b, cv::Size(), 0.6);
    cv::warpPerspective(a, canvas, cv::Mat(Ha), canvas.size(), cv::INTER_LINEAR,
                        cv::BORDER_TRANSPARENT);
    cv::warpPerspective(b, canvas, cv::Mat(Hb), canvas.size(), cv::INTER_LINEAR,
                        cv::BORDER_TRANSPARENT);
    auto res = Retrieve(*stub, canvas);
    std::map<std::string, cv::Matx33d> found;
    for (const auto& m : res.matches()) found[m.document_id()] = FromProto(m.homography());
    ASSERT_EQ(found.size(), 2u);
    ASSERT_TRUE(found.count(pages[1].id));
    ASSERT_TRUE(found.count(pages[2].id));
    EXPECT_LT(
        testdata::MeanHomographyError(found[pages[1].id], Ha, pages[1].image.size(), canvas.size()),
        3.0);
    EXPECT_LT(
        testdata::MeanHomographyError(found[pages[2].id], Hb, pages[2].image.size(), canvas.size()),
        3.0);
  }

  // A page never registered matches nothing.
  {
    auto other = testdata::RenderTextPage(999);
    auto view = testdata::RenderCameraView(other.image, View(10, 0, 5, 0.8), 7);
    EXPECT_EQ(Retrieve(*stub, view.image).matches_size(), 0);
  }

  // Registering the same page again is refused, naming the existing document.
  {
    v1::RegisterDocumentResponse res;
    auto again = testdata::RenderCameraView(pages[0].image, View(0, 0, 0, 1.0), 3);
    const grpc::Status s = Register(*stub, pages[0].image, "again", {}, &res);
    EXPECT_EQ(s.error_code(), grpc::StatusCode::ALREADY_EXISTS);
    EXPECT_NE(s.error_message().find(pages[0].id), std::string::npos) << s.error_message();
  }

  // Delete page 3: it is no longer retrieved; the others still are.
  {
    grpc::ClientContext ctx;
    v1::DeleteDocumentRequest req;
    req.set_document_id(pages[3].id);
    v1::DeleteDocumentResponse res;
    ASSERT_TRUE(stub->DeleteDocument(&ctx, req, &res).ok());
    EXPECT_LT(res.server_ms(), 1000.0);
    auto view = testdata::RenderCameraView(pages[3].image, views[0], 11);
    EXPECT_EQ(Retrieve(*stub, view.image).matches_size(), 0);
  }

  // Restart: what remains survives, the deleted page stays deleted.
  EXPECT_EQ(server->Stop(), 0) << server->Log();
  server = Start();
  ASSERT_FALSE(server->address().empty());
  stub = v1::DocumentService::NewStub(server->Channel());
  {
    grpc::ClientContext ctx;
    v1::ListDocumentsResponse list;
    ASSERT_TRUE(stub->ListDocuments(&ctx, v1::ListDocumentsRequest(), &list).ok());
    EXPECT_EQ(list.documents_size(), 3);
    EXPECT_EQ(list.total(), 3u);
  }
  for (int i = 0; i < 4; ++i) {
    auto view = testdata::RenderCameraView(pages[i].image, views[1], 100 + i);
    auto res = Retrieve(*stub, view.image);
    if (i == 3) {
      EXPECT_EQ(res.matches_size(), 0);
    } else {
      ASSERT_GE(res.matches_size(), 1) << "page " << i << " after restart";
      EXPECT_EQ(res.matches(0).document_id(), pages[i].id);
      if (i == 0) {
        EXPECT_EQ(res.matches(0).annotations_size(), 2);
      }
    }
  }
  // The deleted page can be registered again.
  {
    v1::RegisterDocumentResponse res;
    EXPECT_TRUE(Register(*stub, pages[3].image, "again", {}, &res).ok());
  }
  EXPECT_EQ(server->Stop(), 0);
}

TEST_F(DocumentServiceIntegrationTest, BadInputGetsClearErrorsAndServerStaysUp) {
  auto server = Start();
  ASSERT_FALSE(server->address().empty());
  auto stub = v1::DocumentService::NewStub(server->Channel());
  auto register_bytes = [&](const std::string& bytes, std::vector<v1::Annotation> notes = {}) {
    grpc::ClientContext ctx;
    v1::RegisterDocumentRequest req;
    req.mutable_image()->set_encoded(bytes);
    for (auto& a : notes) *req.add_annotations() = a;
    v1::RegisterDocumentResponse res;
    return stub->RegisterDocument(&ctx, req, &res);
  };

  grpc::Status s = register_bytes("this is not an image at all");
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(s.error_message().find("decoded"), std::string::npos) << s.error_message();

  s = register_bytes("");
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(s.error_message().find("empty"), std::string::npos) << s.error_message();

  // A PNG header announcing 12000 x 9000 pixels (108 MP) is refused before decoding.
  {
    const unsigned char header[] = {0x89, 'P', 'N',  'G',  0x0D, 0x0A, 0x1A, 0x0A, 0,    0,
                                    0,    13,  'I',  'H',  'D',  'R',  0,    0,    0x2E, 0xE0,
                                    0,    0,   0x23, 0x28, 8,    0,    0,    0,    0};
    s = register_bytes(std::string(reinterpret_cast<const char*>(header), sizeof(header)));
    EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
    EXPECT_NE(s.error_message().find("limit"), std::string::npos) << s.error_message();
  }

  // A blank page has too few keypoints.
  s = register_bytes(Encode(testdata::RenderBlankPage(3)));
  EXPECT_EQ(s.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_NE(s.error_message().find("keypoints"), std::string::npos) << s.error_message();

  // Malformed annotations: opacity out of range, empty text, no kind.
  const std::string page = Encode(testdata::RenderTextPage(77).image);
  s = register_bytes(page, {Highlight(10, 10, 100, 20, 1.5)});
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(s.error_message().find("opacity"), std::string::npos) << s.error_message();
  s = register_bytes(page, {Note("", 10, 10)});
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  s = register_bytes(page, {v1::Annotation()});
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  s = register_bytes(page, {Highlight(10, 10, -5, 20, 0.5)});
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);

  // Unknown ids.
  {
    grpc::ClientContext ctx;
    v1::DeleteDocumentRequest req;
    req.set_document_id("0123456789abcdef");
    v1::DeleteDocumentResponse res;
    s = stub->DeleteDocument(&ctx, req, &res);
    EXPECT_EQ(s.error_code(), grpc::StatusCode::NOT_FOUND);
    EXPECT_NE(s.error_message().find("0123456789abcdef"), std::string::npos);
  }
  {
    grpc::ClientContext ctx;
    v1::GetDocumentRequest req;
    req.set_document_id("nope");
    v1::Document res;
    EXPECT_EQ(stub->GetDocument(&ctx, req, &res).error_code(), grpc::StatusCode::NOT_FOUND);
  }
  {
    grpc::ClientContext ctx;
    v1::RetrieveDocumentsRequest req;
    req.mutable_image()->set_encoded("garbage");
    v1::RetrieveDocumentsResponse res;
    EXPECT_EQ(stub->RetrieveDocuments(&ctx, req, &res).error_code(),
              grpc::StatusCode::INVALID_ARGUMENT);
  }
  {
    grpc::ClientContext ctx;
    v1::RetrieveDocumentsRequest req;
    auto* raw = req.mutable_image()->mutable_raw();
    raw->set_format(v1::RawImage::GRAY8);
    raw->set_width(640);
    raw->set_height(480);
    raw->set_pixels(std::string(1000, '\x80'));  // far too short
    v1::RetrieveDocumentsResponse res;
    EXPECT_EQ(stub->RetrieveDocuments(&ctx, req, &res).error_code(),
              grpc::StatusCode::INVALID_ARGUMENT);
  }

  // The server is still up and the good page registers fine.
  EXPECT_TRUE(server->running());
  EXPECT_TRUE(register_bytes(page, {Highlight(10, 10, 100, 20, 0.5)}).ok());
  EXPECT_EQ(server->Stop(), 0);
}

}  // namespace
}  // namespace texfree
