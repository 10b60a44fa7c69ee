// Placeholder tracking, map and survey services: every method answers
// UNIMPLEMENTED with a message naming the service, the method and the
// capability that is still to come.
#include "server/unimplemented_services.h"

#include <string>

namespace texfree::server {
namespace unimplemented {
namespace {

grpc::Status NotYet(const char* service, const char* method,
                    const char* capability) {
  return grpc::Status(
      grpc::StatusCode::UNIMPLEMENTED,
      std::string(service) + "." + method +
          " is not implemented yet in this texfree-server version (see the "
          "project's issue on " +
          capability + ")");
}

constexpr char kTracking[] = "live tracking of documents and maps";
constexpr char kMaps[] = "augmented maps";
constexpr char kSurvey[] = "light photogrammetry";

}  // namespace

using grpc::ServerContext;
using grpc::Status;
namespace v1 = ::texfree::v1;

Status TrackingService::Track(
    ServerContext*,
    grpc::ServerReaderWriter<v1::TrackResponse, v1::TrackRequest>*) {
  return NotYet("TrackingService", "Track", kTracking);
}

Status MapService::ImportGis(ServerContext*, const v1::ImportGisRequest*,
                             v1::ImportGisResponse*) {
  return NotYet("MapService", "ImportGis", kMaps);
}
Status MapService::ListMaps(ServerContext*, const v1::ListMapsRequest*,
                            v1::ListMapsResponse*) {
  return NotYet("MapService", "ListMaps", kMaps);
}
Status MapService::RenderMap(ServerContext*, const v1::RenderMapRequest*,
                             v1::RenderMapResponse*) {
  return NotYet("MapService", "RenderMap", kMaps);
}
Status MapService::DeleteMap(ServerContext*, const v1::DeleteMapRequest*,
                             v1::DeleteMapResponse*) {
  return NotYet("MapService", "DeleteMap", kMaps);
}
Status MapService::RetrieveMap(ServerContext*, const v1::RetrieveMapRequest*,
                               v1::RetrieveMapResponse*) {
  return NotYet("MapService", "RetrieveMap", kMaps);
}

Status SurveyService::CreateSurvey(ServerContext*,
                                   const v1::CreateSurveyRequest*,
                                   v1::Survey*) {
  return NotYet("SurveyService", "CreateSurvey", kSurvey);
}
Status SurveyService::UploadView(ServerContext*,
                                 grpc::ServerReader<v1::UploadViewRequest>*,
                                 v1::UploadViewResponse*) {
  return NotYet("SurveyService", "UploadView", kSurvey);
}
Status SurveyService::Solve(ServerContext*, const v1::SolveRequest*,
                            v1::SolveResponse*) {
  return NotYet("SurveyService", "Solve", kSurvey);
}
Status SurveyService::GetSurvey(ServerContext*, const v1::GetSurveyRequest*,
                                v1::Survey*) {
  return NotYet("SurveyService", "GetSurvey", kSurvey);
}
Status SurveyService::ListSurveys(ServerContext*, const v1::ListSurveysRequest*,
                                  v1::ListSurveysResponse*) {
  return NotYet("SurveyService", "ListSurveys", kSurvey);
}
Status SurveyService::DeleteSurvey(ServerContext*,
                                   const v1::DeleteSurveyRequest*,
                                   v1::DeleteSurveyResponse*) {
  return NotYet("SurveyService", "DeleteSurvey", kSurvey);
}
Status SurveyService::ExportPoints(ServerContext*,
                                   const v1::ExportPointsRequest*,
                                   v1::ExportPointsResponse*) {
  return NotYet("SurveyService", "ExportPoints", kSurvey);
}

}  // namespace unimplemented

std::vector<std::unique_ptr<grpc::Service>> MakeNotYetImplementedServices() {
  std::vector<std::unique_ptr<grpc::Service>> services;
  services.push_back(std::make_unique<unimplemented::TrackingService>());
  services.push_back(std::make_unique<unimplemented::MapService>());
  services.push_back(std::make_unique<unimplemented::SurveyService>());
  return services;
}

}  // namespace texfree::server
