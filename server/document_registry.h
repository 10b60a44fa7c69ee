// DocumentRegistry: the document use cases (register, delete, retrieve,
// annotate) on top of DocumentStore (persistence) and LlahRetriever (in-memory
// index). Plain C++ types in and out; the gRPC layer converts.
#pragma once

#include <memory>
#include <mutex>
#include <opencv2/core.hpp>
#include <optional>
#include <shared_mutex>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "absl/status/statusor.h"
#include "common/figure_keypoints.h"
#include "common/letter_keypoints.h"
#include "common/llah.h"
#include "common/llah_retriever.h"
#include "common/planar_pose.h"
#include "common/word_keypoints.h"
#include "server/document_store.h"

namespace texfree::server {

// Registration (and first query) extractor of a new database: letters joined into words by
// the letter graph, which learns each page's letter and word spacing (monospace, tight or
// loose typesetting) and follows the local text size (headings, perspective).
WordKeypointOptions DefaultKeypointOptions();
// Query extractors tried, in order, when the first one's keypoints retrieve nothing: one
// closing along the text lines (copes better with blur), then a wider closing.
std::vector<WordKeypointOptions> DefaultFallbackKeypointOptions();

// An extra keypoint layer registered with every page (generative learning, as Kise's group
// trained LLAH on degraded renditions): the page downscaled by `scale` and blurred by
// `blur_sigma`, cut into words by `keypoints`, mapped back to page pixels. A camera sees
// small, soft text, which joins and splits letters differently than the sharp page does;
// the layer's descriptors are those a query cut alike produces.
struct RegistrationLayer {
  double scale = 0.6;       // image pixels per page pixel, (0, 1]
  double blur_sigma = 1.2;  // Gaussian blur after downscaling, pixels (0: none)
  WordKeypointOptions keypoints = DefaultKeypointOptions();

