// DocumentTracker implementation: prediction, matching by projection, LLAH against the
// session index, RANSAC + guided refinement, plausibility, on-line learning.
#include "common/document_tracker.h"

#include <algorithm>
#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <utility>

#include "absl/strings/str_cat.h"
#include "common/neighbor_grid.h"
#include "common/status_macros.h"
#include "common/timing.h"

namespace texfree {
namespace {

using Pairs = std::vector<std::pair<int, int>>;  // (frame keypoint, reference keypoint)

constexpr double kPi = 3.14159265358979323846;

// w of a homography at a point (the depth up to a positive scale once normalised).
double W(const cv::Matx33d& H, const cv::Point2d& p) {
  return H(2, 0) * p.x + H(2, 1) * p.y + H(2, 2);
}

bool Finite(const cv::Matx33d& H) {
  for (double v : H.val)
    if (!std::isfinite(v)) return false;
  return true;
}

cv::Point2d Centroid(const std::vector<cv::Point2f>& points) {
  cv::Point2d c(0, 0);
  for (const auto& p : points) c += cv::Point2d(p.x, p.y);
  return points.empty() ? c : c * (1.0 / points.size());
}

// Scales H so that w = 1 at `inside` (a page point the camera sees): then w > 0 for
// every point in front of the camera. False when `inside` is at or behind the horizon.
bool NormaliseInFront(cv::Matx33d& H, const cv::Point2d& inside) {
  const double w = W(H, inside);
  if (!Finite(H) || std::abs(w) < 1e-12) return false;
  H *= 1.0 / w;
  return true;
}

double RotationAngleDeg(const cv::Matx33d& a, const cv::Matx33d& b) {
  const cv::Matx33d d = a * b.t();
  const double c = std::clamp((cv::trace(d) - 1) / 2, -1.0, 1.0);
  return std::acos(c) * 180 / kPi;
}

}  // namespace

const char* TrackStateName(TrackState state) {
  switch (state) {
    case TrackState::kInitializing:
      return "INITIALIZING";
    case TrackState::kTracking:
      return "TRACKING";
    case TrackState::kLost:
      return "LOST";
  }
  return "LOST";
}

absl::Status TrackerOptions::Validate() const {
  RETURN_IF_ERROR(session.Validate());
  RETURN_IF_ERROR(retrieval.Validate());
  if (update_inlier_threshold < 0 || update_inlier_threshold > 100000)
    return absl::InvalidArgumentError(absl::StrCat(
        "update_inlier_threshold must be in [0, 100000], got ", update_inlier_threshold));
  if (llah_interval < 1)
    return absl::InvalidArgumentError(
        absl::StrCat("llah_interval must be >= 1, got ", llah_interval));
  if (!(search_radius_chars > 0) || !(min_search_radius_px > 0) ||
      !(max_search_radius_px >= min_search_radius_px))
    return absl::InvalidArgumentError(
        "search radius: search_radius_chars and min_search_radius_px must be > 0 and "
        "max_search_radius_px >= min_search_radius_px");
  if (!(inlier_chars > 0) || !(min_inlier_px > 0) || !(max_inlier_px >= min_inlier_px))
    return absl::InvalidArgumentError(
        "inlier distance: inlier_chars and min_inlier_px must be > 0 and "
        "max_inlier_px >= min_inlier_px");
  if (!(min_separation_inliers >= 0) || min_separation_inliers > 10)
    return absl::InvalidArgumentError(absl::StrCat(
        "min_separation_inliers must be in [0, 10], got ", min_separation_inliers));
  if (ransac_iterations < 10)
    return absl::InvalidArgumentError(
        absl::StrCat("ransac_iterations must be >= 10, got ", ransac_iterations));
  if (min_inliers < 6)
    return absl::InvalidArgumentError(absl::StrCat(
        "min_inliers must be >= 6 (a homography has 4 points of freedom), got ", min_inliers));
  if (max_hits_per_descriptor < 1)
    return absl::InvalidArgumentError("max_hits_per_descriptor must be >= 1");
  if (min_llah_confirm < 1) return absl::InvalidArgumentError("min_llah_confirm must be >= 1");
  if (!(min_match_ratio >= 0 && min_match_ratio <= 1))
    return absl::InvalidArgumentError("min_match_ratio must be in [0, 1]");
  if (!(max_mean_residual > 0 && max_mean_residual <= 1))
    return absl::InvalidArgumentError("max_mean_residual must be in (0, 1]");
  if (!(max_jump_fraction > 0)) return absl::InvalidArgumentError("max_jump_fraction must be > 0");
  if (reacquire_min_llah_inliers < min_inliers)
    return absl::InvalidArgumentError("reacquire_min_llah_inliers must be >= min_inliers");
  if (!(max_rotation_jump_deg > 0) || max_rotation_jump_deg > 180)
    return absl::InvalidArgumentError("max_rotation_jump_deg must be in (0, 180]");
  if (retrieval_interval < 1) return absl::InvalidArgumentError("retrieval_interval must be >= 1");
  if (retrieval_phase < 0)
    return absl::InvalidArgumentError(
        absl::StrCat("retrieval_phase must be >= 0, got ", retrieval_phase));
  if (max_documents < 1 || max_documents > 64)
    return absl::InvalidArgumentError(
        absl::StrCat("max_documents must be in [1, 64], got ", max_documents));
  if (forget_after_frames < 1)
    return absl::InvalidArgumentError("forget_after_frames must be >= 1");
  return absl::OkStatus();
}

// A page the tracker follows.
struct DocumentTracker::Followed {
  uint32_t id = 0;
  std::vector<cv::Point2f> reference;  // registration-image keypoints
  std::vector<cv::Point2f> hull;       // their convex hull (the page's text area)
  TrackState state = TrackState::kInitializing;
  bool has_homography = false;
  cv::Matx33d homography = cv::Matx33d::eye();  // last accepted
  cv::Matx33d motion = cv::Matx33d::eye();      // last inter-frame image motion
  cv::Point2d seen_centroid;                    // reference points seen last
  bool has_motion = false;
  std::optional<PlanarPose> pose;
  uint64_t last_seen = 0;  // frame of the last accepted pose
  uint64_t last_llah = 0;  // frame of the last LLAH matching
  int lost_frames = 0;
};

// One frame's keypoints with lazily computed LLAH hashes.
struct DocumentTracker::Frame {
  Frame(const WordKeypoints& kp, const cv::Size& image_size, const LlahDescriber& describer,
        const TrackerOptions& o)
      : points(kp.points),
        size(image_size),
        describer(describer),
        per(describer.descriptors_per_point()),
        described(kp.points.size(), 0),
        used(kp.points.size(), 0),
        grid(kp.points) {
    const double ch = kp.char_height > 0 ? kp.char_height : 10.0;
    inlier_px = std::clamp(o.inlier_chars * ch, o.min_inlier_px, o.max_inlier_px);
    search_px =
        std::clamp(o.search_radius_chars * ch, o.min_search_radius_px, o.max_search_radius_px);
    char_height = kp.char_height;
    separation_px = o.min_separation_inliers * inlier_px;
  }

