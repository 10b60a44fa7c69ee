// LlahRetriever: the document database of LLAH (seed 2.3, 5.3): registered
// keypoint sets, their descriptors in an InvertedIndex, and retrieval = voting
// + RANSAC homography verification per candidate document, so that every
// document visible in a query is found.
#pragma once

#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <opencv2/core.hpp>
#include <shared_mutex>
#include <unordered_map>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "common/inverted_index.h"
#include "common/llah.h"
#include "common/text_perspective.h"

namespace texfree {

struct RetrievalOptions {
  // Descriptors found under more entries than max(max_hits_per_descriptor,
  // max_hits_per_1000_documents * documents / 1000) are too common to vote (stop words).
  // The limit grows with the database: text is regular, so informative descriptors also
  // recur on many pages of a large one (at 10,000 pages a fixed limit of 24 loses most).
  // Registration layers put ~1.7 times as many entries under a descriptor as one cut of
  // each page did; 16 and 40 (12 and 30 before the layers) found 2 more views of 200 at
  // 10,000 pages and 1 more at 1,000 for the same median time (50: 2 more, 4 ms slower).
  int max_hits_per_descriptor = 16;
  int max_hits_per_1000_documents = 40;
  // A view with more keypoints than this has evidence to spare: the database's share of its
  // stop-word limit (max_hits_per_1000_documents, never max_hits_per_descriptor) is lowered
  // in proportion (down to a quarter at four times as many), as common descriptors
  // add mostly chance hits and most of the lookup time (hits grow with the keypoints, and a
  // whole page in view has 500-800). Views with few keypoints, the hard ones, keep the full
  // limit. 0: never lowered. At 10,000 pages 150 left the 1,000 views' 13 misses as they
  // were and cut the mean matching time from 15.0 to 12.3 ms.
  int stop_word_keypoints = 150;
  // Only the documents with most hits (this many) are voted for; 0 keeps all. Bounds the
  // query time of large databases.
  int prefilter_documents = 256;
  // Query-side multi-probe (LlahDescriber::DescribeWithProbes): 2^query_probes
  // lookups per descriptor, forgiving that many invariants quantised across a
  // level boundary.
  int query_probes = 1;
  // A document needs this many query keypoints voting for it to be verified.
  int min_votes = 6;
  // ...of which this many agree on one reference keypoint with two or more
  // descriptors.
  int min_strong_votes = 2;
  // ...and this many of them coherent: a neighbouring query keypoint corresponds to a
  // reference keypoint within coherence_radius times the page's typical distance to the
  // n-th nearest keypoint. Candidates are ranked by coherent votes first: at 10,000 pages,
  // chance hits give many pages as many votes, even strong ones, as the right page gets.
  int min_coherent_votes = 3;
  double coherence_radius = 2.0;
  // ...and at least this share of the best document's score.
  double candidate_vote_ratio = 0.05;
  // At most this many documents are verified per query (RANSAC is the costly
  // step).
  int max_candidates = 5;
  // RANSAC inlier distance in query pixels; 0 = derived from the query's
  // character height.
  double ransac_threshold_px = 0;
  int ransac_iterations = 1000;
  // A document is visible when at least this many LLAH correspondences agree
  // with one homography.
  int min_inliers = 12;
  // Large type, blur or a steep view leave few keypoints whose whole neighbourhood
  // survives, so few LLAH correspondences even for the right page. From
  // min_weak_inliers LLAH inliers up, the page's layout decides: the homography must
  // put at least min_layout_matches reference keypoints, and min_layout_ratio of those
  // it projects inside the query's keypoints, onto query keypoints. The right page
  // scores 0.5-0.9; a wrong page's words land near query words by chance (~0.1-0.2,
  // even with aligned text lines, since words along a line fall at random).
  int min_weak_inliers = 6;
  int min_layout_matches = 16;
  double min_layout_ratio = 0.45;
  // A view holding few of the page's keypoints (large type, a corner) cannot show
  // min_layout_matches of them. From min_inliers matches up, the layout also confirms a page
  // when so many of the keypoints it projects inside the query's hit query keypoints that a
  // wrong page, each of whose projected keypoints meets a query keypoint with probability
  // layout_chance, would do it with probability at most max_layout_tail (binomial tail,
  // LayoutLog10Tail). Wrong pages measured shares up to ~0.2 (0.05 or less in the
  // few-keypoint pass); 0 turns the test off.
  double layout_chance = 0.25;
  double max_layout_tail = 1e-4;
  // ...or, when the query's keypoints repeat the page's too poorly for the layout check
  // (blur merging words, a steep view splitting them), the LLAH inliers themselves decide
  // when chance could hardly have produced them: the expected number of candidates with as
  // many inliers among their correspondences, were those random (a-contrario, see
  // WeakMatchLog10Nfa), must be at most max_weak_nfa. Wrong pages measure 10^0.7 and more;
  // 0 turns the test off. Such a page still needs min_significant_layout_ratio of the
  // layout: a few inliers in one corner can be the right page under a homography wrong
  // elsewhere, which puts few of its keypoints on query keypoints.
  double max_weak_nfa = 1e-3;
  double min_significant_layout_ratio = 0.25;
  // The query image's size (set per query; empty: unknown). A keypoint whose n nearest
  // neighbours reach past the frame has lost some of them to it, and intruders from
  // further out took their place: when the share of its neighbourhood disk outside the
  // frame holds max_border_lost of its n neighbours or more, its descriptors cannot match
  // (LLAH forgives n - m = 1) and it is not described: its lookups would only add chance
  // votes. It stays a neighbour of the others. 0 describes every keypoint.
  cv::Size frame;
  double max_border_lost = 1.5;
  // 0 = every visible document.
  int max_results = 0;
  // Query descriptors are computed on keypoints rectified to an affine image of the page
  // when the view is steep (text_perspective.h): LLAH's invariants are only affine.
  bool rectify_perspective = true;
  TextPerspectiveOptions perspective;
  // When the rectified descriptors find no page with min_inliers, the query is also tried
  // with its descriptors as seen (a spacing gradient that is the layout's, not the
  // camera's, fools the fit). Doubles the cost of a query that finds nothing.
  bool retry_unrectified = true;
  // The query's text direction (WordKeypoints::text_angle_rad), set per query (NaN:
  // unknown). With it, a view that neither the rectification nor the view as seen found a
  // page in is tried once more, rectified by the horizon that makes its text lines
  // parallel and evenly spaced (RefineTextPerspective). The keypoint-spacing estimate is
  // a few hundredths of the image's half diagonal off on views of 50-200 words, and LLAH's
  // neighbourhoods are that sensitive (at 10,000 pages the true horizon finds 4 of the 6
  // views missed).
  double text_angle_rad = std::numeric_limits<double>::quiet_NaN();
  bool refine_perspective = true;
  // ...for views of at most this many keypoints (a view of an unregistered page pays for
  // the extra retrieval; the views it found at 10,000 pages had 50 and 215).
  int refine_max_keypoints = 250;
  // Guided matching (every page keypoint the homography puts near a query keypoint, then
  // a refit) keeps its full gate for up to this many extra refits while the matches still
  // grow and are fewer than twice min_layout_matches: a homography from a consensus in one
  // part of a sparse view (a table, large type) reaches the rest of it round by round. The
  // growing refits are RANSAC fits at the gate that must keep 4 of 5 of the LLAH
  // consensus (the full gate lets wrong matches in). 0: one round at the full gate.
  int guided_growth_rounds = 4;
  // When guided matching from the homography finds fewer than min_layout_matches and the
  // consensus lies along a line (a column of figures, which leaves the homography free
  // across it), it also starts from a similarity fitted to the same consensus, which
  // extrapolates soundly, and keeps the larger match set.
  // With both, at 10,000 pages: 983 -> 985 of 1,000 views (two tables in large type, 35 and
  // 37 words), no false match of 300 unregistered views, CPU time unchanged.
  bool guided_similarity_start = true;
  // An accepted page's homography is fitted once more, robustly: RANSAC over its guided
  // matches at polish_gate times the inlier threshold, then (when it moves a corner of the
  // view by more than half that gate) grown by guided matching again. The refit is kept
  // when it puts more of the page's keypoints within that gate of a query keypoint.
  // (Guided matching's last refits are least squares: a few wrong matches at the edge of a
  // view, pieces of a bar chart cut as words, left a homography with 48 right matches of
  // 55 at 27 px mean error over the view; the robust refit put it within 2 px.)
  bool polish_homography = true;
  double polish_gate = 0.5;
  // ...and also RANSAC over every page keypoint within polish_match_gate times the inlier
  // threshold of a query keypoint (0: not): guided matching grows from the consensus, and
  // a homography extrapolated across a figure or a margin misses a second text block
  // beyond it by more than the threshold. That refit must keep half the guided matches
  // within the threshold; of the two refits, the one that puts more of the page within the
  // gate is kept. At 10,000 pages two views whose words lie on both
  // sides of a photograph or a chart went from 10.1-10.4 px mean error over the view to
  // 0.2 and 6.1 px.
  double polish_match_gate = 2.0;
  // The few-keypoint pass. Views of large type, of a page's corner, or steep views of a
  // column keep few whole neighbourhoods: at 10,000 pages the right page's handful of
  // descriptor hits is cut by the hit prefilter among chance hits, or it has one strong
  // vote. A query of at most deep_max_keypoints keypoints that found no page votes again on
  // the same index hits, among the deep_prefilter_documents with most hits (0: all) and
  // with deep_min_strong_votes. A candidate with at most 12 correspondences has every
  // consensus set of deep_min_weak_inliers or more that four of them span refined by guided
  // matching (the 3 largest); one with more gets deep_ransac_iterations of PROSAC. With
  // fewer LLAH inliers than min_weak_inliers only the layout decides: deep_min_layout_ratio
  // of it, and a binomial tail (LayoutLog10Tail) that counts every homography tried as a
  // chance. Right pages measured layout shares of mostly 0.5-1, wrong ones 0.05 or less
  // (0.36 once, 4 of 11 projected keypoints). 0 turns the pass off. 120 keypoints (views of
  // large type hold 15-100): at 250, views of unregistered pages paid for the pass often
  // enough to raise the 10,000-page median by ~1 ms, for one view more of 600 at 100 pages.
  int deep_max_keypoints = 120;
  int deep_prefilter_documents = 512;
  int deep_min_strong_votes = 1;
  int deep_min_weak_inliers = 4;
  int deep_ransac_iterations = 250;
  double deep_min_layout_ratio = 0.6;
  // The neighbourhood pass (LlahRetriever::RetrieveByNeighbourhoods): at most this many
  // descriptor hits are each turned into a homography; 0 turns the pass off.
  int neighbourhood_max_hypotheses = 4000;
  // ...of which those whose m + 1 pairs an affine map fits within this share of the
  // neighbourhood's mean radius are grown by guided matching (right hits measured
  // 0.01-0.02; chance hits of regular text spread from 0 to past 0.3).
  double neighbourhood_max_residual = 0.03;
  // A page is found when its refit homography puts at least neighbourhood_min_tight of its
  // keypoints, and neighbourhood_min_tight_share of those it projects inside the query's
  // keypoints, within neighbourhood_tight_gate times the inlier threshold of a query
  // keypoint. At 10,000 pages the right pages found had 16-36 such keypoints, 0.67-1.2 of
  // those in view; of 18,595 wrong hypotheses (100 views of unregistered pages) those with
  // 0.6 of the view had at most 12 (at 0.5 of it, 15: hence 0.6).
  double neighbourhood_tight_gate = 0.25;
  int neighbourhood_min_tight = 16;
  double neighbourhood_min_tight_share = 0.6;
  // ...but under neighbourhood_min_tight_wide tight matches the share must reach
  // neighbourhood_min_tight_share_close (or agreeing hits confirm the page, below). At 300
  // dpi (pages of 2,480 px) a wrong page grown onto one corner of a view of text lines had
  // 17 tight matches over 0.68 of the view (2 agreeing hits); of 37 right pages found by the
  // pass over ten sets of 1,000 views (10,000 pages and 300 dpi), those under 0.75 of the
  // view with fewer than 3 agreeing hits had 23-33 tight matches.
  int neighbourhood_min_tight_wide = 20;
  double neighbourhood_min_tight_share_close = 0.75;
  // ...or, from neighbourhood_min_tight_agreeing tight matches up (with the same share),
  // when at least neighbourhood_min_agreeing_hits distinct query keypoints have descriptor
  // hits on the page that the homography confirms (their reference keypoint projected
  // within the inlier threshold of them): a wrong page is grown from one chance hit, and a
  // second or third that lands where its homography says is a coincidence of its own. At
  // 10,000 pages, of the wrong hypotheses grown on 900 views of unregistered pages, none
  // with 0.6 of the view had 3 such hits at any count of tight matches (they had at most
  // 12 tight matches and 2 hits), nor on 600 more views held out from that choice; the
  // right pages just under the bar had 15 tight matches and 2-4 hits (two found: 989 ->
  // 990 of 1,000 views on the set). 0 turns this off.
  int neighbourhood_min_tight_agreeing = 13;
  int neighbourhood_min_agreeing_hits = 3;

