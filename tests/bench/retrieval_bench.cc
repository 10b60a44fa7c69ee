// Document retrieval benchmark: registers rendered pages (100 / 1,000 / 10,000
// ...) into a real DocumentRegistry on SQLite, then queries 640x480 camera
// views (tilt up to 40 deg, random roll, scale 0.6-1.3, blur, noise, uneven
// light, JPEG) and prints a table: top-1 accuracy, homography error, false
// matches on never-registered pages, median and p95 server time (decode +
// extract + match + verify), index memory and start-up time.
//
//   texfree-bench-retrieval --pages 100,1000,10000 --queries 300 --unregistered
//   200 [--fonts liberation]
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "common/image_io.h"
#include "common/letter_keypoints.h"
#include "common/neighbor_grid.h"
#include "common/planar_pose.h"
#include "common/text_perspective.h"
#include "common/timing.h"
#include "common/word_keypoints.h"
#include "server/document_registry.h"
#include "server/document_store.h"
#include "tests/data/camera_view.h"
#include "tests/data/page_renderer.h"

namespace fs = std::filesystem;
using Clock = texfree::SteadyClock;
using texfree::server::DocumentRegistry;
using texfree::server::DocumentRegistryOptions;
using texfree::server::DocumentStore;

namespace {

double Percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(q * (v.size() - 1) + 0.5))];
}

long RssKiB() {
  std::ifstream in("/proc/self/status");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("VmRSS:", 0) == 0) return std::stol(line.substr(6));
  return 0;
}

struct Query {
  std::string jpeg;
  int page;            // -1: never registered
  cv::Matx33d truth;   // registered-image pixels -> view (nominal when the page curls)
  cv::Size page_size;  // of the rendered page
  texfree::testdata::CameraViewOptions view;
  texfree::testdata::CameraView camera;  // geometry only (no image), for the true projection
  // Rendered-page pixels -> registered-image pixels (--register-scale).
  cv::Matx33d page_to_registered = cv::Matx33d::eye();
  uint64_t render_seed = 0;  // RenderCameraView's seed
  int jpeg_quality = 0;
};

// How the camera views are drawn: `resolution` scales the camera's pixels (the same views,
// F times as many pixels across, the page scale and the lens blur in pixels growing with
// it, as a phone's full-size photo); the page scale (image px per page px of a 1,000 px
// page) is drawn in [min_scale, max_scale].
struct ViewRange {
  double resolution = 1.0;
  double min_scale = 0.6, max_scale = 1.3;
  // Real-world bends, off by default (the views are then exactly the issue's): the page
  // lifts by up to max_curl page widths (half of the views bowed, half curled from one
  // edge), and the lens has a radial k1 in [-max_k1, max_k1 / 2] (mostly barrel). Drawn
  // from their own stream, so the views are otherwise the same as without.
  double max_curl = 0, max_k1 = 0;
  // Handheld shake: a motion blur of up to this many pixels (of a 640x480 view) in a random
  // direction, from the same separate stream.
  double max_motion_px = 0;
  // Glare of glossy paper: a veil of up to this share of white over a soft spot, from a
  // stream of its own (CameraViewOptions::glare).
  double max_glare = 0;
  // Each view is undistorted with its own lens before it is queried (as `texfree doc
  // retrieve --undistort` does with a calibration), and scored through the ideal pinhole.
  bool undistort = false;
  // The camera held upright (a phone in portrait): 480x640 views whose long side, now the
  // height, sees the field of view drawn for it; the same views otherwise.
  bool portrait = false;
  // Only views of these registered pages are rendered and queried (empty: all). The other
  // views still draw from the streams, so each kept view is the one a full run queries.
  std::vector<int> only_pages;
};

// Seeds of the view sets lie this far apart: a set draws one seed per view from its own.
constexpr uint64_t kViewSetStride = 7'919'000'003;

std::vector<Query> MakeQueries(int count, int registered, uint64_t seed, bool unregistered,
                               const texfree::testdata::PageOptions &page_options,
                               const ViewRange &range) {
  const double resolution = range.resolution;
  std::vector<Query> out;
  std::mt19937_64 rng(seed);
  for (int i = 0; i < count; ++i) {
    const int page =
        unregistered ? -1 : static_cast<int>((static_cast<int64_t>(i) * 7919) % registered);
    const uint64_t page_seed = unregistered ? 1'000'000 + i : page;
    if (!unregistered && !range.only_pages.empty() &&
        std::find(range.only_pages.begin(), range.only_pages.end(), page) ==
            range.only_pages.end()) {
      texfree::testdata::RandomViewOptions(rng, {page_options.width, page_options.height}, 40,
                                           range.min_scale, range.max_scale);
      rng();  // the JPEG quality
      continue;
    }
    auto rendered = texfree::testdata::RenderTextPage(page_seed, page_options);
    auto options = texfree::testdata::RandomViewOptions(rng, rendered.image.size(), 40,
                                                        range.min_scale, range.max_scale);
    options.jpeg_quality = 0;  // encoded below, decoded by the timed server path
    options.image_size =
        cv::Size(static_cast<int>(std::lround(options.image_size.width * resolution)),
                 static_cast<int>(std::lround(options.image_size.height * resolution)));
    if (range.portrait) {
      std::swap(options.image_size.width, options.image_size.height);
      const double half = options.horizontal_fov_deg * CV_PI / 360.0;
      options.horizontal_fov_deg =
          360.0 / CV_PI *
          std::atan(std::tan(half) * options.image_size.width / options.image_size.height);
    }
    // Pages rendered wider than the default 1,000 px (a higher dpi) are seen alike.
    options.scale *= resolution * 1000.0 / page_options.width;
    options.blur_sigma *= resolution;
    if (range.max_curl > 0 || range.max_k1 > 0 || range.max_motion_px > 0) {
      texfree::testdata::DrawBends(seed * 1'000'003 + static_cast<uint64_t>(i) + 0xb3e7,
                                   range.max_curl, range.max_k1, range.max_motion_px * resolution,
                                   &options);
    }
    if (range.max_glare > 0)
      texfree::testdata::DrawGlare(seed * 1'000'003 + static_cast<uint64_t>(i) + 0x61a5e,
                                   range.max_glare, &options);
    auto view = texfree::testdata::RenderCameraView(rendered.image, options, seed + i);
    if (range.undistort) view.image = texfree::testdata::UndistortView(view.image, view, &options);
    std::vector<uchar> bytes;
    const int quality = 60 + static_cast<int>(rng() % 36);
    cv::imencode(".jpg", view.image, bytes, {cv::IMWRITE_JPEG_QUALITY, quality});
    view.image.release();
    out.push_back({std::string(bytes.begin(), bytes.end()), page, view.homography,
                   rendered.image.size(), options, view, cv::Matx33d::eye(), seed + i, quality});
  }
  return out;
}

