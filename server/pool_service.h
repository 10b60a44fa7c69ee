// PoolService: the gRPC face of the pool assistant (texfree.v1.PoolService): table
// profiles kept in pool.db, colour calibration, one-image analysis (table, balls, shots,
// overlays) and live tracking that keeps the chosen shot glued to the table.
#pragma once

#include <cstdint>

#include "common/image_io.h"
#include "server/pool_profile_store.h"
#include "texfree/v1/pool.grpc.pb.h"

namespace texfree::server {

// Thread-safe: the store is; every call and every stream has its own analyzer.
class PoolServiceImpl final : public v1::PoolService::Service {
 public:
  // `live_pixels`: TrackTable analyses each frame reduced to at most this many pixels (0:
  // the analyzer's default, as AnalyzeTable).
  PoolServiceImpl(PoolProfileStore* store, ImageLimits limits, int64_t live_pixels = 0)
      : store_(store), limits_(limits), live_pixels_(live_pixels) {}

  grpc::Status SetTableProfile(grpc::ServerContext*, const v1::SetTableProfileRequest*,
                               v1::TableProfile*) override;
  grpc::Status CalibrateColors(grpc::ServerContext*, const v1::CalibrateColorsRequest*,
                               v1::TableProfile*) override;
  grpc::Status AnalyzeTable(grpc::ServerContext*, const v1::AnalyzeTableRequest*,
                            v1::AnalyzeTableResponse*) override;
  grpc::Status TrackTable(
      grpc::ServerContext*,
      grpc::ServerReaderWriter<v1::AnalyzeTableResponse, v1::TrackTableRequest>*) override;

 private:
  PoolProfileStore* store_;
  ImageLimits limits_;
  int64_t live_pixels_;
};

}  // namespace texfree::server