  absl::Status Validate() const;
};

// log10 of the number of false alarms of `inliers` of `correspondences` agreeing with one
// homography within `threshold_px`, were the correspondences random over a query region of
// `area_px2`: C(n, 4) hypotheses from minimal samples, each explaining k - 4 of the other
// n - 4 correspondences with probability p = pi threshold^2 / area each (binomial tail).
// Very negative: the agreement is no coincidence.
double WeakMatchLog10Nfa(int correspondences, int inliers, double threshold_px, double area_px2);

// log10 of the probability that `matched` or more of `inside` projected keypoints meet a query
// keypoint, each with probability `chance` (binomial tail); `matched` is capped at `inside`.
double LayoutLog10Tail(int inside, int matched, double chance);

// The database's share of the stop-word limit for a view of `keypoints`: `limit` up to
// `plenty` keypoints (or when plenty is 0), then limit * plenty / keypoints, rounded, and
// never below a quarter of `limit` (RetrievalOptions::stop_word_keypoints).
int StopWordLimit(int limit, int keypoints, int plenty);

// How many of a keypoint's n nearest neighbours (the farthest at `radius`) are expected
// beyond the frame's edges, for neighbours spread evenly over the disk.
double NeighboursLostToFrame(const cv::Point2f &p, float radius, int n, const cv::Size &frame);
// Per point: whether max_lost or more of its n neighbours are expected beyond the frame.
std::vector<char> CutByFrame(const std::vector<cv::Point2f> &points, const NeighborGrid &grid,
                             int n, const cv::Size &frame, double max_lost);

struct DocumentHit {
  uint32_t document = 0;
  cv::Matx33d homography;  // reference keypoint frame -> query pixels
  int inliers = 0;         // LLAH correspondences consistent with the homography
  int votes = 0;
  // Inlier pairs (query keypoint index, reference keypoint index), after guided
  // matching; reference indices are into the base layer (Keypoints()).
  std::vector<std::pair<int, int>> matches;
};

// What Retrieve() did with one document, for diagnosing a miss (benchmarks, tests): how far
// the document got through the gates, and the numbers each gate looked at.
struct RetrievalTrace {
  uint32_t watch = 0;  // the document to follow (set by the caller)
  int query_keypoints = 0;
  bool rectified = false;     // the query's descriptors were computed on rectified keypoints
  int stop_word_lookups = 0;  // query descriptors dropped as too common
  int total_hits = 0;         // index hits of every document
  int hits = 0;               // the watched document's
  int votes = 0, strong = 0;  // the watched document's votes and strong votes
  int coherent = -1;          // ...and coherent votes (-1: no votes, or cut by the prefilter)
  int rank_by_score = -1;     // 0-based rank by score among all documents voted for
  int rank = -1;              // among the candidates before the max_candidates cut
  int candidates = 0;         // documents that passed the vote gates
  int ransac_inliers = -1;    // -1: not verified
  int final_inliers = -1;
  int guided = -1;
  // Page keypoints the layout check projected into the query's hull (-1: none counted).
  int layout_inside = -1;
  bool accepted = false;
  // The neighbourhood pass: hypotheses tried; the most tightly matched page keypoints of
  // the watched page and of any other page, and how many each projected inside the query.
  int neighbourhood_hypotheses = -1;
  int neighbourhood_tight = -1, neighbourhood_inside = -1;
  int neighbourhood_other_tight = -1, neighbourhood_other_inside = -1;
  // ...and the agreeing hits (neighbourhood_min_agreeing_hits) of those two hypotheses.
  int neighbourhood_agreeing = -1, neighbourhood_other_agreeing = -1;
};

struct DocumentKeypoints {
  uint32_t id = 0;
  // Every layer's keypoints, in page coordinates: the base layer (the page as registered)
  // first, then the extra layers (the page cut into words as a camera would see it, e.g.
  // smaller and blurred: queries repeat those cuts better than the sharp page's).
  std::vector<cv::Point2f> keypoints;
  cv::Size size;
  // Keypoints of each extra layer, in order; the base layer holds the rest. Empty: one layer.
  std::vector<uint32_t> extra_layers;
  // Descriptor hashes as LlahRetriever::DescribeLayers lays them out, when already known
  // (stored); computed when empty or of the wrong size.
  std::vector<uint64_t> hashes;
};

// Thread-safe: retrievals run concurrently; adding and removing take an
// exclusive lock for the index update only (descriptors are computed outside
// it).
class LlahRetriever {
 public:
  // log2_buckets: the index's least table size (InvertedIndex). A bulk load into an empty
  // index sizes the table for what it loads (InvertedIndex::Log2BucketsFor).
  LlahRetriever(LlahOptions options, InvariantQuantizer quantizer, int log2_buckets = 22);