// How well one extractor's keypoints in a view repeat the registered page's: the share of
// reference keypoints inside the view found again (within a third of the text height), of
// those how many kept at least m of their n nearest neighbours (so that one LLAH
// descriptor can match), and how many share a descriptor with their reference keypoint.
std::string RepeatStats(const std::vector<cv::Point2f> &points, double char_height,
                        const std::vector<cv::Point2f> &ref, const cv::Matx33d &truth,
                        const cv::Size &image, const texfree::LlahDescriber &describer) {
  std::vector<uint64_t> ref_hashes, query_hashes;
  describer.Describe(ref, &ref_hashes);
  describer.Describe(points, &query_hashes);
  const int per = describer.descriptors_per_point();
  const int n = describer.options().n, m = describer.options().m;
  std::vector<int> match(points.size(), -1);  // query -> ref
  int in_view = 0, found = 0, kept_m = 0, equal = 0;
  const double tol = std::max(2.0, char_height / 3);
  for (size_t r = 0; r < ref.size(); ++r) {
    const cv::Point2d v = texfree::ApplyHomography(truth, cv::Point2d(ref[r].x, ref[r].y));
    if (v.x < 0 || v.y < 0 || v.x >= image.width || v.y >= image.height) continue;
    ++in_view;
    for (size_t i = 0; i < points.size(); ++i)
      if (std::hypot(points[i].x - v.x, points[i].y - v.y) < tol) {
        ++found;
        match[i] = static_cast<int>(r);
        break;
      }
  }
  if (points.size() > static_cast<size_t>(n) && ref.size() > static_cast<size_t>(n)) {
    texfree::NeighborGrid ref_grid(ref), query_grid(points);
    std::vector<int> qn, rn;
    for (size_t i = 0; i < points.size(); ++i) {
      if (match[i] < 0) continue;
      query_grid.Nearest(static_cast<int>(i), n, &qn);
      ref_grid.Nearest(match[i], n, &rn);
      int common = 0;
      for (int a : qn)
        if (match[a] >= 0 && std::find(rn.begin(), rn.end(), match[a]) != rn.end()) ++common;
      if (common >= m) ++kept_m;
      bool same = false;
      for (int a = 0; a < per && !same; ++a)
        for (int b = 0; b < per && !same; ++b) {
          const uint64_t hq = query_hashes[i * per + a];
          same = hq != 0 && hq == ref_hashes[static_cast<size_t>(match[i]) * per + b];
        }
      if (same) ++equal;
    }
  }
  char line[300];
  std::snprintf(line, sizeof(line),
                "kp %zu h %.1f: %d/%d found (%.0f%%), %d keep %d/%d nn, %d desc", points.size(),
                char_height, found, in_view, in_view ? 100.0 * found / in_view : 0.0, kept_m, m, n,
                equal);
  return line;
}

// One line per missed query: the view, and how each query extractor saw it.
// save_figures: when not empty, the view is written there with its figure corners (red) and
// the registered page's corners projected by the true homography (green).
void PrintMiss(const DocumentRegistry &registry, const Query &q, const cv::Mat &gray,
               const std::string &id, const texfree::server::RetrievalResult *result,
               const std::string &save_figures) {
  auto record = registry.Get(id);
  if (!record.ok()) return;
  const auto ref = registry.retriever()->Keypoints(record->index_id);
  std::string stats;
  // What happened at each gate of a Retrieve() (RetrievalTrace).
  auto gates = [](const texfree::RetrievalTrace &t) {
    char line[200];
    std::snprintf(line, sizeof(line),
                  " [%sstop %d, hits %d/%d, votes %d/%d/%d rank %d, candidate %d of %d, ransac "
                  "%d final %d guided %d inside %d%s]",
                  t.rectified ? "rectified, " : "", t.stop_word_lookups, t.hits, t.total_hits,
                  t.coherent, t.strong, t.votes, t.rank_by_score, t.rank, t.candidates,
                  t.ransac_inliers, t.final_inliers, t.guided, t.layout_inside,
                  t.accepted ? " accepted" : "");
    return std::string(line);
  };
  std::vector<texfree::WordKeypointOptions> extractors{registry.options().keypoints};
  for (const auto &o : registry.options().fallback_keypoints) extractors.push_back(o);
  for (const auto &o : extractors) {
    const auto kp = texfree::WordKeypointExtractor(o).Extract(gray);
    stats += " | " + RepeatStats(kp.points, kp.char_height, ref, q.truth, gray.size(),
                                 registry.retriever()->describer());
    texfree::RetrievalTrace t;
    t.watch = record->index_id;
    texfree::RetrievalOptions ro = registry.options().retrieval;
    ro.frame = gray.size();  // as the registry sets them per query
    if (registry.options().assumed_horizontal_fov_deg > 0) {
      ro.perspective.focal_px =
          gray.cols / 2.0 / std::tan(registry.options().assumed_horizontal_fov_deg * CV_PI / 360);
      ro.perspective.principal_point = {gray.cols / 2.0, gray.rows / 2.0};
    }
    registry.retriever()->Retrieve(kp.points, kp.char_height, ro, &t);
    stats += gates(t);
    if (static_cast<int>(kp.points.size()) <= ro.deep_max_keypoints) {
      texfree::RetrievalTrace nb;
      nb.watch = record->index_id;
      texfree::RetrievalOptions no = ro;
      no.text_angle_rad = kp.text_angle_rad;
      registry.retriever()->RetrieveByNeighbourhoods(kp.points, kp.char_height, no, &nb);
      char line[200];
      std::snprintf(line, sizeof(line),
                    " [neighbourhoods: %d hypotheses, page %d tight of %d inside (%d agreeing), "
                    "best other %d of %d (%d agreeing)]",
                    nb.neighbourhood_hypotheses, nb.neighbourhood_tight, nb.neighbourhood_inside,
                    nb.neighbourhood_agreeing, nb.neighbourhood_other_tight,
                    nb.neighbourhood_other_inside, nb.neighbourhood_other_agreeing);
      stats += line;
    }
    // A rectified query's trace is the rectified attempt's: the unrectified one is traced
    // apart (with the few-keypoint pass the registry would allow it first).
    if (t.rectified) {
      texfree::RetrievalTrace seen;
      seen.watch = record->index_id;
      ro.rectify_perspective = false;
      registry.retriever()->Retrieve(kp.points, kp.char_height, ro, &seen);
      stats += " as seen" + gates(seen);
    }
  }
  // The figures' corners, as the registry's last try takes them.
  if (const auto figures = registry.figure_retriever()) {
    const auto corners = registry.FigureKeypoints(gray);
    const auto figure_ref = figures->Keypoints(record->index_id);
    stats += " | figures: page " + std::to_string(figure_ref.size()) + ", " +
             RepeatStats(corners, 9.0, figure_ref, q.truth, gray.size(), figures->describer());
    if (!save_figures.empty()) {
      cv::Mat shown;
      cv::cvtColor(gray, shown, cv::COLOR_GRAY2BGR);
      for (const cv::Point2f &r : figure_ref) {
        const cv::Point2d v = texfree::ApplyHomography(q.truth, cv::Point2d(r.x, r.y));
        cv::circle(shown, v, 6, {0, 200, 0}, 1, cv::LINE_AA);
      }
      for (const cv::Point2f &c : corners) cv::circle(shown, c, 3, {0, 0, 255}, 1, cv::LINE_AA);
      cv::imwrite(save_figures, shown);
    }
    texfree::RetrievalOptions ro = registry.options().retrieval;
    ro.frame = gray.size();
    ro = registry.FigureRetrievalOptions(ro);
    texfree::RetrievalTrace t;
    t.watch = record->index_id;
    figures->Retrieve(corners, 0, ro, &t);
    texfree::RetrievalTrace nb;
    nb.watch = record->index_id;
    figures->RetrieveByNeighbourhoods(corners, 0, ro, &nb);
    char line[300];
    std::snprintf(line, sizeof(line),
                  " [stop %d, hits %d/%d, votes %d/%d/%d rank %d, candidate %d of %d, ransac %d "
                  "final %d guided %d inside %d%s; neighbourhoods %d tight of %d (%d agreeing), "
                  "other %d of %d]",
                  t.stop_word_lookups, t.hits, t.total_hits, t.coherent, t.strong, t.votes,
                  t.rank_by_score, t.rank, t.candidates, t.ransac_inliers, t.final_inliers,
                  t.guided, t.layout_inside, t.accepted ? " accepted" : "", nb.neighbourhood_tight,
                  nb.neighbourhood_inside, nb.neighbourhood_agreeing, nb.neighbourhood_other_tight,
                  nb.neighbourhood_other_inside);
    stats += line;
  }
  // The letters of large type, as the registry's try after the figures cuts them.
  if (const auto letters = registry.letter_retriever()) {
    const texfree::LetterKeypoints cut =
        texfree::LetterKeypointExtractor(registry.options().letter_keypoints).Extract(gray);
    const auto letter_ref = letters->Keypoints(record->index_id);
    stats += " | letters: page " + std::to_string(letter_ref.size()) + ", " +
             RepeatStats(cut.points, cut.letter_size, letter_ref, q.truth, gray.size(),
                         letters->describer());
    texfree::RetrievalOptions ro = registry.options().retrieval;
    ro.frame = gray.size();
    ro = registry.LetterRetrievalOptions(ro, cut.letter_size);
    texfree::RetrievalTrace t;
    t.watch = record->index_id;
    letters->Retrieve(cut.points, cut.letter_size, ro, &t);
    stats += gates(t);
  }
  std::fprintf(
      stderr,
      "miss page %d: tilt %.0f scale %.2f blur %.1f noise %.1f light %.2f (roll %.1f azimuth %.1f "
      "fov %.1f look-at %.0f,%.0f curl %.3f k1 %+.3f motion %.1f glare %.2f)%s | %s\n",
      q.page, q.view.tilt_deg, q.view.scale, q.view.blur_sigma, q.view.noise_sigma,
      q.view.illumination_gradient, q.view.roll_deg, q.view.tilt_azimuth_deg,
      q.view.horizontal_fov_deg, q.view.look_at.x, q.view.look_at.y, q.view.page_curl,
      q.view.radial_k1, q.view.motion_blur_px, q.view.glare, stats.c_str(),
      result == nullptr || result->documents.empty() ? "nothing"
                                                     : result->documents[0].document.title.c_str());
}

