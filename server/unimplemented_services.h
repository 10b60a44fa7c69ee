// Placeholder gRPC services (maps, pool) whose every method
// answers UNIMPLEMENTED with a message naming the missing capability, so that
// clients and reflection see the whole texfree.v1 API from the first version.
#pragma once

#include <grpcpp/grpcpp.h>

#include <memory>
#include <vector>

#include "texfree/v1/map.grpc.pb.h"
#include "texfree/v1/pool.grpc.pb.h"

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

class PoolService final : public texfree::v1::PoolService::Service {
 public:
  grpc::Status SetTableProfile(
      grpc::ServerContext* context,
      const texfree::v1::SetTableProfileRequest* request,
      texfree::v1::TableProfile* response) override;
  grpc::Status CalibrateColors(
      grpc::ServerContext* context,
      const texfree::v1::CalibrateColorsRequest* request,
      texfree::v1::TableProfile* response) override;
  grpc::Status AnalyzeTable(
      grpc::ServerContext* context,
      const texfree::v1::AnalyzeTableRequest* request,
      texfree::v1::AnalyzeTableResponse* response) override;
  grpc::Status TrackTable(
      grpc::ServerContext* context,
      grpc::ServerReaderWriter<texfree::v1::AnalyzeTableResponse,
                               texfree::v1::TrackTableRequest>* stream)
      override;
};

}  // namespace unimplemented

// One instance of each placeholder service, ready for ServerBuilder::
// RegisterService (the caller keeps them alive as long as the server). Drop a
// service from this list once its real implementation is registered.
std::vector<std::unique_ptr<grpc::Service>> MakeNotYetImplementedServices();

}  // namespace texfree::server