  // Fails with ALREADY_EXISTS for a known id, INVALID_ARGUMENT for over 65535
  // keypoints.
  absl::Status AddDocument(DocumentKeypoints document);
  // Bulk load at start-up: descriptors not given are computed on `threads` threads and
  // handed to `computed(id, hashes)` (serialised) so the caller can store them. Into an
  // empty index, the hash table is first sized for the entries loaded (at least the
  // constructor's size): at 100,000 pages 2^22 buckets would hold chains of ~180 entries.
  // `progress(done, total)` is called now and then.
  absl::Status AddDocuments(
      std::vector<DocumentKeypoints> documents, int threads,
      const std::function<void(size_t, size_t)> &progress = nullptr,
      const std::function<void(uint32_t, const std::vector<uint64_t> &)> &computed = nullptr);
  // Removes a document's keypoints and every index entry; false if unknown.
  bool RemoveDocument(uint32_t id);
  bool Contains(uint32_t id) const;

  // query_char_height: the extractor's estimate, used for the RANSAC threshold.
  // `trace`, when given, records what happened to the document trace->watch.
  // `text_line_horizon`, when given, receives the text-line rectification (query pixels ->
  // rectified) of the last try when that try ran and found a horizon, so that a caller
  // that goes on to rectify the picture itself need not fit it again.
  std::vector<DocumentHit> Retrieve(const std::vector<cv::Point2f> &query, double query_char_height,
                                    const RetrievalOptions &options,
                                    RetrievalTrace *trace = nullptr,
                                    std::optional<cv::Matx33d> *text_line_horizon = nullptr) const;