  absl::Status Validate() const;
};
// The layers new pages get.
std::vector<RegistrationLayer> DefaultRegistrationLayers();

struct DocumentRegistryOptions {
  // A database keeps the grouping it was built with (setting keypoints.grouping): pages
  // must be registered alike, and queries try that grouping first.
  WordKeypointOptions keypoints = DefaultKeypointOptions();
  std::vector<WordKeypointOptions> fallback_keypoints = DefaultFallbackKeypointOptions();
  // Frames of tracking streams. The line closing: on the tracking benchmark's close orbit it
  // held a correct pose to 79 deg at 4.2 ms CPU per frame, against 77.5 deg at 6.4 ms with
  // the letter graph; on-line learning absorbs the difference from the registered cut.
  WordKeypointOptions tracking_keypoints = DefaultFallbackKeypointOptions()[0];
  // Used for a new database; an existing one keeps the settings it was built
  // with.
  LlahOptions llah;
  RetrievalOptions retrieval;
  // The few-keypoint pass (RetrievalOptions::deep_max_keypoints) runs for the first this
  // many extractors (the registration one, then the fallbacks) while none has found a page:
  // each pass costs a view of an unregistered page ~4 ms at 10,000 pages, and the views it
  // found were found with the first two.
  int deep_pass_extractors = 2;
  // The neighbourhood pass (LlahRetriever::RetrieveByNeighbourhoods) is the last try of a
  // picture no other try found a page in: on the keypoints of this many extractors (the
  // registration one, then the fallbacks) when they cut at most
  // RetrievalOptions::deep_max_keypoints. 0: never.
  int neighbourhood_pass_extractors = 3;
  // And on the keypoints of the rectified picture (rectified_picture_retry), when its first
  // cut has at most RetrievalOptions::deep_max_keypoints: words that perspective merged or
  // split are cut there as on the page (at 10,000 pages one view more of 3,000, at 6-10%
  // more CPU for a view of an unregistered page).
  bool neighbourhood_pass_rectified = true;
  // The unrectified retry (RetrievalOptions::retry_unrectified) runs for the registration
  // extractor, and for the fallbacks when they cut at most this many keypoints (0: never).
  // The perspective fit from few keypoints is the one a layout's spacing fools most (a
  // near-frontal view of large type found only as seen), and a small view's retrievals are
  // cheap; a large view that finds nothing would pay for a second retrieval with each.
  int fallback_retry_max_keypoints = 120;
  // Queries without intrinsics: the camera's horizontal field of view assumed when
  // rectifying a steep view (RetrievalOptions::perspective.focal_px), a phone's main camera
  // (60-75 degrees). 0: the rectification stays affine unless intrinsics are given.
  double assumed_horizontal_fov_deg = 65;
  // Query pictures with more pixels are retrieved reduced by the smallest whole factor that
  // brings them to this many (INTER_AREA), every result in the pixels of the picture as
  // given. A phone's 12 MP photo (4032x3024 -> 1344x1008) holds words of 15-60 px, which the
  // reduction keeps above the 3-4 px the extractor needs: on 12 MP views of 1,000 pages the
  // same views were found, whole pages included, at 58 ms median instead of 216 (extraction
  // 19 ms instead of 190). 1920x1440 leaves 1080p and 1600x1200 frames as they are.
  // 0: never reduce.
  int64_t max_query_pixels = kDefaultMaxQueryPixels;
  // A picture in which no extractor found a page (of at most
  // rectified_picture_max_keypoints keypoints) is warped by the horizon that makes its text
  // lines parallel and evenly spaced (RefineTextPerspective), cut into words anew and
  // retrieved once more. At 10,000 pages it found 2 more of 200 views (196 -> 198: steep
  // views of large type, where perspective merges and splits words differently than the
  // page), with no false match of 100 unregistered views; the median moved by under 1 ms,
  // the p95 by 20-28 ms (views of unregistered pages pay for it).
  bool rectified_picture_retry = true;
  // ...also when the extractors found a page only weakly (fewer than
  // RetrievalOptions::min_inliers LLAH inliers, confirmed by the layout check); the answer
  // with more inliers is kept. A weak consensus can hold in one part of the view only.
  bool rectified_picture_after_weak = true;
  // ...for pictures of at most this many first-extractor keypoints. Steep views of small
  // type (300-700 keypoints at 35-40 degrees, text 4-6 px high) keep few neighbourhoods:
  // perspective merges the far side's words differently than the page. 0: none.
  int rectified_picture_max_keypoints = 1500;
  // Warps of the rectified-picture retry: a round that finds nothing fits the horizon again
  // on the warped picture's own keypoints (its far side, no longer squeezed, is cut into
  // words as the page is) and the next round warps the picture by both.
  // With both (250 keypoints and 1 round before) and the gate below: at 10,000 pages 4 more
  // of 1,000 views found (968 -> 972), no false match of 300 unregistered views; views of
  // registered pages 14.4 -> 14.3 ms median CPU, views of unregistered pages (which take
  // every try) 51.6 -> 59.6 ms median, 72 -> 101 ms p95.
  int rectified_picture_rounds = 2;
  // ...a next round only when the refitted horizon's depth varies over the warped
  // picture's keypoints by at least this ratio: 312 refits of one run (views of
  // unregistered pages, most of them) had a median of 1.017; at 1.02 the same 972 of 1,000
  // views were found and the unregistered views' median fell from 74.6 to 57.4 ms.
  double rectified_picture_min_refit_ratio = 1.02;
  // The fallback extractors (fallback_keypoints) also cut each warped picture that the
  // registration extractor's words did not find a page in. At 10,000 pages: 3 more of
  // 1,000 views (973 -> 976, with the warped picture's residual perspective rectified),
  // no false match of 300 unregistered views, whose median CPU time rose from 59.7 to
  // 82.1 ms (p95 107 -> 146 ms); views of registered pages unchanged (14.4 / 37.1 ms).
  bool rectified_picture_fallbacks = true;
  // After those rounds, the picture warped by the horizon's perspective alone: neither the
  // foreshortening (assumed from a field of view, assumed_horizontal_fov_deg, when the
  // intrinsics are not given) undone nor the text turned upright. Either can cut a steep
  // view's small type into other words than the page's. At 10,000 pages: 3 more of 1,000
  // views (980 -> 983: 36-39 degree views of small type whose text-line horizon was within
  // 0.01-0.04 of the truth), no false match of 300 unregistered views.
  bool rectified_picture_projective = true;
  // ...only for a picture whose horizon changes the depth by at least this much over a
  // half-diagonal from the centre (relative to the centre's depth; 0.45 is about 30 degrees
  // of tilt at a 60-degree field of view): below it the warps differ too little. Views of
  // unregistered pages, which take every try, cost 102 ms median CPU with it, 131 ms with
  // none (every picture), 94 ms without the warp.
  double rectified_picture_projective_min_slope = 0.45;
  // Small type: a picture in which nothing was found and whose text measured under
  // small_type_below_px high is retrieved once more (word tries only) at
  // small_type_upscale times the size it was retrieved at, to at most
  // small_type_max_pixels: from the picture as given when it was reduced
  // (max_query_pixels; a 12 MP photo of a page far away has the detail the reduction took),
  // else upscaled (bicubic). The word closing joins letters across gaps of gap_factor text
  // heights, under a pixel for 3-4 px type, which no kernel on the pixel grid can draw; at
  // the larger size it can. Under 1.5 times larger the retry is skipped. 0: never.
  double small_type_below_px = 5.0;
  double small_type_upscale = 3.0;
  int64_t small_type_max_pixels = 4 * 1920 * 1440;
  static constexpr int64_t kDefaultMaxQueryPixels = 1920 * 1440;
  static constexpr int64_t kMinMaxQueryPixels = 320 * 240;  // smallest limit but 0
  static bool ValidMaxQueryPixels(int64_t n) { return n == 0 || n >= kMinMaxQueryPixels; }
  // Extra keypoint layers of every page registered (pages registered earlier keep the
  // layers they were registered with). Empty: the page as given only.
  std::vector<RegistrationLayer> registration_layers = DefaultRegistrationLayers();
  // Figures (charts, diagrams, photographs): their corners (FigureKeypointExtractor) are
  // indexed apart from the words, with the words' LLAH settings and quantisation, for pages
  // with at least figure_min_keypoints of them. A picture in which no word try found a page
  // is retrieved on its figure corners last, with RANSAC's inlier distance at
  // figure_inlier_px (corners are located to a pixel or two, whatever the text's size).
  // Views of a chart or a photograph hold a handful of words (tick labels) or none; at
  // 10,000 pages they were most of the views the words did not find.
  bool index_figures = true;
  FigureKeypointOptions figure_keypoints;
  int figure_min_keypoints = 12;
  double figure_inlier_px = 4.0;
  // Query-side multi-probe of the figures' descriptors (RetrievalOptions::query_probes).
  int figure_query_probes = 1;
  // LLAH neighbourhoods of the figures' index (k and the quantisation are the words'): a
  // figure's corners repeat less surely than words (a marker or a bar's corner is missed or
  // a speck of text is taken), so their neighbourhoods forgive more. Used for a new
  // database; an existing one keeps the ones it was built with.
  int figure_llah_n = 7;
  int figure_llah_m = 6;
  // Quantisation levels of the figures' invariants: a divisor of the words' k, whose
  // thresholds every (k / figure_llah_k)-th of the words' are (0: the words' k). A chart's
  // corners are regular (bars and markers in rows, on lines), so their area ratios sit near
  // the levels' boundaries more often than words' do; coarser levels keep more of them.
  // Measured with the corners' blob centroids (FigureKeypointOptions::centroid_max_blob_px),
  // five sets of 1,000 views at 1,000 pages: 4,938 with 8 levels or with 4 levels and local
  // maxima, 4,946 with both (4,939 before either). Used for a new database.
  int figure_llah_k = 4;
  // Large type (titles, headings, posters, slides, large body text): the centroids of its
  // letters (LetterKeypointExtractor) are indexed apart from the words, with the words' LLAH
  // settings and quantisation. A close view of large type holds a handful of words, too few
  // whole neighbourhoods for any word cut, but dozens of letters. A page is registered with
  // the letters of its type of at least letter_min_type_share of its shorter side (body text
  // of 10-12 pt on an A4 page is 0.010-0.013; its views are found by their words and would
  // multiply the index), the largest type first up to letter_max_keypoints, when they are
  // at least letter_min_keypoints. Rendered pages hold 73 such letters on average at 0.018
  // (187 at 0.016, 877 at 0.012): at 10,000 pages the index is 967 MiB with them at 0.018,
  // 1,086 at 0.016 (858 without), for 4,942 and 4,943 of 5,000 views (4,940 without). A picture in
  // which nothing else found a page is retrieved on every letter letter_keypoints cuts, with
  // RANSAC's inlier distance at letter_inlier_share times the letters' size (a letter's centroid is
  // located to a pixel or two; neighbouring letters are less than a letter's size apart).
  bool index_letters = true;
  LetterKeypointOptions letter_keypoints;
  double letter_min_type_share = 0.018;
  int letter_min_keypoints = 12;
  int letter_max_keypoints = 1000;
  double letter_inlier_share = 0.2;
  // ...only for pictures whose first word cut has at most this many keypoints: type small
  // enough for many words in view is found by them, and its letters would cost every
  // unregistered view of small type another retrieval.
  int letter_max_word_keypoints = 150;
  // The neighbourhood pass (RetrievalOptions::neighbourhood_min_tight) on letters confirms
  // a page from this many tight matches, without agreeing hits: a view of an unregistered
  // page (10,000 pages, close views) grew a wrong page to 14 tight matches of its 112
  // letters with 3 agreeing hits; the right pages it found had 20-38.
  int letter_neighbourhood_min_tight = 20;
  // A page with fewer word keypoints cannot be recognised reliably by its words...
  int min_keypoints = 30;
  // ...unless it is large type (a poster, a title page, a slide: index_letters) with at least
  // this many letters registered and more than llah.n words.
  int min_letters_alone = 60;
  // Registering a page that retrieves a registered one with this many inliers
  // is refused.
  int duplicate_min_inliers = 16;
  // Least index hash table size: 2^log2_buckets heads (16 MiB at 22). The start-up
  // rebuild sizes the table for the entries it loads (about 16 a chain), so a database that
  // has grown is served with short chains from its next start.
  int log2_buckets = 22;
  // Threads computing descriptors during the start-up rebuild.
  int rebuild_threads = 2;

