// TrackingService handler: first message = config, then frames handed to a
// TrackingSession until the client closes, cancels or stays silent.
#include "server/tracking_service.h"

#include <spdlog/spdlog.h>

#include "absl/strings/str_cat.h"
#include "common/status_macros.h"
#include "common/timing.h"
#include "server/proto_convert.h"
#include "server/tracking_session.h"

namespace texfree::server {

absl::Status TrackingServiceOptions::Validate() const {
  if (idle_timeout.count() <= 0) return absl::InvalidArgumentError("idle_timeout must be > 0");
  if (max_sessions < 1) return absl::InvalidArgumentError("max_sessions must be >= 1");
  if (queue_frames < 1 || queue_frames > 64)
    return absl::InvalidArgumentError("queue_frames must be in [1, 64]");
  if (max_frame_age_ms < 1 || max_frame_age_ms > 60'000)
    return absl::InvalidArgumentError("max_frame_age_ms must be in [1, 60000]");
  RETURN_IF_ERROR(limits.Validate());
  RETURN_IF_ERROR(tracker.Validate());
  return absl::OkStatus();
}

absl::StatusOr<TrackerOptions> TrackerOptionsFromProto(const v1::TrackOptions& in,
                                                       const TrackingServiceOptions& service) {
  TrackerOptions o = service.tracker;
  if (in.track_maps())
    return absl::UnimplementedError(
        "map tracking is not available in this server version: set track_documents only");
  switch (in.update_policy()) {
    case v1::TrackOptions::UPDATE_POLICY_UNSPECIFIED:
    case v1::TrackOptions::BELOW_THRESHOLD:
      o.update_policy = UpdatePolicy::kBelowThreshold;
      break;
    case v1::TrackOptions::EVERY_FRAME:
      o.update_policy = UpdatePolicy::kEveryFrame;
      break;
    case v1::TrackOptions::NEVER:
      o.update_policy = UpdatePolicy::kNever;
      break;
    default:
      return absl::InvalidArgumentError(
          absl::StrCat("options.update_policy ", in.update_policy(), " is not a known policy"));
  }
  if (in.update_inlier_threshold() > 100000)
    return absl::InvalidArgumentError("options.update_inlier_threshold must be at most 100000");
  if (in.update_inlier_threshold() > 0)
    o.update_inlier_threshold = static_cast<int>(in.update_inlier_threshold());
  if (in.max_learned_entries() > service.max_learned_entries_limit)
    return absl::InvalidArgumentError(absl::StrCat("options.max_learned_entries must be at most ",
                                                   service.max_learned_entries_limit));
  if (in.max_learned_entries() > 0) o.session.max_learned_entries = in.max_learned_entries();
  if (in.max_documents() > 64)
    return absl::InvalidArgumentError("options.max_documents must be at most 64");
  if (in.max_documents() > 0) o.max_documents = static_cast<int>(in.max_documents());
  if (in.disable_prediction()) o.predict = false;
  RETURN_IF_ERROR(o.Validate());
  return o;
}

grpc::Status TrackingServiceImpl::Track(
    grpc::ServerContext* context,
    grpc::ServerReaderWriter<v1::TrackResponse, v1::TrackRequest>* stream) {
  const uint64_t id = next_session_.fetch_add(1);
  const int active = active_.fetch_add(1) + 1;
  struct Release {
    std::atomic<int>& count;
    ~Release() { count.fetch_sub(1); }
  } release{active_};
  if (active > options_.max_sessions) {
    spdlog::warn("tracking: refused a stream, {} are open (max_sessions)", active - 1);
    return grpc::Status(grpc::StatusCode::RESOURCE_EXHAUSTED,
                        absl::StrCat("the server is tracking ", active - 1,
                                     " streams, its maximum; try again later"));
  }
  IdleWatchdog watchdog(options_.idle_timeout, [context] { context->TryCancel(); });
  const auto idle_status = [&] {
    return grpc::Status(grpc::StatusCode::DEADLINE_EXCEEDED,
                        absl::StrCat("no message for ", options_.idle_timeout.count() / 1000.0,
                                     " s: the tracking session was closed"));
  };

  v1::TrackRequest request;
  if (!stream->Read(&request)) return watchdog.fired() ? idle_status() : grpc::Status::OK;
  watchdog.Touch();
  if (request.message_case() != v1::TrackRequest::kConfig) {
    return ToGrpcStatus(absl::InvalidArgumentError(
        "the first message of a Track stream must be a config (intrinsics and options); "
        "frames come after it"));
  }
  auto camera = CameraFromProto(request.config().intrinsics());
  if (!camera.ok()) return ToGrpcStatus(camera.status());
  auto tracker = TrackerOptionsFromProto(request.config().options(), options_);
  if (!tracker.ok()) return ToGrpcStatus(tracker.status());
  TrackingSessionOptions session_options;
  session_options.queue_frames = options_.queue_frames;
  session_options.max_frame_age_ms = options_.max_frame_age_ms;
  session_options.limits = options_.limits;
  session_options.tracker = *tracker;
  session_options.camera = *camera;
  if (options_.stagger_streams) {
    // Phases taken modulo the cycles' lengths: consecutive streams get consecutive phases.
    const int phase = static_cast<int>(id % 1024);
    session_options.keypoints.measure_phase = phase;
    session_options.tracker.retrieval_phase = phase;
  }
  if (auto s = session_options.Validate(); !s.ok()) return ToGrpcStatus(s);

  spdlog::info("tracking session {} opened from {} ({} active{})", id, context->peer(), active,
               *camera ? ", with intrinsics" : "");
  const auto t0 = SteadyClock::now();
  TrackingSessionStats stats;
  bool cancelled = false;
  {
    TrackingSession session(registry_, std::move(session_options),
                            [stream](const v1::TrackResponse& r) { return stream->Write(r); });
    while (stream->Read(&request)) {
      watchdog.Touch();
      if (request.message_case() == v1::TrackRequest::kFrame) {
        if (!session.Push(std::move(*request.mutable_frame()))) break;
      } else {
        session.PushError(0, "a config is only accepted as the first message; ignored");
      }
    }
    cancelled = context->IsCancelled();
    if (cancelled)
      session.Cancel();
    else
      session.Finish();  // the client closed its side: answer what is queued
    stats = session.stats();
  }
  const double seconds = MillisecondsSince(t0) / 1000.0;
  spdlog::info(
      "tracking session {} closed ({}): {} frames in {:.1f} s, {} results, {} dropped, {} "
      "errors, {:.2f} ms server time per frame ({} active)",
      id, watchdog.fired() ? "idle" : cancelled ? "cancelled" : "client done", stats.frames,
      seconds, stats.results, stats.dropped, stats.errors,
      stats.results ? stats.server_ms / stats.results : 0.0, active_.load() - 1);
  if (watchdog.fired()) return idle_status();
  return grpc::Status::OK;
}

}  // namespace texfree::server
