// TrackingSession: the two-stage pipeline of one tracking stream, and IdleWatchdog.
#include "server/tracking_session.h"

#include <exception>
#include <utility>

#include <spdlog/spdlog.h>

#include "absl/strings/str_cat.h"
#include "common/status_macros.h"
#include "server/proto_convert.h"

namespace texfree::server {
namespace {

v1::TrackedTarget::State StateToProto(TrackState state) {
  switch (state) {
    case TrackState::kInitializing:
      return v1::TrackedTarget::INITIALIZING;
    case TrackState::kTracking:
      return v1::TrackedTarget::TRACKING;
    case TrackState::kLost:
      return v1::TrackedTarget::LOST;
  }
  return v1::TrackedTarget::LOST;
}

void AddTiming(v1::TrackResponse* r, const char* stage, double ms) {
  auto* t = r->add_timings();
  t->set_stage(stage);
  t->set_ms(ms);
}

}  // namespace

absl::Status TrackingSessionOptions::Validate() const {
  if (queue_frames < 1 || queue_frames > 64)
    return absl::InvalidArgumentError(absl::StrCat("queue_frames must be in [1, 64], got ", queue_frames));
  if (max_frame_age_ms < 1 || max_frame_age_ms > 60'000)
    return absl::InvalidArgumentError(
        absl::StrCat("max_frame_age_ms must be in [1, 60000], got ", max_frame_age_ms));
  RETURN_IF_ERROR(limits.Validate());
  RETURN_IF_ERROR(tracker.Validate());
  RETURN_IF_ERROR(keypoints.Validate());
  if (camera) RETURN_IF_ERROR(camera->Validate());
  return absl::OkStatus();
}

TrackingSession::TrackingSession(const DocumentRegistry* registry,
                                 TrackingSessionOptions options, Writer writer)
    : registry_(registry),
      options_(std::move(options)),
      writer_(std::move(writer)),
      extractor_(registry->options().tracking_keypoints, options_.keypoints),
      tracker_(options_.tracker, options_.camera) {
  extract_thread_ = std::thread([this] { ExtractLoop(); });
  match_thread_ = std::thread([this] { MatchLoop(); });
}

TrackingSession::~TrackingSession() { Cancel(); }

bool TrackingSession::Push(v1::Frame frame) {
  {
    std::lock_guard lock(mutex_);
    if (cancelled_ || finishing_) return false;
    ++stats_.frames;
    if (static_cast<int>(input_.size()) >= options_.queue_frames) {
      dropped_.push_back(input_.front().frame.frame_index());
      input_.pop_front();
      ++stats_.dropped;
    }
    input_.push_back({std::move(frame), SteadyClock::now(), {}});
  }
  input_cv_.notify_one();
  return true;
}

void TrackingSession::PushError(uint64_t frame_index, std::string message) {
  v1::Frame frame;
  frame.set_frame_index(frame_index);
  {
    std::lock_guard lock(mutex_);
    if (cancelled_ || finishing_) return;
    input_.push_back({std::move(frame), SteadyClock::now(), std::move(message)});
  }
  input_cv_.notify_one();
}

void TrackingSession::Finish() { Stop(/*drain=*/true); }
void TrackingSession::Cancel() { Stop(/*drain=*/false); }

void TrackingSession::Stop(bool drain) {
  {
    std::lock_guard lock(mutex_);
    if (drain)
      finishing_ = true;
    else
      cancelled_ = true;
  }
  input_cv_.notify_all();
  stage_cv_.notify_all();
  if (extract_thread_.joinable()) extract_thread_.join();
  if (match_thread_.joinable()) match_thread_.join();
}

TrackingSessionStats TrackingSession::stats() const {
  std::lock_guard lock(mutex_);
  return stats_;
}

TrackingSession::Extracted TrackingSession::Extract(Pending pending) {
  Extracted e;
  e.frame_index = pending.frame.frame_index();
  e.timestamp_us = pending.frame.timestamp_us();
  e.arrived = pending.arrived;
  e.error = std::move(pending.error);
  if (!e.error.empty()) return e;
  auto t = SteadyClock::now();
  auto gray = ImageFromProto(pending.frame.image(), options_.limits);
  e.decode_ms = MillisecondsSince(t);
  if (!gray.ok()) {
    e.error = absl::StrCat("frame ", e.frame_index, ": ", gray.status().message());
    return e;
  }
  e.size = gray->size();
  if (options_.camera && options_.camera->size.area() > 0 && e.size != options_.camera->size) {
    e.error = absl::StrCat("frame ", e.frame_index, " is ", e.size.width, "x", e.size.height,
                           " but the intrinsics are for ", options_.camera->size.width, "x",
                           options_.camera->size.height, " images");
    return e;
  }
  // Stage 2 is one frame behind while busy: the prediction is for 1 or 2 frames ahead.
  e.sequence = ++extracted_sequence_;
  std::vector<PageInView> pages;
  {
    std::lock_guard lock(mutex_);
    const uint64_t ahead = e.sequence - tracked_sequence_;
    if (ahead == 1 || ahead == 2) pages = predicted_[ahead - 1];
  }
  t = SteadyClock::now();
  try {
    VideoFrameInfo info;
    e.keypoints = extractor_.Extract(*gray, pages, &info);
    e.whole_frame = info.whole_frame;
  } catch (const std::exception& ex) {  // OpenCV throws cv::Exception
    e.error = absl::StrCat("frame ", e.frame_index, ": keypoint extraction failed: ", ex.what());
  }
  e.extract_ms = MillisecondsSince(t);
  return e;
}

void TrackingSession::ExtractLoop() {
  while (true) {
    Pending pending;
    {
      std::unique_lock lock(mutex_);
      input_cv_.wait(lock, [&] { return cancelled_ || finishing_ || !input_.empty(); });
      if (cancelled_ || input_.empty()) break;
      // The oldest waiting frame is stale: the stream has fallen behind for longer than a
      // burst, so it skips to the newest frame, dropping those in between (error results
      // are kept: every bad frame is answered).
      const auto stale_before =
          SteadyClock::now() - std::chrono::milliseconds(options_.max_frame_age_ms);
      if (input_.size() > 1 && input_.front().arrived < stale_before) {
        std::deque<Pending> kept;
        for (size_t i = 0; i + 1 < input_.size(); ++i) {
          if (!input_[i].error.empty()) {
            kept.push_back(std::move(input_[i]));
            continue;
          }
          dropped_.push_back(input_[i].frame.frame_index());
          ++stats_.dropped;
        }
        kept.push_back(std::move(input_.back()));
        input_ = std::move(kept);
      }
      pending = std::move(input_.front());
      input_.pop_front();
    }
    Extracted e = Extract(std::move(pending));
    {
      std::unique_lock lock(mutex_);
      stage_cv_.wait(lock, [&] { return cancelled_ || stage_.empty(); });
      if (cancelled_) break;
      stage_.push_back(std::move(e));
    }
    stage_cv_.notify_all();
  }
  {
    std::lock_guard lock(mutex_);
    extract_done_ = true;
  }
  stage_cv_.notify_all();
}

void TrackingSession::MatchLoop() {
  while (true) {
    Extracted e;
    {
      std::unique_lock lock(mutex_);
      stage_cv_.wait(lock, [&] { return cancelled_ || !stage_.empty() || extract_done_; });
      if (cancelled_ || stage_.empty()) break;
      e = std::move(stage_.front());
      stage_.pop_front();
    }
    stage_cv_.notify_all();  // room for the next frame of stage 1
    TrackerFrameResult tracked;
    if (e.error.empty()) {
      try {
        tracked = tracker_.Track(e.keypoints, e.size, registry_->retriever(), e.whole_frame);
        std::vector<PageInView> next = tracker_.PredictedPages(1);
        std::vector<PageInView> after = tracker_.PredictedPages(2);
        std::lock_guard lock(mutex_);
        tracked_sequence_ = e.sequence;
        predicted_[0] = std::move(next);
        predicted_[1] = std::move(after);
      } catch (const std::exception& ex) {
        spdlog::error("tracking frame {}: {}", e.frame_index, ex.what());
        e.error = absl::StrCat("frame ", e.frame_index, ": internal error while tracking");
        tracker_.Reset();
      }
    }
    const v1::TrackResponse response = Respond(e, e.error.empty() ? &tracked : nullptr);
    const bool written = writer_(response);
    {
      std::lock_guard lock(mutex_);
      ++stats_.results;
      if (!e.error.empty()) ++stats_.errors;
      stats_.server_ms += response.server_ms();
      if (!written) cancelled_ = true;  // the client is gone
    }
    if (!written) {
      input_cv_.notify_all();
      stage_cv_.notify_all();
      break;
    }
  }
}

v1::TrackResponse TrackingSession::Respond(const Extracted& f, const TrackerFrameResult* tracked) {
  v1::TrackResponse r;
  r.set_frame_index(f.frame_index);
  r.set_timestamp_us(f.timestamp_us);
  {
    std::lock_guard lock(mutex_);
    r.set_dropped_frames(static_cast<uint32_t>(dropped_.size()));
    for (uint64_t i : dropped_) r.add_dropped_frame_indices(i);
    dropped_.clear();
  }
  double server_ms = f.decode_ms + f.extract_ms;
  AddTiming(&r, "decode", f.decode_ms);
  AddTiming(&r, "extract", f.extract_ms);
  if (!f.error.empty()) {
    r.set_error(f.error);
  } else if (tracked) {
    r.set_keypoints(static_cast<uint32_t>(f.keypoints.points.size()));
    AddTiming(&r, "match", tracked->timings.match_ms);
    AddTiming(&r, "pose", tracked->timings.pose_ms);
    AddTiming(&r, "update", tracked->timings.update_ms);
    server_ms += tracked->timings.match_ms + tracked->timings.pose_ms + tracked->timings.update_ms;
    for (const TrackedDocument& doc : tracked->documents) {
      const auto summary = registry_->FindByIndexId(doc.document);
      if (!summary) continue;  // deleted meanwhile
      auto* t = r.add_targets();
      t->set_kind(v1::TrackedTarget::DOCUMENT);
      t->set_id(summary->id);
      t->set_title(summary->title);
      t->set_width(summary->size.width);
      t->set_height(summary->size.height);
      t->set_state(StateToProto(doc.state));
      t->set_inliers(doc.inliers);
      t->set_llah_inliers(doc.llah_inliers);
      t->set_learned_entries(static_cast<uint32_t>(doc.learned_entries));
      t->set_learned_this_frame(doc.learned);
      t->set_method(doc.method);
      if (doc.state == TrackState::kLost) continue;
      HomographyToProto(doc.homography, t->mutable_homography());
      OutlineToProto(doc.homography, summary->size, t->mutable_outline());
      if (doc.pose) PoseToProto(*doc.pose, t->mutable_pose());
      auto cached = annotations_.find(doc.document);
      if (cached == annotations_.end() || doc.state == TrackState::kInitializing) {
        auto annotations = registry_->AnnotationsByIndexId(doc.document);
        if (!annotations.ok()) {
          spdlog::warn("tracking: annotations of {}: {}", summary->id,
                       annotations.status().ToString());
          annotations = std::vector<AnnotationRecord>{};
        }
        cached = annotations_.insert_or_assign(doc.document, std::move(*annotations)).first;
      }
      for (const AnnotationRecord& a : cached->second)
        MappedAnnotationToProto(a, doc.homography, t->add_annotations());
      PageOverlaysToProto(doc.homography, summary->size, cached->second, t->mutable_overlays());
    }
  }
  r.set_server_ms(server_ms);
  r.set_latency_ms(MillisecondsSince(f.arrived));
  return r;
}

IdleWatchdog::IdleWatchdog(std::chrono::milliseconds timeout, std::function<void()> on_idle)
    : timeout_(timeout), on_idle_(std::move(on_idle)), last_(SteadyClock::now()) {
  thread_ = std::thread([this] {
    std::unique_lock lock(mutex_);
    while (!stop_) {
      const auto deadline = last_ + timeout_;
      if (SteadyClock::now() >= deadline) {
        fired_ = true;
        lock.unlock();
        on_idle_();
        return;
      }
      cv_.wait_until(lock, deadline);
    }
  });
}

IdleWatchdog::~IdleWatchdog() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  cv_.notify_all();
  thread_.join();
}

void IdleWatchdog::Touch() {
  std::lock_guard lock(mutex_);
  last_ = SteadyClock::now();
}

bool IdleWatchdog::fired() const {
  std::lock_guard lock(mutex_);
  return fired_;
}

}  // namespace texfree::server
