// TrackingSession: the work of one TrackingService.Track stream, off gRPC's threads, as
// a two-stage pipeline (seed 5.4): stage 1 decodes frame t+1 and extracts its word
// keypoints while stage 2 matches frame t, estimates the pose, learns and writes the
// result, so one stream keeps two cores busy. Queues are bounded in time and in count:
// stage 1 waits for stage 2 (one frame in between); when the oldest waiting frame has
// waited longer than `max_frame_age_ms` it is stale, and stage 1 skips to the newest
// frame, dropping those in between; frames arriving while `queue_frames` wait already
// push the oldest waiting frame out. A server that falls behind thus drops stale frames,
// and says so in the next result, instead of queueing without bound and answering late,
// while a burst (many streams starting at once, each running retrieval) is absorbed
// without a drop as long as no frame gets stale.
//
// IdleWatchdog ends a stream that stays silent.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <unordered_map>
#include <vector>

#include "absl/status/status.h"
#include "common/document_tracker.h"
#include "common/image_io.h"
#include "common/planar_pose.h"
#include "common/timing.h"
#include "common/video_keypoints.h"
#include "common/word_keypoints.h"
#include "server/document_registry.h"
#include "texfree/v1/tracking.pb.h"

namespace texfree::server {

struct TrackingSessionOptions {
  // A frame waiting for stage 1 longer than this is stale: the stream skips to the newest
  // frame waiting (which is always answered). 250 ms: an overlay lagging
  // more than a quarter second no longer looks attached to the page, while start-up
  // bursts (retrieval, about 30 ms per frame, on every stream at once) last less.
  int max_frame_age_ms = 250;
  // Frames waiting for stage 1 at most (memory bound when a client sends faster than
  // the stale rule can tell): when a frame arrives and this many wait, the oldest is
  // dropped. 16: half a second of video at 30 fps.
  int queue_frames = 16;
  ImageLimits limits;
  TrackerOptions tracker;
  // How often stage 1 measures the text size (frames in between reuse it).
  VideoKeypointOptions keypoints;
  std::optional<CameraModel> camera;  // frames must have its size when it has one

  absl::Status Validate() const;
};

struct TrackingSessionStats {
  uint64_t frames = 0;   // frames received
  uint64_t results = 0;  // results written
  uint64_t dropped = 0;
  uint64_t errors = 0;   // error results
  double server_ms = 0;  // sum of per-frame processing times
};

// Thread-safe: Push/PushError/Finish/Cancel are called by the stream's reader thread
// while the session's two threads work; the writer is only called from stage 2.
class TrackingSession {
 public:
  // Writes one result to the client; returns false when the client is gone.
  using Writer = std::function<bool(const v1::TrackResponse&)>;

  TrackingSession(const DocumentRegistry* registry, TrackingSessionOptions options,
                  Writer writer);
  ~TrackingSession();  // Cancel()
  TrackingSession(const TrackingSession&) = delete;
  TrackingSession& operator=(const TrackingSession&) = delete;

  // Queues a frame without blocking. False once the session has stopped.
  bool Push(v1::Frame frame);
  // Queues an error result (a message that is not a frame), in order with the frames.
  void PushError(uint64_t frame_index, std::string message);
  // No more frames: processes what is queued, then stops. Blocks until done.
  void Finish();
  // Stops now, discarding queued frames. Blocks until the threads have stopped.
  void Cancel();

  TrackingSessionStats stats() const;

 private:
  struct Pending {
    v1::Frame frame;
    SteadyClock::time_point arrived;
    std::string error;  // set: answer with this error, do not decode
  };
  struct Extracted {
    uint64_t frame_index = 0;
    int64_t timestamp_us = 0;
    SteadyClock::time_point arrived;
    std::string error;
    WordKeypoints keypoints;
    bool whole_frame = true;  // false: only the predicted pages were extracted
    uint64_t sequence = 0;    // frames handed to the tracker before this one, plus one
    cv::Size size;
    double decode_ms = 0, extract_ms = 0;
  };

  void ExtractLoop();
  void MatchLoop();
  Extracted Extract(Pending pending);  // stage 1 only
  v1::TrackResponse Respond(const Extracted& frame, const TrackerFrameResult* tracked);
  void Stop(bool drain);

  const DocumentRegistry* registry_;
  const TrackingSessionOptions options_;
  const Writer writer_;
  VideoKeypointExtractor extractor_;  // stage 1 only
  DocumentTracker tracker_;  // stage 2 only
  // Annotations of the followed pages (stage 2 only), fetched when a page is found.
  std::unordered_map<uint32_t, std::vector<AnnotationRecord>> annotations_;

  mutable std::mutex mutex_;
  std::condition_variable input_cv_;  // input_ has frames, or stopping
  std::condition_variable stage_cv_;  // stage_ changed, or stopping
  std::deque<Pending> input_;
  std::deque<Extracted> stage_;       // at most one frame between the stages
  std::vector<uint64_t> dropped_;     // since the last result
  // The tracker's prediction for the frames after the last one tracked (stage 2 writes,
  // stage 1 reads): where the pages will be 1 and 2 frames later, for the rectified
  // extraction of pages seen at a slant.
  uint64_t tracked_sequence_ = 0;
  std::vector<PageInView> predicted_[2];
  uint64_t extracted_sequence_ = 0;  // stage 1 only
  bool finishing_ = false;            // no more input; drain
  bool cancelled_ = false;            // stop now
  bool extract_done_ = false;
  TrackingSessionStats stats_;

  std::thread extract_thread_;
  std::thread match_thread_;
};

// Calls `on_idle` once when Touch() has not been called for `timeout`. Thread-safe.
class IdleWatchdog {
 public:
  IdleWatchdog(std::chrono::milliseconds timeout, std::function<void()> on_idle);
  ~IdleWatchdog();
  IdleWatchdog(const IdleWatchdog&) = delete;
  IdleWatchdog& operator=(const IdleWatchdog&) = delete;

  void Touch();
  bool fired() const;

 private:
  const std::chrono::milliseconds timeout_;
  const std::function<void()> on_idle_;
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  SteadyClock::time_point last_;
  bool stop_ = false, fired_ = false;
  std::thread thread_;
};

}  // namespace texfree::server
