// Placeholder gRPC services (maps) whose every method
// answers UNIMPLEMENTED with a message naming the missing capability, so that
// clients and reflection see the whole texfree.v1 API from the first version.
#pragma once

#include <grpcpp/grpcpp.h>

#include <memory>
#include <vector>

#include "texfree/v1/map.grpc.pb.h"

namespace texfree::server {
namespace unimplemented {

class MapService final : public texfree::v1::MapService::Service {
 public:
  grpc::Status ImportGis(grpc::ServerContext* context,
                         const texfree::v1::ImportGisRequest* request,
                         texfree::v1::ImportGisResponse* response) override;
  grpc::Status ListMaps(grpc::ServerContext* context,
                        const texfree::v1::ListMapsRequest* request,
                        texfree::v1::ListMapsResponse* response) override;
  grpc::Status RenderMap(grpc::ServerContext* context,
                         const texfree::v1::RenderMapRequest* request,
                         texfree::v1::RenderMapResponse* response) override;
  grpc::Status DeleteMap(grpc::ServerContext* context,
                         const texfree::v1::DeleteMapRequest* request,
                         texfree::v1::DeleteMapResponse* response) override;
  grpc::Status RetrieveMap(grpc::ServerContext* context,
                           const texfree::v1::RetrieveMapRequest* request,
                           texfree::v1::RetrieveMapResponse* response) override;
};

}  // namespace unimplemented

// One instance of each placeholder service, ready for ServerBuilder::
// RegisterService (the caller keeps them alive as long as the server). Drop a
// service from this list once its real implementation is registered.
std::vector<std::unique_ptr<grpc::Service>> MakeNotYetImplementedServices();

}  // namespace texfree::server
