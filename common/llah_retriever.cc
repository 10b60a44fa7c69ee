// LlahRetriever implementation: voting, candidate selection, RANSAC and guided
// refinement.
#include "common/llah_retriever.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <mutex>
#include <numeric>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <thread>
#include <unordered_set>

#include "absl/strings/str_cat.h"
#include "common/homography_fit.h"
#include "common/neighbor_grid.h"
#include "common/planar_pose.h"
#include "common/text_perspective.h"

namespace texfree {

absl::Status RetrievalOptions::Validate() const {
  if (max_hits_per_descriptor < 1)
    return absl::InvalidArgumentError("max_hits_per_descriptor must be >= 1");
  if (guided_growth_rounds < 0 || guided_growth_rounds > 20)
    return absl::InvalidArgumentError("guided_growth_rounds must be in [0, 20]");
  if (!(polish_gate > 0 && polish_gate <= 1))
    return absl::InvalidArgumentError(
        "polish_gate must be in (0, 1] (a share of the inlier threshold)");
  if (!(polish_match_gate >= 0 && polish_match_gate <= 5))
    return absl::InvalidArgumentError(
        "polish_match_gate must be in [0, 5] (times the inlier threshold; 0: the guided matches)");
  if (max_hits_per_1000_documents < 0)
    return absl::InvalidArgumentError("max_hits_per_1000_documents must be >= 0");
  if (stop_word_keypoints < 0)
    return absl::InvalidArgumentError("stop_word_keypoints must be >= 0 (0: never lowered)");
  if (prefilter_documents < 0)
    return absl::InvalidArgumentError("prefilter_documents must be >= 0 (0 keeps all)");
  if (query_probes < 0 || query_probes > LlahDescriber::kMaxProbes)
    return absl::InvalidArgumentError(absl::StrCat(
        "query_probes must be in [0, ", LlahDescriber::kMaxProbes, "], got ", query_probes));
  if (min_votes < 4) return absl::InvalidArgumentError("min_votes must be >= 4");
  if (min_coherent_votes < 0) return absl::InvalidArgumentError("min_coherent_votes must be >= 0");
  if (!(coherence_radius > 0))
    return absl::InvalidArgumentError(
        absl::StrCat("coherence_radius must be > 0 (times a page's neighbour distance), got ",
                     coherence_radius));
  if (candidate_vote_ratio < 0 || candidate_vote_ratio > 1)
    return absl::InvalidArgumentError("candidate_vote_ratio must be in [0, 1]");
  if (max_candidates < 1) return absl::InvalidArgumentError("max_candidates must be >= 1");
  if (ransac_threshold_px < 0) return absl::InvalidArgumentError("ransac_threshold_px < 0");
  if (ransac_iterations < 10) return absl::InvalidArgumentError("ransac_iterations must be >= 10");
  if (min_inliers < 6)
    return absl::InvalidArgumentError(absl::StrCat(
        "min_inliers must be >= 6 (a homography has 4 points of freedom), got ", min_inliers));
  if (min_weak_inliers < 5 || min_weak_inliers > min_inliers)
    return absl::InvalidArgumentError(absl::StrCat(
        "min_weak_inliers must be in [5, min_inliers] (a homography needs 4 points and one "
        "to check), got ",
        min_weak_inliers));
  if (min_layout_matches < min_inliers)
    return absl::InvalidArgumentError(absl::StrCat("min_layout_matches must be >= min_inliers (",
                                                   min_inliers, "), got ", min_layout_matches));
  if (!(layout_chance > 0 && layout_chance < 1))
    return absl::InvalidArgumentError(
        absl::StrCat("layout_chance must be in (0, 1), got ", layout_chance));
  if (max_layout_tail < 0 || max_layout_tail > 1)
    return absl::InvalidArgumentError(
        absl::StrCat("max_layout_tail must be in [0, 1] (0: off), got ", max_layout_tail));
  if (min_layout_ratio <= 0.25 || min_layout_ratio > 1)
    return absl::InvalidArgumentError(absl::StrCat(
        "min_layout_ratio must be in (0.25, 1] (chance alignments of text reach ~0.2), got ",
        min_layout_ratio));
  if (min_significant_layout_ratio <= 0 || min_significant_layout_ratio > min_layout_ratio)
    return absl::InvalidArgumentError(
        absl::StrCat("min_significant_layout_ratio must be in (0, min_layout_ratio], got ",
                     min_significant_layout_ratio));
  if (max_weak_nfa < 0 || max_weak_nfa > 1)
    return absl::InvalidArgumentError(
        absl::StrCat("max_weak_nfa must be in [0, 1] (0: off), got ", max_weak_nfa));
  if (!(max_border_lost >= 0))
    return absl::InvalidArgumentError(
        absl::StrCat("max_border_lost must be >= 0 (0: off), got ", max_border_lost));
  if (max_results < 0) return absl::InvalidArgumentError("max_results must be >= 0");
  if (refine_max_keypoints < 0)
    return absl::InvalidArgumentError(
        absl::StrCat("refine_max_keypoints must be >= 0, got ", refine_max_keypoints));
  if (deep_max_keypoints < 0)
    return absl::InvalidArgumentError("deep_max_keypoints must be >= 0 (0: no second pass)");
  if (deep_min_strong_votes < 0 || deep_min_strong_votes > min_strong_votes)
    return absl::InvalidArgumentError(absl::StrCat(
        "deep_min_strong_votes must be in [0, min_strong_votes], got ", deep_min_strong_votes));
  if (deep_min_layout_ratio <= 0.25 || deep_min_layout_ratio > 1)
    return absl::InvalidArgumentError(absl::StrCat(
        "deep_min_layout_ratio must be in (0.25, 1] (chance alignments of text reach ~0.2), got ",
        deep_min_layout_ratio));
  if (deep_min_weak_inliers < 4 || deep_min_weak_inliers > min_weak_inliers)
    return absl::InvalidArgumentError(absl::StrCat(
        "deep_min_weak_inliers must be in [4, min_weak_inliers], got ", deep_min_weak_inliers));
  if (neighbourhood_max_hypotheses < 0)
    return absl::InvalidArgumentError(
        absl::StrCat("neighbourhood_max_hypotheses must be >= 0 (0: no neighbourhood pass), got ",
                     neighbourhood_max_hypotheses));
  if (!(neighbourhood_max_residual > 0 && neighbourhood_max_residual <= 1))
    return absl::InvalidArgumentError(
        absl::StrCat("neighbourhood_max_residual must be in (0, 1] (a share of the neighbourhood's "
                     "radius), got ",
                     neighbourhood_max_residual));
  if (!(neighbourhood_tight_gate > 0 && neighbourhood_tight_gate <= 1))
    return absl::InvalidArgumentError(absl::StrCat(
        "neighbourhood_tight_gate must be in (0, 1] (a share of the inlier threshold), got ",
        neighbourhood_tight_gate));
  if (neighbourhood_min_tight < 8)
    return absl::InvalidArgumentError(
        absl::StrCat("neighbourhood_min_tight must be >= 8 (fewer matches align by chance), got ",
                     neighbourhood_min_tight));
  if (neighbourhood_min_tight_agreeing < 0 ||
      (neighbourhood_min_tight_agreeing > 0 && neighbourhood_min_tight_agreeing < 8))
    return absl::InvalidArgumentError(absl::StrCat(
        "neighbourhood_min_tight_agreeing must be 0 (off) or >= 8 (fewer matches align by "
        "chance), got ",
        neighbourhood_min_tight_agreeing));
  if (neighbourhood_min_agreeing_hits < 2)
    return absl::InvalidArgumentError(
        absl::StrCat("neighbourhood_min_agreeing_hits must be >= 2 (one hit is the hypothesis "
                     "itself), got ",
                     neighbourhood_min_agreeing_hits));
  if (!(neighbourhood_min_tight_share > 0 && neighbourhood_min_tight_share <= 1))
    return absl::InvalidArgumentError(absl::StrCat(
        "neighbourhood_min_tight_share must be in (0, 1], got ", neighbourhood_min_tight_share));
  if (neighbourhood_min_tight_wide < neighbourhood_min_tight)
    return absl::InvalidArgumentError(
        absl::StrCat("neighbourhood_min_tight_wide must be >= neighbourhood_min_tight (",
                     neighbourhood_min_tight, "), got ", neighbourhood_min_tight_wide));
  if (!(neighbourhood_min_tight_share_close >= neighbourhood_min_tight_share &&
        neighbourhood_min_tight_share_close <= 1))
    return absl::InvalidArgumentError(absl::StrCat(
        "neighbourhood_min_tight_share_close must be in [", neighbourhood_min_tight_share,
        " (neighbourhood_min_tight_share), 1], got ", neighbourhood_min_tight_share_close));
  if (rectify_perspective) {
    absl::Status status = perspective.Validate();
    if (!status.ok())
      return absl::InvalidArgumentError(absl::StrCat("perspective: ", status.message()));
  }
  return absl::OkStatus();
}

namespace {

// Typical distance from a keypoint to its k-th nearest neighbour on a page (the median over
// up to 64 keypoints spread over it): what "near" means on this page for the coherence check.
float NeighbourRadius(const std::vector<cv::Point2f> &points, int k) {
  if (points.size() <= static_cast<size_t>(k)) return 0.f;
  NeighborGrid grid(points);
  std::vector<float> d;
  std::vector<int> nearest;
  const size_t step = std::max<size_t>(1, points.size() / 64);
  for (size_t i = 0; i < points.size(); i += step) {
    grid.Nearest(static_cast<int>(i), k, &nearest);
    if (nearest.size() < static_cast<size_t>(k)) continue;
    d.push_back(static_cast<float>(cv::norm(points[i] - points[nearest.back()])));
  }
  if (d.empty()) return 0.f;
  std::nth_element(d.begin(), d.begin() + d.size() / 2, d.end());
  return d[d.size() / 2];
}

// NeighbourRadius of a document's base layer (its extra layers are other cuts of the same
// words).
float BaseLayerRadius(const DocumentKeypoints &d, int k, int64_t base) {
  return NeighbourRadius(std::vector<cv::Point2f>(d.keypoints.begin(), d.keypoints.begin() + base),
                         k);
}

double LogChoose(int a, int b) {
  return std::lgamma(a + 1.0) - std::lgamma(b + 1.0) - std::lgamma(a - b + 1.0);
}

// log10 P[X >= k] for X ~ B(n, p), 0 < k <= n, 0 < p < 1: summed in log space from its
// largest term, so that tails of 1e-300 and beyond stay finite.
double Log10BinomialTail(int n, int k, double p) {
  const double lp = std::log(p), lq = std::log1p(-p);
  const double top = LogChoose(n, k) + k * lp + (n - k) * lq;
  double sum = 0;
  for (int j = k; j <= n; ++j) {
    const double term = std::exp(LogChoose(n, j) + j * lp + (n - j) * lq - top);
    sum += term;
    if (term < 1e-12 * sum) break;
  }
  return (top + std::log(sum)) / std::log(10.0);
}

}  // namespace

int StopWordLimit(int limit, int keypoints, int plenty) {
  if (plenty <= 0 || keypoints <= plenty) return limit;
  const double lowered = static_cast<double>(limit) * plenty / keypoints;
  return static_cast<int>(std::lround(std::max(lowered, 0.25 * limit)));
}

double LayoutLog10Tail(int inside, int matched, double chance) {
  const int n = inside, k = std::min(matched, inside);
  if (n <= 0 || k <= 0 || !(chance > 0) || chance >= 1) return 0;
  return std::min(0.0, Log10BinomialTail(n, k, chance));
}

double WeakMatchLog10Nfa(int correspondences, int inliers, double threshold_px, double area_px2) {
  const int n = correspondences, k = inliers;
  if (n < 4 || k <= 4 || k > n || !(area_px2 > 0)) return 0;
  const double p = std::min(1.0, CV_PI * threshold_px * threshold_px / area_px2);
  if (p >= 1) return 0;
  // C(n, 4) minimal samples, each explaining k - 4 of the other n - 4 by chance.
  return LogChoose(n, 4) / std::log(10.0) + Log10BinomialTail(n - 4, k - 4, p);
}

LlahRetriever::LlahRetriever(LlahOptions options, InvariantQuantizer quantizer, int log2_buckets)
    : describer_(options, std::move(quantizer)),
      min_log2_buckets_(log2_buckets),
      index_(log2_buckets) {}

int64_t LlahRetriever::BaseLayerSize(size_t points, const std::vector<uint32_t> &extra_layers) {
  uint64_t extra = 0;
  for (uint32_t n : extra_layers) extra += n;
  return extra > points ? -1 : static_cast<int64_t>(points - extra);
}

std::shared_ptr<LlahRetriever::Model> LlahRetriever::MakeModel(DocumentKeypoints *document,
                                                               float radius) {
  auto model = std::make_shared<Model>();
  model->base =
      static_cast<uint32_t>(BaseLayerSize(document->keypoints.size(), document->extra_layers));
  model->keypoints = std::move(document->keypoints);
  model->size = document->size;
  model->neighbour_radius = radius;
  model->extra_layers = std::move(document->extra_layers);
  return model;
}

bool LlahRetriever::DescribeLayers(const std::vector<cv::Point2f> &points,
                                   const std::vector<uint32_t> &extra_layers,
                                   std::vector<uint64_t> *hashes) const {
  const int64_t base = BaseLayerSize(points.size(), extra_layers);
  if (base < 0) return false;
  if (extra_layers.empty()) {
    describer_.Describe(points, hashes);
    return true;
  }
  const size_t per = static_cast<size_t>(describer_.descriptors_per_point());
  hashes->assign(points.size() * per, 0);
  std::unordered_set<uint64_t> earlier;  // hashes of the layers described so far
  std::vector<cv::Point2f> layer;
  std::vector<uint64_t> layer_hashes;
  size_t begin = 0;
  for (size_t l = 0; l <= extra_layers.size(); ++l) {
    const size_t count = l == 0 ? static_cast<size_t>(base) : extra_layers[l - 1];
    layer.assign(points.begin() + begin, points.begin() + begin + count);
    describer_.Describe(layer, &layer_hashes);
    for (size_t i = 0; i < layer_hashes.size(); ++i) {
      const uint64_t h = layer_hashes[i];
      if (h != 0 && (l == 0 || !earlier.count(h))) (*hashes)[begin * per + i] = h;
    }
    earlier.insert(layer_hashes.begin(), layer_hashes.end());
    begin += count;
  }
  return true;
}

absl::Status LlahRetriever::AddDocument(DocumentKeypoints document) {
  if (document.keypoints.size() > 65535)
    return absl::InvalidArgumentError(absl::StrCat("document has ", document.keypoints.size(),
                                                   " keypoints; at most 65535 are indexed"));
  const int64_t base = BaseLayerSize(document.keypoints.size(), document.extra_layers);
  if (base < 0)
    return absl::InvalidArgumentError(absl::StrCat("document's extra layers hold more than its ",
                                                   document.keypoints.size(), " keypoints"));
  std::vector<uint64_t> hashes = std::move(document.hashes);
  if (hashes.size() != document.keypoints.size() * describer_.descriptors_per_point())
    DescribeLayers(document.keypoints, document.extra_layers, &hashes);
  const float radius = BaseLayerRadius(document, describer_.options().n, base);
  auto model = MakeModel(&document, radius);
  std::unique_lock lock(mutex_);
  if (models_.count(document.id))
    return absl::AlreadyExistsError(absl::StrCat("document ", document.id, " is already indexed"));
  index_.Add(document.id, hashes, describer_.descriptors_per_point());
  SetDenseModel(document.id, model.get());
  models_.emplace(document.id, std::move(model));
  return absl::OkStatus();
}

absl::Status LlahRetriever::AddDocuments(
    std::vector<DocumentKeypoints> documents, int threads,
    const std::function<void(size_t, size_t)> &progress,
    const std::function<void(uint32_t, const std::vector<uint64_t> &)> &computed) {
  const size_t total = documents.size();
  for (const auto &d : documents) {
    if (d.keypoints.size() > 65535)
      return absl::InvalidArgumentError(absl::StrCat("document ", d.id, " has too many keypoints"));
    if (BaseLayerSize(d.keypoints.size(), d.extra_layers) < 0)
      return absl::InvalidArgumentError(
          absl::StrCat("document ", d.id, "'s extra layers hold more than its keypoints"));
  }
  // Workers compute the descriptors that are not stored; then one bucket-ordered load.
  std::atomic<size_t> next{0}, done{0};
  std::vector<float> radius(total, 0.f);
  std::mutex callback_mutex;
  const size_t per = static_cast<size_t>(describer_.descriptors_per_point());
  auto work = [&]() {
    while (true) {
      const size_t i = next.fetch_add(1);
      if (i >= total) return;
      DocumentKeypoints &d = documents[i];
      radius[i] = BaseLayerRadius(d, describer_.options().n,
                                  BaseLayerSize(d.keypoints.size(), d.extra_layers));
      if (d.hashes.size() != d.keypoints.size() * per) {
        DescribeLayers(d.keypoints, d.extra_layers, &d.hashes);
        if (computed) {
          std::lock_guard g(callback_mutex);
          computed(d.id, d.hashes);
        }
      }
      const size_t n = done.fetch_add(1) + 1;
      if (progress && (n % 2000 == 0 || n == total)) {
        std::lock_guard g(callback_mutex);
        progress(n, total);
      }
    }
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < std::max(1, threads); ++t) pool.emplace_back(work);
  work();
  for (auto &t : pool) t.join();

  // Room for exactly the entries to add: extra layers leave many descriptor slots empty
  // (their duplicates of earlier layers), which a reserve by slots would pay for.
  size_t new_entries = 0;
  for (const DocumentKeypoints &d : documents)
    new_entries += d.hashes.size() - std::count(d.hashes.begin(), d.hashes.end(), uint64_t{0});
  std::unique_lock lock(mutex_);
  if (index_.entries() == 0) {
    const int log2_buckets = InvertedIndex::Log2BucketsFor(new_entries, min_log2_buckets_);
    if (log2_buckets != index_.log2_buckets()) index_.Rebucket(log2_buckets);
  }
  index_.Reserve(index_.entries() + new_entries);
  // A known id is reported; the other documents are still added.
  absl::Status status;
  std::vector<InvertedIndex::Batch> batch;
  batch.reserve(documents.size());
  std::vector<char> added(documents.size(), 0);
  std::unordered_set<uint32_t> ids;
  for (size_t i = 0; i < documents.size(); ++i) {
    const DocumentKeypoints &d = documents[i];
    if (models_.count(d.id) || !ids.insert(d.id).second) {
      status = absl::AlreadyExistsError(absl::StrCat("document ", d.id, " indexed twice"));
      continue;
    }
    batch.push_back({d.id, &d.hashes});
    added[i] = 1;
  }
  index_.AddBatch(batch, static_cast<int>(per), threads);
  for (size_t i = 0; i < documents.size(); ++i) {
    if (!added[i]) continue;
    DocumentKeypoints &d = documents[i];
    auto model = MakeModel(&d, radius[i]);
    SetDenseModel(d.id, model.get());
    models_.emplace(d.id, std::move(model));
  }
  return status;
}

bool LlahRetriever::RemoveDocument(uint32_t id) {
  std::shared_ptr<const Model> model;
  {
    std::shared_lock lock(mutex_);
    auto it = models_.find(id);
    if (it == models_.end()) return false;
    model = it->second;
  }
  std::vector<uint64_t> hashes;  // deterministic: the same hashes Add() inserted
  DescribeLayers(model->keypoints, model->extra_layers, &hashes);
  std::unique_lock lock(mutex_);
  if (!models_.erase(id)) return false;
  SetDenseModel(id, nullptr);
  index_.Remove(id, hashes, describer_.descriptors_per_point());
  return true;
}

void LlahRetriever::SetDenseModel(uint32_t id, const Model *model) {
  if (id >= kDenseIds) return;
  if (dense_models_.size() <= id) {
    if (model == nullptr) return;
    dense_models_.resize(id + 1, nullptr);
  }
  dense_models_[id] = model;
}

const LlahRetriever::Model *LlahRetriever::FindModel(uint32_t id) const {
  if (id < kDenseIds) return id < dense_models_.size() ? dense_models_[id] : nullptr;
  auto it = models_.find(id);
  return it == models_.end() ? nullptr : it->second.get();
}

bool LlahRetriever::Contains(uint32_t id) const {
  std::shared_lock lock(mutex_);
  return models_.count(id) > 0;
}

std::vector<cv::Point2f> LlahRetriever::Keypoints(uint32_t id) const {
  std::shared_lock lock(mutex_);
  auto it = models_.find(id);
  if (it == models_.end()) return {};
  const Model &m = *it->second;
  return std::vector<cv::Point2f>(m.keypoints.begin(), m.keypoints.begin() + m.base);
}

size_t LlahRetriever::documents() const {
  std::shared_lock lock(mutex_);
  return models_.size();
}

size_t LlahRetriever::entries() const {
  std::shared_lock lock(mutex_);
  return index_.entries();
}

size_t LlahRetriever::MemoryBytes() const {
  std::shared_lock lock(mutex_);
  size_t bytes = index_.MemoryBytes();
  for (const auto &[id, m] : models_)
    bytes += sizeof(Model) + m->keypoints.capacity() * sizeof(cv::Point2f) + 64;
  return bytes;
}

namespace {

// The deep pass tries every 4-subset of a candidate's correspondences up to this many
// (C(12, 4) = 495 homographies).
constexpr int kMaxExhaustivePairs = 12;
// ...and refines at most this many of their consensus sets.
constexpr int kMaxDeepHypotheses = 3;
// RANSAC iterations of the robust refit of an accepted page's homography.
constexpr int kPolishIterations = 500;
// ...which is grown again only when it moves a corner of the view by more than this share
// of its gate (most robust fits are the guided refit's own, to the pixel).
constexpr double kPolishMinMove = 0.5;

struct Correspondence {
  uint32_t document;
  int query;
  uint16_t reference;
  int count;  // descriptors of the query keypoint that hit this reference
              // keypoint
};

// A document to verify: its correspondences and its votes.
struct Candidate {
  uint32_t document;
  int votes;         // query keypoints with any hit in the document
  int strong;        // ...of which two or more descriptors agree on one reference
                     // keypoint
  int coherent = 0;  // ...whose neighbourhood a neighbouring correspondence confirms
  int Score() const { return coherent * (1 << 20) + strong * 1024 + std::min(votes, 1023); }
  std::vector<Correspondence> correspondences;
};

// Hits, votes, strong and coherent votes per document for one query. The registry's ids
// are dense, so the counters are a per-thread array indexed by id, reset after use (no
// hashing and no allocation per hit); ids from 2^24 up, too sparse for that, go to a hash
// map. Find() on a document never touched reads zeros.
class VoteTally {
 public:
  struct Count {
    int hits = 0, votes = 0, strong = 0, coherent = 0;
  };
  VoteTally() { touched().clear(); }
  ~VoteTally() {
    for (uint32_t d : touched()) counts()[d] = Count{};
  }
  void AddHit(uint32_t document) { ++Touch(document)->hits; }
  void AddVote(uint32_t document, bool strong) {
    Count *c = Touch(document);
    ++c->votes;
    if (strong) ++c->strong;
  }
  void AddCoherent(uint32_t document) { ++Touch(document)->coherent; }
  Count Get(uint32_t document) const {
    if (document >= kDense) {
      auto it = sparse_.find(document);
      return it == sparse_.end() ? Count{} : it->second;
    }
    return document < counts().size() ? counts()[document] : Count{};
  }
  // The hit count a document needs to be among the `keep` with most hits (0: all pass).
  int HitFloor(int keep) const {
    std::vector<int> hits;
    ForEach([&](uint32_t, const Count &c) { hits.push_back(c.hits); });
    if (keep <= 0 || hits.size() <= static_cast<size_t>(keep)) return 0;
    std::nth_element(hits.begin(), hits.begin() + (keep - 1), hits.end(), std::greater<int>());
    return hits[static_cast<size_t>(keep - 1)];
  }
  // f(document, count) for every document touched.
  template <typename F>
  void ForEach(F f) const {
    for (uint32_t d : touched()) f(d, counts()[d]);
    for (const auto &[d, c] : sparse_) f(d, c);
  }

