// SurveyService: the gRPC face of light photogrammetry (texfree.v1.SurveyService): surveys
// with their camera and reference lights, bursts uploaded as client streams and decoded while
// they arrive, view poses, triangulation and point export.
#pragma once

#include <string>

#include "common/image_io.h"
#include "common/light_decoder.h"
#include "common/light_survey.h"
#include "server/survey_store.h"
#include "texfree/v1/survey.grpc.pb.h"

namespace texfree::server {

struct SurveyServiceOptions {
  lights::BurstDecoderOptions decoder;
  survey::SolveOptions solve;
  ImageLimits limits;

  absl::Status Validate() const;
};

// Points as CSV (header id,x,y,z,views,rms_px,sigma_x,sigma_y,sigma_z), JSON or ASCII PLY.
std::string PointsToCsv(const std::vector<survey::SolvedPoint>& points);
std::string PointsToJson(const std::string& survey_id, const std::vector<survey::SolvedPoint>& points);
std::string PointsToPly(const std::vector<survey::SolvedPoint>& points);

// Thread-safe (SurveyStore is; each upload has its own decoder); gRPC calls handlers
// concurrently.
class SurveyServiceImpl final : public v1::SurveyService::Service {
 public:
  SurveyServiceImpl(SurveyStore* store, SurveyServiceOptions options)
      : store_(store), options_(std::move(options)) {}

  grpc::Status CreateSurvey(grpc::ServerContext*, const v1::CreateSurveyRequest*,
                            v1::Survey*) override;
  grpc::Status UploadView(grpc::ServerContext*, grpc::ServerReader<v1::UploadViewRequest>*,
                          v1::UploadViewResponse*) override;
  grpc::Status Solve(grpc::ServerContext*, const v1::SolveRequest*, v1::SolveResponse*) override;
  grpc::Status GetSurvey(grpc::ServerContext*, const v1::GetSurveyRequest*, v1::Survey*) override;
  grpc::Status ListSurveys(grpc::ServerContext*, const v1::ListSurveysRequest*,
                           v1::ListSurveysResponse*) override;
  grpc::Status DeleteSurvey(grpc::ServerContext*, const v1::DeleteSurveyRequest*,
                            v1::DeleteSurveyResponse*) override;
  grpc::Status ExportPoints(grpc::ServerContext*, const v1::ExportPointsRequest*,
                            v1::ExportPointsResponse*) override;

 private:
  SurveyStore* store_;
  SurveyServiceOptions options_;
};

}  // namespace texfree::server
