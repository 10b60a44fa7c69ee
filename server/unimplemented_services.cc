// Placeholder map service: every method answers
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

constexpr char kMaps[] = "augmented maps";

}  // namespace

using grpc::ServerContext;
using grpc::Status;
namespace v1 = ::texfree::v1;

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

}  // namespace unimplemented

std::vector<std::unique_ptr<grpc::Service>> MakeNotYetImplementedServices() {
  std::vector<std::unique_ptr<grpc::Service>> services;
  services.push_back(std::make_unique<unimplemented::MapService>());
  return services;
}

}  // namespace texfree::server
