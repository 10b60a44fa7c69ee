// DocumentTracker: keypoint tracking of printed pages with on-line geometric feature
// learning (seed 3.1), for one camera stream, several pages at once (seed 5.2.2).
//
// Per frame (word keypoints of the frame in, one result per followed page out):
//   1. Initialisation by retrieval: LLAH over the shared document index (LlahRetriever)
//      finds pages not followed yet, on every frame while nothing is followed and every
//      `retrieval_interval` frames otherwise (on the keypoints off the text areas of the
//      pages tracked on this frame: a page filling the view leaves it nothing to do).
//   2. Prediction: the page's previous homography, moved on by the last inter-frame
//      motion, projects the reference keypoints into the frame; a frame keypoint that is
//      the mutual nearest neighbour of a projected one within a search radius is a
//      candidate correspondence ("matching by projection", cheap and valid at any tilt).
//      Reference keypoints the prediction squeezes together (lines below the camera's
//      resolution at grazing tilt) are left out: the blobs there match none of them.
//   3. LLAH matching against the session index (the page's reference descriptors plus
//      what this session learned) gives correspondences that do not depend on the
//      prediction: they re-find a page after fast motion or a loss, and their count is
//      the seed's measure of how well the index knows the current view.
//   4. Pose: RANSAC homography, then two rounds of guided refinement (project with the
//      estimate, match mutual nearest neighbours within the inlier threshold, refit);
//      with intrinsics, the planar pose (IPPE + LM, honouring distortion).
//   5. Sanity: a homography that mirrors the page, puts seen points behind the camera,
//      has an absurd scale, or jumps further from the prediction than a hand moves in
//      one frame without strong LLAH evidence is not drawn: the page is LOST this frame.
//   6. Index update (on-line learning, seed 3.1.4) by the update policy: the frame
//      keypoints matched by projection add their freshly computed LLAH hashes to the
//      session index under the reference keypoint's id where the slot is empty for it.
//
// The shared index is only read. Learned entries stay in this tracker's SessionIndex.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "absl/status/status.h"
#include "common/llah_retriever.h"
#include "common/planar_pose.h"
#include "common/session_index.h"
#include "common/video_keypoints.h"
#include "common/word_keypoints.h"

namespace texfree {

enum class TrackState {
  kInitializing,  // found by retrieval on this frame (pose from the shared index alone)
  kTracking,      // pose from tracking
  kLost,          // followed, but no trustworthy pose on this frame
};
const char* TrackStateName(TrackState state);

enum class UpdatePolicy {
  kBelowThreshold,  // learn when LLAH inliers < update_inlier_threshold (seed: 20 or 40)
  kEveryFrame,
  kNever,
};

struct TrackerOptions {
  UpdatePolicy update_policy = UpdatePolicy::kBelowThreshold;
  // kBelowThreshold learns on frames whose LLAH inliers fall under this.
  int update_inlier_threshold = 40;
  // Session index size and learned-entry budget (shared by the followed pages).
  SessionIndexOptions session;

  // Matching by projection from the predicted homography (step 2). Off: LLAH alone, as
  // the seed's experiment.
  bool predict = true;
  // While projection keeps the page, LLAH matching runs every `llah_interval` frames
  // (1 = every frame, as the seed). It always runs when projection fails.
  int llah_interval = 1;
  // First projection round: search radius in character heights of the frame, clamped.
  double search_radius_chars = 1.2;
  double min_search_radius_px = 6;
  double max_search_radius_px = 40;
  // Inlier distance: this many character heights, clamped to [min, max] pixels.
  double inlier_chars = 0.45;
  double min_inlier_px = 2.5;
  double max_inlier_px = 12;
  // Matching by projection skips a reference keypoint that the prediction puts closer
  // than this many inlier distances to another one (lines squeezed below the camera's
  // resolution at grazing tilt). 0: never.
  double min_separation_inliers = 2.0;
  int ransac_iterations = 1000;
  // A pose needs this many correspondences agreeing with one homography.
  int min_inliers = 12;
  // Descriptors with more session-index entries than this do not vote.
  int max_hits_per_descriptor = 8;
  // A pose found by projection is trusted when this many LLAH correspondences agree with
  // it, or else when it matches at least min_match_ratio of the reference keypoints it
  // puts in the image with a mean residual under max_mean_residual inlier distances
  // (chance alignments with other text score about 0.15 and 0.5).
  int min_llah_confirm = 4;
  double min_match_ratio = 0.4;
  double max_mean_residual = 0.35;

  // Plausibility: the page's seen points may move at most this fraction of the image
  // diagonal away from the prediction between two frames ...
  double max_jump_fraction = 0.25;
  // ... unless this many LLAH correspondences agree with the new pose.
  int reacquire_min_llah_inliers = 20;
  // With intrinsics: largest plausible rotation between two consecutive frames.
  double max_rotation_jump_deg = 40;

