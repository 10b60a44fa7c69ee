// End-to-end test of SurveyService through the real texfree-server binary on the simulated
// tunnel (quarter-size D300 frames, JPEG, clock drift, distractor lamps): create a survey,
// upload two 100-frame views, solve, compare with ground truth, export, restart and find it
// all again; bad input (unknown survey, frames of different sizes, too few frames, a view
// with too few references, bad references) answered with a clear status.
#include <gtest/gtest.h>

#include <filesystem>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "tests/data/light_scene.h"
#include "tests/server/server_process.h"
#include "tests/server/survey_requests.h"
#include "texfree/v1/survey.grpc.pb.h"

namespace texfree {
namespace {

namespace fs = std::filesystem;
using testing::ServerProcess;

testdata::LightSceneOptions SceneOptions() {
  testdata::LightSceneOptions options;
  options.seed = 21;
  options.scale = 0.25;
  return options;
}

// Encoded frames of both views, rendered once for the whole test suite.
struct Bursts {
  testdata::LightScene scene;
  std::vector<std::string> frames[2];
  std::vector<testdata::LightTruth> truth[2];
};

const Bursts& TunnelBursts() {
  static const Bursts* bursts = [] {
    auto* b = new Bursts;
    const auto options = SceneOptions();
    b->scene = testdata::MakeTunnelScene(options);
    for (int v = 0; v < 2; ++v) {
      testdata::BurstRenderer renderer(b->scene, testdata::TunnelViewPose(v), options, 100 + v);
      for (int k = 0; k < options.frames; ++k) b->frames[v].push_back(renderer.EncodeFrame(k));
      b->truth[v] = renderer.truth();
    }
    return b;
  }();
  return *bursts;
}

v1::CreateSurveyRequest CreateRequest(const testdata::LightScene& scene,
                                      const std::map<uint32_t, cv::Point3d>& references) {
  return testing::SurveyRequestFor(scene, references, "tunnel");
}

grpc::Status Upload(v1::SurveyService::Stub& stub, const std::string& survey_id,
                    const std::string& view, const std::vector<std::string>& frames,
                    v1::UploadViewResponse* response) {
  grpc::ClientContext ctx;
  auto writer = stub.UploadView(&ctx, response);
  v1::UploadViewRequest header;
  header.mutable_header()->set_survey_id(survey_id);
  header.mutable_header()->set_view_name(view);
  bool open = writer->Write(header);
  for (const auto& f : frames) {
    if (!open) break;
    v1::UploadViewRequest m;
    m.mutable_frame()->set_encoded(f);
    open = writer->Write(m);
  }
  writer->WritesDone();
  return writer->Finish();
}

class SurveyServiceIntegrationTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("texfree-survey-it-" + std::to_string(::getpid()) + "-" + std::to_string(std::rand()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::unique_ptr<ServerProcess> Start() {
    auto server = std::make_unique<ServerProcess>(TEXFREE_SERVER_BINARY, dir_.string());
    EXPECT_FALSE(server->address().empty()) << server->Log();
    return server;
  }

  fs::path dir_;
};

TEST_F(SurveyServiceIntegrationTest, TwoViewsSolvedAgainstGroundTruthAndSurviveRestart) {
  const Bursts& bursts = TunnelBursts();
  std::string survey_id;
  {
    auto server = Start();
    auto stub = v1::SurveyService::NewStub(server->Channel());
    grpc::ClientContext ctx;
    v1::Survey survey;
    ASSERT_TRUE(
        stub->CreateSurvey(&ctx, CreateRequest(bursts.scene, bursts.scene.references), &survey)
            .ok());
    survey_id = survey.survey_id();

    for (int v = 0; v < 2; ++v) {
      v1::UploadViewResponse response;
      const std::string name = v == 0 ? "left" : "right";
      const grpc::Status status = Upload(*stub, survey_id, name, bursts.frames[v], &response);
      ASSERT_TRUE(status.ok()) << status.error_message() << server->Log();
      const v1::View& view = response.view();
      EXPECT_EQ(view.frames(), 100u);
      ASSERT_EQ(view.lights_size(), static_cast<int>(bursts.truth[v].size())) << name;
      for (int i = 0; i < view.lights_size(); ++i) {
        const auto& light = view.lights(i);
        EXPECT_EQ(light.id(), bursts.truth[v][i].id);
        EXPECT_LE(cv::norm(cv::Point2d(light.u(), light.v()) - bursts.truth[v][i].pixel), 0.3)
            << name << " light " << light.id();
        EXPECT_FALSE(light.conflict());
      }
      EXPECT_TRUE(view.posed()) << view.pose_error();
      EXPECT_EQ(view.references_used(), 7u);
      EXPECT_LT(view.reprojection_rms_px(), 0.3);
    }

    grpc::ClientContext solve_ctx;
    v1::SolveRequest solve;
    solve.set_survey_id(survey_id);
    solve.set_bundle_adjustment(true);
    v1::SolveResponse solved;
    const grpc::Status status = stub->Solve(&solve_ctx, solve, &solved);
    ASSERT_TRUE(status.ok()) << status.error_message();
    ASSERT_EQ(solved.points_size(), 7);
    double sum = 0;
    for (const auto& p : solved.points()) {
      const cv::Point3d truth = bursts.scene.measured.at(p.id());
      const double error =
          cv::norm(cv::Point3d(p.position_m().x(), p.position_m().y(), p.position_m().z()) - truth);
      sum += error;
      // Quarter resolution: a pixel covers 4x the tunnel; the full-size figure is in the bench.
      EXPECT_LT(error, 0.04) << "light " << p.id();
      EXPECT_EQ(p.views(), 2u);
      EXPECT_GT(p.sigma_m().y(), 0);
    }
    EXPECT_LT(sum / 7, 0.015);
    EXPECT_TRUE(solved.bundle_adjusted());

    grpc::ClientContext export_ctx;
    v1::ExportPointsRequest export_request;
    export_request.set_survey_id(survey_id);
    export_request.set_format(v1::ExportPointsRequest::PLY);
    v1::ExportPointsResponse exported;
    ASSERT_TRUE(stub->ExportPoints(&export_ctx, export_request, &exported).ok());
    EXPECT_NE(exported.data().find("element vertex 7"), std::string::npos);
    EXPECT_EQ(server->Stop(), 0);
  }
  {
    auto server = Start();
    auto stub = v1::SurveyService::NewStub(server->Channel());
    grpc::ClientContext ctx;
    v1::GetSurveyRequest get;
    get.set_survey_id(survey_id);
    v1::Survey survey;
    ASSERT_TRUE(stub->GetSurvey(&ctx, get, &survey).ok());
    EXPECT_EQ(survey.views_size(), 2);
    EXPECT_EQ(survey.references_size(), 7);
    EXPECT_EQ(survey.points_size(), 7);
    EXPECT_TRUE(survey.solved());
    EXPECT_EQ(survey.views(0).lights_size(), static_cast<int>(bursts.truth[0].size()));

    grpc::ClientContext export_ctx;
    v1::ExportPointsRequest export_request;
    export_request.set_survey_id(survey_id);
    v1::ExportPointsResponse exported;
    ASSERT_TRUE(stub->ExportPoints(&export_ctx, export_request, &exported).ok());
    EXPECT_EQ(exported.data().rfind("id,x,y,z", 0), 0u);

    grpc::ClientContext delete_ctx;
    v1::DeleteSurveyRequest del;
    del.set_survey_id(survey_id);
    v1::DeleteSurveyResponse deleted;
    ASSERT_TRUE(stub->DeleteSurvey(&delete_ctx, del, &deleted).ok());
    grpc::ClientContext again;
    EXPECT_EQ(stub->GetSurvey(&again, get, &survey).error_code(), grpc::StatusCode::NOT_FOUND);
  }
}

TEST_F(SurveyServiceIntegrationTest, BadInputAnsweredClearly) {
  const Bursts& bursts = TunnelBursts();
  auto server = Start();
  auto stub = v1::SurveyService::NewStub(server->Channel());
  std::vector<std::string> few(bursts.frames[0].begin(), bursts.frames[0].begin() + 47);

  // Unknown survey.
  {
    v1::UploadViewResponse response;
    const grpc::Status status = Upload(*stub, "0123456789abcdef", "left", few, &response);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::NOT_FOUND);
    grpc::ClientContext ctx;
    v1::SolveRequest solve;
    solve.set_survey_id("0123456789abcdef");
    v1::SolveResponse solved;
    EXPECT_EQ(stub->Solve(&ctx, solve, &solved).error_code(), grpc::StatusCode::NOT_FOUND);
  }
  // Bad references: out-of-range id, duplicate, too few.
  {
    auto request = CreateRequest(bursts.scene, bursts.scene.references);
    request.mutable_references(2)->set_id(64);
    grpc::ClientContext ctx;
    v1::Survey survey;
    const grpc::Status status = stub->CreateSurvey(&ctx, request, &survey);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
    EXPECT_NE(status.error_message().find("64"), std::string::npos);
    request.mutable_references(2)->set_id(1);
    grpc::ClientContext ctx2;
    EXPECT_EQ(stub->CreateSurvey(&ctx2, request, &survey).error_code(),
              grpc::StatusCode::INVALID_ARGUMENT);
    std::map<uint32_t, cv::Point3d> three(bursts.scene.references.begin(),
                                          std::next(bursts.scene.references.begin(), 3));
    grpc::ClientContext ctx3;
    EXPECT_EQ(stub->CreateSurvey(&ctx3, CreateRequest(bursts.scene, three), &survey).error_code(),
              grpc::StatusCode::INVALID_ARGUMENT);
  }
  // A survey whose references the view mostly cannot see: 1, 2, 3 and an absent 40.
  std::map<uint32_t, cv::Point3d> refs = {{1, bursts.scene.references.at(1)},
                                          {2, bursts.scene.references.at(2)},
                                          {3, bursts.scene.references.at(3)},
                                          {40, {50, 80, 15}}};
  grpc::ClientContext ctx;
  v1::Survey survey;
  ASSERT_TRUE(stub->CreateSurvey(&ctx, CreateRequest(bursts.scene, refs), &survey).ok());
  // Fewer than 48 frames.
  {
    v1::UploadViewResponse response;
    const grpc::Status status = Upload(*stub, survey.survey_id(), "left", few, &response);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
    EXPECT_NE(status.error_message().find("at least 48 frames"), std::string::npos)
        << status.error_message();
  }
  // Frames of different sizes.
  {
    std::vector<std::string> mixed = few;
    cv::Mat small(100, 150, CV_8UC1, cv::Scalar(5));
    std::vector<uchar> bytes;
    cv::imencode(".png", small, bytes);
    mixed.insert(mixed.begin() + 10, std::string(bytes.begin(), bytes.end()));
    v1::UploadViewResponse response;
    const grpc::Status status = Upload(*stub, survey.survey_id(), "left", mixed, &response);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
    EXPECT_NE(status.error_message().find("same size"), std::string::npos)
        << status.error_message();
  }
  // Too few references to pose: stored, not posed, and Solve says why.
  {
    v1::UploadViewResponse response;
    const grpc::Status status =
        Upload(*stub, survey.survey_id(), "left", bursts.frames[0], &response);
    ASSERT_TRUE(status.ok()) << status.error_message();
    EXPECT_FALSE(response.view().posed());
    EXPECT_NE(response.view().pose_error().find("reference"), std::string::npos);
    grpc::ClientContext solve_ctx;
    v1::SolveRequest solve;
    solve.set_survey_id(survey.survey_id());
    v1::SolveResponse solved;
    const grpc::Status solve_status = stub->Solve(&solve_ctx, solve, &solved);
    EXPECT_EQ(solve_status.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
    EXPECT_NE(solve_status.error_message().find("left"), std::string::npos);
  }
  EXPECT_TRUE(server->running());
}

}  // namespace
}  // namespace texfree
