// gRPC loopback throughput of TrackingService for the tracking benchmark: one stream
// sending JPEG frames as fast as results come back (two frames in flight), then N streams
// sending at a fixed frame rate like cameras; prints fps, server time, latency, drops and
// the process's CPU time per answered frame (frames are encoded once, beforehand).
#pragma once

#include <string>
#include <vector>

#include "server/document_registry.h"
#include "server/tracking_service.h"

namespace texfree::bench {

void RunGrpcThroughput(const server::DocumentRegistry* registry,
                       const std::vector<std::string>& jpegs, const std::string& sequence,
                       int streams, double fps, double seconds,
                       const server::TrackingServiceOptions& options);

}  // namespace texfree::bench