  // Retrieval of pages not followed yet, every this many frames while following some.
  int retrieval_interval = 10;
  // This stream retrieves that many frames earlier in the cycle (modulo
  // retrieval_interval), so that streams started together do not all retrieve on the
  // same frame (see VideoKeypointOptions::measure_phase).
  int retrieval_phase = 0;
  // The few-keypoint pass is off: a frame's free keypoints are often few (the followed pages
  // hold the rest), and a page missed now is retrieved a few frames later.
  RetrievalOptions retrieval = [] {
    RetrievalOptions o;
    o.deep_max_keypoints = 0;
    return o;
  }();
  // Pages followed at once.
  int max_documents = 8;
  // A page LOST for this many consecutive frames is forgotten (with what was learned).
  int forget_after_frames = 90;

  absl::Status Validate() const;
};

// One followed page on one frame.
struct TrackedDocument {
  uint32_t document = 0;  // registry index id
  TrackState state = TrackState::kLost;
  // Registration-image pixels -> frame pixels; valid unless state == kLost. Scaled so
  // that w > 0 in front of the camera.
  cv::Matx33d homography = cv::Matx33d::eye();
  std::optional<PlanarPose> pose;  // with intrinsics, unless lost
  int inliers = 0;                 // correspondences agreeing with the homography
  // Those correspondences: (frame keypoint index, reference keypoint index).
  std::vector<std::pair<int, int>> matches;
  int llah_inliers = -1;           // LLAH correspondences among them; -1: LLAH not run
  int learned = 0;                 // entries added to the session index on this frame
  size_t learned_entries = 0;      // entries learned for this page so far (kept)
  std::string method;              // "retrieval", "projection", "llah", "" when lost
};

struct TrackerTimings {
  double match_ms = 0;   // description, LLAH, projection matching, retrieval, RANSAC
  double pose_ms = 0;    // refinement and planar pose
  double update_ms = 0;  // on-line learning
};

struct TrackerFrameResult {
  std::vector<TrackedDocument> documents;  // every followed page, LOST ones included
  TrackerTimings timings;
  bool retrieved = false;  // retrieval over the shared index ran on this frame
};

// Not thread-safe: one tracker per stream, fed frames in order by one thread at a time.
class DocumentTracker {
 public:
  explicit DocumentTracker(TrackerOptions options, std::optional<CameraModel> camera = {});
  ~DocumentTracker();
  DocumentTracker(const DocumentTracker&) = delete;
  DocumentTracker& operator=(const DocumentTracker&) = delete;

  // Tracks the pages in one frame. `shared` is the registry's index (null while nothing
  // is registered); the tracker keeps it alive while it follows its pages. `whole_frame`
  // false: the keypoints cover only the pages tracked (VideoKeypointExtractor's rectified
  // extraction), so retrieval of further pages waits for a frame that covers it all.
  TrackerFrameResult Track(const WordKeypoints& frame, const cv::Size& image_size,
                           std::shared_ptr<const LlahRetriever> shared,
                           bool whole_frame = true);

  // Forgets every page and everything learned.
  void Reset();

  // Where the pages tracked on the last frame are expected `frames_ahead` frames after it
  // (the last homography moved on by the last inter-frame motion), with their text areas:
  // for VideoKeypointExtractor's rectified extraction. Pages lost on the last frame are
  // left out; nothing without options().predict.
  std::vector<PageInView> PredictedPages(int frames_ahead = 1) const;

  const TrackerOptions& options() const { return options_; }
  const SessionIndex& session_index() const { return session_; }
  size_t followed_documents() const;

 private:
  struct Followed;
  struct Frame;

  void Follow(uint32_t document, const DocumentHit& hit, Frame& frame,
              TrackerFrameResult& result);
  TrackedDocument TrackOne(Followed& doc, Frame& frame, TrackerTimings& timings);
  // LLAH correspondences of the page in the frame from the session index: per free frame
  // keypoint, the reference keypoint most of its descriptors hit (`strong`: two or more).
  void MatchLlah(const Followed& doc, Frame& frame, std::vector<std::pair<int, int>>* all,
                 std::vector<std::pair<int, int>>* strong) const;
  void Learn(Followed& doc, Frame& frame, const std::vector<std::pair<int, int>>& matches,
             TrackedDocument& out);
  bool ShouldLearn(int llah_inliers) const;

  TrackerOptions options_;
  std::optional<CameraModel> camera_;
  std::shared_ptr<const LlahRetriever> shared_;
  SessionIndex session_;
  std::vector<std::unique_ptr<Followed>> followed_;
  uint64_t frame_count_ = 0;
  uint64_t next_retrieval_ = 0;  // frame_count_ at which retrieval is next due
};

}  // namespace texfree