  void EnsureHashes(const std::vector<int>& which) {
    std::vector<int> todo;
    for (int i : which)
      if (!described[i]) todo.push_back(i);
    if (todo.empty()) return;
    describer.DescribeSubset(points, todo, &hashes);
    for (int i : todo) described[i] = 1;
  }

  const std::vector<cv::Point2f>& points;
  cv::Size size;
  const LlahDescriber& describer;
  int per;
  std::vector<uint64_t> hashes;
  std::vector<char> described;
  std::vector<char> used;  // claimed by a page on this frame
  NeighborGrid grid;
  double inlier_px = 4, search_px = 10, char_height = 0, separation_px = 0;
};

namespace {

// Matching by projection: each reference keypoint projected by H takes its nearest frame
// keypoint within `radius` (and, with ratio > 0, clearly nearer than the second nearest);
// a frame keypoint chosen by several keeps the closest. Claimed keypoints are skipped.
// A reference keypoint whose projection lies closer than `min_separation` to another
// projected reference keypoint is skipped too: at grazing tilt the page's lines are
// squeezed below what the camera resolves, and a frame keypoint there (a blob of merged
// lines) cannot say which of them it is.
Pairs ProjectionMatch(const cv::Matx33d& H, const std::vector<cv::Point2f>& reference,
                      const std::vector<cv::Point2f>& points, const NeighborGrid& grid,
                      const std::vector<char>& used, const cv::Size& size, double radius,
                      double ratio, double min_separation) {
  Pairs out;
  if (points.empty()) return out;
  const double margin = radius;
  std::vector<int> in_view;
  std::vector<cv::Point2f> projected;
  for (int r = 0; r < static_cast<int>(reference.size()); ++r) {
    const cv::Point2d ref(reference[r].x, reference[r].y);
    if (W(H, ref) <= 1e-9) continue;
    const cv::Point2d p = ApplyHomography(H, ref);
    if (!(p.x >= -margin && p.y >= -margin && p.x < size.width + margin &&
          p.y < size.height + margin))
      continue;
    in_view.push_back(r);
    projected.emplace_back(static_cast<float>(p.x), static_cast<float>(p.y));
  }
  std::vector<char> separated(projected.size(), 1);
  std::vector<int> nearest;
  if (min_separation > 0 && projected.size() > 1) {
    const NeighborGrid projected_grid(projected);
    for (int i = 0; i < static_cast<int>(projected.size()); ++i) {
      projected_grid.Nearest(i, 1, &nearest);
      if (!nearest.empty() && cv::norm(projected[nearest[0]] - projected[i]) < min_separation)
        separated[i] = 0;
    }
  }
  std::vector<int> owner(points.size(), -1);
  std::vector<float> owner_d(points.size(), 0.f);
  for (size_t i = 0; i < projected.size(); ++i) {
    if (!separated[i]) continue;
    const int r = in_view[i];
    const cv::Point2d p(projected[i].x, projected[i].y);
    grid.NearestTo(projected[i], ratio > 0 ? 2 : 1, -1, &nearest);
    if (nearest.empty() || used[nearest[0]]) continue;
    const double d1 = cv::norm(cv::Point2d(points[nearest[0]]) - p);
    if (d1 > radius) continue;
    if (ratio > 0 && nearest.size() > 1) {
      const double d2 = cv::norm(cv::Point2d(points[nearest[1]]) - p);
      if (d1 > ratio * d2) continue;
    }
    const int q = nearest[0];
    if (owner[q] < 0 || d1 < owner_d[q]) {
      owner[q] = r;
      owner_d[q] = static_cast<float>(d1);
    }
  }
  for (int q = 0; q < static_cast<int>(points.size()); ++q)
    if (owner[q] >= 0) out.emplace_back(q, owner[q]);
  return out;
}

struct Fit {
  bool ok = false;
  cv::Matx33d H = cv::Matx33d::eye();
  Pairs inliers;
};

Pairs InliersOf(const cv::Matx33d& H, const Pairs& pairs, const std::vector<cv::Point2f>& ref,
                const std::vector<cv::Point2f>& points, double threshold) {
  Pairs out;
  for (const auto& [q, r] : pairs) {
    if (cv::norm(ApplyHomography(H, ref[r]) - cv::Point2d(points[q])) <= threshold)
      out.emplace_back(q, r);
  }
  return out;
}

// RANSAC homography over the pairs (the `sample` subset when it is large enough), then
// the inliers among all pairs.
Fit RansacFit(const Pairs& pairs, const Pairs& sample, const std::vector<cv::Point2f>& ref,
              const std::vector<cv::Point2f>& points, double threshold, int iterations,
              int min_inliers) {
  Fit fit;
  if (static_cast<int>(pairs.size()) < min_inliers) return fit;
  const Pairs& use = sample.size() >= 10 ? sample : pairs;
  std::vector<cv::Point2f> src, dst;
  for (const auto& [q, r] : use) {
    src.push_back(ref[r]);
    dst.push_back(points[q]);
  }
  cv::Mat Hm;
  try {
    Hm = cv::findHomography(src, dst, cv::RANSAC, threshold, cv::noArray(), iterations, 0.995);
  } catch (const cv::Exception&) {
    return fit;
  }
  if (Hm.empty()) return fit;
  fit.H = cv::Matx33d(Hm);
  fit.inliers = InliersOf(fit.H, pairs, ref, points, threshold);
  if (static_cast<int>(fit.inliers.size()) < min_inliers) return fit;
  std::vector<cv::Point2f> seen;
  for (const auto& [q, r] : fit.inliers) seen.push_back(ref[r]);
  if (!NormaliseInFront(fit.H, Centroid(seen)) || !MakePlausibleHomography(&fit.H, seen))
    return fit;
  fit.ok = true;
  return fit;
}

// Guided refinement: project with the estimate, match mutual nearest neighbours within
// the inlier distance, refit; keep the estimate when a round does not improve it.
template <typename FrameT>
Fit Refine(Fit fit, const std::vector<cv::Point2f>& ref, const FrameT& frame, int min_inliers) {
  for (int round = 0; round < 2; ++round) {
    const Pairs guided = ProjectionMatch(fit.H, ref, frame.points, frame.grid, frame.used,
                                         frame.size, frame.inlier_px, 0, frame.separation_px);
    if (guided.size() < fit.inliers.size()) break;
    Fit refined = RansacFit(guided, {}, ref, frame.points, frame.inlier_px, 100, min_inliers);
    if (!refined.ok || refined.inliers.size() < fit.inliers.size()) break;
    fit = std::move(refined);
  }
  return fit;
}

// How well a pose explains the frame: the share of reference keypoints it puts in the
// image that found a frame keypoint, and their mean distance.
struct Evidence {
  double match_ratio = 0;
  double mean_residual = 1e9;
};

template <typename FrameT>
Evidence Measure(const Fit& fit, const std::vector<cv::Point2f>& ref, const FrameT& frame) {
  Evidence e;
  int visible = 0;
  for (const auto& r : ref) {
    if (W(fit.H, r) <= 1e-9) continue;
    const cv::Point2d p = ApplyHomography(fit.H, r);
    if (p.x >= 0 && p.y >= 0 && p.x < frame.size.width && p.y < frame.size.height) ++visible;
  }
  if (visible == 0 || fit.inliers.empty()) return e;
  double sum = 0;
  for (const auto& [q, r] : fit.inliers)
    sum += cv::norm(ApplyHomography(fit.H, ref[r]) - cv::Point2d(frame.points[q]));
  e.match_ratio = static_cast<double>(fit.inliers.size()) / visible;
  e.mean_residual = sum / fit.inliers.size();
  return e;
}

}  // namespace

DocumentTracker::DocumentTracker(TrackerOptions options, std::optional<CameraModel> camera)
    : options_(std::move(options)), camera_(std::move(camera)), session_(options_.session) {}

DocumentTracker::~DocumentTracker() = default;

void DocumentTracker::Reset() {
  followed_.clear();
  session_ = SessionIndex(options_.session);
  frame_count_ = 0;
  next_retrieval_ = 0;
}

size_t DocumentTracker::followed_documents() const { return followed_.size(); }

std::vector<PageInView> DocumentTracker::PredictedPages(int frames_ahead) const {
  std::vector<PageInView> out;
  if (!options_.predict) return out;  // LLAH alone, as the seed's experiment
  for (const auto& doc : followed_) {
    if (!doc->has_homography || doc->lost_frames > 0 || doc->last_seen != frame_count_ ||
        doc->hull.empty())
      continue;
    cv::Matx33d H = doc->homography;
    for (int k = 0; k < frames_ahead && doc->has_motion; ++k) {
      cv::Matx33d moved = doc->motion * H;
      if (!NormaliseInFront(moved, doc->seen_centroid) ||
          !MakePlausibleHomography(&moved, {cv::Point2f(doc->seen_centroid)}))
        break;
      H = moved;
    }
    PageInView page;
    page.document = doc->id;
    page.page_to_frame = H;
    // The keypoints are word centres: the words reach a little beyond their hull.
    const cv::Rect2f box = cv::boundingRect(doc->hull);
    const float margin = 0.03f * std::max(box.width, box.height);
    page.area = cv::Rect2f(box.x - margin, box.y - margin, box.width + 2 * margin,
                           box.height + 2 * margin);
    out.push_back(page);
  }
  return out;
}

bool DocumentTracker::ShouldLearn(int llah_inliers) const {
  switch (options_.update_policy) {
    case UpdatePolicy::kEveryFrame:
      return true;
    case UpdatePolicy::kNever:
      return false;
    case UpdatePolicy::kBelowThreshold:
      return llah_inliers >= 0 && llah_inliers < options_.update_inlier_threshold;
  }
  return false;
}

void DocumentTracker::Learn(Followed& doc, Frame& frame, const Pairs& matches,
                            TrackedDocument& out) {
  std::vector<int> which;
  for (const auto& [q, r] : matches) which.push_back(q);
  frame.EnsureHashes(which);
  int added = 0;
  for (const auto& [q, r] : matches) {
    for (int j = 0; j < frame.per; ++j) {
      const uint64_t h = frame.hashes[static_cast<size_t>(q) * frame.per + j];
      if (h != 0 && session_.Learn(h, doc.id, static_cast<uint16_t>(r))) ++added;
    }
  }
  out.learned = added;
}

void DocumentTracker::MatchLlah(const Followed& doc, Frame& frame, Pairs* all,
                                Pairs* strong) const {
  const auto& ref = doc.reference;
  std::vector<int> which;
  for (int q = 0; q < static_cast<int>(frame.points.size()); ++q)
    if (!frame.used[q]) which.push_back(q);
  frame.EnsureHashes(which);
  std::vector<std::pair<uint16_t, int>> votes;  // (reference keypoint, hits)
  for (int q : which) {
    votes.clear();
    for (int j = 0; j < frame.per; ++j) {
      const uint64_t h = frame.hashes[static_cast<size_t>(q) * frame.per + j];
      if (h == 0) continue;
      if (session_.Count(h, options_.max_hits_per_descriptor + 1) >
          options_.max_hits_per_descriptor)
        continue;  // too common to tell keypoints apart
      session_.ForEach(h, [&](uint32_t d, uint16_t kp) {
        if (d != doc.id || kp >= ref.size()) return;
        for (auto& v : votes) {
          if (v.first == kp) {
            ++v.second;
            return;
          }
        }
        votes.emplace_back(kp, 1);
      });
    }
    if (votes.empty()) continue;
    const auto best =
        std::max_element(votes.begin(), votes.end(), [](const auto& a, const auto& b) {
          return a.second < b.second || (a.second == b.second && a.first > b.first);
        });
    all->emplace_back(q, best->first);
    if (best->second >= 2) strong->emplace_back(q, best->first);
  }
}

TrackedDocument DocumentTracker::TrackOne(Followed& doc, Frame& frame, TrackerTimings& timings) {
  auto t = SteadyClock::now();
  TrackedDocument out;
  out.document = doc.id;
  const auto& ref = doc.reference;

  // Prediction from the last pose and motion (a page lost for a while is searched by
  // LLAH alone: its old position says little).
  std::optional<cv::Matx33d> predicted;
  if (options_.predict && doc.has_homography && doc.lost_frames <= 3) {
    predicted = doc.homography;
    if (doc.has_motion && doc.lost_frames == 0) {
      cv::Matx33d moved = doc.motion * doc.homography;
      if (NormaliseInFront(moved, doc.seen_centroid) &&
          MakePlausibleHomography(&moved, {cv::Point2f(doc.seen_centroid)}))
        predicted = moved;
    }
  }
  Fit projected;
  if (predicted) {
    const Pairs candidates = ProjectionMatch(*predicted, ref, frame.points, frame.grid, frame.used,
                                             frame.size, frame.search_px, 0.8,
                                             frame.separation_px);
    projected =
        RansacFit(candidates, {}, ref, frame.points, frame.inlier_px, 200, options_.min_inliers);
    if (projected.ok) projected = Refine(projected, ref, frame, options_.min_inliers);
  }

  Pairs llah, strong;
  const bool llah_ran =
      !projected.ok || !options_.predict || options_.llah_interval <= 1 ||
      frame_count_ - doc.last_llah >= static_cast<uint64_t>(options_.llah_interval);
  if (llah_ran) {
    doc.last_llah = frame_count_;
    MatchLlah(doc, frame, &llah, &strong);
  }
  timings.match_ms += MillisecondsSince(t);

  t = SteadyClock::now();
  // A projection pose is trusted when LLAH agrees with it, or when it explains most of
  // the page it claims to see, tightly. Chance alignments (the text lines of another
  // page, or of a mirror image, fall on the predicted lines) meet neither.
  Fit chosen;
  if (projected.ok) {
    const int agree =
        llah_ran ? static_cast<int>(
                       InliersOf(projected.H, llah, ref, frame.points, frame.inlier_px).size())
                 : -1;
    const Evidence evidence = Measure(projected, ref, frame);
    if (agree >= options_.min_llah_confirm ||
        (evidence.match_ratio >= options_.min_match_ratio &&
         evidence.mean_residual <= options_.max_mean_residual * frame.inlier_px)) {
      chosen = std::move(projected);
      out.method = "projection";
    }
  }
  if (!chosen.ok && llah_ran) {
    // LLAH correspondences agreeing on one homography are evidence of their own.
    chosen = RansacFit(llah, strong, ref, frame.points, frame.inlier_px, options_.ransac_iterations,
                       options_.min_inliers);
    if (chosen.ok) {
      chosen = Refine(chosen, ref, frame, options_.min_inliers);
      out.method = "llah";
    }
  }
  bool accepted = chosen.ok;
  const cv::Matx33d H = chosen.H;
  const Pairs& matches = chosen.inliers;
  if (accepted) {
    out.inliers = static_cast<int>(matches.size());
    if (llah_ran)
      out.llah_inliers =
          static_cast<int>(InliersOf(H, llah, ref, frame.points, frame.inlier_px).size());
  }
  std::vector<cv::Point2f> plane, pixels;
  for (const auto& [q, r] : matches) {
    plane.push_back(ref[r]);
    pixels.push_back(frame.points[q]);
  }
  // Jump check against where the page was expected.
  if (accepted && doc.has_homography && doc.lost_frames == 0) {
    const cv::Matx33d& expected = predicted ? *predicted : doc.homography;
    double moved = 0;
    for (const auto& p : plane)
      moved += cv::norm(ApplyHomography(H, p) - ApplyHomography(expected, p));
    moved /= std::max<size_t>(1, plane.size());
    const double diagonal = std::hypot(frame.size.width, frame.size.height);
    if (moved > options_.max_jump_fraction * diagonal &&
        out.llah_inliers < options_.reacquire_min_llah_inliers)
      accepted = false;
  }
  std::optional<PlanarPose> pose;
  if (accepted && camera_) {
    auto estimated = EstimatePlanarPose(plane, pixels, *camera_);
    if (estimated.ok()) {
      pose = *estimated;
      if (doc.pose && doc.lost_frames == 0 &&
          RotationAngleDeg(pose->R, doc.pose->R) > options_.max_rotation_jump_deg &&
          out.llah_inliers < options_.reacquire_min_llah_inliers)
        accepted = false;
    }
  }
  timings.pose_ms += MillisecondsSince(t);

  if (!accepted) {
    ++doc.lost_frames;
    doc.has_motion = false;
    doc.state = TrackState::kLost;
    out.state = TrackState::kLost;
    out.inliers = 0;
    out.method.clear();
    out.learned_entries = session_.learned_entries(doc.id);
    return out;
  }

  for (const auto& [q, r] : matches) frame.used[q] = 1;
  if (doc.has_homography && doc.lost_frames == 0 && doc.last_seen + 1 == frame_count_) {
    cv::Matx33d inverse;
    if (cv::invert(doc.homography, inverse) != 0) {
      doc.motion = H * inverse;
      doc.has_motion = Finite(doc.motion);
    }
  } else {
    doc.has_motion = false;
  }
  doc.homography = H;
  doc.seen_centroid = Centroid(plane);
  doc.has_homography = true;
  doc.pose = pose;
  doc.last_seen = frame_count_;
  doc.lost_frames = 0;
  doc.state = TrackState::kTracking;
  out.state = TrackState::kTracking;
  out.homography = H;
  out.pose = pose;
  out.matches = matches;

  t = SteadyClock::now();
  if (ShouldLearn(out.llah_inliers)) Learn(doc, frame, matches, out);
  out.learned_entries = session_.learned_entries(doc.id);
  timings.update_ms += MillisecondsSince(t);
  return out;
}

void DocumentTracker::Follow(uint32_t id, const DocumentHit& hit, Frame& frame,
                             TrackerFrameResult& result) {
  auto t = SteadyClock::now();
  // A page followed already (lost) is re-acquired in place; a new one joins the session
  // with its reference descriptors.
  Followed* doc = nullptr;
  size_t slot = result.documents.size();
  for (size_t i = 0; i < followed_.size(); ++i) {
    if (followed_[i]->id == id) {
      doc = followed_[i].get();
      slot = i;
    }
  }
  if (!doc) {
    if (static_cast<int>(followed_.size()) >= options_.max_documents) return;
    std::vector<cv::Point2f> reference = shared_->Keypoints(id);
    if (reference.empty()) return;  // deleted meanwhile
    std::vector<uint64_t> hashes;
    shared_->describer().Describe(reference, &hashes);
    session_.AddDocument(id, std::move(hashes), shared_->describer().descriptors_per_point());
    auto followed = std::make_unique<Followed>();
    followed->id = id;
    cv::convexHull(reference, followed->hull);
    followed->reference = std::move(reference);
    doc = followed.get();
    followed_.push_back(std::move(followed));
    result.documents.emplace_back();
  }
  const auto& ref = doc->reference;
  cv::Matx33d H = hit.homography;
  Pairs matches;
  for (const auto& [q, r] : hit.matches)
    if (!frame.used[q] && r < static_cast<int>(ref.size())) matches.emplace_back(q, r);
  std::vector<cv::Point2f> seen;
  for (const auto& [q, r] : matches) seen.push_back(ref[r]);
  TrackedDocument out;
  out.document = id;
  result.timings.match_ms += MillisecondsSince(t);
  t = SteadyClock::now();
  if (static_cast<int>(matches.size()) < options_.min_inliers ||
      !NormaliseInFront(H, Centroid(seen)) || !MakePlausibleHomography(&H, seen)) {
    out.state = TrackState::kLost;
    result.documents[slot] = out;
    return;
  }
  std::vector<cv::Point2f> plane, pixels;
  for (const auto& [q, r] : matches) {
    plane.push_back(ref[r]);
    pixels.push_back(frame.points[q]);
    frame.used[q] = 1;
  }
  std::optional<PlanarPose> pose;
  if (camera_) {
    auto estimated = EstimatePlanarPose(plane, pixels, *camera_);
    if (estimated.ok()) pose = *estimated;
  }
  result.timings.pose_ms += MillisecondsSince(t);
  doc->homography = H;
  doc->seen_centroid = Centroid(plane);
  doc->has_homography = true;
  doc->has_motion = false;
  doc->pose = pose;
  doc->last_seen = frame_count_;
  doc->last_llah = frame_count_;
  doc->lost_frames = 0;
  doc->state = TrackState::kInitializing;
  out.state = TrackState::kInitializing;
  out.homography = H;
  out.pose = pose;
  out.inliers = static_cast<int>(matches.size());
  out.matches = matches;
  out.llah_inliers = hit.inliers;
  out.method = "retrieval";
  t = SteadyClock::now();
  if (ShouldLearn(out.llah_inliers)) Learn(*doc, frame, matches, out);
  out.learned_entries = session_.learned_entries(id);
  result.timings.update_ms += MillisecondsSince(t);
  result.documents[slot] = out;
}

TrackerFrameResult DocumentTracker::Track(const WordKeypoints& keypoints,
                                          const cv::Size& image_size,
                                          std::shared_ptr<const LlahRetriever> shared,
                                          bool whole_frame) {
  TrackerFrameResult result;
  if (shared != shared_) {
    // A new shared index (the first page was registered): hashes of the old one mean
    // nothing to it.
    Reset();
    shared_ = std::move(shared);
  }
  ++frame_count_;
  if (!shared_) return result;
  auto t = SteadyClock::now();
  Frame frame(keypoints, image_size, shared_->describer(), options_);

  // Pages deleted from the registry stop being followed.
  for (size_t i = 0; i < followed_.size();) {
    if (!shared_->Contains(followed_[i]->id)) {
      session_.RemoveDocument(followed_[i]->id);
      followed_.erase(followed_.begin() + static_cast<std::ptrdiff_t>(i));
    } else {
      ++i;
    }
  }
  result.timings.match_ms += MillisecondsSince(t);

  bool any_tracked = false;
  for (auto& doc : followed_) {
    result.documents.push_back(TrackOne(*doc, frame, result.timings));
    any_tracked = any_tracked || result.documents.back().state != TrackState::kLost;
  }

  // Retrieval: pages not followed yet, and lost ones the session index cannot re-find.
  if (whole_frame && (!any_tracked || frame_count_ >= next_retrieval_)) {
    t = SteadyClock::now();
    result.retrieved = true;
    // While nothing is followed retrieval runs every frame; from the last such frame the
    // cycle starts at this stream's phase (so streams started together spread it out).
    next_retrieval_ = frame_count_ + static_cast<uint64_t>(options_.retrieval_interval);
    if (!any_tracked)
      next_retrieval_ -=
          static_cast<uint64_t>(options_.retrieval_phase % options_.retrieval_interval);
    std::vector<int> free_index;
    std::vector<cv::Point2f> free_points;
    // Keypoints on a tracked page's text area belong to it: retrieval looks for other
    // pages elsewhere (with the page filling the view, it has nothing to do).
    std::vector<std::vector<cv::Point2f>> covered;
    for (size_t i = 0; i < followed_.size(); ++i) {
      if (result.documents[i].state == TrackState::kLost) continue;
      const cv::Matx33d& H = result.documents[i].homography;
      std::vector<cv::Point2f> outline;
      for (const auto& p : followed_[i]->hull) {
        if (W(H, p) <= 1e-9) break;  // the text area crosses the horizon
        const cv::Point2d q = ApplyHomography(H, p);
        outline.emplace_back(static_cast<float>(q.x), static_cast<float>(q.y));
      }
      if (outline.size() == followed_[i]->hull.size() && outline.size() >= 3)
        covered.push_back(std::move(outline));
    }
    for (int q = 0; q < static_cast<int>(keypoints.points.size()); ++q) {
      if (frame.used[q]) continue;
      bool on_page = false;
      for (const auto& outline : covered)
        on_page = on_page || cv::pointPolygonTest(outline, keypoints.points[q], false) >= 0;
      if (on_page) continue;
      free_index.push_back(q);
      free_points.push_back(keypoints.points[q]);
    }
    std::vector<DocumentHit> hits;
    if (free_points.size() >= 8)
      hits = shared_->Retrieve(free_points, keypoints.char_height, options_.retrieval);
    result.timings.match_ms += MillisecondsSince(t);
    for (DocumentHit& hit : hits) {
      bool tracked = false;
      for (size_t i = 0; i < followed_.size(); ++i)
        tracked = tracked || (followed_[i]->id == hit.document &&
                              result.documents[i].state != TrackState::kLost);
      if (tracked) continue;
      for (auto& [q, r] : hit.matches) q = free_index[q];
      Follow(hit.document, hit, frame, result);
    }
  }

  // Forget pages lost for too long.
  for (size_t i = 0; i < followed_.size();) {
    if (followed_[i]->lost_frames >= options_.forget_after_frames) {
      session_.RemoveDocument(followed_[i]->id);
      followed_.erase(followed_.begin() + static_cast<std::ptrdiff_t>(i));
      result.documents.erase(result.documents.begin() + static_cast<std::ptrdiff_t>(i));
    } else {
      ++i;
    }
  }
  return result;
}

}  // namespace texfree
