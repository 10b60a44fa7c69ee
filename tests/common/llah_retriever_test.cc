// Tests of LlahRetriever on synthetic keypoint sets: 50 registered "documents" (uniform
// point processes and jittered text-line layouts), queries made of a perspective view of a
// window of one or two documents with noise, outliers and missing points. Checks the
// document found, the homography against the exact one, rejection of unknown point sets,
// removal, duplicate ids and option validation.
#include "common/llah_retriever.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <opencv2/imgproc.hpp>
#include <ostream>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "common/planar_pose.h"
#include "tests/data/camera_view.h"

namespace texfree {
namespace {

constexpr int kDocuments = 50;
constexpr int kPointsPerDocument = 300;
const cv::Size kPageSize(1000, 1400);
// Passed as the query's character height: RANSAC threshold 0.45 * 10 = 4.5 px.
constexpr double kQueryCharHeight = 10;

enum class Layout { kUniform, kTextLines };

std::string LayoutName(Layout layout) {
  return layout == Layout::kUniform ? "Uniform" : "TextLines";
}

void PrintTo(Layout layout, std::ostream* os) { *os << LayoutName(layout); }

// A Poisson-like point process over the page.
std::vector<cv::Point2f> UniformDocument(std::mt19937& rng) {
  std::uniform_real_distribution<float> ux(0, kPageSize.width), uy(0, kPageSize.height);
  std::vector<cv::Point2f> pts(kPointsPerDocument);
  for (auto& p : pts) p = {ux(rng), uy(rng)};
  return pts;
}

// Word centroids of a text page: lines 46 px apart, words 45..115 px apart along a line,
// with a little vertical jitter (ascenders, descenders, punctuation).
std::vector<cv::Point2f> TextLineDocument(std::mt19937& rng) {
  std::uniform_real_distribution<float> gap(45, 115), start(20, 80), jitter(-2.5f, 2.5f);
  std::vector<cv::Point2f> pts;
  for (float y = 30; pts.size() < static_cast<size_t>(kPointsPerDocument); y += 46) {
    for (float x = start(rng); x < kPageSize.width - 20; x += gap(rng)) {
      pts.emplace_back(x, y + jitter(rng));
      if (pts.size() == static_cast<size_t>(kPointsPerDocument)) break;
    }
  }
  return pts;
}

std::vector<cv::Point2f> MakeDocument(Layout layout, std::mt19937& rng) {
  return layout == Layout::kUniform ? UniformDocument(rng) : TextLineDocument(rng);
}

// A view of part of a document.
struct Query {
  std::vector<cv::Point2f> points;
  std::vector<cv::Point2f> window_points;  // reference points inside the window
  cv::Matx33d homography;                  // exact: reference -> query
};

cv::Matx33d Translation(double dx, double dy) { return {1, 0, dx, 0, 1, dy, 0, 0, 1}; }

// How a query differs from its document, beyond the window.
struct Disturbance {
  double tilt_deg = 20;
  double noise_px = 0.5;
  double outliers = 0.2;  // extra random points, share of the kept points
  double dropped = 0.1;   // share of the window's points missing
};

// What the default LLAH options (n=7, m=6) reliably survive: each query keypoint's 7
// nearest neighbours may change by one point only, so extra and missing keypoints are the
// hardest disturbance. 5% + 5% keeps most neighbourhoods intact.
constexpr Disturbance kModerate{20, 0.5, 0.05, 0.05};
// The target of the product: 20% extra keypoints and 10% missing ones.
constexpr Disturbance kHeavy{20, 0.5, 0.20, 0.10};

// Random window of 40% of the page area; a camera tilted by tilt_deg (random azimuth and
// roll) looking at the window's centre; a share of the window's points dropped, Gaussian
// noise, then extra random points spread over the view's bounding box; shuffled.
// `side` scales the window's sides (1: 40% of the page).
Query MakeQuery(const std::vector<cv::Point2f>& document, std::mt19937& rng,
                const Disturbance& disturbance, double side = 1.0) {
  std::uniform_real_distribution<double> u01(0, 1), angle(-180, 180);
  const double w = side * 0.6 * kPageSize.width, h = side * (0.4 / 0.6) * kPageSize.height;
  const cv::Rect2d window(u01(rng) * (kPageSize.width - w), u01(rng) * (kPageSize.height - h), w,
                          h);
  testdata::CameraViewOptions view;
  view.tilt_deg = disturbance.tilt_deg;
  view.tilt_azimuth_deg = angle(rng);
  view.roll_deg = angle(rng);
  view.scale = 0.8;
  view.look_at = {window.x + w / 2, window.y + h / 2};
  Query q;
  q.homography = testdata::ComputeCameraGeometry(kPageSize, view).homography;
  q.homography *= 1.0 / q.homography(2, 2);

  std::normal_distribution<double> noise(0, std::max(1e-9, disturbance.noise_px));
  float min_x = 1e9f, min_y = 1e9f, max_x = -1e9f, max_y = -1e9f;
  for (const auto& p : document) {
    if (!window.contains(cv::Point2d(p))) continue;
    q.window_points.push_back(p);
    if (u01(rng) < disturbance.dropped) continue;
    const cv::Point2d m = ApplyHomography(q.homography, p);
    const cv::Point2f v(static_cast<float>(m.x + noise(rng)), static_cast<float>(m.y + noise(rng)));
    q.points.push_back(v);
    min_x = std::min(min_x, v.x);
    min_y = std::min(min_y, v.y);
    max_x = std::max(max_x, v.x);
    max_y = std::max(max_y, v.y);
  }
  const size_t outliers = static_cast<size_t>(disturbance.outliers * q.points.size());
  std::uniform_real_distribution<float> ox(min_x, max_x), oy(min_y, max_y);
  for (size_t i = 0; i < outliers; ++i) q.points.emplace_back(ox(rng), oy(rng));
  std::shuffle(q.points.begin(), q.points.end(), rng);
  return q;
}

// Mean distance between where the found and the exact homography put the window's reference
// points (the benchmark's criterion).
double MeanHomographyError(const cv::Matx33d& found, const Query& q) {
  double sum = 0;
  for (const auto& p : q.window_points)
    sum += cv::norm(ApplyHomography(found, p) - ApplyHomography(q.homography, p));
  return q.window_points.empty() ? 0 : sum / q.window_points.size();
}

// Largest distance between where the found and the exact homography put the window's
// reference points.
double MaxHomographyError(const cv::Matx33d& found, const Query& q) {
  double worst = 0;
  for (const auto& p : q.window_points) {
    worst = std::max(worst, cv::norm(ApplyHomography(found, p) - ApplyHomography(q.homography, p)));
  }
  return worst;
}

const DocumentHit* FindHit(const std::vector<DocumentHit>& hits, uint32_t doc) {
  for (const auto& h : hits)
    if (h.document == doc) return &h;
  return nullptr;
}

std::string Describe(const std::vector<DocumentHit>& hits) {
  std::string s = "[";
  for (const auto& h : hits)
    s += " doc " + std::to_string(h.document) + " (inliers " + std::to_string(h.inliers) +
         ", votes " + std::to_string(h.votes) + ")";
  return s + " ]";
}

// One database per layout, shared by the tests of the suite (building it is the costly
// part). Tests that remove documents use their own retriever.
class LlahRetrieverTest : public ::testing::TestWithParam<Layout> {
 protected:
  struct Database {
    std::vector<std::vector<cv::Point2f>> documents;
    LlahOptions options;
    InvariantQuantizer quantizer;
    std::unique_ptr<LlahRetriever> retriever;
  };