  absl::Status Validate() const;
};

struct StageTimes {
  std::vector<std::pair<std::string, double>> stages;  // name, milliseconds
  void Add(std::string name, double ms) { stages.emplace_back(std::move(name), ms); }
};

struct RetrievedDocument {
  DocumentSummary document;
  cv::Matx33d homography;  // registration pixels -> query pixels
  int inliers = 0;
  int votes = 0;
  std::optional<PlanarPose> pose;  // with a camera model
  std::vector<AnnotationRecord> annotations;
};

struct RetrievalResult {
  std::vector<RetrievedDocument> documents;
  int query_keypoints = 0;
  double text_height_px = 0;  // as the first extractor measured it (0: no text)
  StageTimes timings;
};

// Thread-safe. Registrations cut their pages into keypoints concurrently and are
// serialised from the duplicate check to the index write (so the check cannot race);
// retrievals run concurrently with each other.
class DocumentRegistry {
 public:
  static absl::StatusOr<std::unique_ptr<DocumentRegistry>> Open(
      std::unique_ptr<DocumentStore> store, DocumentRegistryOptions options);

  absl::StatusOr<DocumentRecord> Register(const cv::Mat &gray, std::string title,
                                          std::vector<AnnotationRecord> annotations);
  absl::Status Delete(const std::string &id);
  absl::StatusOr<RetrievalResult> Retrieve(const cv::Mat &gray,
                                           const std::optional<CameraModel> &camera,
                                           int max_results) const;
  absl::StatusOr<DocumentRecord> Get(const std::string &id) const;
  absl::StatusOr<std::vector<DocumentSummary>> List(uint32_t after_index_id, int limit) const;
  absl::StatusOr<int64_t> Count() const;
  absl::StatusOr<AnnotationRecord> AddAnnotation(const std::string &id,
                                                 AnnotationRecord annotation);
  absl::Status DeleteAnnotation(const std::string &id, const std::string &annotation_id);

