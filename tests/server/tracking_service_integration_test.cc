// End-to-end test of TrackingService through the real texfree-server binary: a page
// registered with an annotation through DocumentService is tracked over a tilt sequence
// of JPEG frames (homography and mapped annotation against ground truth), a garbage frame
// in the middle gets an error result while the stream goes on, and the server log shows
// the session opened and closed.
#include <gtest/gtest.h>

#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "common/planar_pose.h"
#include "tests/data/page_renderer.h"
#include "tests/server/server_process.h"
#include "tests/server/tracking_stream.h"
#include "texfree/v1/document.grpc.pb.h"

namespace texfree {
namespace {

namespace fs = std::filesystem;
using testing::ConfigMessage;
using testing::FrameMessage;

TEST(TrackingServiceIntegrationTest, TracksARegisteredPageThroughTheServerBinary) {
  const fs::path dir =
      fs::temp_directory_path() / ("texfree-track-it-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  {
    testing::ServerProcess server(TEXFREE_SERVER_BINARY, dir.string());
    ASSERT_FALSE(server.address().empty()) << server.Log();
    const cv::Mat page = testdata::RenderTextPage(4242).image;

    auto documents = v1::DocumentService::NewStub(server.Channel());
    v1::RegisterDocumentRequest reg;
    std::vector<uchar> png;
    cv::imencode(".png", page, png);
    reg.mutable_image()->set_encoded(std::string(png.begin(), png.end()));
    reg.set_title("tracked page");
    auto* hl = reg.add_annotations()->mutable_highlight();
    hl->mutable_rect()->set_x(100);
    hl->mutable_rect()->set_y(200);
    hl->mutable_rect()->set_width(400);
    hl->mutable_rect()->set_height(60);
    hl->set_opacity(0.4);
    v1::RegisterDocumentResponse registered;
    grpc::ClientContext reg_context;
    const grpc::Status s = documents->RegisterDocument(&reg_context, reg, &registered);
    ASSERT_TRUE(s.ok()) << s.error_message() << "\n" << server.Log();

    const auto frames = testing::RenderTrackFrames(page, 10, 3.0, 8);
    std::vector<v1::TrackRequest> messages = {ConfigMessage(nullptr)};
    for (size_t i = 0; i < frames.size(); ++i) {
      messages.push_back(FrameMessage(i, frames[i].jpeg));
      if (i == 4) messages.push_back(FrameMessage(1000, std::string(5000, '\x11')));
    }
    auto tracking = v1::TrackingService::NewStub(server.Channel());
    const auto outcome = testing::RunStream(*tracking, messages);
    ASSERT_TRUE(outcome.status.ok()) << outcome.status.error_message();
    ASSERT_EQ(outcome.responses.size(), frames.size() + 1);
    size_t frame = 0;
    for (const v1::TrackResponse& r : outcome.responses) {
      if (r.frame_index() == 1000) {
        EXPECT_FALSE(r.error().empty());
        continue;
      }
      SCOPED_TRACE(::testing::Message() << "frame " << frame);
      ASSERT_EQ(r.frame_index(), frame);
      ASSERT_EQ(r.targets_size(), 1);
      const v1::TrackedTarget& t = r.targets(0);
      EXPECT_EQ(t.id(), registered.document().document_id());
      EXPECT_EQ(t.title(), "tracked page");
      EXPECT_NE(t.state(), v1::TrackedTarget::LOST);
      const auto& truth = frames[frame].truth;
      EXPECT_LE(testdata::MeanHomographyError(testing::HomographyOf(t), truth.homography,
                                              page.size(), truth.image.size()),
                3.0);
      ASSERT_EQ(t.annotations_size(), 1);
      ASSERT_EQ(t.annotations(0).quad_size(), 4);
      const cv::Point2d corner = ApplyHomography(truth.homography, {100, 200});
      EXPECT_NEAR(t.annotations(0).quad(0).x(), corner.x, 3.0);
      EXPECT_NEAR(t.annotations(0).quad(0).y(), corner.y, 3.0);
      // The same, ready to draw: the page's outline, then the highlight.
      ASSERT_EQ(t.overlays_size(), 2);
      EXPECT_EQ(t.overlays(0).kind(), v1::Overlay::POLYGON);
      ASSERT_EQ(t.overlays(0).points_size(), 4);
      const cv::Point2d far_corner =
          ApplyHomography(truth.homography, cv::Point2d(page.cols, page.rows));
      EXPECT_NEAR(t.overlays(0).points(2).x(), far_corner.x, 3.0);
      EXPECT_NEAR(t.overlays(0).points(2).y(), far_corner.y, 3.0);
      EXPECT_EQ(t.overlays(1).kind(), v1::Overlay::FILLED_POLYGON);
      EXPECT_DOUBLE_EQ(t.overlays(1).opacity(), 0.4);
      ASSERT_EQ(t.overlays(1).points_size(), 4);
      EXPECT_NEAR(t.overlays(1).points(0).x(), corner.x, 3.0);
      EXPECT_NEAR(t.overlays(1).points(0).y(), corner.y, 3.0);
      ++frame;
    }
    EXPECT_EQ(server.Stop(), 0);
    const std::string log = server.Log();
    EXPECT_NE(log.find("tracking session 1 opened"), std::string::npos) << log;
    EXPECT_NE(log.find("tracking session 1 closed (client done): 11 frames"), std::string::npos)
        << log;
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace texfree