// `gray` warped by `warp`, shifted so that the whole picture lands in the result (at most
// 4000 px a side, white around it); `shifted` (when given) receives the shifted warp.
cv::Mat WarpWhole(const cv::Mat &gray, const cv::Matx33d &warp, cv::Matx33d *shifted = nullptr) {
  double min_x = 1e18, min_y = 1e18, max_x = -1e18, max_y = -1e18;
  for (const cv::Point2d &corner : {cv::Point2d(0, 0), cv::Point2d(gray.cols, 0),
                                    cv::Point2d(gray.cols, gray.rows), cv::Point2d(0, gray.rows)}) {
    const cv::Point2d p = texfree::ApplyHomography(warp, corner);
    min_x = std::min(min_x, p.x);
    min_y = std::min(min_y, p.y);
    max_x = std::max(max_x, p.x);
    max_y = std::max(max_y, p.y);
  }
  const cv::Matx33d moved = cv::Matx33d(1, 0, -min_x, 0, 1, -min_y, 0, 0, 1) * warp;
  if (shifted) *shifted = moved;
  cv::Mat out;
  cv::warpPerspective(gray, out, cv::Mat(moved),
                      cv::Size(std::min(4000, static_cast<int>(max_x - min_x)),
                               std::min(4000, static_cast<int>(max_y - min_y))),
                      cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(255));
  return out;
}