 private:
  static constexpr uint32_t kDense = 1u << 24;
  Count *Touch(uint32_t document) {
    if (document >= kDense) return &sparse_[document];
    auto &dense = counts();
    if (dense.size() <= document) dense.resize(document + 1);
    Count *c = &dense[document];
    if (c->hits == 0 && c->votes == 0 && c->coherent == 0) touched().push_back(document);
    return c;
  }
  static std::vector<Count> &counts() {
    thread_local std::vector<Count> dense;
    return dense;
  }
  static std::vector<uint32_t> &touched() {
    thread_local std::vector<uint32_t> list;
    return list;
  }
  std::unordered_map<uint32_t, Count> sparse_;
};

// Reference keypoints (the first `count`) that H puts inside the query keypoints' hull.
int InsideHull(const std::vector<cv::Point2f> &reference, size_t count, const cv::Matx33d &H,
               const std::vector<cv::Point2f> &query_hull) {
  int inside = 0;
  for (size_t i = 0; i < count && i < reference.size(); ++i) {
    const cv::Point2d p = ApplyHomography(H, reference[i]);
    if (!std::isfinite(p.x) || !std::isfinite(p.y)) continue;
    if (cv::pointPolygonTest(
            query_hull, cv::Point2f(static_cast<float>(p.x), static_cast<float>(p.y)), false) >= 0)
      ++inside;
  }
  return inside;
}

// The layout check for documents with few LLAH inliers: the share of the reference
// keypoints that H puts inside the query keypoints' hull which found a query keypoint
// (`matched`, from the guided refinement), from min_layout_matches of them, or from
// min_inliers when chance could hardly give that share (max_layout_tail).
// Only the first `count` reference keypoints (the base layer) count.
// `hypotheses` > 0: the homography is the best of that many (the few-keypoint pass), so only
// the tail decides, with that many chances. `inside_out` (when given) receives the number of
// reference keypoints projected inside the hull, when they were counted.
bool LayoutConfirms(const std::vector<cv::Point2f> &reference, size_t count, const cv::Matx33d &H,
                    const std::vector<cv::Point2f> &query_hull, int matched,
                    const RetrievalOptions &o, double min_ratio, int hypotheses = 0,
                    int *inside_out = nullptr) {
  if (matched < o.min_inliers || query_hull.size() < 3) return false;
  const int inside = InsideHull(reference, count, H, query_hull);
  if (inside_out) *inside_out = inside;
  if (matched < min_ratio * inside) return false;
  if (hypotheses == 0 && matched >= o.min_layout_matches) return true;
  return o.max_layout_tail > 0 &&
         LayoutLog10Tail(inside, matched, o.layout_chance) +
                 std::log10(std::max(1, hypotheses) * static_cast<double>(o.max_candidates)) <=
             std::log10(o.max_layout_tail);
}

// The inlier distance in query pixels: RetrievalOptions::ransac_threshold_px, or derived from
// the query's character height.
double InlierThreshold(const RetrievalOptions &o, double query_char_height) {
  return o.ransac_threshold_px > 0 ? o.ransac_threshold_px
                                   : std::clamp(0.45 * query_char_height, 2.5, 12.0);
}

// The gate of guided matching once the matches stop growing: a few times the median
// residual of the pairs (gr, gq) under H, so that extra keypoints a few pixels from a projected
// word stop pulling the least-squares refit; within [1, threshold].
double ShrunkGate(const cv::Matx33d &H, const std::vector<cv::Point2f> &gr,
                  const std::vector<cv::Point2f> &gq, double threshold) {
  std::vector<double> residuals(gr.size());
  for (size_t i = 0; i < gr.size(); ++i)
    residuals[i] = cv::norm(ApplyHomography(H, gr[i]) - cv::Point2d(gq[i]));
  if (residuals.empty()) return threshold;
  std::nth_element(residuals.begin(), residuals.begin() + residuals.size() / 2, residuals.end());
  return std::clamp(3.0 * residuals[residuals.size() / 2], 1.0, threshold);
}

// Guided matching: every reference keypoint (the first `count`) that h puts within `gate` of
// a query keypoint not `used` (when given), each query keypoint taken by the nearest one:
// (query, reference) pairs, and their points in gr and gq.
void MatchProjected(const std::vector<cv::Point2f> &reference, size_t count, const cv::Matx33d &h,
                    double gate, const std::vector<cv::Point2f> &query,
                    const NeighborGrid &query_grid, const cv::Rect &query_box,
                    const std::vector<char> *used, std::vector<std::pair<int, int>> *matched,
                    std::vector<cv::Point2f> *gr, std::vector<cv::Point2f> *gq) {
  thread_local std::vector<int> owner, nearest;
  thread_local std::vector<float> owner_d;
  owner.assign(query.size(), -1);
  owner_d.assign(query.size(), 0.f);
  for (int r = 0; r < static_cast<int>(std::min(count, reference.size())); ++r) {
    const cv::Point2d p = ApplyHomography(h, reference[r]);
    if (!std::isfinite(p.x) || !std::isfinite(p.y)) continue;
    // Most of a page projects outside the view, where the grid's ring search is longest and
    // finds nothing within the gate anyway.
    if (p.x < query_box.x - gate || p.y < query_box.y - gate ||
        p.x > query_box.x + query_box.width + gate || p.y > query_box.y + query_box.height + gate)
      continue;
    query_grid.NearestTo(cv::Point2f(static_cast<float>(p.x), static_cast<float>(p.y)), 1, -1,
                         &nearest);
    if (nearest.empty() || (used != nullptr && (*used)[nearest[0]])) continue;
    const float d = static_cast<float>(cv::norm(cv::Point2d(query[nearest[0]]) - p));
    if (d > gate) continue;
    if (owner[nearest[0]] < 0 || d < owner_d[nearest[0]]) {
      owner[nearest[0]] = r;
      owner_d[nearest[0]] = d;
    }
  }
  matched->clear();
  gr->clear();
  gq->clear();
  for (int q = 0; q < static_cast<int>(query.size()); ++q) {
    if (owner[q] < 0) continue;
    matched->emplace_back(q, owner[q]);
    gr->push_back(reference[owner[q]]);
    gq->push_back(query[q]);
  }
}

// RANSAC iterations of the neighbourhood pass's growing refits: a right page's matches are
// mostly right (60% need 38 for 99.5% confidence), and the wrong hypotheses, hundreds a
// view, are what would spend the rest.
constexpr int kNeighbourhoodRansacIterations = 50;
// Largest LlahOptions::n the neighbourhood pass handles.
constexpr int kMaxNeighbourhood = 16;

// ids (neighbours of `centre` in `points`) ordered by angle around it, as LLAH orders them.
void OrderByAngle(const std::vector<cv::Point2f> &points, const cv::Point2f &centre,
                  const std::vector<int> &ids, int *out) {
  std::array<std::pair<float, int>, kMaxNeighbourhood> by_angle;
  const int count = std::min<int>(static_cast<int>(ids.size()), kMaxNeighbourhood);
  for (int i = 0; i < count; ++i) {
    const cv::Point2f d = points[ids[i]] - centre;
    by_angle[i] = {std::atan2(d.y, d.x), ids[i]};
  }
  std::sort(by_angle.begin(), by_angle.begin() + count);
  for (int i = 0; i < count; ++i) out[i] = by_angle[i].second;
}

// The n points of points[begin, end) nearest to points[index] (which is among them),
// ordered by angle around it: a registered keypoint's neighbourhood in its own layer.
bool NearestByAngle(const std::vector<cv::Point2f> &points, size_t begin, size_t end, size_t index,
                    int n, int *out) {
  if (n > kMaxNeighbourhood || end - begin < static_cast<size_t>(n) + 1) return false;
  std::array<std::pair<float, int>, kMaxNeighbourhood + 1> nearest;
  int count = 0;
  const cv::Point2f p = points[index];
  for (size_t i = begin; i < end; ++i) {
    if (i == index) continue;
    const cv::Point2f d = points[i] - p;
    const float d2 = d.dot(d);
    if (count == n && d2 >= nearest[n - 1].first) continue;
    int k = count < n ? count++ : n - 1;
    while (k > 0 && nearest[k - 1].first > d2) {
      nearest[k] = nearest[k - 1];
      --k;
    }
    nearest[k] = {d2, static_cast<int>(i)};
  }
  std::vector<int> ids(n);
  for (int i = 0; i < n; ++i) ids[i] = nearest[i].second;
  OrderByAngle(points, p, ids, out);
  return true;
}

// Least-squares affine map of src onto dst (count pairs) and its rms residual; false when
// src is degenerate (collinear).
bool FitAffine(const cv::Point2f *src, const cv::Point2f *dst, int count, cv::Matx23d *A,
               double *rms) {
  cv::Point2d cs(0, 0), cd(0, 0);
  for (int i = 0; i < count; ++i) {
    cs += cv::Point2d(src[i]);
    cd += cv::Point2d(dst[i]);
  }
  cs *= 1.0 / count;
  cd *= 1.0 / count;
  double sxx = 0, sxy = 0, syy = 0, bxx = 0, bxy = 0, byx = 0, byy = 0;
  for (int i = 0; i < count; ++i) {
    const cv::Point2d a = cv::Point2d(src[i]) - cs, b = cv::Point2d(dst[i]) - cd;
    sxx += a.x * a.x;
    sxy += a.x * a.y;
    syy += a.y * a.y;
    bxx += a.x * b.x;
    bxy += a.y * b.x;
    byx += a.x * b.y;
    byy += a.y * b.y;
  }
  const double det = sxx * syy - sxy * sxy;
  if (!(det > 1e-9 * (sxx + syy) * (sxx + syy))) return false;
  // [a11 a12] solves [sxx sxy; sxy syy] [a11; a12] = [bxx; bxy]; likewise the second row.
  const double a11 = (syy * bxx - sxy * bxy) / det, a12 = (sxx * bxy - sxy * bxx) / det;
  const double a21 = (syy * byx - sxy * byy) / det, a22 = (sxx * byy - sxy * byx) / det;
  double sum = 0;
  for (int i = 0; i < count; ++i) {
    const cv::Point2d a = cv::Point2d(src[i]) - cs, b = cv::Point2d(dst[i]) - cd;
    const double ex = a11 * a.x + a12 * a.y - b.x, ey = a21 * a.x + a22 * a.y - b.y;
    sum += ex * ex + ey * ey;
  }
  *rms = std::sqrt(sum / count);
  *A = cv::Matx23d(a11, a12, cd.x - a11 * cs.x - a12 * cs.y, a21, a22,
                   cd.y - a21 * cs.x - a22 * cs.y);
  return true;
}

// The homography that a descriptor hit makes of two neighbourhoods. `dst`: the query
// keypoint then its m descriptor neighbours in order (on the view as described); `page`:
// the page keypoint then its n nearest in its own layer, ordered by angle. The page's
// keypoint lost one of its n (or none: then the query's m are n - 1 of them) and the
// cyclic start is unknown: the drop and the shift whose affine map fits best pair the two.
// False when that fit's rms is over max_residual times the query neighbourhood's mean
// radius, or its homography (to_query times the affine map) is not a plausible view.
bool PairNeighbourhoods(const cv::Point2f *dst, const cv::Point2f *page, int n, int m,
                        double max_residual, const cv::Matx33d &to_query, cv::Matx33d *H) {
  double spread = 0;
  for (int i = 1; i <= m; ++i) spread += cv::norm(dst[i] - dst[0]);
  spread /= m;
  cv::Point2f src[kMaxNeighbourhood + 1], best_src[kMaxNeighbourhood + 1];
  src[0] = page[0];
  double best_rms = std::numeric_limits<double>::infinity();
  cv::Matx23d best_affine;
  for (int drop = 0; drop < n; ++drop) {
    for (int shift = 0; shift < m; ++shift) {
      for (int i = 0, k = 0; i < n; ++i) {
        if (i == drop && n > m) continue;
        if (k < m) src[1 + (k + shift) % m] = page[1 + i];
        ++k;
      }
      cv::Matx23d affine;
      double rms;
      if (!FitAffine(src, dst, m + 1, &affine, &rms)) continue;
      if (rms < best_rms) {
        best_rms = rms;
        best_affine = affine;
        std::copy(src, src + m + 1, best_src);
      }
    }
    if (n == m) break;
  }
  if (!(best_rms <= max_residual * spread)) return false;
  const cv::Matx33d affine(best_affine(0, 0), best_affine(0, 1), best_affine(0, 2),
                           best_affine(1, 0), best_affine(1, 1), best_affine(1, 2), 0, 0, 1);
  *H = to_query * affine;
  return MakePlausibleHomography(H, std::vector<cv::Point2f>(best_src, best_src + m + 1));
}

// Grows a paired neighbourhood's homography H by guided matching of the page's base layer
// (its first `base` keypoints) within `threshold`: RANSAC refits while the matches grow
// (four rounds at most), then least-squares refits within a gate shrunk to the matches'
// spread. False when a round matches fewer than 8 keypoints; else `guided`, `gr` and `gq`
// are the matches of the final homography and gate (MatchProjected).
bool GrowNeighbourhood(const std::vector<cv::Point2f> &page, size_t base,
                       const std::vector<cv::Point2f> &query, const NeighborGrid &query_grid,
                       const cv::Rect &query_box, double threshold, cv::Matx33d *H,
                       std::vector<std::pair<int, int>> *guided, std::vector<cv::Point2f> *gr,
                       std::vector<cv::Point2f> *gq) {
  double gate = threshold;
  size_t grown = 0;
  for (int round = 0; round < 6; ++round) {
    MatchProjected(page, base, *H, gate, query, query_grid, query_box, nullptr, guided, gr, gq);
    if (guided->size() < 8) return false;
    // FitHomography's least squares converge where cv::findHomography's ten
    // Levenberg-Marquardt steps stop short, at a third of its time (round 32).
    cv::Matx33d rh;
    const bool fitted =
        round < 4 ? FitHomographyRansac(*gr, *gq, gate, kNeighbourhoodRansacIterations, &rh)
                  : FitHomography(*gr, *gq, &rh);
    if (!fitted) break;
    if (!MakePlausibleHomography(&rh, *gr)) break;
    *H = rh;
    if (round < 4 && guided->size() > grown) {
      grown = guided->size();
      continue;
    }
    gate = ShrunkGate(*H, *gr, *gq, threshold);
  }
  MatchProjected(page, base, *H, gate, query, query_grid, query_box, nullptr, guided, gr, gq);
  return true;
}

}  // namespace

double NeighboursLostToFrame(const cv::Point2f &p, float radius, int n, const cv::Size &frame) {
  if (!(radius > 0)) return 0;
  // Share of a disk beyond a line at distance d from its centre (a circular segment); the
  // edges are taken one at a time (at a corner the overlap is small).
  auto beyond = [&](double d) {
    const double c = std::clamp(d / radius, -1.0, 1.0);
    return (std::acos(c) - c * std::sqrt(1 - c * c)) / CV_PI;
  };
  const double share =
      beyond(p.x) + beyond(p.y) + beyond(frame.width - p.x) + beyond(frame.height - p.y);
  return n * std::min(1.0, share);
}

std::vector<char> CutByFrame(const std::vector<cv::Point2f> &points, const NeighborGrid &grid,
                             int n, const cv::Size &frame, double max_lost) {
  std::vector<char> cut(points.size(), 0);
  std::vector<int> nearest;
  for (size_t i = 0; i < points.size(); ++i) {
    grid.Nearest(static_cast<int>(i), n, &nearest);
    if (nearest.size() < static_cast<size_t>(n)) continue;
    const float r = static_cast<float>(cv::norm(points[i] - points[nearest.back()]));
    cut[i] = NeighboursLostToFrame(points[i], r, n, frame) >= max_lost;
  }
  return cut;
}

int LlahRetriever::MaxHitsPerDescriptor(const RetrievalOptions &o, size_t query_keypoints) const {
  return std::max<int>(
      o.max_hits_per_descriptor,
      StopWordLimit(static_cast<int>(o.max_hits_per_1000_documents * models_.size() / 1000),
                    static_cast<int>(query_keypoints), o.stop_word_keypoints));
}

std::vector<DocumentHit> LlahRetriever::Retrieve(
    const std::vector<cv::Point2f> &query, double query_char_height, const RetrievalOptions &o,
    RetrievalTrace *trace, std::optional<cv::Matx33d> *text_line_horizon) const {
  // Descriptors of a steep view are computed on its keypoints rectified to an affine image
  // of the page (text_perspective.h); positions stay the query's.
  std::optional<cv::Matx33d> rectification;
  if (o.rectify_perspective && query.size() >= 8)
    rectification = EstimateTextPerspective(query, o.perspective);
  // The few-keypoint pass (deep_max_keypoints) votes on the descriptors tried first.
  const bool deep =
      o.deep_max_keypoints > 0 && static_cast<int>(query.size()) <= o.deep_max_keypoints;
  // The last try of a view nothing found: rectified by its text lines (text_angle_rad).
  const auto by_text_lines = [&]() -> std::vector<DocumentHit> {
    if (!o.refine_perspective || !std::isfinite(o.text_angle_rad) ||
        static_cast<int>(query.size()) > o.refine_max_keypoints)
      return {};
    const auto refined =
        RefineTextPerspective(query, o.text_angle_rad, rectification, o.perspective);
    if (!refined) return {};
    if (text_line_horizon) *text_line_horizon = refined;
    return RetrieveDescribed(query, ApplyPerspective(*refined, query), query_char_height, o,
                             nullptr, deep);
  };
  if (!rectification) {
    auto plain = RetrieveDescribed(query, query, query_char_height, o, trace, deep);
    if (!plain.empty()) return plain;
    return by_text_lines();
  }
  RetrievalTrace rectified_trace;
  if (trace) rectified_trace.watch = trace->watch;
  rectified_trace.rectified = true;
  auto rectified =
      RetrieveDescribed(query, ApplyPerspective(*rectification, query), query_char_height, o,
                        trace ? &rectified_trace : nullptr, deep);
  const int rectified_inliers = rectified.empty() ? 0 : rectified[0].inliers;
  if (rectified_inliers < o.min_inliers && o.retry_unrectified) {
    // A spacing gradient that is the layout's (a figure, a heading, a column break) rather
    // than the camera's fools the fit, and a near-frontal view then loses descriptors it
    // had: weak or no evidence is checked against the view as seen.
    auto plain = RetrieveDescribed(query, query, query_char_height, o, trace);
    if (!plain.empty() && plain[0].inliers > rectified_inliers) return plain;
    if (plain.empty() && rectified.empty()) return by_text_lines();
  }
  if (trace) *trace = rectified_trace;
  return rectified;
}

std::vector<DocumentHit> LlahRetriever::RetrieveDescribed(const std::vector<cv::Point2f> &query,
                                                          const std::vector<cv::Point2f> &described,
                                                          double query_char_height,
                                                          const RetrievalOptions &o,
                                                          RetrievalTrace *trace,
                                                          bool allow_deep) const {
  std::vector<DocumentHit> results;
  if (trace) trace->query_keypoints = static_cast<int>(query.size());
  if (query.size() < 8) return results;
  NeighborGrid query_grid(query);
  std::vector<char> cut;
  if (o.max_border_lost > 0 && !o.frame.empty())
    cut = CutByFrame(query, query_grid, describer_.options().n, o.frame, o.max_border_lost);
  std::vector<uint64_t> hashes;
  describer_.DescribeWithProbes(described, o.query_probes, &hashes, cut.empty() ? nullptr : &cut);
  const int per = static_cast<int>(hashes.size() / query.size());

  std::unordered_map<uint32_t, std::shared_ptr<const Model>> candidates_models;
  // Per (document, query keypoint): the reference keypoint it hit most often, and how often.
  thread_local std::vector<Correspondence> best;
  std::vector<Candidate> ranked;
  // All hits, grouped by query keypoint (hit_begin[q] is where keypoint q's start).
  struct LocalHit {
    uint32_t document;
    uint16_t reference;
    bool operator<(const LocalHit &o) const {
      return document != o.document ? document < o.document : reference < o.reference;
    }
  };
  // Scratch kept per thread: a query's hits run to hundreds of thousands at 10,000 pages.
  // Filled through a pointer, field by field: push_back built each {document, reference} on
  // the stack with two narrow stores and copied it with one wide load, a store-forwarding
  // stall on every hit (a fifth of this function's time at 10,000 pages). Sized ahead and
  // never shrunk, so it is zeroed only when it grows; hit_count is the part in use.
  thread_local std::vector<LocalHit> hit_buffer;
  size_t hit_count = 0;
  std::vector<size_t> hit_begin(query.size() + 1, 0);
  // Pass 0 votes among the documents with most hits; pass 1, the few-keypoint pass
  // (deep_max_keypoints), when pass 0 found nothing, votes again on the same hits.
  for (int pass = 0; pass < (allow_deep ? 2 : 1); ++pass) {
    const bool deep = pass == 1;
    if (deep && !results.empty()) break;
    candidates_models.clear();
    best.clear();
    ranked.clear();
    {
      std::shared_lock lock(mutex_);
      if (pass == 0) {
        const int max_hits = MaxHitsPerDescriptor(o, query.size());
        for (size_t q = 0; q < query.size(); ++q) {
          hit_begin[q] = hit_count;
          for (int j = 0; j < per; ++j) {
            const uint64_t h = hashes[q * per + j];
            if (h == 0) continue;
            // Descriptors under more than max_hits entries are stop words: their hits are dropped.
            if (index_.LikelyExceeds(h, max_hits)) {
              if (trace) ++trace->stop_word_lookups;
              continue;
            }
            const size_t room = hit_count + static_cast<size_t>(max_hits) + 1;
            if (hit_buffer.size() < room) hit_buffer.resize(std::max(room, 2 * hit_buffer.size()));
            LocalHit *out = hit_buffer.data() + hit_count;
            const int found = index_.ForEachUpTo(h, max_hits, [&](uint32_t doc, uint16_t kp) {
              out->document = doc;
              out->reference = kp;
              ++out;
            });
            if (found > max_hits) {
              if (trace) ++trace->stop_word_lookups;
            } else {
              hit_count += static_cast<size_t>(found);
            }
          }
        }
        hit_begin[query.size()] = hit_count;
        if (trace) trace->total_hits = static_cast<int>(hit_count);
      }
      const LocalHit *hits = hit_buffer.data();
      // Only the documents with most hits go on (bounds the query time of large databases).
      // Raw hits favour long pages, which collect chance hits by the hundred, so the cut is
      // generous (256 pages) and the ranking below uses votes instead.
      VoteTally tally;
      for (size_t i = 0; i < hit_count; ++i) tally.AddHit(hits[i].document);
      const int floor = tally.HitFloor(deep ? o.deep_prefilter_documents : o.prefilter_documents);
      if (trace) trace->hits = tally.Get(trace->watch).hits;

      // Voting, one query keypoint at a time: its hits are few (at most per * max_hits), and
      // sorting them finds, per document, the reference keypoint most of its descriptors
      // agree on. Every document gets one vote per
      // query keypoint, and a strong vote when two or more descriptors agree on one reference
      // keypoint: a single hit is often chance (text is regular, so some arrangements recur on
      // every page), agreement rarely is.
      thread_local std::vector<LocalHit> local;
      std::vector<size_t> best_begin(query.size() + 1, 0);
      for (size_t q = 0; q < query.size(); ++q) {
        best_begin[q] = best.size();
        local.clear();
        for (size_t i = hit_begin[q]; i < hit_begin[q + 1]; ++i)
          if (tally.Get(hits[i].document).hits >= floor) local.push_back(hits[i]);
        std::sort(local.begin(), local.end());
        for (size_t i = 0; i < local.size();) {
          Correspondence c{local[i].document, static_cast<int>(q), 0, 0};
          size_t j = i;
          for (; j < local.size() && local[j].document == c.document;) {
            size_t run = j;
            while (run < local.size() && local[run].document == local[j].document &&
                   local[run].reference == local[j].reference)
              ++run;
            if (static_cast<int>(run - j) > c.count) {
              c.count = static_cast<int>(run - j);
              c.reference = local[j].reference;
            }
            j = run;
          }
          tally.AddVote(c.document, c.count >= 2);
          best.push_back(c);
          i = j;
        }
      }
      best_begin[query.size()] = best.size();
      // Coherence: a correspondence (q, r) of a page is confirmed when a neighbouring query
      // keypoint q' corresponds to a reference keypoint r' near r on the same page. The right
      // page's correspondences come in such pairs wherever a patch of text repeats; chance
      // hits, scattered over a page, rarely do. Each keypoint's correspondences are sorted by
      // document, so one merge per neighbouring pair finds the pages both hit.
      const int k = describer_.options().n;
      std::vector<char> confirmed(best.size(), 0);
      std::vector<int> nearest;
      for (size_t q = 0; q < query.size(); ++q) {
        query_grid.Nearest(static_cast<int>(q), k, &nearest);
        for (int q2 : nearest) {
          if (static_cast<size_t>(q2) < q) continue;  // each pair once
          size_t a = best_begin[q], b = best_begin[q2];
          const size_t a_end = best_begin[q + 1], b_end = best_begin[q2 + 1];
          while (a < a_end && b < b_end) {
            if (best[a].document < best[b].document) {
              ++a;
            } else if (best[b].document < best[a].document) {
              ++b;
            } else {
              if ((!confirmed[a] || !confirmed[b]) &&
                  tally.Get(best[a].document).votes >= o.min_votes) {
                const Model *model = FindModel(best[a].document);
                if (model != nullptr && best[a].reference != best[b].reference) {
                  const cv::Point2f d =
                      model->keypoints[best[a].reference] - model->keypoints[best[b].reference];
                  const float radius =
                      static_cast<float>(o.coherence_radius) * model->neighbour_radius;
                  if (d.dot(d) <= radius * radius) confirmed[a] = confirmed[b] = 1;
                }
              }
              ++a;
              ++b;
            }
          }
        }
      }
      for (size_t i = 0; i < best.size(); ++i)
        if (confirmed[i]) tally.AddCoherent(best[i].document);
      std::vector<int> scores;  // for the trace only
      tally.ForEach([&](uint32_t doc, const VoteTally::Count &n) {
        if (n.votes == 0) return;
        Candidate c{doc, n.votes, n.strong, n.coherent, {}};
        if (trace) {
          scores.push_back(c.Score());
          if (doc == trace->watch) {
            trace->votes = n.votes;
            trace->strong = n.strong;
            trace->coherent = n.coherent;
          }
        }
        if (n.votes >= o.min_votes &&
            n.strong >= (deep ? o.deep_min_strong_votes : o.min_strong_votes) &&
            n.coherent >= o.min_coherent_votes)
          ranked.push_back(std::move(c));
      });
      if (trace) {
        const Candidate mine{trace->watch, trace->votes, trace->strong, trace->coherent, {}};
        trace->rank_by_score = static_cast<int>(
            std::count_if(scores.begin(), scores.end(), [&](int s) { return s > mine.Score(); }));
      }
      std::sort(ranked.begin(), ranked.end(), [](const Candidate &a, const Candidate &b) {
        if (a.Score() != b.Score()) return a.Score() > b.Score();
        return a.document > b.document;
      });
      if (!ranked.empty()) {
        const double floor = o.candidate_vote_ratio * ranked.front().Score();
        while (!ranked.empty() && ranked.back().Score() < floor) ranked.pop_back();
      }
      if (trace) {
        trace->candidates = static_cast<int>(ranked.size());
        for (size_t r = 0; r < ranked.size(); ++r)
          if (ranked[r].document == trace->watch) trace->rank = static_cast<int>(r);
      }
      if (static_cast<int>(ranked.size()) > o.max_candidates) ranked.resize(o.max_candidates);
      for (const Candidate &c : ranked) {
        auto it = models_.find(c.document);
        if (it != models_.end()) candidates_models[c.document] = it->second;
      }
    }
    // The candidates' correspondences, in query keypoint order.
    for (const Correspondence &c : best)
      for (Candidate &candidate : ranked)
        if (candidate.document == c.document) {
          candidate.correspondences.push_back(c);
          break;
        }

    const double threshold = InlierThreshold(o, query_char_height);
    const int min_weak = deep ? o.deep_min_weak_inliers : o.min_weak_inliers;
    std::vector<char> used(query.size(), 0);
    const cv::Rect query_box = cv::boundingRect(query);  // whole pixels around every point
    std::vector<cv::Point2f> query_hull;                 // computed when a layout check needs it
    for (const Candidate &candidate : ranked) {
      const uint32_t doc = candidate.document;
      auto mit = candidates_models.find(doc);
      if (mit == candidates_models.end()) continue;
      const Model &model = *mit->second;
      std::vector<cv::Point2f> ref_pts, query_pts;
      std::vector<std::pair<int, int>> pairs;
      std::vector<int> strength;
      for (const Correspondence &c : candidate.correspondences) {
        if (used[c.query] || c.reference >= model.keypoints.size()) continue;
        ref_pts.push_back(model.keypoints[c.reference]);
        query_pts.push_back(query[c.query]);
        pairs.emplace_back(c.query, c.reference);
        strength.push_back(c.count);
      }
      if (static_cast<int>(pairs.size()) < min_weak) continue;
      // The few-keypoint pass tries every 4-subset of few correspondences (below).
      const bool exhaustive = deep && static_cast<int>(pairs.size()) <= kMaxExhaustivePairs;
      cv::Matx33d H = cv::Matx33d::eye();
      if (!exhaustive) {
        // PROSAC: correspondences ordered by how many descriptors agree on them, so that
        // hypotheses come from the likeliest inliers first and a good model stops the search
        // early; hopeless candidates still cost at most ransac_iterations.
        std::vector<int> order(pairs.size());
        std::iota(order.begin(), order.end(), 0);
        std::stable_sort(order.begin(), order.end(),
                         [&](int a, int b) { return strength[a] > strength[b]; });
        std::vector<cv::Point2f> sample_ref, sample_query;
        for (int i : order) {
          sample_ref.push_back(ref_pts[i]);
          sample_query.push_back(query_pts[i]);
        }
        if (!FitHomographyProsac(sample_ref, sample_query, threshold, o.ransac_iterations, &H))
          continue;
      }
      auto inliers_of = [&](const cv::Matx33d &h, std::vector<std::pair<int, int>> *inlier_pairs,
                            std::vector<cv::Point2f> *inlier_ref) {
        inlier_pairs->clear();
        inlier_ref->clear();
        for (size_t i = 0; i < pairs.size(); ++i) {
          const cv::Point2d p = ApplyHomography(h, ref_pts[i]);
          if (cv::norm(p - cv::Point2d(query_pts[i])) <= threshold) {
            inlier_ref->push_back(ref_pts[i]);
            inlier_pairs->push_back(pairs[i]);
          }
        }
      };
      // LLAH correspondences that `h` puts within the threshold.
      auto count_inliers = [&](const cv::Matx33d &h) {
        int n = 0;
        for (size_t i = 0; i < pairs.size(); ++i)
          n += cv::norm(ApplyHomography(h, ref_pts[i]) - cv::Point2d(query_pts[i])) <= threshold;
        return n;
      };
      std::vector<cv::Point2f> inlier_ref;
      std::vector<std::pair<int, int>> inlier_pairs;
      if (!exhaustive) inliers_of(H, &inlier_pairs, &inlier_ref);
      const bool traced = trace && doc == trace->watch;
      if (traced && !exhaustive) trace->ransac_inliers = static_cast<int>(inlier_pairs.size());

      // Every page keypoint that `h` puts within `gate` of a free query keypoint, each query
      // keypoint taken by the nearest one: (query, page) pairs and their points.
      auto match_at = [&](const cv::Matx33d &h, double gate,
                          std::vector<std::pair<int, int>> *matched, std::vector<cv::Point2f> *gr,
                          std::vector<cv::Point2f> *gq) {
        MatchProjected(model.keypoints, model.base, h, gate, query, query_grid, query_box, &used,
                       matched, gr, gq);
      };
      // Guided refinement: every reference keypoint projected by H takes the
      // nearest free query keypoint within the threshold; the homography is
      // refitted on those matches. (Their number alone is no evidence: projected text
      // lands near some word by chance too often. Only the layout check below uses them,
      // as a share of the page in view, which chance alignments do not reach.)
      // The gate starts at the RANSAC threshold and then shrinks to a few times the median
      // residual, so that extra keypoints a few pixels from a projected word stop pulling the
      // least-squares refit.
      auto refine_from = [&](cv::Matx33d *h, const std::vector<std::pair<int, int>> &agreeing) {
        std::vector<std::pair<int, int>> guided;
        double gate = threshold;
        size_t grown = 0;  // matches of the last round at the full gate
        int shrunk = 0;    // rounds since the gate began to shrink
        for (int round = 0; round < o.guided_growth_rounds + 3; ++round) {
          std::vector<std::pair<int, int>> previous;
          previous.swap(guided);
          std::vector<cv::Point2f> gr, gq;
          match_at(*h, gate, &guided, &gr, &gq);
          if (guided.size() < agreeing.size() || guided.size() < 8) {
            guided = agreeing;
            break;
          }
          // Growth rounds refit robustly: the full gate lets wrong matches in.
          const bool growing = round > 0 && shrunk == 0;
          cv::Mat refined = growing
                                ? cv::findHomography(gr, gq, cv::RANSAC, gate, cv::noArray(), 200)
                                : cv::findHomography(gr, gq, 0);
          if (refined.empty()) break;
          cv::Matx33d refined_h(refined);
          if (!MakePlausibleHomography(&refined_h, gr)) break;
          // A refit of a growing match set must keep the consensus it started from: wrong
          // matches gathered at the full gate in a noisy view would otherwise pull it away,
          // round by round. Then the last refit that kept it stands.
          if (growing) {
            size_t kept = 0;
            for (const auto &[qi, ri] : agreeing)
              kept += cv::norm(ApplyHomography(refined_h, model.keypoints[ri]) -
                               cv::Point2d(query[qi])) <= threshold;
            if (kept * 5 < agreeing.size() * 4) {
              guided = std::move(previous);
              break;
            }
          }
          *h = refined_h;
          // While the matches still grow at the full gate, the refit homography reaches
          // further from the consensus it started from: keep growing. Then shrink.
          if (shrunk == 0 && guided.size() > grown &&
              guided.size() < 2 * static_cast<size_t>(o.min_layout_matches) &&
              round < o.guided_growth_rounds) {
            grown = guided.size();
            continue;
          }
          if (++shrunk > 2) break;  // two refits at the shrunk gate
          gate = ShrunkGate(*h, gr, gq, threshold);
        }
        return guided;
      };
      // A consensus along one line (a column of figures, a line of large type) leaves the
      // homography free across it, and guided matching from it finds little beyond the
      // line. A similarity (rotation, scale, shift) fitted to the same pairs extrapolates
      // soundly from two points: when the homography's matches stay few and the consensus
      // lies along a line, guided matching also starts from it, and the larger match set
      // (and its refit homography) is kept.
      auto refine = [&](cv::Matx33d *h, const std::vector<std::pair<int, int>> &agreeing) {
        std::vector<std::pair<int, int>> guided = refine_from(h, agreeing);
        if (!o.guided_similarity_start ||
            guided.size() >= static_cast<size_t>(o.min_layout_matches) || agreeing.size() < 2)
          return guided;
        std::vector<cv::Point2f> r, q;
        for (const auto &[qi, ri] : agreeing) {
          r.push_back(model.keypoints[ri]);
          q.push_back(query[qi]);
        }
        // Only a consensus along a line: its spread across it under a quarter of its spread
        // along it (a chance consensus on a wrong page seldom is, and costs no second try).
        cv::Mat cloud(static_cast<int>(r.size()), 2, CV_32F, r.data());
        cv::Mat covariance, mean;
        cv::calcCovarMatrix(cloud, covariance, mean, cv::COVAR_NORMAL | cv::COVAR_ROWS);
        cv::Mat spread;
        cv::eigen(covariance, spread);
        if (!(spread.at<double>(1) < 0.0625 * spread.at<double>(0))) return guided;
        const cv::Mat similarity = cv::estimateAffinePartial2D(r, q, cv::noArray(), cv::LMEDS);
        if (similarity.empty()) return guided;
        const cv::Mat_<double> m(similarity);
        cv::Matx33d start(m(0, 0), m(0, 1), m(0, 2), m(1, 0), m(1, 1), m(1, 2), 0, 0, 1);
        std::vector<std::pair<int, int>> other = refine_from(&start, agreeing);
        if (other.size() > guided.size()) {
          *h = start;
          guided = std::move(other);
        }
        return guided;
      };
      std::vector<std::pair<int, int>> guided;
      int hypotheses = 0;  // homographies refined, when more than RANSAC's one
      if (exhaustive) {
        // Few correspondences, few of them right: RANSAC's largest consensus may be a chance
        // one as large as the right one. Every consensus set of min_weak or more that a
        // 4-subset spans is refined, and the one whose homography puts most of the page on
        // query keypoints is kept.
        std::vector<uint32_t> masks;
        const int np = static_cast<int>(pairs.size());
        cv::Point2f src[4], dst[4];
        for (int a = 0; a < np; ++a)
          for (int b = a + 1; b < np; ++b)
            for (int c = b + 1; c < np; ++c)
              for (int d = c + 1; d < np; ++d) {
                const int idx[4] = {a, b, c, d};
                for (int t = 0; t < 4; ++t) {
                  src[t] = ref_pts[idx[t]];
                  dst[t] = query_pts[idx[t]];
                }
                // Three collinear points leave the system singular: solved as zeros.
                const cv::Matx33d h(cv::getPerspectiveTransform(src, dst));
                if (std::abs(cv::determinant(h)) < 1e-12) continue;
                uint32_t m = 0;
                int count = 0;
                for (int i = 0; i < np; ++i) {
                  const cv::Point2d p = ApplyHomography(h, ref_pts[i]);
                  if (std::isfinite(p.x) && cv::norm(p - cv::Point2d(query_pts[i])) <= threshold) {
                    m |= 1u << i;
                    ++count;
                  }
                }
                if (count >= min_weak) masks.push_back(m);
              }
        std::sort(masks.begin(), masks.end());
        masks.erase(std::unique(masks.begin(), masks.end()), masks.end());
        std::vector<uint32_t> maximal;
        for (uint32_t m : masks) {
          bool is_maximal = true;
          for (uint32_t other : masks) is_maximal = is_maximal && (other == m || (other & m) != m);
          if (is_maximal) maximal.push_back(m);
        }
        // The largest consensus sets first; at most kMaxDeepHypotheses are refined.
        std::stable_sort(maximal.begin(), maximal.end(), [](uint32_t a, uint32_t b) {
          return __builtin_popcount(a) > __builtin_popcount(b);
        });
        if (maximal.size() > static_cast<size_t>(kMaxDeepHypotheses))
          maximal.resize(kMaxDeepHypotheses);
        size_t best_guided = 0;
        for (uint32_t m : maximal) {
          ++hypotheses;
          std::vector<cv::Point2f> r, q;
          std::vector<std::pair<int, int>> agreeing;
          for (int i = 0; i < np; ++i)
            if (m >> i & 1) {
              r.push_back(ref_pts[i]);
              q.push_back(query_pts[i]);
              agreeing.push_back(pairs[i]);
            }
          cv::Mat fitted = cv::findHomography(r, q, 0);
          if (fitted.empty()) continue;
          cv::Matx33d h(fitted);
          if (!MakePlausibleHomography(&h, r)) continue;
          std::vector<std::pair<int, int>> g = refine(&h, agreeing);
          if (g.size() > best_guided) {
            best_guided = g.size();
            H = h;
            guided = std::move(g);
            inlier_pairs = agreeing;
          }
        }
        if (best_guided == 0) continue;
        if (traced) trace->ransac_inliers = static_cast<int>(inlier_pairs.size());
      } else {
        if (static_cast<int>(inlier_pairs.size()) < min_weak) continue;
        if (!MakePlausibleHomography(&H, inlier_ref)) continue;
        guided = refine(&H, inlier_pairs);
      }
      // Re-count LLAH inliers under the final homography.
      int inliers = count_inliers(H);
      if (traced) {
        trace->final_inliers = inliers;
        trace->guided = static_cast<int>(guided.size());
      }
      if (inliers < min_weak) continue;
      if (inliers < o.min_inliers) {
        if (query_hull.empty()) cv::convexHull(query, query_hull);
        // The a-contrario test counts the inliers of both homographies (RANSAC's, from the
        // correspondences alone, and the guided refit's), whichever is fewer, and every
        // candidate verified as a separate chance. The homography must also put more of the
        // page's keypoints onto query keypoints than chance does: few inliers in one corner
        // can be the right page under a homography wrong elsewhere.
        const int agreed = std::min(inliers, static_cast<int>(inlier_pairs.size()));
        const int matched = static_cast<int>(guided.size());
        const bool significant = o.max_weak_nfa > 0 && agreed >= o.min_weak_inliers &&
                                 WeakMatchLog10Nfa(static_cast<int>(pairs.size()), agreed,
                                                   threshold, cv::contourArea(query_hull)) +
                                         std::log10(static_cast<double>(o.max_candidates)) <=
                                     std::log10(o.max_weak_nfa);
        // Fewer LLAH inliers than the first pass's gate (the few-keypoint pass): the layout
        // alone decides, with every homography tried counted as a chance.
        const bool layout_only = inliers < o.min_weak_inliers;
        if (!LayoutConfirms(model.keypoints, model.base, H, query_hull, matched, o,
                            layout_only   ? o.deep_min_layout_ratio
                            : significant ? o.min_significant_layout_ratio
                                          : o.min_layout_ratio,
                            layout_only ? std::max(1, hypotheses) : 0,
                            traced ? &trace->layout_inside : nullptr))
          continue;
      }
      if (traced) trace->accepted = true;
      // The robust refit (RetrievalOptions::polish_homography): the guided refits above are
      // least squares, which a few wrong matches far from the rest can pull off; the
      // refit is kept only when more of the page then lands on query keypoints.
      if (o.polish_homography && guided.size() >= 8) {
        const double gate = o.polish_gate * threshold;
        std::vector<cv::Point2f> gr, gq;
        // Page keypoints within the gate of a query keypoint, now and for each refit (gr, gq
        // are scratch here).
        std::vector<std::pair<int, int>> before, after;
        match_at(H, gate, &before, &gr, &gq);
        size_t best = before.size();
        const cv::Matx33d to_page = H.inv();
        cv::Matx33d best_h = H;
        std::vector<std::pair<int, int>> best_guided;
        // Two match sets to refit on: the guided matches, and (polish_match_gate) every page
        // keypoint near a query keypoint, which reaches past the guided matches' region.
        for (int set = 0; set < (o.polish_match_gate > 0 ? 2 : 1); ++set) {
          gr.clear();
          gq.clear();
          if (set == 0) {
            for (const auto &[qi, ri] : guided) {
              gr.push_back(model.keypoints[ri]);
              gq.push_back(query[qi]);
            }
          } else {
            std::vector<std::pair<int, int>> wide;
            match_at(H, o.polish_match_gate * threshold, &wide, &gr, &gq);
            if (gr.size() < 8) continue;
          }
          const cv::Mat robust =
              cv::findHomography(gr, gq, cv::RANSAC, gate, cv::noArray(), kPolishIterations);
          if (robust.empty()) continue;
          cv::Matx33d polished(robust);
          // How far the robust fit moves the corners of the view.
          double moved = 0;
          for (const cv::Point2d corner :
               {cv::Point2d(query_box.x, query_box.y), cv::Point2d(query_box.br().x, query_box.y),
                cv::Point2d(query_box.x, query_box.br().y), cv::Point2d(query_box.br())}) {
            moved = std::max(
                moved,
                cv::norm(ApplyHomography(polished, ApplyHomography(to_page, corner)) - corner));
          }
          if (moved <= kPolishMinMove * gate || !MakePlausibleHomography(&polished, gr)) continue;
          // The wider set's refit must keep half the guided matches within the inlier
          // threshold: chance pairs in a dense part of the view can outnumber them, and a
          // refit on those keeps none (a test's cut of another layer: 1 of 37). Across a
          // figure it keeps most (page 7027: 61 of 97, the rest being the extrapolated side).
          if (set == 1) {
            int held = 0, held_before = 0;
            for (const auto &[qi, ri] : guided) {
              const cv::Point2d q(query[qi].x, query[qi].y);
              held += cv::norm(ApplyHomography(polished, model.keypoints[ri]) - q) < threshold;
              held_before += cv::norm(ApplyHomography(H, model.keypoints[ri]) - q) < threshold;
            }
            if (2 * held < held_before) continue;
          }
          std::vector<std::pair<int, int>> regrown = refine(&polished, inlier_pairs);
          match_at(polished, gate, &after, &gr, &gq);
          if (after.size() > best) {
            best = after.size();
            best_h = polished;
            best_guided = std::move(regrown);
          }
        }
        if (best > before.size()) {
          H = best_h;
          guided = std::move(best_guided);
          inliers = count_inliers(H);
        }
      }
      DocumentHit hit;
      hit.document = doc;
      // h22 = +-1, keeping the sign that puts the matched points in front of the camera.
      hit.homography = H * (1.0 / std::abs(H(2, 2)));
      hit.inliers = inliers;
      hit.votes = candidate.votes;
      hit.matches = std::move(guided);
      for (const auto &[q, r] : hit.matches) used[q] = 1;
      // A hit whose guided matching fell back to its LLAH inliers may pair query keypoints
      // with extra layers' keypoints: they claim their query keypoints (above), but matches
      // index the base layer only, as Keypoints() returns it.
      const int base = static_cast<int>(model.base);
      hit.matches.erase(
          std::remove_if(hit.matches.begin(), hit.matches.end(),
                         [base](const std::pair<int, int> &m) { return m.second >= base; }),
          hit.matches.end());
      results.push_back(std::move(hit));
      if (o.max_results > 0 && static_cast<int>(results.size()) >= o.max_results) break;
    }
  }
  std::sort(results.begin(), results.end(),
            [](const DocumentHit &a, const DocumentHit &b) { return a.inliers > b.inliers; });
  return results;
}

std::vector<LlahRetriever::NeighbourhoodHypothesis> LlahRetriever::NeighbourhoodHypotheses(
    const std::vector<uint64_t> &hashes, size_t query_keypoints, int variants,
    const RetrievalOptions &o) const {
  const int per = static_cast<int>(hashes.size() / query_keypoints);
  std::vector<NeighbourhoodHypothesis> hypotheses;
  const int max_hits = MaxHitsPerDescriptor(o, query_keypoints);
  for (size_t q = 0; q < query_keypoints; ++q)
    for (int j = 0; j < per; ++j) {
      const uint64_t h = hashes[q * per + j];
      if (h == 0 || index_.LikelyExceeds(h, max_hits)) continue;
      const size_t before = hypotheses.size();
      const int found = index_.ForEachUpTo(h, max_hits, [&](uint32_t doc, uint16_t kp) {
        hypotheses.push_back({doc, kp, static_cast<int>(q), j / variants});
      });
      if (found > max_hits) hypotheses.resize(before);
    }
  std::sort(hypotheses.begin(), hypotheses.end(),
            [](const NeighbourhoodHypothesis &a, const NeighbourhoodHypothesis &b) {
              return std::tie(a.document, a.query, a.reference) <
                     std::tie(b.document, b.query, b.reference);
            });
  hypotheses.erase(
      std::unique(hypotheses.begin(), hypotheses.end(),
                  [](const NeighbourhoodHypothesis &a, const NeighbourhoodHypothesis &b) {
                    return a.document == b.document && a.query == b.query &&
                           a.reference == b.reference;
                  }),
      hypotheses.end());
  // Pages with most hits for their size first: chance hits grow with a page's keypoints
  // (a long page collects them by the dozen), the right page's come from the
  // neighbourhoods that survived. On the 10,000-page views the right page's hits came
  // within the first 14-360 hypotheses of 7,000-69,000 in the passes that found it (behind
  // 8,000-33,000 ranked by hits alone), but for page 3787, lost with a cap of 1,000.
  if (static_cast<int>(hypotheses.size()) > o.neighbourhood_max_hypotheses) {
    struct Run {
      double score;
      size_t first, count;
    };
    std::vector<Run> runs;
    for (size_t i = 0; i < hypotheses.size();) {
      size_t j = i;
      while (j < hypotheses.size() && hypotheses[j].document == hypotheses[i].document) ++j;
      const Model *model = FindModel(hypotheses[i].document);
      if (model != nullptr && !model->keypoints.empty())
        runs.push_back({static_cast<double>(j - i) / model->keypoints.size(), i, j - i});
      i = j;
    }
    std::stable_sort(runs.begin(), runs.end(),
                     [](const Run &a, const Run &b) { return a.score > b.score; });
    std::vector<NeighbourhoodHypothesis> kept;
    for (const Run &run : runs) {
      if (kept.size() + run.count > static_cast<size_t>(o.neighbourhood_max_hypotheses)) break;
      kept.insert(kept.end(), hypotheses.begin() + run.first,
                  hypotheses.begin() + run.first + run.count);
    }
    hypotheses.swap(kept);
  }
  return hypotheses;
}

int LlahRetriever::AgreeingHits(const std::vector<NeighbourhoodHypothesis> &hypotheses,
                                uint32_t document, const std::vector<cv::Point2f> &page,
                                const cv::Matx33d &H, const std::vector<cv::Point2f> &query,
                                double threshold) {
  std::vector<int> agreeing;
  for (const NeighbourhoodHypothesis &h : hypotheses) {
    if (h.document != document || h.reference >= page.size()) continue;
    if (cv::norm(ApplyHomography(H, page[h.reference]) - cv::Point2d(query[h.query])) <= threshold)
      agreeing.push_back(static_cast<int>(h.query));
  }
  std::sort(agreeing.begin(), agreeing.end());
  return static_cast<int>(std::unique(agreeing.begin(), agreeing.end()) - agreeing.begin());
}

std::vector<DocumentHit> LlahRetriever::RetrieveByNeighbourhoods(
    const std::vector<cv::Point2f> &query, double query_char_height, const RetrievalOptions &o,
    RetrievalTrace *trace) const {
  std::vector<DocumentHit> results;
  const int n = describer_.options().n, m = describer_.options().m;
  if (static_cast<int>(query.size()) <= n || o.neighbourhood_max_hypotheses <= 0) return results;
  // Descriptors on the view rectified as Retrieve() rectifies it: by the text lines when
  // asked to (refine_perspective), else by the keypoint spacing.
  std::optional<cv::Matx33d> rectification;
  if (o.rectify_perspective) rectification = EstimateTextPerspective(query, o.perspective);
  if (o.refine_perspective && std::isfinite(o.text_angle_rad)) {
    const auto refined =
        RefineTextPerspective(query, o.text_angle_rad, rectification, o.perspective);
    if (refined) rectification = refined;
  }
  const std::vector<cv::Point2f> described =
      rectification ? ApplyPerspective(*rectification, query) : query;
  const cv::Matx33d to_query = rectification ? rectification->inv() : cv::Matx33d::eye();
  NeighborGrid query_grid(query);
  NeighborGrid described_grid(described);
  std::vector<char> cut;
  if (o.max_border_lost > 0 && !o.frame.empty())
    cut = CutByFrame(query, query_grid, n, o.frame, o.max_border_lost);
  std::vector<uint64_t> hashes;
  describer_.DescribeWithProbes(described, o.query_probes, &hashes, cut.empty() ? nullptr : &cut);
  const int variants = 1 << std::clamp(o.query_probes, 0, LlahDescriber::kMaxProbes);
  // Each query keypoint's n neighbours (in the view rectified as described), by angle.
  std::vector<int> query_neighbours(query.size() * n, -1);
  {
    std::vector<int> ids;
    for (int q = 0; q < static_cast<int>(query.size()); ++q) {
      described_grid.Nearest(q, n, &ids);
      if (static_cast<int>(ids.size()) == n)
        OrderByAngle(described, described[q], ids, &query_neighbours[q * n]);
    }
  }
  std::shared_lock lock(mutex_);
  const std::vector<NeighbourhoodHypothesis> hypotheses =
      NeighbourhoodHypotheses(hashes, query.size(), variants, o);
  if (trace) trace->neighbourhood_hypotheses = static_cast<int>(hypotheses.size());
  const double threshold = InlierThreshold(o, query_char_height);
  const cv::Rect query_box = cv::boundingRect(query);
  std::vector<cv::Point2f> query_hull;
  cv::convexHull(query, query_hull);
  int best_tight = 0;
  DocumentHit best_hit;
  // The fewest tight matches that may find a page (with agreeing hits).
  const int min_tight =
      o.neighbourhood_min_tight_agreeing > 0
          ? std::min(o.neighbourhood_min_tight, o.neighbourhood_min_tight_agreeing)
          : o.neighbourhood_min_tight;
  for (const NeighbourhoodHypothesis &hyp : hypotheses) {
    const int *qn = &query_neighbours[hyp.query * n];
    if (qn[0] < 0) continue;
    const Model *model = FindModel(hyp.document);
    if (model == nullptr || hyp.reference >= model->keypoints.size()) continue;
    // The reference keypoint's layer: its neighbours are those of its own cut.
    size_t begin = 0, end = model->base, layer_index = 0;
    while (hyp.reference >= end && layer_index < model->extra_layers.size()) {
      begin = end;
      end += model->extra_layers[layer_index++];
    }
    int rn[kMaxNeighbourhood];
    if (!NearestByAngle(model->keypoints, begin, end, hyp.reference, n, rn)) continue;
    cv::Point2f dst[kMaxNeighbourhood + 1], page[kMaxNeighbourhood + 1];
    const std::vector<int> &positions = describer_.subset(hyp.subset);
    dst[0] = described[hyp.query];
    for (int i = 0; i < m; ++i) dst[1 + i] = described[qn[positions[i]]];
    page[0] = model->keypoints[hyp.reference];
    for (int i = 0; i < n; ++i) page[1 + i] = model->keypoints[rn[i]];
    cv::Matx33d H;
    if (!PairNeighbourhoods(dst, page, n, m, o.neighbourhood_max_residual, to_query, &H)) continue;
    std::vector<std::pair<int, int>> guided;
    std::vector<cv::Point2f> gr, gq;
    if (!GrowNeighbourhood(model->keypoints, model->base, query, query_grid, query_box, threshold,
                           &H, &guided, &gr, &gq))
      continue;
    // A right page's matches sit within a pixel or so of the refit homography; a wrong page
    // whose text happens to align leaves them spread over the gate.
    int tight = 0;
    for (size_t i = 0; i < gr.size(); ++i)
      tight += cv::norm(ApplyHomography(H, gr[i]) - cv::Point2d(gq[i])) <=
               o.neighbourhood_tight_gate * threshold;
    if (trace == nullptr && (tight < min_tight || tight <= best_tight)) continue;
    // The page's keypoints the homography puts among the query's (the share's denominator).
    const int inside = InsideHull(model->keypoints, model->base, H, query_hull);
    // Enough tight matches on their own: many, or fewer over most of the view.
    const bool alone = tight >= o.neighbourhood_min_tight_wide ||
                       (tight >= o.neighbourhood_min_tight &&
                        tight >= o.neighbourhood_min_tight_share_close * inside);
    // Agreeing hits are counted only where they can decide (or for the trace).
    int agreeing = -1;
    if (trace ||
        (!alone && tight >= min_tight && tight >= o.neighbourhood_min_tight_share * inside))
      agreeing = AgreeingHits(hypotheses, hyp.document, model->keypoints, H, query, threshold);
    if (trace) {
      const bool watched = hyp.document == trace->watch;
      int &bm = watched ? trace->neighbourhood_tight : trace->neighbourhood_other_tight;
      int &bi = watched ? trace->neighbourhood_inside : trace->neighbourhood_other_inside;
      int &ba = watched ? trace->neighbourhood_agreeing : trace->neighbourhood_other_agreeing;
      if (tight > bm) {
        bm = tight;
        bi = inside;
        ba = agreeing;
      }
    }
    const bool enough =
        alone || (tight >= min_tight && agreeing >= o.neighbourhood_min_agreeing_hits);
    if (!enough || tight < o.neighbourhood_min_tight_share * inside || tight <= best_tight)
      continue;
    best_tight = tight;
    best_hit.document = hyp.document;
    best_hit.homography = H * (1.0 / std::abs(H(2, 2)));
    best_hit.inliers = tight;  // the tightly matched keypoints: the evidence here
    best_hit.matches = guided;
  }
  if (best_tight > 0) {
    // Votes: the query keypoints whose descriptors hit the page.
    std::vector<int> voters;
    for (const NeighbourhoodHypothesis &hyp : hypotheses)
      if (hyp.document == best_hit.document) voters.push_back(hyp.query);
    std::sort(voters.begin(), voters.end());
    best_hit.votes = static_cast<int>(std::unique(voters.begin(), voters.end()) - voters.begin());
    results.push_back(std::move(best_hit));
  }
  return results;
}

}  // namespace texfree
