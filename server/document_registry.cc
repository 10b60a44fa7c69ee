// DocumentRegistry implementation.
#include "server/document_registry.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <functional>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "common/status_macros.h"
#include "common/text_perspective.h"
#include "common/timing.h"

namespace texfree::server {
namespace {

using Clock = SteadyClock;

constexpr const char *kLlahOptionsKey = "llah.options";
constexpr const char *kQuantizerKey = "llah.quantizer";
// Version of the descriptor hash function; stored hashes of another version are recomputed.
constexpr const char *kHashVersionKey = "llah.hash_version";
constexpr const char *kHashVersion = "1";
// How the database's pages were cut into words. Absent in databases built before it was
// stored, which all used the line closing.
constexpr const char *kGroupingKey = "keypoints.grouping";
constexpr const char *kFigureLlahKey = "figures.llah.options";
// How the pages' figure corners were placed (FigureKeypointOptions::centroid_max_blob_px).
// Absent in databases built before it was stored, which hold local maxima (0).
constexpr const char *kFigureCornersKey = "figures.corners.centroid_max_blob_px";

// The figures' index holds a few dozen corners of the pages with figures: a smaller table.
constexpr int kFigureLog2Buckets = 19;
// The letters' index holds the large type of some pages: a few hundred letters of those.
constexpr int kLetterLog2Buckets = 20;

const char *GroupingName(WordGrouping g) {
  return g == WordGrouping::kLetterGraph ? "letter_graph" : "line_closing";
}

std::string FormatOptions(const LlahOptions &o) { return absl::StrCat(o.n, ",", o.m, ",", o.k); }

absl::StatusOr<LlahOptions> ParseOptions(const std::string &s) {
  std::vector<std::string> parts = absl::StrSplit(s, ',');
  LlahOptions o;
  if (parts.size() != 3 || !absl::SimpleAtoi(parts[0], &o.n) || !absl::SimpleAtoi(parts[1], &o.m) ||
      !absl::SimpleAtoi(parts[2], &o.k))
    return absl::DataLossError(absl::StrCat("stored LLAH options '", s, "' are malformed"));
  RETURN_IF_ERROR(o.Validate());
  return o;
}

std::string FormatThresholds(const std::vector<float> &t) {
  std::ostringstream out;
  out.precision(9);
  for (size_t i = 0; i < t.size(); ++i) out << (i ? "," : "") << t[i];
  return out.str();
}

absl::StatusOr<InvariantQuantizer> ParseThresholds(const std::string &s, int k) {
  std::vector<float> t;
  for (absl::string_view part : absl::StrSplit(s, ',')) {
    float v;
    if (!absl::SimpleAtof(part, &v))
      return absl::DataLossError("stored LLAH thresholds are malformed");
    t.push_back(v);
  }
  if (static_cast<int>(t.size()) != k - 1)
    return absl::DataLossError("stored LLAH thresholds do not match the stored level count");
  return InvariantQuantizer(std::move(t));
}

}  // namespace

WordKeypointOptions DefaultKeypointOptions() {
  WordKeypointOptions letter_graph;
  letter_graph.grouping = WordGrouping::kLetterGraph;
  return letter_graph;
}

std::vector<WordKeypointOptions> DefaultFallbackKeypointOptions() {
  WordKeypointOptions closing;
  closing.grouping = WordGrouping::kLineClosing;
  WordKeypointOptions wide_closing = closing;
  wide_closing.gap_factor = 0.35;
  return {closing, wide_closing};
}

std::vector<RegistrationLayer> DefaultRegistrationLayers() { return {RegistrationLayer{}}; }

absl::Status RegistrationLayer::Validate() const {
  if (!(scale > 0 && scale <= 1))
    return absl::InvalidArgumentError(absl::StrCat("scale must be in (0, 1], got ", scale));
  if (!(blur_sigma >= 0 && blur_sigma <= 10))
    return absl::InvalidArgumentError(
        absl::StrCat("blur_sigma must be in [0, 10] pixels, got ", blur_sigma));
  if (absl::Status s = keypoints.Validate(); !s.ok())
    return absl::InvalidArgumentError(absl::StrCat("keypoints: ", s.message()));
  return absl::OkStatus();
}

void DocumentRegistry::UseRegistrationGrouping(WordGrouping grouping) {
  if (options_.keypoints.grouping == grouping) return;
  auto it = std::find_if(options_.fallback_keypoints.begin(), options_.fallback_keypoints.end(),
                         [&](const WordKeypointOptions &o) { return o.grouping == grouping; });
  if (it != options_.fallback_keypoints.end()) {
    std::swap(options_.keypoints, *it);
  } else {
    options_.fallback_keypoints.insert(options_.fallback_keypoints.begin(), options_.keypoints);
    options_.keypoints.grouping = grouping;
  }
  extractor_ = WordKeypointExtractor(options_.keypoints);
  fallback_extractors_.clear();
  for (const WordKeypointOptions &o : options_.fallback_keypoints)
    fallback_extractors_.emplace_back(o);
}

absl::Status DocumentRegistryOptions::Validate() const {
  RETURN_IF_ERROR(keypoints.Validate());
  if (!(assumed_horizontal_fov_deg >= 0 && assumed_horizontal_fov_deg < 170))
    return absl::InvalidArgumentError(
        absl::StrCat("assumed_horizontal_fov_deg must be in [0, 170) (0: none), got ",
                     assumed_horizontal_fov_deg));
  if (absl::Status s = tracking_keypoints.Validate(); !s.ok())
    return absl::InvalidArgumentError(absl::StrCat("tracking_keypoints: ", s.message()));
  for (size_t i = 0; i < fallback_keypoints.size(); ++i) {
    if (absl::Status s = fallback_keypoints[i].Validate(); !s.ok())
      return absl::InvalidArgumentError(absl::StrCat("fallback_keypoints[", i, "]: ", s.message()));
  }
  for (size_t i = 0; i < registration_layers.size(); ++i) {
    if (absl::Status s = registration_layers[i].Validate(); !s.ok())
      return absl::InvalidArgumentError(
          absl::StrCat("registration_layers[", i, "]: ", s.message()));
  }
  RETURN_IF_ERROR(llah.Validate());
  RETURN_IF_ERROR(retrieval.Validate());
  if (min_keypoints < llah.n + 1)
    return absl::InvalidArgumentError(absl::StrCat("min_keypoints must exceed LLAH n = ", llah.n));
  if (deep_pass_extractors < 0)
    return absl::InvalidArgumentError("deep_pass_extractors must be >= 0");
  if (neighbourhood_pass_extractors < 0)
    return absl::InvalidArgumentError(
        "neighbourhood_pass_extractors must be >= 0 (0: no neighbourhood pass)");
  if (fallback_retry_max_keypoints < 0)
    return absl::InvalidArgumentError("fallback_retry_max_keypoints must be >= 0");
  if (rectified_picture_rounds < 1)
    return absl::InvalidArgumentError(absl::StrCat(
        "rectified_picture_rounds must be >= 1 (rectified_picture_retry turns the retry off), got ",
        rectified_picture_rounds));
  if (!(rectified_picture_projective_min_slope >= 0))
    return absl::InvalidArgumentError(
        absl::StrCat("rectified_picture_projective_min_slope must be >= 0 (a depth change over a "
                     "half-diagonal, relative to the centre's depth), got ",
                     rectified_picture_projective_min_slope));
  if (!(rectified_picture_min_refit_ratio >= 1))
    return absl::InvalidArgumentError(absl::StrCat(
        "rectified_picture_min_refit_ratio must be >= 1, got ", rectified_picture_min_refit_ratio));
  if (rectified_picture_max_keypoints < 0)
    return absl::InvalidArgumentError(absl::StrCat(
        "rectified_picture_max_keypoints must be >= 0, got ", rectified_picture_max_keypoints));
  if (absl::Status s = figure_keypoints.Validate(); !s.ok())
    return absl::InvalidArgumentError(absl::StrCat("figure_keypoints: ", s.message()));
  {
    LlahOptions figure_llah = llah;
    figure_llah.n = figure_llah_n;
    figure_llah.m = figure_llah_m;
    if (absl::Status s = figure_llah.Validate(); !s.ok())
      return absl::InvalidArgumentError(
          absl::StrCat("figure_llah_n, figure_llah_m: ", s.message()));
  }
  if (figure_llah_k != 0 && (figure_llah_k < 2 || llah.k % figure_llah_k != 0))
    return absl::InvalidArgumentError(
        absl::StrCat("figure_llah_k must be 0 (the words' k) or a divisor of at least 2 of the "
                     "words' k = ",
                     llah.k, ", got ", figure_llah_k));
  if (absl::Status s = letter_keypoints.Validate(); !s.ok())
    return absl::InvalidArgumentError(absl::StrCat("letter_keypoints: ", s.message()));
  if (!(letter_min_type_share > 0 && letter_min_type_share <= 0.5))
    return absl::InvalidArgumentError(
        absl::StrCat("letter_min_type_share must be in (0, 0.5] of the page's shorter side, got ",
                     letter_min_type_share));
  if (letter_min_keypoints < llah.n + 1)
    return absl::InvalidArgumentError(absl::StrCat(
        "letter_min_keypoints must exceed llah.n = ", llah.n, ", got ", letter_min_keypoints));
  if (letter_max_keypoints < letter_min_keypoints)
    return absl::InvalidArgumentError(absl::StrCat(
        "letter_max_keypoints must be >= letter_min_keypoints, got ", letter_max_keypoints));
  if (min_letters_alone < letter_min_keypoints)
    return absl::InvalidArgumentError(
        absl::StrCat("min_letters_alone must be >= letter_min_keypoints, got ", min_letters_alone));
  if (letter_neighbourhood_min_tight < 8)
    return absl::InvalidArgumentError(absl::StrCat(
        "letter_neighbourhood_min_tight must be >= 8, got ", letter_neighbourhood_min_tight));
  if (letter_max_word_keypoints < 0)
    return absl::InvalidArgumentError(
        absl::StrCat("letter_max_word_keypoints must be >= 0, got ", letter_max_word_keypoints));
  if (!(letter_inlier_share > 0 && letter_inlier_share <= 1))
    return absl::InvalidArgumentError(
        absl::StrCat("letter_inlier_share must be in (0, 1], got ", letter_inlier_share));
  if (figure_min_keypoints < figure_llah_n + 1)
    return absl::InvalidArgumentError(
        absl::StrCat("figure_min_keypoints must exceed figure_llah_n = ", figure_llah_n, ", got ",
                     figure_min_keypoints));
  if (figure_query_probes < 0 || figure_query_probes > LlahDescriber::kMaxProbes)
    return absl::InvalidArgumentError(absl::StrCat("figure_query_probes must be in [0, ",
                                                   LlahDescriber::kMaxProbes, "], got ",
                                                   figure_query_probes));
  if (!(figure_inlier_px > 0 && figure_inlier_px <= 50))
    return absl::InvalidArgumentError(
        absl::StrCat("figure_inlier_px must be in (0, 50] pixels, got ", figure_inlier_px));
  if (duplicate_min_inliers < retrieval.min_inliers)
    return absl::InvalidArgumentError("duplicate_min_inliers must be >= retrieval.min_inliers");
  if (log2_buckets < 10 || log2_buckets > 30)
    return absl::InvalidArgumentError("log2_buckets must be in [10, 30]");
  if (rebuild_threads < 1) return absl::InvalidArgumentError("rebuild_threads must be >= 1");
  if (!(small_type_below_px >= 0 && small_type_below_px <= 20))
    return absl::InvalidArgumentError(
        absl::StrCat("small_type_below_px must be in [0, 20] pixels (0: no small-type retry), got ",
                     small_type_below_px));
  if (!(small_type_upscale >= 1.5 && small_type_upscale <= 4))
    return absl::InvalidArgumentError(
        absl::StrCat("small_type_upscale must be in [1.5, 4], got ", small_type_upscale));
  if (small_type_max_pixels != 0 && small_type_max_pixels < kMinMaxQueryPixels)
    return absl::InvalidArgumentError(
        absl::StrCat("small_type_max_pixels must be 0 (no limit) or at least ", kMinMaxQueryPixels,
                     ", got ", small_type_max_pixels));
  if (!ValidMaxQueryPixels(max_query_pixels))
    return absl::InvalidArgumentError(absl::StrCat("max_query_pixels must be 0 (never reduce) or ",
                                                   "at least ", kMinMaxQueryPixels, ", got ",
                                                   max_query_pixels));
  return absl::OkStatus();
}

DocumentRegistry::DocumentRegistry(std::unique_ptr<DocumentStore> store,
                                   DocumentRegistryOptions options)
    : options_(std::move(options)),
      store_(std::move(store)),
      extractor_(options_.keypoints),
      figure_extractor_(options_.figure_keypoints),
      letter_extractor_(options_.letter_keypoints),
      page_letter_extractor_([this] {
        LetterKeypointOptions o = options_.letter_keypoints;
        o.max_keypoints = options_.letter_max_keypoints;
        return o;
      }()) {
  for (const WordKeypointOptions &o : options_.fallback_keypoints)
    fallback_extractors_.emplace_back(o);
  for (const RegistrationLayer &layer : options_.registration_layers)
    layer_extractors_.emplace_back(layer.keypoints);
}

absl::StatusOr<std::unique_ptr<DocumentRegistry>> DocumentRegistry::Open(
    std::unique_ptr<DocumentStore> store, DocumentRegistryOptions options) {
  RETURN_IF_ERROR(options.Validate());
  std::unique_ptr<DocumentRegistry> registry(
      new DocumentRegistry(std::move(store), std::move(options)));
  RETURN_IF_ERROR(registry->LoadIndex());
  return registry;
}

absl::Status DocumentRegistry::LoadIndex() {
  const auto t0 = Clock::now();
  ASSIGN_OR_RETURN(auto stored_options, store_->GetSetting(kLlahOptionsKey));
  ASSIGN_OR_RETURN(auto stored_thresholds, store_->GetSetting(kQuantizerKey));
  if (!stored_options || !stored_thresholds) {
    spdlog::info(
        "document index: empty database, quantisation is learned from "
        "the first page");
    return absl::OkStatus();
  }
  ASSIGN_OR_RETURN(LlahOptions llah, ParseOptions(*stored_options));
  if (llah.n != options_.llah.n || llah.m != options_.llah.m || llah.k != options_.llah.k) {
    spdlog::warn(
        "document index: the database was built with LLAH n,m,k = {}; "
        "keeping it",
        *stored_options);
  }
  options_.llah = llah;
  ASSIGN_OR_RETURN(auto stored_grouping, store_->GetSetting(kGroupingKey));
  const WordGrouping grouping =
      stored_grouping && *stored_grouping == GroupingName(WordGrouping::kLetterGraph)
          ? WordGrouping::kLetterGraph
          : WordGrouping::kLineClosing;
  if (stored_grouping && *stored_grouping != GroupingName(grouping))
    return absl::DataLossError(
        absl::StrCat("stored keypoint grouping '", *stored_grouping, "' is unknown"));
  if (grouping != options_.keypoints.grouping) {
    spdlog::warn(
        "document index: pages were cut into words by the {}; keeping it for this database "
        "(register the pages into a new database to use the {})",
        GroupingName(grouping), GroupingName(options_.keypoints.grouping));
    UseRegistrationGrouping(grouping);
  }
  ASSIGN_OR_RETURN(InvariantQuantizer quantizer, ParseThresholds(*stored_thresholds, llah.k));
  std::shared_ptr<LlahRetriever> figures;
  if (options_.index_figures) {
    ASSIGN_OR_RETURN(figures, CreateFigureIndex(llah, quantizer, /*existing=*/true));
  }
  std::shared_ptr<LlahRetriever> letters;
  if (options_.index_letters)
    letters = std::make_shared<LlahRetriever>(llah, quantizer, kLetterLog2Buckets);
  auto retriever =
      std::make_shared<LlahRetriever>(llah, std::move(quantizer), options_.log2_buckets);

  ASSIGN_OR_RETURN(auto stored_hash_version, store_->GetSetting(kHashVersionKey));
  const bool hashes_valid = stored_hash_version && *stored_hash_version == kHashVersion;
  std::vector<DocumentKeypoints> documents, figure_documents, letter_documents;
  RETURN_IF_ERROR(
      store_->ForEachKeypoints([&](const DocumentSummary &s, DocumentStore::StoredKeypoints k) {
        summaries_[s.index_id] = s;
        if (figures && !k.figure_keypoints.empty())
          figure_documents.push_back({s.index_id, std::move(k.figure_keypoints), s.size, {}, {}});
        if (letters && !k.letter_keypoints.empty()) {
          if (!hashes_valid) k.letter_hashes.clear();
          letter_documents.push_back(
              {s.index_id, std::move(k.letter_keypoints), s.size, {}, std::move(k.letter_hashes)});
        }
        if (!hashes_valid) k.hashes.clear();
        k.keypoints.insert(k.keypoints.end(), k.layer_keypoints.begin(), k.layer_keypoints.end());
        documents.push_back({s.index_id, std::move(k.keypoints), s.size, std::move(k.layer_sizes),
                             std::move(k.hashes)});
      }));
  const double read_ms = MillisecondsSince(t0);
  const size_t n = documents.size();
  // Loads `loaded` into `index`; descriptors it had to compute are stored in `column` once,
  // so that the next start-up reads them.
  const auto load_and_store = [this](LlahRetriever *index, std::vector<DocumentKeypoints> loaded,
                                     const std::function<void(size_t, size_t)> &progress,
                                     DocumentStore::HashColumn column) -> absl::Status {
    std::vector<std::pair<uint32_t, std::vector<uint64_t>>> computed;
    RETURN_IF_ERROR(index->AddDocuments(std::move(loaded), options_.rebuild_threads, progress,
                                        [&](uint32_t id, const std::vector<uint64_t> &hashes) {
                                          computed.emplace_back(id, hashes);
                                        }));
    if (computed.empty()) return absl::OkStatus();
    RETURN_IF_ERROR(store_->PutHashes(computed, column));
    spdlog::info("document index: stored {} descriptors of {} pages",
                 column == DocumentStore::HashColumn::kLetters ? "letter" : "word",
                 computed.size());
    return absl::OkStatus();
  };
  RETURN_IF_ERROR(load_and_store(
      retriever.get(), std::move(documents),
      [](size_t done, size_t total) {
        spdlog::info("document index: rebuilt {}/{} pages", done, total);
      },
      DocumentStore::HashColumn::kWords));
  RETURN_IF_ERROR(store_->PutSetting(kHashVersionKey, kHashVersion));
  const size_t figure_pages = figure_documents.size();
  if (figures)
    RETURN_IF_ERROR(figures->AddDocuments(std::move(figure_documents), options_.rebuild_threads));
  const size_t letter_pages = letter_documents.size();
  if (letters)
    RETURN_IF_ERROR(load_and_store(letters.get(), std::move(letter_documents), nullptr,
                                   DocumentStore::HashColumn::kLetters));
  retriever_ = std::move(retriever);
  figure_retriever_ = std::move(figures);
  letter_retriever_ = std::move(letters);
  spdlog::info(
      "document index: {} pages, {} entries, {:.1f} MiB ({} pages with figures, {:.1f} MiB; "
      "{} with large type, {:.1f} MiB), read {:.0f} ms, rebuilt in {:.0f} ms",
      n, retriever_->entries(), retriever_->MemoryBytes() / 1048576.0, figure_pages,
      figure_retriever_ ? figure_retriever_->MemoryBytes() / 1048576.0 : 0.0, letter_pages,
      letter_retriever_ ? letter_retriever_->MemoryBytes() / 1048576.0 : 0.0, read_ms,
      MillisecondsSince(t0));
  return absl::OkStatus();
}

absl::Status DocumentRegistry::CreateRetriever(const std::vector<cv::Point2f> &training_points) {
  // Thresholds at the quantiles of this page's invariants: every level equally
  // used.
  LlahDescriber sampler(options_.llah, InvariantQuantizer());
  std::vector<float> samples;
  sampler.CollectInvariants(training_points, &samples);
  ASSIGN_OR_RETURN(InvariantQuantizer quantizer,
                   InvariantQuantizer::Learn(std::move(samples), options_.llah.k));
  RETURN_IF_ERROR(store_->PutSetting(kQuantizerKey, FormatThresholds(quantizer.thresholds())));
  RETURN_IF_ERROR(store_->PutSetting(kLlahOptionsKey, FormatOptions(options_.llah)));
  RETURN_IF_ERROR(store_->PutSetting(kHashVersionKey, kHashVersion));
  RETURN_IF_ERROR(store_->PutSetting(kGroupingKey, GroupingName(options_.keypoints.grouping)));
  spdlog::info("document index: learned {} quantisation levels: {}", options_.llah.k,
               FormatThresholds(quantizer.thresholds()));
  std::shared_ptr<LlahRetriever> figures;
  if (options_.index_figures) {
    ASSIGN_OR_RETURN(figures, CreateFigureIndex(options_.llah, quantizer, /*existing=*/false));
  }
  std::shared_ptr<LlahRetriever> letters;
  if (options_.index_letters)
    letters = std::make_shared<LlahRetriever>(options_.llah, quantizer, kLetterLog2Buckets);
  std::unique_lock lock(mutex_);
  figure_retriever_ = std::move(figures);
  letter_retriever_ = std::move(letters);
  retriever_ =
      std::make_shared<LlahRetriever>(options_.llah, std::move(quantizer), options_.log2_buckets);
  return absl::OkStatus();
}

absl::Status DocumentRegistry::SettleFigureCorners(bool existing) {
  ASSIGN_OR_RETURN(auto stored, store_->GetSetting(kFigureCornersKey));
  double blob = options_.figure_keypoints.centroid_max_blob_px;
  if (stored) {
    if (!absl::SimpleAtod(*stored, &blob) || !(blob >= 0))
      return absl::DataLossError(
          absl::StrCat("stored figure corner setting '", *stored, "' is malformed"));
  } else {
    // A database from before the setting holds the corners' local maxima.
    if (existing) blob = 0;
    RETURN_IF_ERROR(store_->PutSetting(kFigureCornersKey, absl::StrCat(blob)));
  }
  if (blob != options_.figure_keypoints.centroid_max_blob_px) {
    spdlog::warn(
        "document index: the database's figure corners are {} (centroid_max_blob_px = {}); "
        "keeping them",
        blob > 0 ? "blob centroids" : "local maxima", blob);
    options_.figure_keypoints.centroid_max_blob_px = blob;
    figure_extractor_ = FigureKeypointExtractor(options_.figure_keypoints);
  }
  return absl::OkStatus();
}

absl::StatusOr<std::shared_ptr<LlahRetriever>> DocumentRegistry::CreateFigureIndex(
    const LlahOptions &words, const InvariantQuantizer &quantizer, bool existing) {
  RETURN_IF_ERROR(SettleFigureCorners(existing));
  ASSIGN_OR_RETURN(const LlahOptions figure_llah, FigureLlahOptions(words));
  return std::make_shared<LlahRetriever>(figure_llah, quantizer.Coarser(figure_llah.k),
                                         kFigureLog2Buckets);
}

absl::StatusOr<LlahOptions> DocumentRegistry::FigureLlahOptions(const LlahOptions &words) {
  ASSIGN_OR_RETURN(auto stored, store_->GetSetting(kFigureLlahKey));
  if (stored) {
    ASSIGN_OR_RETURN(LlahOptions figure_llah, ParseOptions(*stored));
    if (figure_llah.k < 2 || words.k % figure_llah.k != 0)
      return absl::DataLossError(absl::StrCat("stored figure LLAH settings '", *stored,
                                              "': k does not divide the words' k = ", words.k));
    return figure_llah;
  }
  LlahOptions figure_llah = words;
  figure_llah.n = options_.figure_llah_n;
  figure_llah.m = options_.figure_llah_m;
  if (options_.figure_llah_k > 0) figure_llah.k = options_.figure_llah_k;
  RETURN_IF_ERROR(figure_llah.Validate());
  RETURN_IF_ERROR(store_->PutSetting(kFigureLlahKey, FormatOptions(figure_llah)));
  return figure_llah;
}

std::optional<DocumentSummary> DocumentRegistry::Summary(uint32_t index_id) const {
  std::shared_lock lock(mutex_);
  auto it = summaries_.find(index_id);
  if (it == summaries_.end()) return std::nullopt;
  return it->second;
}

absl::StatusOr<DocumentRecord> DocumentRegistry::Register(
    const cv::Mat &gray, std::string title, std::vector<AnnotationRecord> annotations) {
  const auto t0 = Clock::now();
  for (size_t i = 0; i < annotations.size(); ++i) {
    if (absl::Status s = annotations[i].Validate(gray.size()); !s.ok())
      return absl::InvalidArgumentError(absl::StrCat("annotation ", i, ": ", s.message()));
  }
  if (title.size() > 1024) return absl::InvalidArgumentError("title is over 1024 bytes");
  WordKeypoints kp = extractor_.Extract(gray);
  LetterKeypoints page_letters;
  if (options_.index_letters) page_letters = PageLetters(gray);
  // A page of large type with few words (a poster, a title page, a slide) is carried by its
  // letters: it needs enough words to be described at all, and min_letters_alone letters.
  const int words = static_cast<int>(kp.points.size());
  const bool by_letters =
      words < options_.min_keypoints && words > options_.llah.n &&
      static_cast<int>(page_letters.points.size()) >= options_.min_letters_alone;
  if (words < options_.min_keypoints && !by_letters) {
    return absl::FailedPreconditionError(absl::StrCat(
        "found ", words, " word keypoints in the ", gray.cols, "x", gray.rows, " image, at least ",
        options_.min_keypoints, " are needed (or, for a page of large type, ", options_.llah.n + 1,
        " and ", options_.min_letters_alone, " letters of large type; found ",
        page_letters.points.size(), "): register a page of text, in focus, seen from above"));
  }

  std::vector<cv::Point2f> figure_points;
  if (options_.index_figures) {
    figure_points = figure_extractor_.Extract(gray, kp.points, kp.char_height);
    if (static_cast<int>(figure_points.size()) < options_.figure_min_keypoints)
      figure_points.clear();
  }
  // The page as the index will hold it, cut before taking the registration lock: the
  // layers are most of a registration's work and depend on nothing the index holds, so
  // concurrent registrations cut their pages in parallel and queue only for the duplicate
  // check and the writes.
  DocumentRecord record;
  record.title = std::move(title);
  record.size = gray.size();
  record.keypoints = kp.points;
  ExtractLayers(gray, kp.points.size(), &record);
  record.figure_keypoints = std::move(figure_points);  // empty unless index_figures
  record.letter_keypoints = page_letters.points;       // empty unless index_letters
  record.annotations = std::move(annotations);
  const double extract_ms = MillisecondsSince(t0);

  std::lock_guard registering(register_mutex_);
  std::shared_ptr<LlahRetriever> retriever, figures, letters;
  {
    std::shared_lock lock(mutex_);
    retriever = retriever_;
    letters = letter_retriever_;
  }
  if (retriever) {
    RetrievalOptions check = options_.retrieval;
    check.max_results = 1;
    const auto hits = retriever->Retrieve(kp.points, kp.char_height, check);
    // A page carried by its letters may not be found by its few words: its letters find it
    // (only for such a page: two pages of one report share headings, not whole pages).
    std::vector<DocumentHit> letter_hits;
    if (by_letters && letters && letters->documents() > 0)
      letter_hits = letters->Retrieve(page_letters.points, page_letters.letter_size,
                                      LetterRetrievalOptions(check, page_letters.letter_size));
    const std::vector<DocumentHit> *answers[] = {&hits, &letter_hits};
    for (const std::vector<DocumentHit> *found : answers) {
      if (found->empty() || (*found)[0].inliers < options_.duplicate_min_inliers) continue;
      const auto existing = Summary((*found)[0].document);
      return absl::AlreadyExistsError(absl::StrCat(
          "this page is already registered as document '", existing ? existing->id : "?", "' (\"",
          existing ? existing->title : "", "\", ", (*found)[0].inliers,
          " matching keypoints); delete it first to register it again"));
    }
  } else {
    // The quantisation is learned from the first page's keypoints: its letters when they
    // carry it.
    RETURN_IF_ERROR(CreateRetriever(by_letters ? page_letters.points : kp.points));
  }
  {
    std::shared_lock lock(mutex_);
    retriever = retriever_;
    figures = figure_retriever_;
    letters = letter_retriever_;
  }

  std::vector<cv::Point2f> all = kp.points;
  all.insert(all.end(), record.layer_keypoints.begin(), record.layer_keypoints.end());
  retriever->DescribeLayers(all, record.layer_sizes, &record.hashes);
  if (letters && !record.letter_keypoints.empty())
    letters->DescribeLayers(record.letter_keypoints, {}, &record.letter_hashes);
  ASSIGN_OR_RETURN(record, store_->Insert(std::move(record)));
  absl::Status added = retriever->AddDocument(
      {record.index_id, std::move(all), gray.size(), record.layer_sizes, record.hashes});
  if (added.ok() && figures && !record.figure_keypoints.empty()) {
    added = figures->AddDocument({record.index_id, record.figure_keypoints, gray.size(), {}, {}});
    if (!added.ok()) retriever->RemoveDocument(record.index_id);
  }
  if (added.ok() && letters && !record.letter_keypoints.empty()) {
    added = letters->AddDocument(
        {record.index_id, record.letter_keypoints, gray.size(), {}, record.letter_hashes});
    if (!added.ok()) {
      retriever->RemoveDocument(record.index_id);
      if (figures) figures->RemoveDocument(record.index_id);
    }
  }
  if (!added.ok()) {
    store_->Delete(record.id).IgnoreError();  // keep database and index in step
    return added;
  }
  {
    std::unique_lock lock(mutex_);
    summaries_[record.index_id] = {record.index_id,
                                   record.id,
                                   record.title,
                                   record.size,
                                   static_cast<int>(record.keypoints.size()),
                                   record.created_unix_ms};
  }
  spdlog::info(
      "registered document {} \"{}\": {}x{}, {} keypoints, {} figure keypoints, {} letters of "
      "large type, {} annotations (extract {:.1f} ms, total {:.1f} ms)",
      record.id, record.title, gray.cols, gray.rows, record.keypoints.size(),
      record.figure_keypoints.size(), record.letter_keypoints.size(), record.annotations.size(),
      extract_ms, MillisecondsSince(t0));
  return record;
}

void DocumentRegistry::ExtractLayers(const cv::Mat &gray, size_t base_keypoints,
                                     DocumentRecord *record) const {
  // The index addresses a page's keypoints with 16 bits: layers that would not fit are left
  // out.
  constexpr size_t kMaxKeypoints = 65535;
  size_t total = base_keypoints;
  for (size_t i = 0; i < options_.registration_layers.size(); ++i) {
    const RegistrationLayer &layer = options_.registration_layers[i];
    const cv::Size size(std::max(1, static_cast<int>(std::lround(gray.cols * layer.scale))),
                        std::max(1, static_cast<int>(std::lround(gray.rows * layer.scale))));
    cv::Mat seen;
    cv::resize(gray, seen, size, 0, 0, cv::INTER_AREA);
    if (layer.blur_sigma > 0) cv::GaussianBlur(seen, seen, cv::Size(), layer.blur_sigma);
    const WordKeypoints kp = layer_extractors_[i].Extract(seen);
    if (total + kp.points.size() > kMaxKeypoints) break;
    // Pixel centres: pixel i of the small image covers page pixels [i / sx, (i + 1) / sx).
    // Positions stay the layer's own, even where it cuts a word as the base does: snapped to
    // the base keypoint, such words duplicate the base's descriptors (18% fewer layer
    // entries), but the layer's slightly shifted centroids give descriptors with invariants
    // across a level boundary that blurred queries produce too (4 views of 200 fewer found at
    // 1,000 pages when snapped).
    const float sx = static_cast<float>(size.width) / gray.cols;
    const float sy = static_cast<float>(size.height) / gray.rows;
    for (const cv::Point2f &p : kp.points)
      record->layer_keypoints.emplace_back((p.x + 0.5f) / sx - 0.5f, (p.y + 0.5f) / sy - 0.5f);
    record->layer_sizes.push_back(static_cast<uint32_t>(kp.points.size()));
    total += kp.points.size();
  }
}

absl::Status DocumentRegistry::Delete(const std::string &id) {
  const auto t0 = Clock::now();
  std::lock_guard registering(register_mutex_);
  ASSIGN_OR_RETURN(uint32_t index_id, store_->Delete(id));
  std::shared_ptr<LlahRetriever> retriever, figures, letters;
  {
    std::unique_lock lock(mutex_);
    summaries_.erase(index_id);
    retriever = retriever_;
    figures = figure_retriever_;
    letters = letter_retriever_;
  }
  if (retriever) retriever->RemoveDocument(index_id);
  if (figures) figures->RemoveDocument(index_id);
  if (letters) letters->RemoveDocument(index_id);
  spdlog::info("deleted document {} in {:.1f} ms", id, MillisecondsSince(t0));
  return absl::OkStatus();
}

namespace {

// `camera` (for pictures of `from` pixels) for the picture resized to `to`.
std::optional<CameraModel> ScaledCamera(const std::optional<CameraModel> &camera,
                                        const cv::Size &from, const cv::Size &to) {
  if (!camera) return std::nullopt;
  CameraModel scaled = *camera;
  // The distortion coefficients act on normalised coordinates and stay as they are.
  scaled.K = ScaledIntrinsics(camera->K, from, to);
  scaled.size = to;
  return scaled;
}

}  // namespace

absl::StatusOr<RetrievalResult> DocumentRegistry::Retrieve(const cv::Mat &gray,
                                                           const std::optional<CameraModel> &camera,
                                                           int max_results) const {
  // Intrinsics calibrated at another resolution of the same sensor are scaled to the picture.
  std::optional<CameraModel> picture_camera;
  if (camera) {
    ASSIGN_OR_RETURN(picture_camera, CameraForImage(*camera, gray.size()));
  }
  const cv::Size working = WholeFactorWorkingSize(gray.size(), options_.max_query_pixels);
  if (working == gray.size()) {
    ASSIGN_OR_RETURN(RetrievalResult result, RetrieveAsGiven(gray, picture_camera, max_results));
    RETURN_IF_ERROR(RetrieveSmallType(gray, gray.size(), picture_camera, max_results, &result));
    return result;
  }
  const auto t = Clock::now();
  cv::Mat reduced;
  cv::resize(gray, reduced, working, 0, 0, cv::INTER_AREA);
  const std::optional<CameraModel> reduced_camera =
      ScaledCamera(picture_camera, gray.size(), working);
  const double reduce_ms = MillisecondsSince(t);
  ASSIGN_OR_RETURN(RetrievalResult result, RetrieveAsGiven(reduced, reduced_camera, max_results));
  RETURN_IF_ERROR(RetrieveSmallType(gray, working, reduced_camera, max_results, &result));
  // Homographies back to the picture's pixels; poses are the camera's and stay.
  const cv::Matx33d to_given = PixelScaling(working, gray.size());
  for (RetrievedDocument &doc : result.documents) doc.homography = to_given * doc.homography;
  result.timings.stages.insert(result.timings.stages.begin(), {"reduce", reduce_ms});
  return result;
}

absl::Status DocumentRegistry::RetrieveSmallType(const cv::Mat &finest, const cv::Size &working,
                                                 const std::optional<CameraModel> &camera,
                                                 int max_results, RetrievalResult *result) const {
  if (!result->documents.empty() || !(result->text_height_px > 0) ||
      result->text_height_px >= options_.small_type_below_px)
    return absl::OkStatus();
  const double pixels = static_cast<double>(working.width) * working.height;
  double factor = options_.small_type_upscale;
  if (options_.small_type_max_pixels > 0)
    factor = std::min(factor, std::sqrt(options_.small_type_max_pixels / pixels));
  if (factor < 1.5) return absl::OkStatus();  // too little finer to cut differently
  const cv::Size size(static_cast<int>(std::lround(working.width * factor)),
                      static_cast<int>(std::lround(working.height * factor)));
  const auto t = Clock::now();
  cv::Mat upscaled;
  // Reduced from the picture as given: taken again from it, with its own detail.
  cv::resize(finest, upscaled, size, 0, 0,
             size.area() < finest.size().area() ? cv::INTER_AREA : cv::INTER_CUBIC);
  const double upscale_ms = MillisecondsSince(t);
  ASSIGN_OR_RETURN(RetrievalResult found,
                   RetrieveAsGiven(upscaled, ScaledCamera(camera, working, upscaled.size()),
                                   max_results, /*words_only=*/true));
  const cv::Matx33d back = PixelScaling(upscaled.size(), working);
  for (RetrievedDocument &doc : found.documents) {
    doc.homography = back * doc.homography;
    result->documents.push_back(std::move(doc));
  }
  result->timings.Add("small type upscale", upscale_ms);
  for (auto &[name, ms] : found.timings.stages) result->timings.Add("small type " + name, ms);
  return absl::OkStatus();
}

namespace {

// A rotation about the origin that turns the text direction `text_angle_rad` (at the
// picture's centre, through `rectification`) horizontal.
cv::Matx33d UprightText(const cv::Matx33d &rectification, double text_angle_rad,
                        const cv::Size &picture) {
  const cv::Point2f c(picture.width / 2.0f, picture.height / 2.0f);
  const cv::Point2f d = c + 20.0f * cv::Point2f(static_cast<float>(std::cos(text_angle_rad)),
                                                static_cast<float>(std::sin(text_angle_rad)));
  const std::vector<cv::Point2f> ends = ApplyPerspective(rectification, {c, d});
  const double phi = std::atan2(ends[1].y - ends[0].y, ends[1].x - ends[0].x);
  return cv::Matx33d(std::cos(phi), std::sin(phi), 0, -std::sin(phi), std::cos(phi), 0, 0, 0, 1);
}

}  // namespace

void DocumentRegistry::RetrieveRectifiedPicture(
    const cv::Mat &gray, const cv::Matx33d &horizon, double text_angle_rad,
    const LlahRetriever &retriever, const RetrievalOptions &ro, std::vector<DocumentHit> *hits,
    WordKeypoints *hits_kp, double *extract_ms, double *match_ms,
    std::vector<NeighbourhoodView> *small_views) const {
  // The text lines turned horizontal, as on the registered page: the extractors cut
  // upright lines as they cut the page (at 10,000 pages, 976 -> 978 of 1,000 views).
  std::optional<cv::Matx33d> rectification = horizon;
  if (std::isfinite(text_angle_rad))
    rectification = UprightText(horizon, text_angle_rad, gray.size()) * horizon;
  RetrievalOptions warped_options = ro;
  // What perspective the horizon left (its foreshortening was assumed) is rectified as in
  // any view, with the view as warped tried too: at 10,000 pages this found one more of
  // 1,000 views (a 37-degree view of 6 px type) at no measurable cost, since a warped
  // picture is mostly close enough to affine to be described as it is.
  warped_options.rectify_perspective = options_.retrieval.rectify_perspective;
  warped_options.retry_unrectified = true;
  warped_options.refine_perspective = false;
  warped_options.deep_max_keypoints = options_.retrieval.deep_max_keypoints;
  const std::vector<cv::Point2f> corners{
      {0, 0},
      {static_cast<float>(gray.cols), 0},
      {static_cast<float>(gray.cols), static_cast<float>(gray.rows)},
      {0, static_cast<float>(gray.rows)}};
  // The horizon's perspective alone (options_.rectified_picture_projective): the third row,
  // 1 at the picture's centre.
  std::optional<cv::Matx33d> projective;
  if (options_.rectified_picture_projective) {
    projective = PerspectiveOnly(horizon, {gray.cols / 2.0, gray.rows / 2.0});
    // How much the depth changes over a half-diagonal from the centre, relative to the
    // centre's: the view's steepness as the horizon has it.
    if (projective && std::hypot((*projective)(2, 0), (*projective)(2, 1)) *
                              std::hypot(gray.cols, gray.rows) / 2 <
                          options_.rectified_picture_projective_min_slope)
      projective.reset();
  }
  // Each round warps the picture by `rectification`, cuts it anew and retrieves; a round
  // that finds nothing fits the horizon again on the warped picture's own keypoints (cut
  // more evenly than the picture's on the far side) and the next round warps by both.
  // After the rounds, the perspective alone is the last warp.
  int refits_left = options_.rectified_picture_rounds - 1;
  while (rectification || projective) {
    if (!rectification) {
      rectification = projective;
      projective.reset();
      refits_left = 0;
    }
    const std::vector<cv::Point2f> moved = ApplyPerspective(*rectification, corners);
    const cv::Rect2f box = cv::boundingRect(moved);
    // A horizon that blows the picture up beyond 4 times its area is not the text's (the
    // quadrilateral's area: turning the picture upright grows its bounding box, not it).
    if (!(box.width > 0 && box.height > 0 && cv::contourArea(moved) < 4.0 * gray.total())) {
      rectification.reset();
      continue;
    }
    // At most max_query_pixels: a large picture of few words (or of none, a photo of
    // something else) must not cost an extraction of many megapixels.
    const double limit = options_.max_query_pixels > 0
                             ? static_cast<double>(options_.max_query_pixels)
                             : 4.0 * gray.total();
    const double fit = std::min(1.0, std::sqrt(limit / box.area()));
    const cv::Matx33d shift(fit, 0, -fit * box.x, 0, fit, -fit * box.y, 0, 0, 1);
    const cv::Matx33d to_warped = shift * (*rectification);
    cv::Mat warped;
    auto t = Clock::now();
    cv::warpPerspective(gray, warped, cv::Mat(to_warped),
                        cv::Size(std::max(1, static_cast<int>(fit * box.width)),
                                 std::max(1, static_cast<int>(fit * box.height))),
                        cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(255));
    WordKeypoints wkp = extractor_.Extract(warped);
    *extract_ms += MillisecondsSince(t);
    // The first round's cut is also the neighbourhood pass's (its warp is the horizon's).
    if (small_views != nullptr && wkp.char_height > 0 &&
        static_cast<int>(wkp.points.size()) <= options_.retrieval.deep_max_keypoints)
      small_views->push_back({wkp, to_warped, warped.size(), wkp.text_angle_rad, false});
    small_views = nullptr;
    warped_options.frame = warped.size();
    t = Clock::now();
    std::vector<DocumentHit> found =
        retriever.Retrieve(wkp.points, wkp.char_height, warped_options);
    *match_ms += MillisecondsSince(t);
    // The fallback extractors cut the warped picture too, as they would the picture.
    if (found.empty() && options_.rectified_picture_fallbacks && wkp.char_height > 0) {
      const TextGeometry warped_text{wkp.char_height, wkp.text_angle_rad};
      std::vector<cv::Point2f> seen = wkp.points;
      for (const auto &fallback : fallback_extractors_) {
        t = Clock::now();
        WordKeypoints fk = fallback.Extract(warped, warped_text);
        *extract_ms += MillisecondsSince(t);
        if (fk.points == seen) continue;
        seen = fk.points;
        t = Clock::now();
        found = retriever.Retrieve(fk.points, fk.char_height, warped_options);
        *match_ms += MillisecondsSince(t);
        if (!found.empty()) {
          wkp = std::move(fk);
          break;
        }
      }
    }
    if (!found.empty()) {
      // A weaker answer than the one the picture gave is not taken.
      if (!hits->empty() && found[0].inliers <= (*hits)[0].inliers) return;
      // Homographies and keypoints back in the picture's pixels.
      const cv::Matx33d back = to_warped.inv();
      for (DocumentHit &h : found) h.homography = back * h.homography;
      *hits = std::move(found);
      *hits_kp = std::move(wkp);
      hits_kp->points = ApplyPerspective(back, hits_kp->points);
      return;
    }
    rectification.reset();
    if (refits_left-- > 0 && wkp.char_height > 0 && wkp.points.size() >= 12) {
      // The warped picture's foreshortening is already undone: the horizon alone.
      TextPerspectiveOptions affine = ro.perspective;
      affine.focal_px = 0;
      const auto again =
          RefineTextPerspective(wkp.points, wkp.text_angle_rad, std::nullopt, affine);
      // Most pictures of unregistered pages refit within 2%, which cuts the words alike and
      // only costs another round.
      if (again && DepthRatio(*again, wkp.points) >= options_.rectified_picture_min_refit_ratio)
        rectification = (*again) * to_warped;
    }
  }
}

absl::StatusOr<RetrievalResult> DocumentRegistry::RetrieveAsGiven(
    const cv::Mat &gray, const std::optional<CameraModel> &camera, int max_results,
    bool words_only) const {
  RetrievalResult result;
  std::shared_ptr<LlahRetriever> retriever, figures, letters;
  {
    std::shared_lock lock(mutex_);
    retriever = retriever_;
    figures = figure_retriever_;
    letters = letter_retriever_;
  }
  RetrievalOptions ro = options_.retrieval;
  ro.max_results = max_results;
  ro.frame = gray.size();
  // The focal length lets a steep view's rectification undo the foreshortening too.
  if (camera) {
    ro.perspective.focal_px = camera->K(0, 0);
    ro.perspective.principal_point = {camera->K(0, 2), camera->K(1, 2)};
  } else if (options_.assumed_horizontal_fov_deg > 0) {
    ro.perspective.focal_px =
        gray.cols / 2.0 / std::tan(options_.assumed_horizontal_fov_deg * CV_PI / 360.0);
    ro.perspective.principal_point = {gray.cols / 2.0, gray.rows / 2.0};
  }
  // The registration extractor first; when it finds nothing, the fallback
  // extractors (other ways of joining letters into words, for fonts and blur
  // the first one splits or merges differently than on the registered page).
  // Verification keeps false matches out.
  WordKeypoints kp, hits_kp;
  std::vector<cv::Point2f> first_points;  // the registration extractor's
  std::vector<DocumentHit> hits;
  double extract_ms = 0, match_ms = 0;
  // Every extractor measures the text alike (pass 1); the fallbacks reuse the first's
  // measurement, and when it found no text there is nothing for them to group either.
  TextGeometry measured;
  std::vector<cv::Point2f> tried;  // the previous extractor's keypoints
  // The first keypoints' text-line horizon, when the retriever's last try fitted it.
  std::optional<cv::Matx33d> text_line_horizon;
  // The keypoints the neighbourhood pass takes when nothing else finds a page.
  std::vector<NeighbourhoodView> small_views;
  for (size_t attempt = 0; attempt <= fallback_extractors_.size(); ++attempt) {
    auto t = Clock::now();
    if (attempt == 0) {
      kp = extractor_.Extract(gray);
      measured = {kp.char_height, kp.text_angle_rad};
      first_points = kp.points;
    } else {
      kp = fallback_extractors_[attempt - 1].Extract(gray, measured);
    }
    extract_ms += MillisecondsSince(t);
    if (attempt == 0) {
      result.query_keypoints = static_cast<int>(kp.points.size());
      result.text_height_px = kp.char_height;
    }
    if (measured.char_height <= 0) break;
    if (!retriever) break;
    // Two groupings often cut a view alike (the line closings at 0.25 and 0.35 text
    // heights agree on clearly spaced text): the same keypoints would find the same.
    if (attempt > 0 && kp.points == tried) continue;
    tried = kp.points;
    if (static_cast<int>(attempt) < options_.neighbourhood_pass_extractors &&
        static_cast<int>(kp.points.size()) <= options_.retrieval.deep_max_keypoints)
      small_views.push_back({kp, cv::Matx33d::eye(), ro.frame, measured.text_angle_rad,
                             options_.retrieval.refine_perspective && small_views.empty()});
    t = Clock::now();
    // The fallbacks' keypoints are retried unrectified only in small views: a large view
    // that finds nothing would otherwise pay for six retrievals.
    ro.retry_unrectified = options_.retrieval.retry_unrectified &&
                           (attempt == 0 || static_cast<int>(kp.points.size()) <=
                                                options_.fallback_retry_max_keypoints);
    // The few-keypoint pass is for views no extractor has found a page in yet.
    ro.deep_max_keypoints =
        hits.empty() && static_cast<int>(attempt) < options_.deep_pass_extractors
            ? options_.retrieval.deep_max_keypoints
            : 0;
    // The text-line rectification is tried with the registration extractor's keypoints
    // only: each try costs a view of an unregistered page one more retrieval.
    ro.text_angle_rad = measured.text_angle_rad;
    ro.refine_perspective = options_.retrieval.refine_perspective && attempt == 0;
    std::vector<DocumentHit> found = retriever->Retrieve(
        kp.points, kp.char_height, ro, nullptr, attempt == 0 ? &text_line_horizon : nullptr);
    match_ms += MillisecondsSince(t);
    // A page confirmed only by the layout check (fewer than min_inliers LLAH inliers) may
    // be found firmly by the next extractor: the firmest answer is kept.
    if (!found.empty() && (hits.empty() || found[0].inliers > hits[0].inliers)) {
      hits = std::move(found);
      hits_kp = kp;
    }
    if (!hits.empty() && hits[0].inliers >= ro.min_inliers) break;
  }
  // Last: the picture itself rectified by the text-line horizon of the first keypoints and
  // cut anew (words that perspective merged or split are cut as on the page). Also after a
  // page confirmed only weakly (fewer than min_inliers LLAH inliers): such a consensus can
  // hold in one part of the view and not in the rest, and the rectified picture's firmer
  // answer is kept (at 10,000 pages a 50-word view was found by the second fallback
  // extractor with 8 inliers and a homography 29 px off, and by the rectified picture with
  // 13 inliers and 0.2 px).
  if ((hits.empty() ||
       (options_.rectified_picture_after_weak && hits[0].inliers < ro.min_inliers)) &&
      retriever && options_.rectified_picture_retry && options_.retrieval.refine_perspective &&
      measured.char_height > 0 && first_points.size() >= 12 &&
      static_cast<int>(first_points.size()) <= options_.rectified_picture_max_keypoints) {
    // The retriever's last try fitted the horizon (or found none) for the first keypoints
    // when there were at most refine_max_keypoints of them; larger views are fitted here.
    std::optional<cv::Matx33d> horizon = text_line_horizon;
    if (static_cast<int>(first_points.size()) > options_.retrieval.refine_max_keypoints) {
      horizon = RefineTextPerspective(first_points, measured.text_angle_rad,
                                      EstimateTextPerspective(first_points, ro.perspective),
                                      ro.perspective);
    }
    if (horizon) {
      RetrieveRectifiedPicture(
          gray, *horizon, measured.text_angle_rad, *retriever, ro, &hits, &hits_kp, &extract_ms,
          &match_ms,
          options_.neighbourhood_pass_rectified && options_.neighbourhood_pass_extractors > 0
              ? &small_views
              : nullptr);
    }
  }
  // Last of all, for a picture of few keypoints: single descriptor hits, each a homography
  // (the extractors' cuts first, then the rectified picture's), found in the picture's
  // pixels.
  for (size_t i = 0; hits.empty() && retriever && i < small_views.size(); ++i) {
    const NeighbourhoodView &view = small_views[i];
    auto t = Clock::now();
    RetrievalOptions no = ro;
    no.text_angle_rad = view.text_angle_rad;
    no.refine_perspective = view.refine_perspective;
    no.frame = view.frame;
    hits =
        retriever->RetrieveByNeighbourhoods(view.keypoints.points, view.keypoints.char_height, no);
    match_ms += MillisecondsSince(t);
    if (!hits.empty()) {
      const cv::Matx33d back = view.to_view.inv();
      for (DocumentHit &h : hits) h.homography = back * h.homography;
      hits_kp = view.keypoints;
      hits_kp.points = ApplyPerspective(back, hits_kp.points);
    }
  }
  // Last: the figures' corners, for a view of a chart or a photograph.
  const LlahRetriever *hits_index = retriever.get();
  if (hits.empty() && !words_only && figures && figures->documents() > 0) {
    auto t = Clock::now();
    WordKeypoints corners;
    corners.points = figure_extractor_.Extract(gray, first_points, measured.char_height);
    extract_ms += MillisecondsSince(t);
    if (static_cast<int>(corners.points.size()) > figures->describer().options().n) {
      t = Clock::now();
      hits = RetrieveWithNeighbourhoods(*figures, corners.points, 0, FigureRetrievalOptions(ro));
      match_ms += MillisecondsSince(t);
      if (!hits.empty()) {
        hits_kp = std::move(corners);
        hits_index = figures.get();
      }
    }
  }
  // And the letters, for a close view of large type.
  if (hits.empty() && !words_only && letters && letters->documents() > 0 &&
      static_cast<int>(first_points.size()) <= options_.letter_max_word_keypoints) {
    auto t = Clock::now();
    const LetterKeypoints cut = letter_extractor_.Extract(gray);
    extract_ms += MillisecondsSince(t);
    if (static_cast<int>(cut.points.size()) > letters->describer().options().n) {
      t = Clock::now();
      hits = RetrieveWithNeighbourhoods(*letters, cut.points, cut.letter_size,
                                        LetterRetrievalOptions(ro, cut.letter_size));
      match_ms += MillisecondsSince(t);
      if (!hits.empty()) {
        hits_kp.points = cut.points;
        hits_kp.char_height = cut.letter_size;
        hits_index = letters.get();
      }
    }
  }
  kp = std::move(hits_kp);
  result.timings.Add("extract", extract_ms);
  if (!retriever) return result;
  result.timings.Add("match", match_ms);

  auto t = Clock::now();
  for (const DocumentHit &hit : hits) {
    auto summary = Summary(hit.document);
    if (!summary) continue;  // deleted meanwhile
    RetrievedDocument doc;
    doc.document = *summary;
    doc.homography = hit.homography;
    doc.inliers = hit.inliers;
    doc.votes = hit.votes;
    if (camera) {
      const std::vector<cv::Point2f> reference = hits_index->Keypoints(hit.document);
      std::vector<cv::Point2f> plane, pixels;
      for (const auto &[q, r] : hit.matches) {
        if (r < static_cast<int>(reference.size())) {
          plane.push_back(reference[r]);
          pixels.push_back(kp.points[q]);
        }
      }
      auto pose = EstimatePlanarPose(plane, pixels, *camera);
      if (pose.ok()) doc.pose = *pose;
    }
    ASSIGN_OR_RETURN(doc.annotations, store_->Annotations(hit.document));
    result.documents.push_back(std::move(doc));
  }
  result.timings.Add("pose", MillisecondsSince(t));
  return result;
}

absl::StatusOr<DocumentRecord> DocumentRegistry::Get(const std::string &id) const {
  return store_->Get(id);
}

absl::StatusOr<std::vector<DocumentSummary>> DocumentRegistry::List(uint32_t after_index_id,
                                                                    int limit) const {
  return store_->List(after_index_id, limit);
}

absl::StatusOr<int64_t> DocumentRegistry::Count() const { return store_->Count(); }

absl::StatusOr<AnnotationRecord> DocumentRegistry::AddAnnotation(const std::string &id,
                                                                 AnnotationRecord annotation) {
  ASSIGN_OR_RETURN(DocumentRecord doc, store_->Get(id));
  RETURN_IF_ERROR(annotation.Validate(doc.size));
  return store_->AddAnnotation(id, std::move(annotation));
}

absl::Status DocumentRegistry::DeleteAnnotation(const std::string &id,
                                                const std::string &annotation_id) {
  return store_->DeleteAnnotation(id, annotation_id);
}

std::vector<DocumentHit> DocumentRegistry::RetrieveWithNeighbourhoods(
    const LlahRetriever &index, const std::vector<cv::Point2f> &points, double size,
    const RetrievalOptions &o) const {
  std::vector<DocumentHit> hits = index.Retrieve(points, size, o);
  if (hits.empty() && options_.neighbourhood_pass_extractors > 0 &&
      static_cast<int>(points.size()) <= options_.retrieval.deep_max_keypoints)
    hits = index.RetrieveByNeighbourhoods(points, size, o);
  return hits;
}

RetrievalOptions DocumentRegistry::FigureRetrievalOptions(RetrievalOptions ro) const {
  // Corners are not text: no text-line rectification, no spacing gradient to undo.
  ro.rectify_perspective = false;
  ro.refine_perspective = false;
  ro.text_angle_rad = std::numeric_limits<double>::quiet_NaN();
  ro.ransac_threshold_px = options_.figure_inlier_px;
  ro.query_probes = options_.figure_query_probes;
  ro.deep_max_keypoints = options_.retrieval.deep_max_keypoints;
  return ro;
}

std::shared_ptr<const LlahRetriever> DocumentRegistry::figure_retriever() const {
  std::shared_lock lock(mutex_);
  return figure_retriever_;
}

std::shared_ptr<const LlahRetriever> DocumentRegistry::letter_retriever() const {
  std::shared_lock lock(mutex_);
  return letter_retriever_;
}

LetterKeypoints DocumentRegistry::PageLetters(const cv::Mat &gray) const {
  const double min_type = options_.letter_min_type_share * std::min(gray.cols, gray.rows);
  LetterKeypoints letters = page_letter_extractor_.Extract(gray, min_type);
  if (static_cast<int>(letters.points.size()) < options_.letter_min_keypoints) return {};
  return letters;
}

RetrievalOptions DocumentRegistry::LetterRetrievalOptions(RetrievalOptions ro,
                                                          double letter_size) const {
  ro.ransac_threshold_px = std::max(1.5, options_.letter_inlier_share * letter_size);
  // The neighbourhood pass confirms a page on its tight matches alone: agreeing hits come by
  // chance more often among letters, which are many and regularly spaced.
  ro.neighbourhood_min_tight = options_.letter_neighbourhood_min_tight;
  ro.neighbourhood_min_tight_wide =
      std::max(ro.neighbourhood_min_tight_wide, ro.neighbourhood_min_tight);
  ro.neighbourhood_min_tight_agreeing = 0;
  ro.deep_max_keypoints = options_.retrieval.deep_max_keypoints;
  return ro;
}

std::shared_ptr<const LlahRetriever> DocumentRegistry::retriever() const {
  std::shared_lock lock(mutex_);
  return retriever_;
}

absl::StatusOr<std::vector<AnnotationRecord>> DocumentRegistry::AnnotationsByIndexId(
    uint32_t index_id) const {
  return store_->Annotations(index_id);
}

size_t DocumentRegistry::index_memory_bytes() const {
  std::shared_lock lock(mutex_);
  return (retriever_ ? retriever_->MemoryBytes() : 0) +
         (figure_retriever_ ? figure_retriever_->MemoryBytes() : 0) +
         (letter_retriever_ ? letter_retriever_->MemoryBytes() : 0);
}

size_t DocumentRegistry::index_entries() const {
  std::shared_lock lock(mutex_);
  return retriever_ ? retriever_->entries() : 0;
}

}  // namespace texfree::server