// The upper bound of a better rectification: a missed view rectified by the renderer's own
// homography (scaled so that its text keeps its size at the view's centre), retrieved (1) as
// an image, cut anew by the extractors, and (2) as the view's own keypoints of each
// extractor mapped through it (the way Retrieve's rectification describes them).
void PrintTrueRectification(const DocumentRegistry &registry, const Query &q, const cv::Mat &gray,
                            const std::string &id) {
  const cv::Matx33d inv = q.truth.inv();  // view -> registered page
  const cv::Point2d centre = texfree::ApplyHomography(inv, {gray.cols / 2.0, gray.rows / 2.0});
  const cv::Point2d c = texfree::ApplyHomography(q.truth, centre);
  const cv::Point2d dx = texfree::ApplyHomography(q.truth, centre + cv::Point2d(1, 0)) - c;
  const cv::Point2d dy = texfree::ApplyHomography(q.truth, centre + cv::Point2d(0, 1)) - c;
  const double scale = std::sqrt(std::abs(dx.cross(dy)));  // view px per page px there
  cv::Matx33d rectify;                                     // view -> rectified
  const cv::Mat rectified =
      WarpWhole(gray, cv::Matx33d(scale, 0, 0, 0, scale, 0, 0, 0, 1) * inv, &rectify);
  auto as_image = registry.Retrieve(rectified, std::nullopt, 0);
  const bool image_found =
      as_image.ok() && !as_image->documents.empty() && as_image->documents[0].document.id == id;
  // The true horizon alone (the perspective undone, the foreshortening's affine part left, as
  // the registry's rectified picture has it when its horizon is exact).
  bool horizon_found = false;
  const cv::Point2d view_centre(gray.cols / 2.0, gray.rows / 2.0);
  if (const auto projective = texfree::PerspectiveOnly(inv, view_centre)) {
    auto r = registry.Retrieve(WarpWhole(gray, *projective), std::nullopt, 0);
    horizon_found = r.ok() && !r->documents.empty() && r->documents[0].document.id == id;
  }
  auto record = registry.Get(id);
  std::string per_extractor;
  std::vector<texfree::WordKeypointOptions> extractors{registry.options().keypoints};
  for (const auto &o : registry.options().fallback_keypoints) extractors.push_back(o);
  for (const auto &o : extractors) {
    const auto kp = texfree::WordKeypointExtractor(o).Extract(gray);
    std::vector<cv::Point2f> mapped;
    for (const cv::Point2f &p : kp.points) {
      const cv::Point2d m = texfree::ApplyHomography(rectify, cv::Point2d(p.x, p.y));
      mapped.emplace_back(static_cast<float>(m.x), static_cast<float>(m.y));
    }
    texfree::RetrievalOptions ro = registry.options().retrieval;
    ro.rectify_perspective = false;
    const auto hits = registry.retriever()->Retrieve(mapped, kp.char_height, ro, nullptr);
    const bool found = record.ok() && !hits.empty() && hits[0].document == record->index_id;
    per_extractor += " " + std::to_string(kp.points.size()) + (found ? " found" : " missed");
  }
  // The horizon (the rectification's third row, scaled to 1 at the image centre, in units of
  // the half-diagonal) of the truth, the keypoint-spacing fit and the text-line refinement
  // on the registration extractor's keypoints.
  const double half_diagonal = std::hypot(gray.cols, gray.rows) / 2;
  auto horizon = [&](const cv::Matx33d &P) {
    const auto only = texfree::PerspectiveOnly(P, view_centre);
    if (!only) return std::string("(behind the horizon)");
    char text[64];
    std::snprintf(text, sizeof(text), "(%+.3f, %+.3f)", (*only)(2, 0) * half_diagonal,
                  (*only)(2, 1) * half_diagonal);
    return std::string(text);
  };
  std::string horizons = "true " + horizon(inv);
  {
    const auto kp = texfree::WordKeypointExtractor(registry.options().keypoints).Extract(gray);
    texfree::TextPerspectiveOptions po = registry.options().retrieval.perspective;
    if (registry.options().assumed_horizontal_fov_deg > 0) {
      po.focal_px =
          gray.cols / 2.0 / std::tan(registry.options().assumed_horizontal_fov_deg * CV_PI / 360);
      po.principal_point = {gray.cols / 2.0, gray.rows / 2.0};
    }
    const auto spacing = texfree::EstimateTextPerspective(kp.points, po);
    horizons += spacing ? ", spacing fit " + horizon(*spacing) : ", spacing fit none";
    const auto refined = texfree::RefineTextPerspective(kp.points, kp.text_angle_rad, spacing, po);
    horizons += refined ? ", text lines " + horizon(*refined) : ", text lines none";
  }
  std::fprintf(stderr,
               "true rectification, page %d (tilt %.0f): as an image %s (%d keypoints), by its "
               "horizon alone %s; its keypoints mapped:%s; horizon %s\n",
               q.page, q.view.tilt_deg, image_found ? "found" : "missed",
               as_image.ok() ? as_image->query_keypoints : -1, horizon_found ? "found" : "missed",
               per_extractor.c_str(), horizons.c_str());
}

}  // namespace

