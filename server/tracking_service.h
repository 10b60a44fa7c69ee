// TrackingService: the gRPC face of DocumentTracker (texfree.v1.TrackingService.Track).
// Each stream gets a TrackingSession (its own tracker, its own learned index, its two
// pipeline threads); the handler thread only reads messages and hands frames over.
#pragma once

#include <atomic>
#include <chrono>
#include <cstddef>
#include <cstdint>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "common/document_tracker.h"
#include "common/image_io.h"
#include "server/document_registry.h"
#include "texfree/v1/tracking.grpc.pb.h"

namespace texfree::server {

struct TrackingServiceOptions {
  // A stream with no message for this long is ended (its session freed).
  std::chrono::milliseconds idle_timeout{60'000};
  // Streams served at once; more are refused with RESOURCE_EXHAUSTED.
  int max_sessions = 64;
  // Per stream: a frame waiting longer than this is stale, and frames waiting at most
  // (TrackingSessionOptions).
  int max_frame_age_ms = 250;
  int queue_frames = 16;
  // Each new stream does its periodic work (the full text measurement, retrieval of
  // further pages) at its own phase of the cycle: streams started together would
  // otherwise all do it on the same frames, a burst of several times the mean work.
  bool stagger_streams = true;
  ImageLimits limits;
  // Defaults of every session; a stream's TrackOptions override some of them.
  TrackerOptions tracker;
  // Largest learned-entry budget a client may ask for.
  size_t max_learned_entries_limit = 1'000'000;

  absl::Status Validate() const;
};

// The tracker options of a stream: the service defaults with the client's choices.
// INVALID_ARGUMENT for out-of-range values, UNIMPLEMENTED for map tracking.
absl::StatusOr<TrackerOptions> TrackerOptionsFromProto(const v1::TrackOptions& options,
                                                       const TrackingServiceOptions& service);

// Thread-safe: gRPC runs one handler per stream concurrently.
class TrackingServiceImpl final : public v1::TrackingService::Service {
 public:
  TrackingServiceImpl(const DocumentRegistry* registry, TrackingServiceOptions options)
      : registry_(registry), options_(std::move(options)) {}

  grpc::Status Track(grpc::ServerContext* context,
                     grpc::ServerReaderWriter<v1::TrackResponse, v1::TrackRequest>* stream)
      override;

  // Streams with a live session (for logs, tests and shutdown).
  int active_sessions() const { return active_.load(); }

 private:
  const DocumentRegistry* registry_;
  const TrackingServiceOptions options_;
  std::atomic<int> active_{0};
  std::atomic<uint64_t> next_session_{1};
};

}  // namespace texfree::server