  static std::vector<std::vector<cv::Point2f>> MakeDocuments(Layout layout) {
    std::mt19937 rng(layout == Layout::kUniform ? 1000 : 2000);
    std::vector<std::vector<cv::Point2f>> docs;
    for (int d = 0; d < kDocuments; ++d) docs.push_back(MakeDocument(layout, rng));
    return docs;
  }

  static std::unique_ptr<Database> Build(Layout layout) {
    auto db = std::make_unique<Database>();
    db->documents = MakeDocuments(layout);
    LlahDescriber raw(db->options, InvariantQuantizer());
    std::vector<float> samples;
    raw.CollectInvariants(db->documents[0], &samples);
    auto q = InvariantQuantizer::Learn(std::move(samples), db->options.k);
    EXPECT_TRUE(q.ok()) << q.status();
    db->quantizer = *q;
    db->retriever = std::make_unique<LlahRetriever>(db->options, db->quantizer, 20);
    for (int d = 0; d < kDocuments; ++d) {
      EXPECT_TRUE(
          db->retriever->AddDocument({DocumentId(d), db->documents[d], kPageSize, {}, {}}).ok());
    }
    return db;
  }

  // Document ids are not 0..49, so that a test cannot pass by confusing index and id.
  static uint32_t DocumentId(int index) { return 1000 + 7 * index; }

  static const Database& Shared(Layout layout) {
    static std::unique_ptr<Database> dbs[2];
    auto& db = dbs[layout == Layout::kUniform ? 0 : 1];
    if (!db) db = Build(layout);
    return *db;
  }

