// LlahRetriever implementation: voting, candidate selection, RANSAC and guided
// refinement.
#include "common/llah_retriever.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <mutex>
#include <numeric>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <thread>
#include <unordered_set>

#include "absl/strings/str_cat.h"
#include "common/neighbor_grid.h"
#include "common/planar_pose.h"

namespace texfree {

absl::Status RetrievalOptions::Validate() const {
  if (max_hits_per_descriptor < 1)
    return absl::InvalidArgumentError("max_hits_per_descriptor must be >= 1");
  if (max_hits_per_1000_documents < 0)
    return absl::InvalidArgumentError("max_hits_per_1000_documents must be >= 0");
  if (prefilter_documents < 0)
    return absl::InvalidArgumentError("prefilter_documents must be >= 0 (0 keeps all)");
  if (query_probes < 0 || query_probes > LlahDescriber::kMaxProbes)
    return absl::InvalidArgumentError(absl::StrCat(
        "query_probes must be in [0, ", LlahDescriber::kMaxProbes, "], got ", query_probes));
  if (min_votes < 4) return absl::InvalidArgumentError("min_votes must be >= 4");
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
  if (min_layout_ratio <= 0.25 || min_layout_ratio > 1)
    return absl::InvalidArgumentError(absl::StrCat(
        "min_layout_ratio must be in (0.25, 1] (chance alignments of text reach ~0.2), got ",
        min_layout_ratio));
  if (max_results < 0) return absl::InvalidArgumentError("max_results must be >= 0");
  return absl::OkStatus();
}

LlahRetriever::LlahRetriever(LlahOptions options, InvariantQuantizer quantizer, int log2_buckets)
    : describer_(options, std::move(quantizer)), index_(log2_buckets) {}

absl::Status LlahRetriever::AddDocument(DocumentKeypoints document) {
  if (document.keypoints.size() > 65535)
    return absl::InvalidArgumentError(absl::StrCat("document has ", document.keypoints.size(),
                                                   " keypoints; at most 65535 are indexed"));
  std::vector<uint64_t> hashes = std::move(document.hashes);
  if (hashes.size() != document.keypoints.size() * describer_.descriptors_per_point())
    describer_.Describe(document.keypoints, &hashes);
  auto model = std::make_shared<Model>(Model{std::move(document.keypoints), document.size});
  std::unique_lock lock(mutex_);
  if (models_.count(document.id))
    return absl::AlreadyExistsError(absl::StrCat("document ", document.id, " is already indexed"));
  index_.Add(document.id, hashes, describer_.descriptors_per_point());
  models_.emplace(document.id, std::move(model));
  return absl::OkStatus();
}

absl::Status LlahRetriever::AddDocuments(
    std::vector<DocumentKeypoints> documents, int threads,
    const std::function<void(size_t, size_t)> &progress,
    const std::function<void(uint32_t, const std::vector<uint64_t> &)> &computed) {
  const size_t total = documents.size();
  size_t total_points = 0;
  for (const auto &d : documents) {
    if (d.keypoints.size() > 65535)
      return absl::InvalidArgumentError(absl::StrCat("document ", d.id, " has too many keypoints"));
    total_points += d.keypoints.size();
  }
  {
    std::unique_lock lock(mutex_);
    index_.Reserve(index_.entries() + total_points * describer_.descriptors_per_point());
  }
  // Workers compute the descriptors that are not stored; then one bucket-ordered load.
  std::atomic<size_t> next{0}, done{0};
  std::mutex callback_mutex;
  const size_t per = static_cast<size_t>(describer_.descriptors_per_point());
  auto work = [&]() {
    while (true) {
      const size_t i = next.fetch_add(1);
      if (i >= total) return;
      DocumentKeypoints &d = documents[i];
      if (d.hashes.size() != d.keypoints.size() * per) {
        describer_.Describe(d.keypoints, &d.hashes);
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

  std::unique_lock lock(mutex_);
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
  index_.AddBatch(batch, static_cast<int>(per));
  for (size_t i = 0; i < documents.size(); ++i) {
    if (!added[i]) continue;
    DocumentKeypoints &d = documents[i];
    models_.emplace(d.id, std::make_shared<Model>(Model{std::move(d.keypoints), d.size}));
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
  describer_.Describe(model->keypoints, &hashes);
  std::unique_lock lock(mutex_);
  if (!models_.erase(id)) return false;
  index_.Remove(id, hashes, describer_.descriptors_per_point());
  return true;
}

bool LlahRetriever::Contains(uint32_t id) const {
  std::shared_lock lock(mutex_);
  return models_.count(id) > 0;
}

std::vector<cv::Point2f> LlahRetriever::Keypoints(uint32_t id) const {
  std::shared_lock lock(mutex_);
  auto it = models_.find(id);
  return it == models_.end() ? std::vector<cv::Point2f>{} : it->second->keypoints;
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

struct Hit {
  uint32_t document;
  int query;
  uint16_t reference;
  bool operator<(const Hit &o) const {
    if (document != o.document) return document < o.document;
    if (query != o.query) return query < o.query;
    return reference < o.reference;
  }
};

struct Correspondence {
  uint32_t document;
  int query;
  uint16_t reference;
  int count;  // descriptors of the query keypoint that hit this reference
              // keypoint
};

// A document to verify: its slice [begin, end) of the correspondences and its
// votes.
struct Candidate {
  uint32_t document;
  size_t begin, end;
  int votes;   // query keypoints with any hit in the document
  int strong;  // ...of which two or more descriptors agree on one reference
               // keypoint
  int Score() const { return strong * 1024 + std::min(votes, 1023); }
};

// Collapses sorted hits to one correspondence per (document, query keypoint):
// the first reference keypoint with the most hits.
std::vector<Correspondence> BestCorrespondences(const std::vector<Hit> &hits) {
  std::vector<Correspondence> out;
  for (size_t i = 0; i < hits.size();) {
    Correspondence c{hits[i].document, hits[i].query, 0, 0};
    size_t j = i;
    while (j < hits.size() && hits[j].document == c.document && hits[j].query == c.query) {
      size_t run = j;
      while (run < hits.size() && hits[run].document == c.document && hits[run].query == c.query &&
             hits[run].reference == hits[j].reference)
        ++run;
      if (static_cast<int>(run - j) > c.count) {
        c.count = static_cast<int>(run - j);
        c.reference = hits[j].reference;
      }
      j = run;
    }
    out.push_back(c);
    i = j;
  }
  return out;
}

// Keeps only the hits of the `keep` documents with most hits: a large database gives
// common descriptors many entries, and sorting every hit would cost more than the rest of
// the query. Counting per document is linear: one counter per document id (the registry's
// ids are dense), kept per thread and reset after use, so no hashing and no allocation
// per query. Ids from 2^24 up are too sparse for that; such databases skip the prefilter.
void PrefilterHits(int keep, std::vector<Hit> *hits) {
  if (keep <= 0 || hits->size() < 4096) return;
  uint32_t max_document = 0;
  for (const Hit &h : *hits) max_document = std::max(max_document, h.document);
  if (max_document >= (1u << 24)) return;
  thread_local std::vector<uint32_t> count;
  thread_local std::vector<uint32_t> touched;
  if (count.size() <= max_document) count.resize(max_document + 1, 0);
  touched.clear();
  for (const Hit &h : *hits)
    if (count[h.document]++ == 0) touched.push_back(h.document);
  if (touched.size() > static_cast<size_t>(keep)) {
    std::vector<uint32_t> counts;
    counts.reserve(touched.size());
    for (uint32_t d : touched) counts.push_back(count[d]);
    std::nth_element(counts.begin(), counts.begin() + (keep - 1), counts.end(),
                     std::greater<uint32_t>());
    const uint32_t floor = counts[static_cast<size_t>(keep - 1)];
    hits->erase(std::remove_if(hits->begin(), hits->end(),
                               [&](const Hit &h) { return count[h.document] < floor; }),
                hits->end());
  }
  for (uint32_t d : touched) count[d] = 0;
}

// The layout check for documents with few LLAH inliers: the share of the reference
// keypoints that H puts inside the query keypoints' hull which found a query keypoint
// (`matched`, from the guided refinement).
bool LayoutConfirms(const std::vector<cv::Point2f> &reference, const cv::Matx33d &H,
                    const std::vector<cv::Point2f> &query_hull, int matched,
                    const RetrievalOptions &o) {
  if (matched < o.min_layout_matches || query_hull.size() < 3) return false;
  int inside = 0;
  for (const cv::Point2f &r : reference) {
    const cv::Point2d p = ApplyHomography(H, r);
    if (!std::isfinite(p.x) || !std::isfinite(p.y)) continue;
    if (cv::pointPolygonTest(
            query_hull, cv::Point2f(static_cast<float>(p.x), static_cast<float>(p.y)), false) >= 0)
      ++inside;
  }
  return matched >= o.min_layout_ratio * inside;
}

}  // namespace

std::vector<DocumentHit> LlahRetriever::Retrieve(const std::vector<cv::Point2f> &query,
                                                 double query_char_height,
                                                 const RetrievalOptions &o) const {
  std::vector<DocumentHit> results;
  if (query.size() < 8) return results;
  std::vector<uint64_t> hashes;
  describer_.DescribeWithProbes(query, o.query_probes, &hashes);
  const int per = static_cast<int>(hashes.size() / query.size());

  std::vector<Hit> hits;
  hits.reserve(query.size() * per * 2);
  std::unordered_map<uint32_t, std::shared_ptr<const Model>> candidates_models;
  // Per (document, query keypoint): the reference keypoint it hit most often,
  // and how often.
  std::vector<Correspondence> best;
  std::vector<Candidate> ranked;
  {
    std::shared_lock lock(mutex_);
    const int max_hits =
        std::max<int>(o.max_hits_per_descriptor,
                      static_cast<int>(o.max_hits_per_1000_documents * models_.size() / 1000));
    for (size_t q = 0; q < query.size(); ++q) {
      for (int j = 0; j < per; ++j) {
        const uint64_t h = hashes[q * per + j];
        if (h == 0) continue;
        // Descriptors under more than max_hits entries are stop words: their hits are dropped.
        const size_t before = hits.size();
        if (index_.ForEachUpTo(h, max_hits, [&](uint32_t doc, uint16_t kp) {
              hits.push_back({doc, static_cast<int>(q), kp});
            }) > max_hits)
          hits.resize(before);
      }
    }
    PrefilterHits(o.prefilter_documents, &hits);
    std::sort(hits.begin(), hits.end());
    best = BestCorrespondences(hits);
    // Votes per document. A query keypoint whose descriptors agree on one
    // reference keypoint (two or more hits on it) is strong evidence; a single
    // hit is often chance (text is regular, so some arrangements recur on every
    // page). Rank by strong votes, then by all votes.
    for (size_t i = 0; i < best.size();) {
      Candidate c{best[i].document, i, i, 0, 0};
      for (; c.end < best.size() && best[c.end].document == c.document; ++c.end) {
        ++c.votes;
        if (best[c.end].count >= 2) ++c.strong;
      }
      if (c.votes >= o.min_votes && c.strong >= o.min_strong_votes) ranked.push_back(c);
      i = c.end;
    }
    std::sort(ranked.begin(), ranked.end(), [](const Candidate &a, const Candidate &b) {
      if (a.Score() != b.Score()) return a.Score() > b.Score();
      return a.document > b.document;
    });
    if (!ranked.empty()) {
      const double floor = o.candidate_vote_ratio * ranked.front().Score();
      while (!ranked.empty() && ranked.back().Score() < floor) ranked.pop_back();
    }
    if (static_cast<int>(ranked.size()) > o.max_candidates) ranked.resize(o.max_candidates);
    for (const Candidate &c : ranked) {
      auto it = models_.find(c.document);
      if (it != models_.end()) candidates_models[c.document] = it->second;
    }
  }

  const double threshold = o.ransac_threshold_px > 0
                               ? o.ransac_threshold_px
                               : std::clamp(0.45 * query_char_height, 2.5, 12.0);
  std::vector<char> used(query.size(), 0);
  NeighborGrid query_grid(query);
  std::vector<cv::Point2f> query_hull;  // computed when a layout check needs it
  std::vector<int> nearest;
  for (const Candidate &candidate : ranked) {
    const uint32_t doc = candidate.document;
    auto mit = candidates_models.find(doc);
    if (mit == candidates_models.end()) continue;
    const Model &model = *mit->second;
    std::vector<cv::Point2f> ref_pts, query_pts;
    std::vector<std::pair<int, int>> pairs;
    std::vector<int> strength;
    for (size_t i = candidate.begin; i < candidate.end; ++i) {
      const Correspondence &c = best[i];
      if (used[c.query] || c.reference >= model.keypoints.size()) continue;
      ref_pts.push_back(model.keypoints[c.reference]);
      query_pts.push_back(query[c.query]);
      pairs.emplace_back(c.query, c.reference);
      strength.push_back(c.count);
    }
    if (static_cast<int>(pairs.size()) < o.min_weak_inliers) continue;
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
    std::vector<uchar> mask;
    cv::Mat Hm = cv::findHomography(sample_ref, sample_query, cv::USAC_PROSAC, threshold, mask,
                                    o.ransac_iterations, 0.995);
    if (Hm.empty()) continue;
    cv::Matx33d H(Hm);
    std::vector<cv::Point2f> inlier_ref;
    std::vector<std::pair<int, int>> inlier_pairs;
    for (size_t i = 0; i < pairs.size(); ++i) {
      const cv::Point2d p = ApplyHomography(H, ref_pts[i]);
      if (cv::norm(p - cv::Point2d(query_pts[i])) <= threshold) {
        inlier_ref.push_back(ref_pts[i]);
        inlier_pairs.push_back(pairs[i]);
      }
    }
    if (static_cast<int>(inlier_pairs.size()) < o.min_weak_inliers) continue;
    if (!MakePlausibleHomography(&H, inlier_ref)) continue;

    // Guided refinement: every reference keypoint projected by H takes the
    // nearest free query keypoint within the threshold; the homography is
    // refitted on those matches. (Their number alone is no evidence: projected text
    // lands near some word by chance too often. Only the layout check below uses them,
    // as a share of the page in view, which chance alignments do not reach.)
    std::vector<std::pair<int, int>> guided;
    // The gate starts at the RANSAC threshold and then shrinks to a few times the median
    // residual, so that extra keypoints a few pixels from a projected word stop pulling the
    // least-squares refit.
    double gate = threshold;
    for (int round = 0; round < 3; ++round) {
      std::vector<int> owner(query.size(), -1);
      std::vector<float> owner_d(query.size(), 0.f);
      for (int r = 0; r < static_cast<int>(model.keypoints.size()); ++r) {
        const cv::Point2d p = ApplyHomography(H, model.keypoints[r]);
        if (!std::isfinite(p.x) || !std::isfinite(p.y)) continue;
        query_grid.NearestTo(cv::Point2f(static_cast<float>(p.x), static_cast<float>(p.y)), 1, -1,
                             &nearest);
        if (nearest.empty() || used[nearest[0]]) continue;
        const float d = static_cast<float>(cv::norm(cv::Point2d(query[nearest[0]]) - p));
        if (d > gate) continue;
        if (owner[nearest[0]] < 0 || d < owner_d[nearest[0]]) {
          owner[nearest[0]] = r;
          owner_d[nearest[0]] = d;
        }
      }
      guided.clear();
      std::vector<cv::Point2f> gr, gq;
      for (int q = 0; q < static_cast<int>(query.size()); ++q) {
        if (owner[q] < 0) continue;
        guided.emplace_back(q, owner[q]);
        gr.push_back(model.keypoints[owner[q]]);
        gq.push_back(query[q]);
      }
      if (guided.size() < inlier_pairs.size() || guided.size() < 8) {
        guided = inlier_pairs;
        break;
      }
      cv::Mat refined = cv::findHomography(gr, gq, 0);
      if (refined.empty()) break;
      cv::Matx33d refined_h(refined);
      if (!MakePlausibleHomography(&refined_h, gr)) break;
      H = refined_h;
      std::vector<double> residuals(gr.size());
      for (size_t i = 0; i < gr.size(); ++i)
        residuals[i] = cv::norm(ApplyHomography(H, gr[i]) - cv::Point2d(gq[i]));
      std::nth_element(residuals.begin(), residuals.begin() + residuals.size() / 2,
                       residuals.end());
      gate = std::clamp(3.0 * residuals[residuals.size() / 2], 1.0, threshold);
    }
    // Re-count LLAH inliers under the final homography.
    int inliers = 0;
    for (size_t i = 0; i < pairs.size(); ++i) {
      const cv::Point2d p = ApplyHomography(H, ref_pts[i]);
      if (cv::norm(p - cv::Point2d(query_pts[i])) <= threshold) ++inliers;
    }
    if (inliers < o.min_weak_inliers) continue;
    if (inliers < o.min_inliers) {
      if (query_hull.empty()) cv::convexHull(query, query_hull);
      if (!LayoutConfirms(model.keypoints, H, query_hull, static_cast<int>(guided.size()), o))
        continue;
    }
    DocumentHit hit;
    hit.document = doc;
    // h22 = +-1, keeping the sign that puts the matched points in front of the camera.
    hit.homography = H * (1.0 / std::abs(H(2, 2)));
    hit.inliers = inliers;
    hit.votes = candidate.votes;
    hit.matches = std::move(guided);
    for (const auto &[q, r] : hit.matches) used[q] = 1;
    results.push_back(std::move(hit));
    if (o.max_results > 0 && static_cast<int>(results.size()) >= o.max_results) break;
  }
  std::sort(results.begin(), results.end(),
            [](const DocumentHit &a, const DocumentHit &b) { return a.inliers > b.inliers; });
  return results;
}

}  // namespace texfree