  // The neighbourhood pass, for a view of few keypoints that Retrieve() found nothing in:
  // a descriptor hit pairs the query keypoint's neighbourhood with the page keypoint's
  // (m + 1 points each), so one hit is a homography, where voting needs several. The
  // likeliest hits (neighbourhood_max_hypotheses) are each fitted (an affine map on the
  // view rectified as Retrieve() rectifies it), grown by guided matching, and the page
  // whose homography puts most of its keypoints tightly onto query keypoints is returned
  // (neighbourhood_min_tight). At most one page.
  std::vector<DocumentHit> RetrieveByNeighbourhoods(const std::vector<cv::Point2f> &query,
                                                    double query_char_height,
                                                    const RetrievalOptions &options,
                                                    RetrievalTrace *trace = nullptr) const;

  // Reference keypoints of a document's base layer (empty if unknown): DocumentHit::matches
  // index them (guided matching is on the base layer).
  std::vector<cv::Point2f> Keypoints(uint32_t id) const;

  // Descriptor hashes of a document's keypoints (layout of LlahDescriber::Describe over all
  // of them): each layer is described within itself (a keypoint's neighbours are those of
  // its own cut of the page), and an extra layer's descriptor that an earlier layer of the
  // document already holds is dropped (hash 0): it would add an index entry that votes for
  // the same page again. Deterministic, so removal recomputes what was added.
  // `extra_layers` as DocumentKeypoints's; false when the layer sizes exceed `points`.
  bool DescribeLayers(const std::vector<cv::Point2f> &points,
                      const std::vector<uint32_t> &extra_layers,
                      std::vector<uint64_t> *hashes) const;