  const Database& db() const { return Shared(GetParam()); }
};

TEST_P(LlahRetrieverTest, DatabaseHoldsEveryDocument) {
  const LlahRetriever& r = *db().retriever;
  EXPECT_EQ(r.documents(), static_cast<size_t>(kDocuments));
  const size_t per = r.describer().descriptors_per_point();
  EXPECT_EQ(r.entries(), kDocuments * kPointsPerDocument * per);
  EXPECT_GE(r.MemoryBytes(), r.entries() * 12);
  EXPECT_TRUE(r.Contains(DocumentId(3)));
  EXPECT_FALSE(r.Contains(3));
  EXPECT_EQ(r.Keypoints(DocumentId(3)), db().documents[3]);
  EXPECT_TRUE(r.Keypoints(3).empty());
}

// Every query must find its document first, with the homography within 1 px of the exact
// one over the whole window (the noise is 0.5 px; ~100 matches average it down).
void ExpectFindsWindows(const LlahRetriever& retriever,
                        const std::vector<std::vector<cv::Point2f>>& documents, uint32_t (*id)(int),
                        const Disturbance& disturbance, uint32_t seed) {
  std::mt19937 rng(seed);
  int found = 0, trials = 0;
  for (int d : {0, 9, 23, 37, 49}) {
    for (int t = 0; t < 2; ++t) {
      ++trials;
      const Query q = MakeQuery(documents[d], rng, disturbance);
      SCOPED_TRACE("document " + std::to_string(d) + " trial " + std::to_string(t) +
                   ", query points " + std::to_string(q.points.size()));
      const auto hits = retriever.Retrieve(q.points, kQueryCharHeight, RetrievalOptions());
      ASSERT_FALSE(hits.empty());
      EXPECT_EQ(hits[0].document, id(d)) << Describe(hits);
      if (hits[0].document != id(d)) continue;
      ++found;
      EXPECT_LT(MaxHomographyError(hits[0].homography, q), 1.0);
      EXPECT_GE(hits[0].inliers, RetrievalOptions().min_weak_inliers);
      EXPECT_NEAR(hits[0].homography(2, 2), 1.0, 1e-9);
      // Guided matches pair query points with the right reference points.
      const auto ref = retriever.Keypoints(id(d));
      int good = 0;
      for (const auto& [qi, ri] : hits[0].matches) {
        ASSERT_GE(qi, 0);
        ASSERT_LT(qi, static_cast<int>(q.points.size()));
        ASSERT_GE(ri, 0);
        ASSERT_LT(ri, static_cast<int>(ref.size()));
        if (cv::norm(ApplyHomography(q.homography, ref[ri]) - cv::Point2d(q.points[qi])) < 3)
          ++good;
      }
      EXPECT_GE(good, 0.95 * hits[0].matches.size());
      EXPECT_GE(hits[0].matches.size(), 0.7 * q.window_points.size());
      // Nothing else is visible in this query.
      EXPECT_EQ(hits.size(), 1u) << Describe(hits);
    }
  }
  EXPECT_EQ(found, trials);
}

TEST_P(LlahRetrieverTest, FindsDocumentOfAPerspectiveWindowWithAccurateHomography) {
  ExpectFindsWindows(*db().retriever, db().documents, &DocumentId, kModerate,
                     GetParam() == Layout::kUniform ? 31 : 32);
}

// Close and steeply tilted: the page origin is behind the camera, so a homography scaled to
// h22 = 1 has w < 0 at every visible point. The retriever must still accept the page and
// return the homography with w > 0 where the page is seen (its sign is what pose recovery
// and drawing rely on).
// Uniform layout: text lines at this tilt and distance are beyond plain LLAH's reach, which
// is not what this test is about.
class LlahRetrieverSignTest : public LlahRetrieverTest {};

TEST_F(LlahRetrieverSignTest, FindsPageWhoseOriginIsBehindTheCamera) {
  const int d = 23;
  const Database& database = Shared(Layout::kUniform);
  const auto& document = database.documents[d];
  testdata::CameraViewOptions view;
  view.tilt_deg = 40;
  view.tilt_azimuth_deg = 55;
  view.roll_deg = 10;
  view.scale = 0.9;
  view.look_at = {0.65 * kPageSize.width, 0.65 * kPageSize.height};
  const testdata::CameraView camera = testdata::ComputeCameraGeometry(kPageSize, view);
  ASSERT_LT(camera.translation[2], 0) << "test setup: the origin must be behind the camera";
  Query q;
  q.homography = camera.homography;
  for (const auto& p : document) {
    const cv::Point2d m = ApplyHomography(q.homography, p);
    const double w = q.homography(2, 0) * p.x + q.homography(2, 1) * p.y + q.homography(2, 2);
    if (w <= 0 || m.x < 0 || m.y < 0 || m.x >= 640 || m.y >= 480) continue;
    q.window_points.push_back(p);
    q.points.emplace_back(static_cast<float>(m.x), static_cast<float>(m.y));
  }
  ASSERT_GT(q.points.size(), 40u);
  const auto hits = database.retriever->Retrieve(q.points, kQueryCharHeight, RetrievalOptions());
  ASSERT_FALSE(hits.empty());
  ASSERT_EQ(hits[0].document, DocumentId(d)) << Describe(hits);
  EXPECT_LT(MaxHomographyError(hits[0].homography, q), 1.0);
  const cv::Matx33d& h = hits[0].homography;
  for (const auto& p : q.window_points) EXPECT_GT(h(2, 0) * p.x + h(2, 1) * p.y + h(2, 2), 0);
}

TEST_P(LlahRetrieverTest, FindsDocumentUnderTwentyPercentOutliersAndTenPercentDropped) {
  ExpectFindsWindows(*db().retriever, db().documents, &DocumentId, kHeavy,
                     GetParam() == Layout::kUniform ? 33 : 34);
}

// Heavy disturbance leaves few LLAH correspondences even for the right document; the
// layout check (most of the page's keypoints land on query keypoints) confirms it where
// LLAH inliers alone would not, and never confirms a wrong document.
TEST_P(LlahRetrieverTest, LayoutCheckConfirmsWeaklyMatchedWindowsAndNoWrongDocument) {
  constexpr Disturbance kSevere{25, 0.7, 0.25, 0.15};
  // Perspective rectification would make most of these windows strong matches; this test is
  // about the layout check, so the descriptors are taken as seen.
  RetrievalOptions options;
  options.rectify_perspective = false;
  options.deep_max_keypoints = 0;  // the few-keypoint pass has its own test
  RetrievalOptions llah_only = options;
  llah_only.min_weak_inliers = llah_only.min_inliers;  // the layout check never decides
  std::mt19937 rng(GetParam() == Layout::kUniform ? 71 : 72);
  int with_layout = 0, without_layout = 0, weak = 0, trials = 0;
  for (int d = 0; d < kDocuments; d += 3) {
    ++trials;
    const Query q = MakeQuery(db().documents[d], rng, kSevere);
    const auto hits = db().retriever->Retrieve(q.points, kQueryCharHeight, options);
    for (const DocumentHit& h : hits) {
      ASSERT_EQ(h.document, DocumentId(d)) << "document " << d << ": " << Describe(hits);
      EXPECT_LT(MaxHomographyError(h.homography, q), 2.0) << "document " << d;
    }
    with_layout += !hits.empty();
    weak += !hits.empty() && hits[0].inliers < RetrievalOptions().min_inliers;
    const auto strict = db().retriever->Retrieve(q.points, kQueryCharHeight, llah_only);
    for (const DocumentHit& h : strict) ASSERT_EQ(h.document, DocumentId(d));
    without_layout += !strict.empty();
  }
  EXPECT_GT(weak, 0) << "no window needed the layout check; the test disturbs too little";
  EXPECT_GT(with_layout, without_layout);
  std::printf("layout check: %d of %d windows found (LLAH inliers alone: %d)\n", with_layout,
              trials, without_layout);
}

// Guided matching that keeps its full gate while it grows, and that also starts from a
// similarity when the homography's matches stay few, finds at least the windows that one
// round from the homography finds accurately, with as accurate homographies, and never a
// wrong document.
TEST_P(LlahRetrieverTest, GuidedGrowthKeepsWeakWindowsAccurateAndNoWrongDocument) {
  constexpr Disturbance kSevere{25, 0.7, 0.25, 0.15};
  RetrievalOptions grown;
  grown.rectify_perspective = false;
  grown.deep_max_keypoints = 0;
  RetrievalOptions single = grown;
  single.guided_growth_rounds = 0;
  single.guided_similarity_start = false;
  std::mt19937 rng(GetParam() == Layout::kUniform ? 171 : 172);
  int found_grown = 0, found_single = 0, matches_grown = 0, matches_single = 0;
  for (int d = 0; d < kDocuments; d += 2) {
    const Query q = MakeQuery(db().documents[d], rng, kSevere);
    const auto a = db().retriever->Retrieve(q.points, kQueryCharHeight, grown);
    const auto b = db().retriever->Retrieve(q.points, kQueryCharHeight, single);
    for (const DocumentHit& h : a) {
      ASSERT_EQ(h.document, DocumentId(d)) << "document " << d << ": " << Describe(a);
      // Within 2 px over the window, or (where one round was off too: a severe
      // disturbance can confirm the page under a homography off at the window's corners)
      // no worse than one round.
      const double single_error = b.empty() ? 0 : MaxHomographyError(b[0].homography, q);
      EXPECT_LT(MaxHomographyError(h.homography, q), std::max(2.0, single_error + 0.5))
          << "document " << d << " inliers " << h.inliers << " matches " << h.matches.size();
    }
    // A window counts as found when its homography is within 3 px over it: one round can
    // confirm a page under a homography 12 px off, which growth then rightly refuses.
    found_grown += !a.empty() && MaxHomographyError(a[0].homography, q) < 3;
    found_single += !b.empty() && MaxHomographyError(b[0].homography, q) < 3;
    if (!a.empty() && !b.empty()) {
      matches_grown += static_cast<int>(a[0].matches.size());
      matches_single += static_cast<int>(b[0].matches.size());
    }
  }
  EXPECT_GE(found_grown, found_single);
  EXPECT_GE(matches_grown, matches_single);
  std::printf("guided growth: %d windows found (one round: %d), %d matches (%d)\n", found_grown,
              found_single, matches_grown, matches_single);
}

// Where the query's keypoints repeat the page's too poorly for the layout check, the LLAH
// inliers decide when chance could hardly have made them agree (a-contrario): windows the
// layout check cannot confirm are found, and neither a wrong document nor an unknown one.
TEST_P(LlahRetrieverTest, ImprobableInlierAgreementConfirmsWeakMatchesAndNoWrongDocument) {
  constexpr Disturbance kSevere{25, 0.7, 0.25, 0.15};
  RetrievalOptions options;
  options.rectify_perspective = false;
  options.min_layout_ratio = 1.0;  // the layout check (practically) never confirms
  options.deep_max_keypoints = 0;  // nor does the few-keypoint pass's
  RetrievalOptions without = options;
  without.max_weak_nfa = 0;
  std::mt19937 rng(GetParam() == Layout::kUniform ? 81 : 82);
  int with_nfa = 0, without_nfa = 0, trials = 0;
  for (int d = 0; d < kDocuments; d += 2) {
    ++trials;
    const Query q = MakeQuery(db().documents[d], rng, kSevere);
    const auto hits = db().retriever->Retrieve(q.points, kQueryCharHeight, options);
    for (const DocumentHit& h : hits) {
      ASSERT_EQ(h.document, DocumentId(d)) << "document " << d << ": " << Describe(hits);
      EXPECT_LT(MaxHomographyError(h.homography, q), 3.0) << "document " << d;
    }
    with_nfa += !hits.empty();
    without_nfa += !db().retriever->Retrieve(q.points, kQueryCharHeight, without).empty();
  }
  EXPECT_GT(with_nfa, without_nfa);
  std::printf("a-contrario: %d of %d windows found (%d with %d+ inliers only)\n", with_nfa, trials,
              without_nfa, RetrievalOptions().min_inliers);
  // Documents never registered, seen alike, are found in none.
  std::mt19937 unknown_rng(GetParam() == Layout::kUniform ? 91 : 92);
  for (int i = 0; i < 20; ++i) {
    const Query q = MakeQuery(MakeDocument(GetParam(), unknown_rng), unknown_rng, kSevere);
    EXPECT_TRUE(db().retriever->Retrieve(q.points, kQueryCharHeight, options).empty())
        << "unknown document " << i;
  }
}

// A view holding ~25-40 of a page's keypoints (large type, a corner of the page) keeps few
// whole LLAH neighbourhoods: the first pass finds few such windows. The few-keypoint pass
// (a second vote with one strong vote, every homography of four correspondences tried, the
// layout deciding a contrario) finds more, each with its matches right and its homography
// within the benchmark's tolerance, and finds neither a wrong document nor an unknown one.
TEST_P(LlahRetrieverTest, FewKeypointWindowsAreFoundByTheSecondPassAndNoWrongDocument) {
  constexpr Disturbance kSmallView{25, 0.5, 0.1, 0.1};
  constexpr double kSide = 0.55;  // 12% of the page
  RetrievalOptions options;
  RetrievalOptions first_pass = options;
  first_pass.deep_max_keypoints = 0;
  std::mt19937 rng(GetParam() == Layout::kUniform ? 61 : 62);
  int deep = 0, first = 0, trials = 0;
  size_t fewest = 1000, most = 0;
  for (int d = 0; d < kDocuments; ++d) {
    const Query q = MakeQuery(db().documents[d], rng, kSmallView, kSide);
    ASSERT_LE(static_cast<int>(q.points.size()), options.deep_max_keypoints);
    fewest = std::min(fewest, q.points.size());
    most = std::max(most, q.points.size());
    ++trials;
    const auto hits = db().retriever->Retrieve(q.points, kQueryCharHeight, options);
    for (const DocumentHit& h : hits) {
      ASSERT_EQ(h.document, DocumentId(d)) << "document " << d << ": " << Describe(hits);
      // Few matches, in part of the window: the homography is right where they are and may
      // drift towards the far corners (a uniform window's 21 matches, one of them wrong, gave
      // a mean error of 6 px and 27 px at the farthest point). The benchmark's criterion, and
      // the matches themselves:
      EXPECT_LT(MeanHomographyError(h.homography, q), 10.0) << "document " << d;
      const auto ref = db().retriever->Keypoints(h.document);
      int good = 0;
      for (const auto& [qi, ri] : h.matches)
        good += cv::norm(ApplyHomography(q.homography, ref[ri]) - cv::Point2d(q.points[qi])) < 3;
      EXPECT_GE(good, 0.9 * h.matches.size()) << "document " << d;
      EXPECT_GE(good, RetrievalOptions().min_inliers) << "document " << d;
    }
    deep += !hits.empty();
    const auto plain = db().retriever->Retrieve(q.points, kQueryCharHeight, first_pass);
    for (const DocumentHit& h : plain) ASSERT_EQ(h.document, DocumentId(d));
    first += !plain.empty();
  }
  std::printf("few keypoints (%zu-%zu): %d of %d windows found (first pass alone: %d)\n", fewest,
              most, deep, trials, first);
  EXPECT_LE(most, 60u) << "test setup: the windows should hold few keypoints";
  EXPECT_GT(deep, first);
  // Windows of documents never registered, seen alike, find nothing.
  std::mt19937 unknown_rng(GetParam() == Layout::kUniform ? 63 : 64);
  for (int i = 0; i < 30; ++i) {
    const Query q =
        MakeQuery(MakeDocument(GetParam(), unknown_rng), unknown_rng, kSmallView, kSide);
    const auto hits = db().retriever->Retrieve(q.points, kQueryCharHeight, options);
    EXPECT_TRUE(hits.empty()) << "unknown document " << i << ": " << Describe(hits);
  }
}

// Smaller and more disturbed windows than the few-keypoint pass's test: many keep no vote
// that survives, but single descriptor hits whose neighbourhoods pair up.
TEST_P(LlahRetrieverTest, NeighbourhoodPassFindsWindowsTheVotesMissAndNoWrongDocument) {
  constexpr Disturbance kSmallView{30, 0.5, 0.15, 0.15};
  constexpr double kSide = 0.5;  // 10% of the page
  RetrievalOptions options;
  std::mt19937 rng(GetParam() == Layout::kUniform ? 71 : 72);
  int with_pass = 0, without = 0;
  for (int d = 0; d < kDocuments; ++d) {
    const Query q = MakeQuery(db().documents[d], rng, kSmallView, kSide);
    const bool voted = !db().retriever->Retrieve(q.points, kQueryCharHeight, options).empty();
    without += voted;
    if (voted) {
      ++with_pass;
      continue;
    }
    const auto hits = db().retriever->RetrieveByNeighbourhoods(q.points, kQueryCharHeight, options);
    ASSERT_LE(hits.size(), 1u);
    for (const DocumentHit& h : hits) {
      ASSERT_EQ(h.document, DocumentId(d)) << "document " << d << ": " << Describe(hits);
      EXPECT_LT(MeanHomographyError(h.homography, q), 3.0) << "document " << d;
      EXPECT_GE(static_cast<int>(h.matches.size()), options.neighbourhood_min_tight);
    }
    with_pass += !hits.empty();
  }
  std::printf("small windows: %d of %d found with the neighbourhood pass, %d without\n", with_pass,
              kDocuments, without);
  // Measured: 26 of 50 against 10 (uniform), 32 against 7 (text lines).
  EXPECT_GE(with_pass, without + 10);
  std::mt19937 unknown_rng(GetParam() == Layout::kUniform ? 73 : 74);
  for (int i = 0; i < 30; ++i) {
    const Query q =
        MakeQuery(MakeDocument(GetParam(), unknown_rng), unknown_rng, kSmallView, kSide);
    const auto hits = db().retriever->RetrieveByNeighbourhoods(q.points, kQueryCharHeight, options);
    EXPECT_TRUE(hits.empty()) << "unknown document " << i << ": " << Describe(hits);
  }
}

// Windows just too small for the neighbourhood pass's tight-match bar: below it, a page is
// confirmed only by several of its descriptor hits landing where its homography says
// (RetrievalOptions::neighbourhood_min_agreeing_hits). More pages are found with it than
// without, each the right one with an accurate homography, and unknown pages stay unfound.
TEST_P(LlahRetrieverTest, AgreeingHitsConfirmPagesUnderTheTightBarAndNoWrongDocument) {
  constexpr Disturbance kSmallView{30, 0.5, 0.15, 0.15};
  constexpr double kSide = 0.36;  // 13% of the page
  RetrievalOptions with_agreeing, without_agreeing;
  without_agreeing.neighbourhood_min_tight_agreeing = 0;
  std::mt19937 rng(GetParam() == Layout::kUniform ? 81 : 82);
  int found_with = 0, found_without = 0;
  constexpr int kWindowsPerDocument = 4;
  for (int w = 0; w < kWindowsPerDocument * kDocuments; ++w) {
    const int d = w % kDocuments;
    const Query q = MakeQuery(db().documents[d], rng, kSmallView, kSide);
    const auto hits =
        db().retriever->RetrieveByNeighbourhoods(q.points, kQueryCharHeight, with_agreeing);
    const auto strict =
        db().retriever->RetrieveByNeighbourhoods(q.points, kQueryCharHeight, without_agreeing);
    ASSERT_LE(hits.size(), 1u);
    for (const DocumentHit& h : hits) {
      ASSERT_EQ(h.document, DocumentId(d)) << "document " << d << ": " << Describe(hits);
      EXPECT_LT(MeanHomographyError(h.homography, q), 3.0) << "document " << d;
      EXPECT_GE(h.inliers, with_agreeing.neighbourhood_min_tight_agreeing);
    }
    // The bar is only lowered: what the strict pass finds, the lowered one finds too.
    if (!strict.empty()) {
      EXPECT_EQ(hits.size(), 1u) << "document " << d;
    }
    found_with += !hits.empty();
    found_without += !strict.empty();
  }
  std::printf("windows of 13%% of a page: %d of %d found with agreeing hits, %d without\n",
              found_with, kWindowsPerDocument * kDocuments, found_without);
  // Measured: 30 of 200 against 16 (uniform), 36 against 33 (text lines, whose regular
  // layout leaves the right page fewer agreeing hits).
  EXPECT_GE(found_with, found_without + (GetParam() == Layout::kUniform ? 8 : 2));
  std::mt19937 unknown_rng(GetParam() == Layout::kUniform ? 83 : 84);
  for (int i = 0; i < 60; ++i) {
    const Query q =
        MakeQuery(MakeDocument(GetParam(), unknown_rng), unknown_rng, kSmallView, kSide);
    const auto hits =
        db().retriever->RetrieveByNeighbourhoods(q.points, kQueryCharHeight, with_agreeing);
    EXPECT_TRUE(hits.empty()) << "unknown document " << i << ": " << Describe(hits);
  }
}

TEST(LayoutLog10TailTest, ChanceSharesAreLikelyAndNearlyWholeLayoutsAreNot) {
  // A quarter of the projected keypoints on query keypoints: what chance gives.
  EXPECT_GT(LayoutLog10Tail(100, 25, 0.25), -0.5);
  // Twelve of twelve (a view holding a dozen of the page's words): p = 0.25^12.
  EXPECT_NEAR(LayoutLog10Tail(12, 12, 0.25), 12 * std::log10(0.25), 1e-9);
  // More matches are less likely; matches beyond the projected count are capped.
  EXPECT_LT(LayoutLog10Tail(40, 30, 0.25), LayoutLog10Tail(40, 20, 0.25));
  EXPECT_EQ(LayoutLog10Tail(12, 14, 0.25), LayoutLog10Tail(12, 12, 0.25));
  // A likelier chance match makes the same share less significant.
  EXPECT_GT(LayoutLog10Tail(40, 20, 0.4), LayoutLog10Tail(40, 20, 0.25));
  // Degenerate input is never significant.
  EXPECT_EQ(LayoutLog10Tail(0, 0, 0.25), 0);
  EXPECT_EQ(LayoutLog10Tail(20, 10, 0), 0);
  EXPECT_EQ(LayoutLog10Tail(20, 10, 1), 0);
}

TEST(NeighboursLostToFrameTest, ShareOfTheNeighbourhoodDiskBeyondTheEdges) {
  const cv::Size frame(640, 480);
  EXPECT_DOUBLE_EQ(NeighboursLostToFrame({320, 240}, 50, 7, frame), 0);
  EXPECT_DOUBLE_EQ(NeighboursLostToFrame({50, 240}, 50, 7, frame), 0);    // touches the edge
  EXPECT_NEAR(NeighboursLostToFrame({0, 240}, 50, 7, frame), 3.5, 1e-9);  // half the disk
  // A third of the radius from the edge: a 0.2 segment, about 1.4 of 7 neighbours.
  EXPECT_NEAR(NeighboursLostToFrame({640 - 25, 240}, 50, 7, frame), 7 * 0.1955, 1e-3);
  EXPECT_NEAR(NeighboursLostToFrame({0, 0}, 50, 7, frame), 7, 1e-9);
}

// A view cut by the frame: the keypoints along its edges lost neighbours to it. Leaving them
// undescribed keeps every window found as accurately while their chance hits are gone.
TEST_P(LlahRetrieverTest, KeypointsCutByTheFrameAreNotDescribed) {
  std::mt19937 rng(GetParam() == Layout::kUniform ? 61 : 62);
  RetrievalOptions seen_all;
  seen_all.max_border_lost = 0;
  int found_all = 0, found_cut = 0, hits_all = 0, hits_cut = 0;
  for (int d = 0; d < kDocuments; d += 5) {
    const Query window = MakeQuery(db().documents[d], rng, kModerate);
    // The frame: the middle of the view, as a camera closer to the page would see it.
    cv::Rect2f box = cv::boundingRect(window.points);
    const cv::Rect2f frame(box.x + box.width * 0.15f, box.y + box.height * 0.15f, box.width * 0.7f,
                           box.height * 0.7f);
    Query q = window;
    q.points.clear();
    for (const cv::Point2f& p : window.points)
      if (frame.contains(p)) q.points.push_back(p - frame.tl());
    q.homography = Translation(-frame.x, -frame.y) * window.homography;
    RetrievalOptions cut;
    cut.frame = cv::Size(static_cast<int>(frame.width), static_cast<int>(frame.height));
    RetrievalTrace trace_all, trace_cut;
    trace_all.watch = trace_cut.watch = DocumentId(d);
    const auto all = db().retriever->Retrieve(q.points, kQueryCharHeight, seen_all, &trace_all);
    const auto kept = db().retriever->Retrieve(q.points, kQueryCharHeight, cut, &trace_cut);
    const DocumentHit* hit = FindHit(kept, DocumentId(d));
    if (hit != nullptr) {
      EXPECT_LT(MaxHomographyError(hit->homography, q), 2.0) << "document " << d;
    }
    for (const DocumentHit& h : kept) {
      EXPECT_EQ(h.document, DocumentId(d));
    }
    found_all += FindHit(all, DocumentId(d)) != nullptr;
    found_cut += hit != nullptr;
    hits_all += trace_all.total_hits;
    hits_cut += trace_cut.total_hits;
  }
  EXPECT_GE(found_cut, found_all);
  EXPECT_LT(hits_cut, hits_all);
}

TEST(WeakMatchLog10NfaTest, ChanceAgreementIsNotSignificantAndRareAgreementIs) {
  const double area = 640.0 * 480.0;
  // Six of hundreds of correspondences: a chance homography explains that many.
  EXPECT_GT(WeakMatchLog10Nfa(300, 6, 4.5, area), 0);
  // Nine of forty: no coincidence.
  EXPECT_LT(WeakMatchLog10Nfa(40, 9, 4.5, area), -5);
  // More inliers are less likely; more correspondences, or a looser threshold, more so.
  EXPECT_LT(WeakMatchLog10Nfa(40, 10, 4.5, area), WeakMatchLog10Nfa(40, 9, 4.5, area));
  EXPECT_GT(WeakMatchLog10Nfa(400, 9, 4.5, area), WeakMatchLog10Nfa(40, 9, 4.5, area));
  EXPECT_GT(WeakMatchLog10Nfa(40, 9, 12, area), WeakMatchLog10Nfa(40, 9, 4.5, area));
  // Degenerate input is never significant.
  EXPECT_EQ(WeakMatchLog10Nfa(3, 3, 4.5, area), 0);
  EXPECT_EQ(WeakMatchLog10Nfa(40, 9, 4.5, 0), 0);
}

TEST_P(LlahRetrieverTest, FindsBothDocumentsSideBySide) {
  std::mt19937 rng(GetParam() == Layout::kUniform ? 41 : 42);
  int found_alone = 0;
  for (const auto& [a, b] : {std::pair{4, 30}, std::pair{17, 44}, std::pair{8, 26}}) {
    SCOPED_TRACE("documents " + std::to_string(a) + " and " + std::to_string(b));
    const Query qa = MakeQuery(db().documents[a], rng, kModerate);
    // Shift the second view to the right of the first, tops aligned.
    float max_x = -1e9f, min_y = 1e9f;
    for (const auto& p : qa.points) max_x = std::max(max_x, p.x), min_y = std::min(min_y, p.y);
    Query qb = MakeQuery(db().documents[b], rng, kModerate);
    float min_xb = 1e9f, min_yb = 1e9f;
    for (const auto& p : qb.points) min_xb = std::min(min_xb, p.x), min_yb = std::min(min_yb, p.y);
    const cv::Matx33d shift = Translation(max_x + 40 - min_xb, min_y - min_yb);
    for (auto& p : qb.points) {
      const cv::Point2d m = ApplyHomography(shift, p);
      p = cv::Point2f(static_cast<float>(m.x), static_cast<float>(m.y));
    }
    qb.homography = shift * qb.homography;

    // A text-line window is occasionally missed even alone (see the skipped test above);
    // the side-by-side query must find every document whose window alone is found, and
    // lose none of them to the other half.
    const bool a_alone =
        FindHit(db().retriever->Retrieve(qa.points, kQueryCharHeight, RetrievalOptions()),
                DocumentId(a)) != nullptr;
    const bool b_alone =
        FindHit(db().retriever->Retrieve(qb.points, kQueryCharHeight, RetrievalOptions()),
                DocumentId(b)) != nullptr;
    if (GetParam() == Layout::kUniform) {
      EXPECT_TRUE(a_alone && b_alone);
    }
    found_alone += a_alone + b_alone;

    std::vector<cv::Point2f> both = qa.points;
    both.insert(both.end(), qb.points.begin(), qb.points.end());
    const auto hits = db().retriever->Retrieve(both, kQueryCharHeight, RetrievalOptions());
    EXPECT_EQ(hits.size(), static_cast<size_t>(a_alone + b_alone)) << Describe(hits);
    const DocumentHit* ha = FindHit(hits, DocumentId(a));
    const DocumentHit* hb = FindHit(hits, DocumentId(b));
    EXPECT_EQ(ha != nullptr, a_alone) << Describe(hits);
    EXPECT_EQ(hb != nullptr, b_alone) << Describe(hits);
    if (ha) {
      EXPECT_LT(MaxHomographyError(ha->homography, qa), 1.0);
    }
    if (hb) {
      EXPECT_LT(MaxHomographyError(hb->homography, qb), 1.0);
    }
    // No query keypoint is claimed by both documents.
    std::set<int> used;
    for (const auto* h : {ha, hb}) {
      if (!h) continue;
      for (const auto& [qi, ri] : h->matches) EXPECT_TRUE(used.insert(qi).second) << qi;
    }
    if (!(a_alone && b_alone)) continue;

    RetrievalOptions one;
    one.max_results = 1;
    EXPECT_EQ(db().retriever->Retrieve(both, kQueryCharHeight, one).size(), 1u);
  }
  EXPECT_GE(found_alone, 5) << "of 6 windows";
}

TEST_P(LlahRetrieverTest, UnregisteredPointSetsFindNothing) {
  std::mt19937 rng(GetParam() == Layout::kUniform ? 51 : 52);
  for (int t = 0; t < 5; ++t) {
    // An unregistered document of the same kind, viewed like the queries above.
    const auto stranger = MakeDocument(GetParam(), rng);
    const Query q = MakeQuery(stranger, rng, kHeavy);
    const auto hits = db().retriever->Retrieve(q.points, kQueryCharHeight, RetrievalOptions());
    EXPECT_TRUE(hits.empty()) << "trial " << t << ": " << Describe(hits);
  }
}

TEST_P(LlahRetrieverTest, TinyQueriesFindNothing) {
  const auto& doc = db().documents[5];
  const std::vector<cv::Point2f> few(doc.begin(), doc.begin() + 7);
  EXPECT_TRUE(db().retriever->Retrieve(few, kQueryCharHeight, RetrievalOptions()).empty());
  EXPECT_TRUE(db().retriever->Retrieve({}, kQueryCharHeight, RetrievalOptions()).empty());
}

TEST_P(LlahRetrieverTest, RemoveDocumentMakesItUnfindable) {
  const Database& shared = db();
  LlahRetriever r(shared.options, shared.quantizer, 18);
  for (int d = 0; d < 10; ++d)
    ASSERT_TRUE(r.AddDocument({DocumentId(d), shared.documents[d], kPageSize, {}, {}}).ok());
  const size_t entries = r.entries();
  const size_t per_doc = kPointsPerDocument * r.describer().descriptors_per_point();

  std::mt19937 rng(GetParam() == Layout::kUniform ? 61 : 62);
  const Query q6 = MakeQuery(shared.documents[6], rng, kModerate);
  const Query q2 = MakeQuery(shared.documents[2], rng, kModerate);
  auto hits = r.Retrieve(q6.points, kQueryCharHeight, RetrievalOptions());
  ASSERT_FALSE(hits.empty());
  ASSERT_EQ(hits[0].document, DocumentId(6)) << Describe(hits);

  EXPECT_TRUE(r.RemoveDocument(DocumentId(6)));
  EXPECT_FALSE(r.Contains(DocumentId(6)));
  EXPECT_EQ(r.documents(), 9u);
  EXPECT_EQ(r.entries(), entries - per_doc);
  EXPECT_TRUE(r.Keypoints(DocumentId(6)).empty());
  EXPECT_FALSE(r.RemoveDocument(DocumentId(6)));
  EXPECT_FALSE(r.RemoveDocument(424242));

  hits = r.Retrieve(q6.points, kQueryCharHeight, RetrievalOptions());
  EXPECT_EQ(FindHit(hits, DocumentId(6)), nullptr) << Describe(hits);
  EXPECT_TRUE(hits.empty()) << Describe(hits);
  hits = r.Retrieve(q2.points, kQueryCharHeight, RetrievalOptions());
  ASSERT_FALSE(hits.empty());
  EXPECT_EQ(hits[0].document, DocumentId(2)) << Describe(hits);
  EXPECT_LT(MaxHomographyError(hits[0].homography, q2), 1.0);

  // Re-adding restores it.
  ASSERT_TRUE(r.AddDocument({DocumentId(6), shared.documents[6], kPageSize, {}, {}}).ok());
  EXPECT_EQ(r.entries(), entries);
  hits = r.Retrieve(q6.points, kQueryCharHeight, RetrievalOptions());
  ASSERT_FALSE(hits.empty());
  EXPECT_EQ(hits[0].document, DocumentId(6)) << Describe(hits);
}

INSTANTIATE_TEST_SUITE_P(Layouts, LlahRetrieverTest,
                         ::testing::Values(Layout::kUniform, Layout::kTextLines),
                         [](const ::testing::TestParamInfo<Layout>& info) {
                           return LayoutName(info.param);
                         });

// ---------------------------------------------------------------- registration errors

class LlahRetrieverRegistrationTest : public ::testing::Test {
 protected:
  LlahRetrieverRegistrationTest() {
    std::mt19937 rng(7);
    for (int d = 0; d < 4; ++d) docs_.push_back(UniformDocument(rng));
    LlahDescriber raw(options_, InvariantQuantizer());
    std::vector<float> samples;
    raw.CollectInvariants(docs_[0], &samples);
    quantizer_ = *InvariantQuantizer::Learn(std::move(samples), options_.k);
  }
  LlahOptions options_;
  InvariantQuantizer quantizer_;
  std::vector<std::vector<cv::Point2f>> docs_;
};

TEST_F(LlahRetrieverRegistrationTest, AddExistingIdIsAlreadyExists) {
  LlahRetriever r(options_, quantizer_, 16);
  ASSERT_TRUE(r.AddDocument({5, docs_[0], kPageSize, {}, {}}).ok());
  const size_t entries = r.entries();
  const absl::Status s = r.AddDocument({5, docs_[1], kPageSize, {}, {}});
  EXPECT_EQ(s.code(), absl::StatusCode::kAlreadyExists) << s;
  EXPECT_EQ(r.entries(), entries);
  EXPECT_EQ(r.documents(), 1u);
  EXPECT_EQ(r.Keypoints(5), docs_[0]) << "the first registration must be kept";
}

TEST_F(LlahRetrieverRegistrationTest, TooManyKeypointsIsInvalidArgument) {
  LlahRetriever r(options_, quantizer_, 16);
  std::vector<cv::Point2f> huge(65536);
  for (size_t i = 0; i < huge.size(); ++i) huge[i] = cv::Point2f(i % 256 * 4.f, i / 256 * 4.f);
  const absl::Status s = r.AddDocument({1, huge, cv::Size(1024, 1024), {}, {}});
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << s;
  EXPECT_EQ(r.documents(), 0u);
  EXPECT_EQ(r.entries(), 0u);
}

TEST_F(LlahRetrieverRegistrationTest, BulkAddEqualsSequentialAdd) {
  LlahRetriever sequential(options_, quantizer_, 16), bulk(options_, quantizer_, 16);
  std::vector<DocumentKeypoints> batch;
  for (size_t d = 0; d < docs_.size(); ++d) {
    ASSERT_TRUE(
        sequential.AddDocument({static_cast<uint32_t>(d + 1), docs_[d], kPageSize, {}, {}}).ok());
    batch.push_back({static_cast<uint32_t>(d + 1), docs_[d], kPageSize, {}, {}});
  }
  size_t last_done = 0, last_total = 0;
  ASSERT_TRUE(bulk.AddDocuments(batch, 2,
                                [&](size_t done, size_t total) {
                                  last_done = done;
                                  last_total = total;
                                })
                  .ok());
  EXPECT_EQ(bulk.documents(), sequential.documents());
  EXPECT_EQ(bulk.entries(), sequential.entries());
  EXPECT_EQ(last_done, docs_.size());
  EXPECT_EQ(last_total, docs_.size());
  for (size_t d = 0; d < docs_.size(); ++d)
    EXPECT_EQ(bulk.Keypoints(static_cast<uint32_t>(d + 1)), docs_[d]);

  // A known id in a batch is reported; the other documents are still added.
  std::vector<DocumentKeypoints> again = {{2, docs_[0], kPageSize, {}, {}},
                                          {9, docs_[1], kPageSize, {}, {}}};
  const absl::Status s = bulk.AddDocuments(again, 1);
  EXPECT_EQ(s.code(), absl::StatusCode::kAlreadyExists) << s;
  EXPECT_TRUE(bulk.Contains(9));
  EXPECT_EQ(bulk.Keypoints(2), docs_[1]);
}

// A document registered with an extra layer (another cut of the same page into keypoints) is
// found from views of either layer, as one document whose Keypoints() are the base layer's;
// a layer that repeats the base adds no index entry; removal takes every layer's entries.
TEST_F(LlahRetrieverRegistrationTest, ExtraLayerIsFoundAsTheSameDocument) {
  LlahRetriever r(options_, quantizer_, 16);
  const std::vector<cv::Point2f>& base = docs_[0];
  const std::vector<cv::Point2f>& layer = docs_[1];
  std::vector<cv::Point2f> all = base;
  all.insert(all.end(), layer.begin(), layer.end());
  const std::vector<uint32_t> extra = {static_cast<uint32_t>(layer.size())};
  ASSERT_TRUE(r.AddDocument({7, all, kPageSize, extra, {}}).ok());
  ASSERT_TRUE(r.AddDocument({8, docs_[2], kPageSize, {}, {}}).ok());
  EXPECT_EQ(r.Keypoints(7), base);

  // Each layer is described within itself: the layer's hashes are those it has alone, but
  // for those the base layer holds already (dropped: 0).
  std::vector<uint64_t> hashes, alone, base_alone;
  ASSERT_TRUE(r.DescribeLayers(all, extra, &hashes));
  r.describer().Describe(layer, &alone);
  r.describer().Describe(base, &base_alone);
  const size_t per = static_cast<size_t>(r.describer().descriptors_per_point());
  ASSERT_EQ(hashes.size(), all.size() * per);
  EXPECT_TRUE(std::equal(base_alone.begin(), base_alone.end(), hashes.begin()));
  const std::set<uint64_t> in_base(base_alone.begin(), base_alone.end());
  int kept = 0;
  for (size_t i = 0; i < alone.size(); ++i) {
    const uint64_t h = hashes[base.size() * per + i];
    EXPECT_EQ(h, in_base.count(alone[i]) ? 0 : alone[i]) << i;
    kept += h != 0;
  }
  EXPECT_GT(kept, static_cast<int>(alone.size() / 2)) << "two different cuts share few";
  EXPECT_FALSE(r.DescribeLayers(base, {static_cast<uint32_t>(base.size() + 1)}, &hashes));

  std::mt19937 rng(71);
  for (const auto* cut : {&base, &layer}) {
    const Query q = MakeQuery(*cut, rng, kModerate);
    const auto hits = r.Retrieve(q.points, kQueryCharHeight, RetrievalOptions());
    ASSERT_FALSE(hits.empty()) << (cut == &base ? "base" : "layer");
    EXPECT_EQ(hits[0].document, 7u) << Describe(hits);
    EXPECT_LT(MaxHomographyError(hits[0].homography, q), 1.0);
    EXPECT_EQ(hits.size(), 1u) << Describe(hits);
  }

  // A layer identical to the base duplicates every descriptor: no entry is added for it.
  LlahRetriever single(options_, quantizer_, 16), doubled(options_, quantizer_, 16);
  ASSERT_TRUE(single.AddDocument({1, base, kPageSize, {}, {}}).ok());
  std::vector<cv::Point2f> twice = base;
  twice.insert(twice.end(), base.begin(), base.end());
  ASSERT_TRUE(
      doubled.AddDocument({1, twice, kPageSize, {static_cast<uint32_t>(base.size())}, {}}).ok());
  EXPECT_EQ(doubled.entries(), single.entries());

  const size_t entries_of_8 = r.entries() - single.entries() - [&] {
    size_t n = 0;
    for (size_t i = base.size() * per; i < hashes.size(); ++i) n += hashes[i] != 0;
    return n;
  }();
  EXPECT_TRUE(r.RemoveDocument(7));
  EXPECT_EQ(r.entries(), entries_of_8);
  EXPECT_EQ(
      r.AddDocument({9, base, kPageSize, {static_cast<uint32_t>(base.size() + 1)}, {}}).code(),
      absl::StatusCode::kInvalidArgument);
}

// ---------------------------------------------------------------- RetrievalOptions

TEST(StopWordLimitTest, LoweredInProportionForViewsWithManyKeypointsToAQuarter) {
  // 10,000 pages: 40 per 1,000 documents = 400 entries.
  EXPECT_EQ(StopWordLimit(400, 80, 150), 400);   // few keypoints: the full limit
  EXPECT_EQ(StopWordLimit(400, 150, 150), 400);  // up to `plenty` included
  EXPECT_EQ(StopWordLimit(400, 300, 150), 200);  // twice as many: half
  EXPECT_EQ(StopWordLimit(400, 200, 150), 300);
  EXPECT_EQ(StopWordLimit(400, 600, 150), 100);   // four times: a quarter
  EXPECT_EQ(StopWordLimit(400, 2000, 150), 100);  // and never below it
  EXPECT_EQ(StopWordLimit(400, 2000, 0), 400);    // 0: never lowered
  EXPECT_EQ(StopWordLimit(0, 500, 150), 0);       // an empty database's share stays 0
}

TEST(RetrievalOptionsTest, DefaultsAreValid) { EXPECT_TRUE(RetrievalOptions().Validate().ok()); }

TEST(RetrievalOptionsTest, ValidateRejectsBadValuesWithAMessage) {
  struct Case {
    const char* field;
    void (*set)(RetrievalOptions&);
  };
  const Case cases[] = {
      {"max_hits_per_descriptor", [](RetrievalOptions& o) { o.max_hits_per_descriptor = 0; }},
      {"stop_word_keypoints", [](RetrievalOptions& o) { o.stop_word_keypoints = -1; }},
      {"min_votes", [](RetrievalOptions& o) { o.min_votes = 3; }},
      {"candidate_vote_ratio", [](RetrievalOptions& o) { o.candidate_vote_ratio = -0.1; }},
      {"candidate_vote_ratio", [](RetrievalOptions& o) { o.candidate_vote_ratio = 1.5; }},
      {"max_candidates", [](RetrievalOptions& o) { o.max_candidates = 0; }},
      {"ransac_threshold_px", [](RetrievalOptions& o) { o.ransac_threshold_px = -1; }},
      {"ransac_iterations", [](RetrievalOptions& o) { o.ransac_iterations = 5; }},
      {"min_inliers", [](RetrievalOptions& o) { o.min_inliers = 5; }},
      {"min_weak_inliers", [](RetrievalOptions& o) { o.min_weak_inliers = 4; }},
      {"min_weak_inliers", [](RetrievalOptions& o) { o.min_weak_inliers = 13; }},
      {"min_layout_matches", [](RetrievalOptions& o) { o.min_layout_matches = 11; }},
      {"min_layout_ratio", [](RetrievalOptions& o) { o.min_layout_ratio = 0.2; }},
      {"min_layout_ratio", [](RetrievalOptions& o) { o.min_layout_ratio = 1.5; }},
      {"max_results", [](RetrievalOptions& o) { o.max_results = -1; }},
      {"layout_chance", [](RetrievalOptions& o) { o.layout_chance = 0; }},
      {"layout_chance", [](RetrievalOptions& o) { o.layout_chance = 1; }},
      {"max_layout_tail", [](RetrievalOptions& o) { o.max_layout_tail = -1; }},
      {"deep_max_keypoints", [](RetrievalOptions& o) { o.deep_max_keypoints = -1; }},
      {"refine_max_keypoints", [](RetrievalOptions& o) { o.refine_max_keypoints = -1; }},
      {"deep_min_strong_votes", [](RetrievalOptions& o) { o.deep_min_strong_votes = 3; }},
      {"deep_min_weak_inliers", [](RetrievalOptions& o) { o.deep_min_weak_inliers = 3; }},
      {"deep_min_weak_inliers", [](RetrievalOptions& o) { o.deep_min_weak_inliers = 7; }},
      {"deep_min_layout_ratio", [](RetrievalOptions& o) { o.deep_min_layout_ratio = 0.2; }},
      {"neighbourhood_max_hypotheses",
       [](RetrievalOptions& o) { o.neighbourhood_max_hypotheses = -1; }},
      {"neighbourhood_max_residual", [](RetrievalOptions& o) { o.neighbourhood_max_residual = 0; }},
      {"neighbourhood_tight_gate", [](RetrievalOptions& o) { o.neighbourhood_tight_gate = 1.5; }},
      {"neighbourhood_min_tight", [](RetrievalOptions& o) { o.neighbourhood_min_tight = 5; }},
      {"neighbourhood_min_tight_share",
       [](RetrievalOptions& o) { o.neighbourhood_min_tight_share = 0; }},
      {"neighbourhood_min_tight_wide",
       [](RetrievalOptions& o) { o.neighbourhood_min_tight_wide = 12; }},
      {"neighbourhood_min_tight_share_close",
       [](RetrievalOptions& o) { o.neighbourhood_min_tight_share_close = 0.5; }},
      {"neighbourhood_min_tight_share_close",
       [](RetrievalOptions& o) { o.neighbourhood_min_tight_share_close = 1.2; }},
      {"neighbourhood_min_tight_agreeing",
       [](RetrievalOptions& o) { o.neighbourhood_min_tight_agreeing = 6; }},
      {"neighbourhood_min_agreeing_hits",
       [](RetrievalOptions& o) { o.neighbourhood_min_agreeing_hits = 1; }},
      {"guided_growth_rounds", [](RetrievalOptions& o) { o.guided_growth_rounds = -1; }},
      {"polish_gate", [](RetrievalOptions& o) { o.polish_gate = 0; }},
      {"polish_gate", [](RetrievalOptions& o) { o.polish_gate = 1.5; }},
      {"polish_match_gate", [](RetrievalOptions& o) { o.polish_match_gate = -1; }},
      {"polish_match_gate", [](RetrievalOptions& o) { o.polish_match_gate = 6; }},
  };
  for (const Case& c : cases) {
    RetrievalOptions o;
    c.set(o);
    const absl::Status s = o.Validate();
    EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << c.field;
    EXPECT_NE(s.message().find(c.field), std::string::npos)
        << "message should name " << c.field << ": " << s.message();
  }
  // Boundary values that are allowed.
  RetrievalOptions edge;
  edge.max_hits_per_descriptor = 1;
  edge.min_votes = 4;
  edge.candidate_vote_ratio = 1;
  edge.max_candidates = 1;
  edge.ransac_threshold_px = 0;
  edge.ransac_iterations = 10;
  edge.min_inliers = 6;
  edge.min_weak_inliers = 5;
  edge.min_layout_matches = 6;
  edge.min_layout_ratio = 1;
  edge.max_results = 0;
  edge.polish_gate = 1;
  edge.stop_word_keypoints = 0;
  EXPECT_TRUE(edge.Validate().ok()) << edge.Validate();
}

}  // namespace
}  // namespace texfree