int main(int argc, char **argv) {
  CLI::App app{"texfree document retrieval benchmark"};
  std::vector<int> checkpoints{100, 1000};
  int queries = 200, unregistered = 100;
  std::string dir = "/tmp/texfree-bench-retrieval";
  bool keep = false;
  app.add_option("--pages", checkpoints, "registered page counts to measure at")->delimiter(',');
  app.add_option("--queries", queries, "camera views of registered pages per checkpoint");
  int query_pages = 0;
  uint64_t view_set = 0;
  app.add_option("--view-set", view_set,
                 "another set of camera views (0: the issue's set); the pages and the views' "
                 "ranges stay, their draws change");
  app.add_option("--query-pages", query_pages,
                 "draw the views from the first N pages only, with one seed for every checkpoint "
                 "(the same views at each size; 0: from all registered pages)");
  app.add_option("--unregistered", unregistered, "camera views of never-registered pages");
  app.add_option("--dir", dir, "working directory for the database");
  app.add_flag("--keep", keep, "reuse an existing database in --dir");
  DocumentRegistryOptions registry_options;
  app.add_option("--probes", registry_options.retrieval.query_probes,
                 "query-side multi-probe: invariants per descriptor allowed "
                 "across a boundary");
  app.add_option("--figure-probes", registry_options.figure_query_probes,
                 "query-side multi-probe of the figures' descriptors");
  app.add_option("--figure-llah-n", registry_options.figure_llah_n,
                 "LLAH neighbours of the figures' index (new database only)");
  app.add_option("--figure-llah-m", registry_options.figure_llah_m,
                 "LLAH neighbours per descriptor of the figures' index (new database only)");
  app.add_option("--figure-llah-k", registry_options.figure_llah_k,
                 "quantisation levels of the figures' index, a divisor of the words' (0: the "
                 "words'; new database only)");
  app.add_option("--figure-centroid-blob", registry_options.figure_keypoints.centroid_max_blob_px,
                 "figure corners at the centroids of cornerness blobs up to this size (px; 0: "
                 "local maxima only; new database only)");
  app.add_option("--figure-inlier-px", registry_options.figure_inlier_px,
                 "RANSAC inlier distance of the figures' corners (px)");
  app.add_flag("!--no-figures", registry_options.index_figures,
               "no figure index (new database), no figure retrieval");
  app.add_flag("!--no-letters", registry_options.index_letters,
               "no index of large type's letters (new database: no letters stored), no letter "
               "retrieval");
  app.add_option("--letter-min-type", registry_options.letter_min_type_share,
                 "type registered by its letters: at least this share of the page's shorter side "
                 "(new pages only)");
  app.add_option("--letter-inlier-share", registry_options.letter_inlier_share,
                 "RANSAC inlier distance of the letters, times their size");
  app.add_option("--small-type-below", registry_options.small_type_below_px,
                 "views that found nothing with text under this height (px) are retrieved again "
                 "at a larger size (0: never)");
  app.add_option("--small-type-upscale", registry_options.small_type_upscale,
                 "the small-type retry's size, times the size the view was retrieved at");
  app.add_option("--max-hits", registry_options.retrieval.max_hits_per_descriptor,
                 "descriptors with more index entries than this do not vote");
  app.add_option("--max-hits-per-1000", registry_options.retrieval.max_hits_per_1000_documents,
                 "stop-word limit growth: entries per 1,000 registered pages");
  app.add_option("--stop-word-keypoints", registry_options.retrieval.stop_word_keypoints,
                 "views with more keypoints get a proportionally lower stop-word limit (0: off)");
  app.add_option("--max-candidates", registry_options.retrieval.max_candidates,
                 "documents verified per query");
  app.add_option("--min-votes", registry_options.retrieval.min_votes,
                 "query keypoints voting for a document before it is verified");
  app.add_option("--prefilter", registry_options.retrieval.prefilter_documents,
                 "documents (most hits) that are voted for (0: all)");
  std::string layers = "default";
  app.add_option("--layers", layers,
                 "extra keypoint layers of registered pages: 'default', 'none', or "
                 "SCALE:BLUR[:closing],... (new pages only)");
  app.add_option("--max-query-pixels", registry_options.max_query_pixels,
                 "query pictures with more pixels are retrieved reduced to this many (0: never)");
  bool no_rectify = false;
  app.add_flag("--no-rectify", no_rectify,
               "describe steep views' keypoints as seen (no perspective rectification)");
  app.add_option("--perspective-neighbour", registry_options.retrieval.perspective.neighbour,
                 "keypoint spacing = distance to this nearest neighbour");
  app.add_option("--perspective-min-points", registry_options.retrieval.perspective.min_points,
                 "fewer keypoints than this are described as seen");
  app.add_option("--depth-ratio", registry_options.retrieval.perspective.min_depth_ratio,
                 "rectify when the fitted depth varies over the keypoints by at least this ratio");
  app.add_option("--assumed-fov", registry_options.assumed_horizontal_fov_deg,
                 "horizontal field of view assumed to undo a steep view's foreshortening "
                 "(0: affine rectification only)");
  app.add_option("--max-border-lost", registry_options.retrieval.max_border_lost,
                 "keypoints expected to lose this many neighbours to the frame are not "
                 "described (0: all are)");
  app.add_option("--min-coherent", registry_options.retrieval.min_coherent_votes,
                 "...of which have a neighbouring correspondence near on the page");
  app.add_option("--coherence-radius", registry_options.retrieval.coherence_radius,
                 "'near': times the page's typical distance to the n-th nearest keypoint");
  app.add_option("--min-strong", registry_options.retrieval.min_strong_votes,
                 "...of which agree on one reference keypoint with 2+ descriptors");
  app.add_option("--min-weak-inliers", registry_options.retrieval.min_weak_inliers,
                 "LLAH inliers from which the layout check may confirm a page");
  app.add_option("--layout-ratio", registry_options.retrieval.min_layout_ratio,
                 "share of projected reference keypoints that must meet query keypoints");
  app.add_option("--max-layout-tail", registry_options.retrieval.max_layout_tail,
                 "below min_layout_matches, the layout confirms a page when chance would match "
                 "that share with at most this probability (0: off)");
  app.add_option("--neighbourhood-hypotheses",
                 registry_options.retrieval.neighbourhood_max_hypotheses,
                 "hits turned into homographies by the neighbourhood pass (0: off)");
  app.add_option("--neighbourhood-agreeing",
                 registry_options.retrieval.neighbourhood_min_tight_agreeing,
                 "tight matches from which agreeing descriptor hits may confirm a page in the "
                 "neighbourhood pass (0: off)");
  app.add_option("--neighbourhood-agreeing-hits",
                 registry_options.retrieval.neighbourhood_min_agreeing_hits,
                 "agreeing descriptor hits that confirm a page below the tight-match bar");
  app.add_option("--neighbourhood-extractors", registry_options.neighbourhood_pass_extractors,
                 "extractors whose keypoints the neighbourhood pass takes (0: none)");
  app.add_option("--neighbourhood-rectified", registry_options.neighbourhood_pass_rectified,
                 "the neighbourhood pass on the rectified picture's keypoints too (0 or 1)");
  app.add_option("--deep-max-keypoints", registry_options.retrieval.deep_max_keypoints,
                 "queries of at most this many keypoints that found nothing vote again on "
                 "their hits (the few-keypoint pass; 0: off)");
  app.add_option("--fallback-retry", registry_options.fallback_retry_max_keypoints,
                 "fallback extractors retry unrectified up to this many keypoints (0: never)");
  app.add_option("--deep-extractors", registry_options.deep_pass_extractors,
                 "extractors (in order) whose keypoints may take the few-keypoint pass");
  app.add_option("--deep-prefilter", registry_options.retrieval.deep_prefilter_documents,
                 "documents (most hits) voted for in that second pass (0: all)");
  app.add_option("--deep-min-strong", registry_options.retrieval.deep_min_strong_votes,
                 "strong votes a candidate needs in that second pass");
  app.add_option("--deep-min-weak-inliers", registry_options.retrieval.deep_min_weak_inliers,
                 "LLAH inliers a candidate needs in that second pass");
  app.add_option("--ransac-iterations", registry_options.retrieval.ransac_iterations,
                 "RANSAC iterations per candidate document");
  app.add_option("--llah-n", registry_options.llah.n, "LLAH neighbours (new database only)");
  app.add_option("--llah-m", registry_options.llah.m, "LLAH neighbours per descriptor");
  app.add_option("--llah-k", registry_options.llah.k, "LLAH quantisation levels");
  app.add_option("--guided-growth", registry_options.retrieval.guided_growth_rounds,
                 "refits at the full gate while guided matching still grows (0: one)");
  bool no_similarity_start = false;
  app.add_flag("--no-similarity-start", no_similarity_start,
               "guided matching from the homography only, not also from a similarity");
  bool no_polish = false;
  app.add_option("--polish-match-gate", registry_options.retrieval.polish_match_gate,
                 "the robust refit of an accepted page over its keypoints within this many "
                 "inlier thresholds of a query keypoint (0: over the guided matches)");
  app.add_flag("--no-polish", no_polish,
               "no robust refit of an accepted page's homography (RetrievalOptions::"
               "polish_homography)");
  bool line_closing = false;
  app.add_flag("--line-closing", line_closing,
               "register and query first with the line closing (new database only)");
  app.add_option("--log2-buckets", registry_options.log2_buckets, "index hash table size");
  int register_threads = 1;
  int measure_delete = 0;
  app.add_option("--measure-delete", measure_delete,
                 "after the queries, delete this many registered pages one by one (timed), then "
                 "register each again (it must be accepted: nothing of it may be left in the "
                 "index); the database keeps its pages");
  app.add_option("--register-threads", register_threads,
                 "threads rendering and registering pages (the registry serialises the index "
                 "writes; each thread renders and cuts its own pages)")
      ->check(CLI::Range(1, 16));
  int page_width = 1000;
  app.add_option("--page-width", page_width,
                 "width of the rendered pages in pixels (1000: about 120 dpi on A4; 2480: 300 "
                 "dpi); the camera views are the same at any width")
      ->check(CLI::Range(500, 5000));
  double register_scale = 1.0;
  app.add_option("--register-scale", register_scale,
                 "register each page downscaled by this factor (the views still see the full "
                 "page): a page registered at a lower dpi than it is printed at")
      ->check(CLI::Range(0.1, 1.0));
  ViewRange view_range;
  double &resolution = view_range.resolution;
  std::string view_scale = "0.6:1.3";
  app.add_option("--view-scale", view_scale,
                 "MIN:MAX page scale of the views (image px per px of a 1,000 px page; a whole "
                 "A4 page fills a 640x480 view at about 0.34)");
  app.add_option("--curl", view_range.max_curl,
                 "the pages of the views lift off the desk by up to this many page widths "
                 "(a sheet lying curled, a page of an open book; 0: flat, as the issue's views)")
      ->check(CLI::Range(0.0, 0.3));
  app.add_option("--lens-k1", view_range.max_k1,
                 "the views' lens has a radial distortion k1 in [-K, K/2] (0: ideal pinhole)")
      ->check(CLI::Range(0.0, 0.5));
  app.add_option("--only-pages", view_range.only_pages,
                 "query only the views of these registered pages (the views a full run draws for "
                 "them; e.g. the pages --misses names)")
      ->delimiter(',');
  app.add_flag("--portrait", view_range.portrait,
               "views of 480x640 (a phone held upright), the drawn field of view along the long "
               "side");
  app.add_flag("--undistort", view_range.undistort,
               "undistort each view with its own lens before querying it (texfree doc retrieve "
               "--undistort)");
  app.add_option("--glare", view_range.max_glare,
                 "glossy paper: each view has a veil of light of up to this share of white over "
                 "a soft spot (from 0.3 the paper's white clips at its centre; 0: none)")
      ->check(CLI::Range(0.0, 2.0));
  app.add_option("--motion-blur", view_range.max_motion_px,
                 "the views are smeared by camera shake of up to this many pixels (0: none)")
      ->check(CLI::Range(0.0, 30.0));
  app.add_option("--resolution", resolution,
                 "camera pixels per 640x480 view's pixel: the same views at F times the width "
                 "and height (page scale and blur scaled alike)")
      ->check(CLI::Range(0.25, 8.0));
  std::string fonts = "dejavu";
  app.add_option("--fonts", fonts,
                 "font set of the registered and the unregistered pages: dejavu (the one the "
                 "extractor was tuned on), liberation, freefont, latinmodern or all (held out)");
  bool no_fallback = false, misses = false;
  double slow_ms = 0;
  app.add_option("--slow", slow_ms, "print the stages of queries slower than this (ms)");
  app.add_flag("--misses", misses, "print why each missed query failed (keypoint repeatability)");
  std::string save_misses;
  app.add_option("--save-misses", save_misses, "with --misses: write each missed view here (PNG)");
  app.add_flag("--no-fallback", no_fallback, "query with the registration extractor only");
  int picture_max_keypoints = -1, refine_max_keypoints = -1;
  app.add_option("--picture-max-keypoints", picture_max_keypoints,
                 "the rectified-picture retry is for pictures of at most this many keypoints");
  app.add_option("--refine-max-keypoints", refine_max_keypoints,
                 "the text-line refinement is for views of at most this many keypoints");
  app.add_option("--picture-rounds", registry_options.rectified_picture_rounds,
                 "warps of the rectified-picture retry (each refits the horizon on the last)");
  app.add_option("--picture-min-refit", registry_options.rectified_picture_min_refit_ratio,
                 "a next warp only when the refitted horizon's depth ratio is at least this");
  bool no_picture_projective = false;
  app.add_flag("--no-picture-projective", no_picture_projective,
               "no last warp of the picture by its horizon's perspective alone");
  app.add_option("--picture-projective-min-slope",
                 registry_options.rectified_picture_projective_min_slope,
                 "the perspective-only warp only for horizons changing the depth by at least "
                 "this over a half-diagonal");
  bool no_picture_fallbacks = false;
  app.add_flag("--no-picture-fallbacks", no_picture_fallbacks,
               "the rectified-picture retry cuts the warped picture with the registration "
               "extractor only");
  bool no_rectified_picture = false;
  app.add_flag("--no-rectified-picture", no_rectified_picture,
               "no last try of views nothing found on the picture warped by their text-line "
               "horizon and cut anew");
  bool no_picture_after_weak = false;
  app.add_flag("--no-picture-after-weak", no_picture_after_weak,
               "the rectified-picture retry only for views no extractor found a page in, not "
               "also after a page found with fewer than min_inliers LLAH inliers");
  bool no_line_refinement = false;
  app.add_flag("--no-line-refinement", no_line_refinement,
               "no last try of views nothing found, rectified by the horizon that makes their "
               "text lines parallel and evenly spaced");
  bool true_rectification = false;
  app.add_flag("--true-rectification", true_rectification,
               "retry each missed view rectified by the renderer's homography (as an image, and "
               "its keypoints mapped): what a perfect perspective estimate would find");
  CLI11_PARSE(app, argc, argv);
  if (layers != "default") {
    registry_options.registration_layers.clear();
    std::stringstream list(layers == "none" ? "" : layers);
    std::string item;
    while (std::getline(list, item, ',')) {
      texfree::server::RegistrationLayer layer;
      char grouping[16] = "";
      if (std::sscanf(item.c_str(), "%lf:%lf:%15s", &layer.scale, &layer.blur_sigma, grouping) <
          2) {
        std::fprintf(stderr, "--layers: cannot parse '%s'\n", item.c_str());
        return 1;
      }
      if (std::string(grouping) == "closing")
        layer.keypoints = texfree::server::DefaultFallbackKeypointOptions()[0];
      registry_options.registration_layers.push_back(layer);
    }
  }
  if (std::sscanf(view_scale.c_str(), "%lf:%lf", &view_range.min_scale, &view_range.max_scale) !=
          2 ||
      !(view_range.min_scale > 0.05 && view_range.min_scale <= view_range.max_scale &&
        view_range.max_scale <= 5)) {
    std::fprintf(stderr, "--view-scale: expected MIN:MAX with 0.05 < MIN <= MAX <= 5, got %s\n",
                 view_scale.c_str());
    return 1;
  }
  texfree::testdata::PageOptions page_options;
  page_options.width = page_width;
  page_options.height = static_cast<int>(std::lround(page_width * 1.414));
  if (auto set = texfree::testdata::AvailableFontSet(fonts); set.ok()) {
    page_options.fonts = *set;
  } else {
    std::fprintf(stderr, "--fonts: %s\n", set.status().ToString().c_str());
    return 1;
  }
  if (no_rectify) registry_options.retrieval.rectify_perspective = false;
  if (line_closing) std::swap(registry_options.keypoints, registry_options.fallback_keypoints[0]);
  if (no_similarity_start) registry_options.retrieval.guided_similarity_start = false;
  if (no_polish) registry_options.retrieval.polish_homography = false;
  if (no_fallback) registry_options.fallback_keypoints.clear();
  if (no_line_refinement) registry_options.retrieval.refine_perspective = false;
  if (no_rectified_picture) registry_options.rectified_picture_retry = false;
  if (no_picture_after_weak) registry_options.rectified_picture_after_weak = false;
  if (no_picture_fallbacks) registry_options.rectified_picture_fallbacks = false;
  if (no_picture_projective) registry_options.rectified_picture_projective = false;
  if (picture_max_keypoints >= 0)
    registry_options.rectified_picture_max_keypoints = picture_max_keypoints;
  if (refine_max_keypoints >= 0)
    registry_options.retrieval.refine_max_keypoints = refine_max_keypoints;
  spdlog::set_level(spdlog::level::warn);
  cv::setNumThreads(1);  // one core per query, as the targets count it (and CPU time is exact)
  std::sort(checkpoints.begin(), checkpoints.end());

  if (!keep) fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string db = dir + "/texfree.db";
  texfree::ImageLimits limits;

  auto open = [&]() {
    auto store = DocumentStore::Open(db);
    if (!store.ok()) {
      std::fprintf(stderr, "%s\n", store.status().ToString().c_str());
      std::exit(1);
    }
    auto registry = DocumentRegistry::Open(std::move(*store), registry_options);
    if (!registry.ok()) {
      std::fprintf(stderr, "%s\n", registry.status().ToString().c_str());
      std::exit(1);
    }
    return std::move(*registry);
  };

  // Page n as it is registered: rendered, grey, scaled by --register-scale.
  const auto registration_image = [&](int n) {
    const auto page = texfree::testdata::RenderTextPage(n, page_options);
    cv::Mat gray;
    cv::cvtColor(page.image, gray, cv::COLOR_BGR2GRAY);
    if (register_scale != 1.0)
      cv::resize(gray, gray, cv::Size(), register_scale, register_scale, cv::INTER_AREA);
    return gray;
  };
  auto registry = open();
  int registered = static_cast<int>(*registry->Count());
  std::vector<std::string> ids;
  std::printf(
      "| pages | top-1 | H err px (median) | false matches | median ms | p95 ms | median CPU ms "
      "| p95 CPU ms | index MiB | RSS MiB | start-up s | register ms/page |\n");
  std::printf("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
  // Ground truth in registered-image pixels.
  auto registered_frame = [&](std::vector<Query> queries) {
    const cv::Matx33d to_page(1 / register_scale, 0, 0, 0, 1 / register_scale, 0, 0, 0, 1);
    for (Query &q : queries) {
      q.truth = q.truth * to_page;
      q.page_to_registered = to_page.inv();
    }
    return queries;
  };
  const uint64_t view_set_offset = kViewSetStride * view_set;
  const auto unregistered_queries =
      MakeQueries(unregistered, 1, 99 + view_set_offset, true, page_options, view_range);
  for (int target : checkpoints) {
    const auto t_reg = Clock::now();
    const int before = registered;
    // Pages are numbered by seed, so titles (and the views drawn from them) do not depend
    // on which thread registered a page first.
    std::atomic<int> next_page{registered};
    std::atomic<int> done{0};
    auto register_pages = [&]() {
      for (int n = next_page++; n < target; n = next_page++) {
        auto record = registry->Register(registration_image(n), "page " + std::to_string(n), {});
        if (!record.ok())
          std::fprintf(stderr, "register page %d: %s\n", n, record.status().ToString().c_str());
        const int d = ++done;
        if ((before + d) % 500 == 0)
          std::fprintf(stderr, "registered %d (%.1f ms a page)\n", before + d,
                       texfree::MillisecondsSince(t_reg) / d);
      }
    };
    std::vector<std::thread> workers;
    for (int t = 1; t < register_threads; ++t) workers.emplace_back(register_pages);
    register_pages();
    for (std::thread &w : workers) w.join();
    registered = std::max(registered, target);
    const double reg_ms =
        registered > before ? texfree::MillisecondsSince(t_reg) / (registered - before) : 0;

    // Start-up: reopen the database and rebuild the index.
    registry.reset();
    const auto t_open = Clock::now();
    registry = open();
    const double startup_s = texfree::MillisecondsSince(t_open) / 1000.0;

    // Titles map back to page numbers.
    std::vector<std::string> id_of_page(registered);
    std::vector<uint32_t> index_of_page(registered, 0);
    uint32_t after = 0;
    while (true) {
      auto page = registry->List(after, 1000);
      if (!page.ok() || page->empty()) break;
      for (const auto &d : *page) {
        const int n = std::stoi(d.title.substr(5));
        if (n < registered) {
          id_of_page[n] = d.id;
          index_of_page[n] = d.index_id;
        }
        after = d.index_id;
      }
    }

    const auto queries_now = registered_frame(
        query_pages > 0 ? MakeQueries(queries, std::min(query_pages, registered),
                                      1234 + view_set_offset, false, page_options, view_range)
                        : MakeQueries(queries, registered, 1234 + target + view_set_offset, false,
                                      page_options, view_range));
    std::vector<double> times, cpu_times, errors;
    const auto report_slow = [&](const Query &q,
                                 const absl::StatusOr<texfree::server::RetrievalResult> &result,
                                 double ms) {
      if (!(slow_ms > 0 && ms > slow_ms && result.ok())) return;
      std::string stages;
      for (const auto &[stage, stage_ms] : result->timings.stages)
        stages += " " + stage + " " + std::to_string(static_cast<int>(stage_ms)) + " ms";
      std::fprintf(stderr, "slow query, page %d: %.0f ms (%d keypoints):%s\n", q.page, ms,
                   result->query_keypoints, stages.c_str());
    };
    std::map<std::string, double> stage_ms;
    int correct = 0, false_matches = 0;
    // Top-1 by how many of the page's registered words the view shows: a view of a figure
    // or a margin shows too few for any text descriptor (LLAH needs n + 1 words around each).
    const std::vector<int> word_bins{0, 20, 50, 100};
    std::vector<int> bin_views(word_bins.size(), 0), bin_correct(word_bins.size(), 0);
    for (const Query &q : queries_now) {
      int words_in_view = 0;
      for (const cv::Point2f &r : registry->retriever()->Keypoints(index_of_page[q.page])) {
        const cv::Point2d v = texfree::ApplyHomography(q.truth, cv::Point2d(r.x, r.y));
        if (v.x >= 0 && v.y >= 0 && v.x < q.view.image_size.width && v.y < q.view.image_size.height)
          ++words_in_view;
      }
      size_t bin = 0;
      while (bin + 1 < word_bins.size() && words_in_view >= word_bins[bin + 1]) ++bin;
      ++bin_views[bin];
      const int correct_before = correct;
      const auto t0 = Clock::now();
      const double c0 = texfree::ThreadCpuMilliseconds();
      auto gray = texfree::DecodeImage(q.jpeg, limits);
      auto result = registry->Retrieve(*gray, std::nullopt, 0);
      times.push_back(texfree::MillisecondsSince(t0));
      cpu_times.push_back(texfree::ThreadCpuMilliseconds() - c0);
      if (result.ok())
        for (const auto &[stage, ms] : result->timings.stages) stage_ms[stage] += ms;
      report_slow(q, result, times.back());
      if (result.ok() && !result->documents.empty() &&
          result->documents[0].document.id == id_of_page[q.page]) {
        const double err = texfree::testdata::MeanProjectionError(
            result->documents[0].homography * q.page_to_registered, q.camera, q.view, q.page_size);
        errors.push_back(err);
        if (err < 10) {
          ++correct;
        } else if (misses) {
          // The view's draws to the last digit (a test can render it again).
          std::fprintf(stderr,
                       "off page %d: found, but %.1f px off (render seed %llu, JPEG %d, fov "
                       "%.17g tilt %.17g azimuth %.17g roll %.17g scale %.17g look-at %.17g,%.17g "
                       "blur %.17g noise %.17g light %.17g desk %.17g,%.17g,%.17g curl %.3f k1 "
                       "%+.3f)\n",
                       q.page, err, static_cast<unsigned long long>(q.render_seed), q.jpeg_quality,
                       q.view.horizontal_fov_deg, q.view.tilt_deg, q.view.tilt_azimuth_deg,
                       q.view.roll_deg, q.view.scale, q.view.look_at.x, q.view.look_at.y,
                       q.view.blur_sigma, q.view.noise_sigma, q.view.illumination_gradient,
                       q.view.background[0], q.view.background[1], q.view.background[2],
                       q.view.page_curl, q.view.radial_k1);
          if (!save_misses.empty())
            cv::imwrite(save_misses + "/off_page" + std::to_string(q.page) + ".png", *gray);
        }
      } else if (misses || true_rectification) {
        if (true_rectification) PrintTrueRectification(*registry, q, *gray, id_of_page[q.page]);
        if (misses)
          PrintMiss(*registry, q, *gray, id_of_page[q.page], result.ok() ? &*result : nullptr,
                    save_misses.empty()
                        ? std::string()
                        : save_misses + "/figures_page" + std::to_string(q.page) + ".png");
        if (!save_misses.empty())
          cv::imwrite(save_misses + "/miss_page" + std::to_string(q.page) + ".png", *gray);
      }
      if (result.ok()) {
        for (const auto &d : result->documents)
          if (d.document.id != id_of_page[q.page]) {
            ++false_matches;
            std::fprintf(stderr, "wrong page for the view of page %d: %s (%d inliers)\n", q.page,
                         d.document.title.c_str(), d.inliers);
          }
      }
      bin_correct[bin] += correct - correct_before;
    }
    std::fprintf(stderr, "top-1 by registered words in view:");
    for (size_t b = 0; b < word_bins.size(); ++b) {
      std::fprintf(
          stderr, "  %d%s: %d/%d", word_bins[b],
          b + 1 < word_bins.size() ? ("-" + std::to_string(word_bins[b + 1] - 1)).c_str() : "+",
          bin_correct[b], bin_views[b]);
    }
    std::fprintf(stderr, "\n");
    int unreg_false = 0;
    std::vector<double> unreg_cpu_times;
    for (const Query &q : unregistered_queries) {
      const auto t0 = Clock::now();
      const double c0 = texfree::ThreadCpuMilliseconds();
      auto gray = texfree::DecodeImage(q.jpeg, limits);
      auto result = registry->Retrieve(*gray, std::nullopt, 0);
      times.push_back(texfree::MillisecondsSince(t0));
      cpu_times.push_back(texfree::ThreadCpuMilliseconds() - c0);
      unreg_cpu_times.push_back(cpu_times.back());
      report_slow(q, result, times.back());
      if (result.ok()) {
        unreg_false += static_cast<int>(result->documents.size());
        for (const auto &d : result->documents)
          std::fprintf(stderr,
                       "false match: unregistered view %d (tilt %.0f scale %.2f) found \"%s\" "
                       "with %d inliers, %d votes (%d keypoints in the view)\n",
                       static_cast<int>(&q - unregistered_queries.data()), q.view.tilt_deg,
                       q.view.scale, d.document.title.c_str(), d.inliers, d.votes,
                       result->query_keypoints);
      }
    }
    // Views of unregistered pages take every fallback and last try: their own figures.
    const std::vector<double> reg_cpu_times(cpu_times.begin(),
                                            cpu_times.begin() + queries_now.size());
    std::fprintf(stderr,
                 "CPU ms median / p95: views of registered pages %.1f / %.1f, of unregistered "
                 "pages %.1f / %.1f\n",
                 Percentile(reg_cpu_times, 0.5), Percentile(reg_cpu_times, 0.95),
                 Percentile(unreg_cpu_times, 0.5), Percentile(unreg_cpu_times, 0.95));
    std::printf(
        "| %d | %.1f%% (%d/%d) | %.2f | %d of %d unregistered (+%d "
        "wrong) | %.1f | %.1f | %.1f | %.1f | %.0f | "
        "%.0f | %.2f | %.1f |\n",
        registered, 100.0 * correct / queries_now.size(), correct,
        static_cast<int>(queries_now.size()), Percentile(errors, 0.5), unreg_false,
        static_cast<int>(unregistered_queries.size()), false_matches, Percentile(times, 0.5),
        Percentile(times, 0.95), Percentile(cpu_times, 0.5), Percentile(cpu_times, 0.95),
        registry->index_memory_bytes() / 1048576.0, RssKiB() / 1024.0, startup_s, reg_ms);
    std::string stages;
    for (const auto &[stage, ms] : stage_ms)
      stages += stage + " " + std::to_string(ms / queries_now.size()).substr(0, 5) + " ms  ";
    std::fprintf(stderr, "mean stage times (registered-page queries): %s\n", stages.c_str());
    if (measure_delete > 0) {
      std::vector<double> delete_ms, reregister_ms;
      int refused = 0;
      for (int k = 0; k < measure_delete && k < registered; ++k) {
        const int p = static_cast<int>((static_cast<int64_t>(k) * 7919 + 13) % registered);
        if (id_of_page[p].empty()) continue;
        const auto t_delete = Clock::now();
        const absl::Status deleted = registry->Delete(id_of_page[p]);
        delete_ms.push_back(texfree::MillisecondsSince(t_delete));
        if (!deleted.ok()) {
          std::fprintf(stderr, "delete page %d: %s\n", p, deleted.ToString().c_str());
          continue;
        }
        const cv::Mat gray = registration_image(p);
        const auto t_register = Clock::now();
        auto record = registry->Register(gray, "page " + std::to_string(p), {});
        reregister_ms.push_back(texfree::MillisecondsSince(t_register));
        if (!record.ok()) {
          ++refused;
          std::fprintf(stderr, "register page %d again: %s\n", p,
                       record.status().ToString().c_str());
        } else {
          id_of_page[p] = record->id;
        }
      }
      std::printf(
          "delete: %zu pages, median %.1f ms, max %.1f ms; registered again: median %.1f ms, "
          "%d refused\n",
          delete_ms.size(), Percentile(delete_ms, 0.5), Percentile(delete_ms, 1.0),
          Percentile(reregister_ms, 0.5), refused);
    }
    std::fflush(stdout);
  }
  return 0;
}