  // For tracking sessions: the shared LLAH index (null until the first page is
  // registered; read-only for sessions), a document's summary by index id (nullopt once
  // deleted) and its annotations.
  std::shared_ptr<const LlahRetriever> retriever() const;
  // The figures' index (null until the first page is registered, or with index_figures off).
  std::shared_ptr<const LlahRetriever> figure_retriever() const;
  std::optional<DocumentSummary> FindByIndexId(uint32_t index_id) const {
    return Summary(index_id);
  }
  absl::StatusOr<std::vector<AnnotationRecord>> AnnotationsByIndexId(uint32_t index_id) const;

  // The figure corners of a picture as retrieval takes them (for diagnosis), and the options
  // their retrieval runs with, from `ro` as the word tries had it.
  std::vector<cv::Point2f> FigureKeypoints(const cv::Mat &gray) const {
    const WordKeypoints words = extractor_.Extract(gray);
    return figure_extractor_.Extract(gray, words.points, words.char_height);
  }
  RetrievalOptions FigureRetrievalOptions(RetrievalOptions ro) const;
  // The letters' index (null until the first page is registered, or with index_letters off),
  // the letters a page is registered with, and the options their retrieval runs with.
  std::shared_ptr<const LlahRetriever> letter_retriever() const;
  LetterKeypoints PageLetters(const cv::Mat &gray) const;
  RetrievalOptions LetterRetrievalOptions(RetrievalOptions ro, double letter_size) const;