  const LlahDescriber &describer() const { return describer_; }
  size_t documents() const;
  size_t entries() const;
  // Index and keypoint memory in bytes.
  size_t MemoryBytes() const;

 private:
  struct Model {
    std::vector<cv::Point2f> keypoints;  // every layer's, the base layer first
    cv::Size size;
    float neighbour_radius = 0;  // median distance to the n-th nearest base keypoint
    std::vector<uint32_t> extra_layers;
    // The base layer is keypoints[0, base): the layout check and guided matching count
    // the page's words once, not once per layer.
    uint32_t base = 0;
  };
  static std::shared_ptr<Model> MakeModel(DocumentKeypoints *document, float radius);
  // The base layer's size, or -1 when extra_layers do not fit in `points`.
  static int64_t BaseLayerSize(size_t points, const std::vector<uint32_t> &extra_layers);
  // Retrieve() with the query's descriptors computed on `described` (the query's keypoints,
  // or the same rectified), everything else on `query`. `allow_deep`: when the first vote
  // finds nothing, the few-keypoint pass votes again on the same index hits.
  std::vector<DocumentHit> RetrieveDescribed(const std::vector<cv::Point2f> &query,
                                             const std::vector<cv::Point2f> &described,
                                             double query_char_height, const RetrievalOptions &o,
                                             RetrievalTrace *trace, bool allow_deep = false) const;
  // One descriptor hit of the neighbourhood pass: the page keypoint `reference` of
  // `document` for query keypoint `query`, by its descriptor subset `subset`.
  struct NeighbourhoodHypothesis {
    uint32_t document;
    uint16_t reference;
    int query;
    int subset;
  };
  // The neighbourhood pass's hits for the query's descriptor hashes (`variants` probes per
  // subset, every keypoint alike), stop words dropped, each hit once, ranked by page:
  // pages with most hits per keypoint first, whole pages up to
  // RetrievalOptions::neighbourhood_max_hypotheses. Under a lock.
  std::vector<NeighbourhoodHypothesis> NeighbourhoodHypotheses(const std::vector<uint64_t> &hashes,
                                                               size_t query_keypoints, int variants,
                                                               const RetrievalOptions &o) const;
  // Distinct query keypoints with a hypothesis on `document` whose reference keypoint (of
  // any layer; all are in page coordinates) H projects within `threshold` of them
  // (RetrievalOptions::neighbourhood_min_agreeing_hits).
  static int AgreeingHits(const std::vector<NeighbourhoodHypothesis> &hypotheses, uint32_t document,
                          const std::vector<cv::Point2f> &page, const cv::Matx33d &H,
                          const std::vector<cv::Point2f> &query, double threshold);
  // The index entries a query descriptor may have before it is a stop word (its hits are
  // dropped): RetrievalOptions::max_hits_per_descriptor, max_hits_per_1000_documents and
  // stop_word_keypoints. Under a lock.
  int MaxHitsPerDescriptor(const RetrievalOptions &o, size_t query_keypoints) const;
  // Ids below kDenseIds (the registry's are dense from 1) also find their model through
  // dense_models_, without hashing: the coherence check looks up thousands per query.
  static constexpr uint32_t kDenseIds = 1u << 24;
  void SetDenseModel(uint32_t id, const Model *model);  // under the exclusive lock
  const Model *FindModel(uint32_t id) const;            // under a lock
  LlahDescriber describer_;
  mutable std::shared_mutex mutex_;
  int min_log2_buckets_;
  InvertedIndex index_;
  std::unordered_map<uint32_t, std::shared_ptr<const Model>> models_;
  std::vector<const Model *> dense_models_;
};

}  // namespace texfree