  // Every index's memory (words, figures and letters).
  size_t index_memory_bytes() const;
  size_t index_entries() const;
  const DocumentRegistryOptions &options() const { return options_; }

 private:
  // Keypoints the neighbourhood pass takes when nothing else finds a page: an extractor's
  // cut of the picture, or the rectified picture's first cut (`to_view` the warp from the
  // picture to it, identity for the picture itself), with the frame they lie in and how the
  // pass rectifies them.
  struct NeighbourhoodView {
    WordKeypoints keypoints;
    cv::Matx33d to_view = cv::Matx33d::eye();
    cv::Size frame;
    double text_angle_rad = 0;
    bool refine_perspective = false;
  };
  DocumentRegistry(std::unique_ptr<DocumentStore> store, DocumentRegistryOptions options);
  absl::Status LoadIndex();
  // The extra keypoint layers of a page (options_.registration_layers) into `record`.
  void ExtractLayers(const cv::Mat &gray, size_t base_keypoints, DocumentRecord *record) const;
  // Makes `grouping` the registration and first query extractor (the database's own).
  void UseRegistrationGrouping(WordGrouping grouping);
  absl::Status CreateRetriever(const std::vector<cv::Point2f> &training_points);
  // The figures' corner extraction (FigureKeypointOptions::centroid_max_blob_px): the
  // stored one, else options_'s for a new database (`existing` false) or local maxima for
  // one from before the setting; stored now. Rebuilds figure_extractor_ when it differs, so
  // call it before any registration or query can use it.
  absl::Status SettleFigureCorners(bool existing);
  // The figures' LLAH settings: stored ones, else options_'s (stored now).
  absl::StatusOr<LlahOptions> FigureLlahOptions(const LlahOptions &words);
  // The figures' empty index (SettleFigureCorners, then FigureLlahOptions): the words'
  // `quantizer` at the figures' coarser levels.
  absl::StatusOr<std::shared_ptr<LlahRetriever>> CreateFigureIndex(
      const LlahOptions &words, const InvariantQuantizer &quantizer, bool existing);
  std::optional<DocumentSummary> Summary(uint32_t index_id) const;
  // The last try of RetrieveAsGiven: the picture warped by the text-line `horizon` (turned
  // so that the text lines are horizontal), cut anew and retrieved, in up to
  // options_.rectified_picture_rounds rounds, then (options_.rectified_picture_projective)
  // warped by the horizon's perspective alone. A page found fills `hits` and `hits_kp` in the
  // picture's pixels, unless `hits` already holds a page with as many inliers or more; the
  // stage times are added to `extract_ms` and `match_ms`.
  void RetrieveRectifiedPicture(const cv::Mat &gray, const cv::Matx33d &horizon,
                                double text_angle_rad, const LlahRetriever &retriever,
                                const RetrievalOptions &ro, std::vector<DocumentHit> *hits,
                                WordKeypoints *hits_kp, double *extract_ms, double *match_ms,
                                std::vector<NeighbourhoodView> *small_views = nullptr) const;
  // The last tries, on the figures' or the letters' own index: Retrieve(), then (for at most
  // deep_max_keypoints points, when neighbourhood_pass_extractors allows the pass) the
  // neighbourhood pass. `size`: the keypoints' text or letter size (0: none).
  std::vector<DocumentHit> RetrieveWithNeighbourhoods(const LlahRetriever &index,
                                                      const std::vector<cv::Point2f> &points,
                                                      double size, const RetrievalOptions &o) const;
  // Retrieve() on the picture at the size given (Retrieve reduces large pictures first).
  // `words_only`: no figure or letter try.
  absl::StatusOr<RetrievalResult> RetrieveAsGiven(const cv::Mat &gray,
                                                  const std::optional<CameraModel> &camera,
                                                  int max_results, bool words_only = false) const;
  // The small-type retry (small_type_below_px) of a picture that RetrieveAsGiven took at
  // `working` size and found nothing in; `finest` is the picture as given (the same or
  // larger), `camera` the intrinsics at `working` size. Found pages are added to `result`,
  // in `working` pixels.
  absl::Status RetrieveSmallType(const cv::Mat &finest, const cv::Size &working,
                                 const std::optional<CameraModel> &camera, int max_results,
                                 RetrievalResult *result) const;

  DocumentRegistryOptions options_;
  std::unique_ptr<DocumentStore> store_;
  WordKeypointExtractor extractor_;
  std::vector<WordKeypointExtractor> fallback_extractors_;
  std::vector<WordKeypointExtractor> layer_extractors_;  // per registration layer
  std::mutex register_mutex_;
  mutable std::shared_mutex mutex_;  // guards retriever_ (pointer) and summaries_
  std::shared_ptr<LlahRetriever> retriever_;
  // The figures' index (index_figures), created with retriever_ and guarded alike.
  std::shared_ptr<LlahRetriever> figure_retriever_;
  FigureKeypointExtractor figure_extractor_;
  // The letters' index (index_letters), created with retriever_ and guarded alike.
  std::shared_ptr<LlahRetriever> letter_retriever_;
  LetterKeypointExtractor letter_extractor_;       // a query's letters
  LetterKeypointExtractor page_letter_extractor_;  // a registered page's (letter_max_keypoints)
  std::unordered_map<uint32_t, DocumentSummary> summaries_;
};

}  // namespace texfree::server
