// FigureKeypointExtractor implementation.
#include "common/figure_keypoints.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "absl/strings/str_cat.h"
#include "common/connected_components.h"
#include "common/word_keypoints.h"

namespace texfree {

absl::Status FigureKeypointOptions::Validate() const {
  auto bad = [](const std::string &what) { return absl::InvalidArgumentError(what); };
  if (!(ink_window_share > 0 && ink_window_share <= 1))
    return bad(absl::StrCat("ink_window_share must be in (0, 1], got ", ink_window_share));
  if (!(threshold_offset >= 0 && threshold_offset < 255))
    return bad(absl::StrCat("threshold_offset must be in [0, 255), got ", threshold_offset));
  if (!(min_extent_px >= 0) || !(min_extent_chars >= 0))
    return bad("min_extent_px and min_extent_chars must be >= 0");
  if (!(text_exclusion_chars >= 0)) return bad("text_exclusion_chars must be >= 0");
  if (!(smoothing_sigma >= 0 && smoothing_sigma <= 10))
    return bad(absl::StrCat("smoothing_sigma must be in [0, 10], got ", smoothing_sigma));
  if (block_size < 3 || block_size > 31 || block_size % 2 == 0)
    return bad(absl::StrCat("block_size must be odd and in [3, 31], got ", block_size));
  if (!(min_quality >= 0 && min_quality < 1))
    return bad(absl::StrCat("min_quality must be in [0, 1), got ", min_quality));
  if (!(min_eigenvalue >= 0)) return bad("min_eigenvalue must be >= 0");
  if (!(min_distance_px >= 1))
    return bad(absl::StrCat("min_distance_px must be >= 1, got ", min_distance_px));
  if (!(centroid_max_blob_px >= 0))
    return bad(absl::StrCat("centroid_max_blob_px must be >= 0, got ", centroid_max_blob_px));
  if (!(border_margin_px >= 0)) return bad("border_margin_px must be >= 0");
  if (max_keypoints < 1)
    return bad(absl::StrCat("max_keypoints must be >= 1, got ", max_keypoints));
  return absl::OkStatus();
}

FigureKeypointExtractor::FigureKeypointExtractor(FigureKeypointOptions options)
    : options_(std::move(options)) {}

std::vector<cv::Point2f> FigureKeypointExtractor::Extract(const cv::Mat &gray,
                                                          const std::vector<cv::Point2f> &words,
                                                          double char_height) const {
  CV_Assert(gray.empty() || gray.type() == CV_8UC1);
  const FigureKeypointOptions &o = options_;
  std::vector<cv::Point2f> corners;
  const int margin = static_cast<int>(std::ceil(o.border_margin_px));
  if (gray.cols <= 2 * margin + o.block_size || gray.rows <= 2 * margin + o.block_size)
    return corners;
  // A new image: blurring into a header of `gray` would blur the caller's picture.
  cv::Mat smooth;
  if (o.smoothing_sigma > 0) {
    cv::GaussianBlur(gray, smooth, cv::Size(0, 0), o.smoothing_sigma);
  } else {
    smooth = gray;
  }

  // Figure ink: components too large to be letters or words.
  const int block =
      std::max(15,
               static_cast<int>(std::lround(std::min(gray.cols, gray.rows) * o.ink_window_share))) |
      1;
  const cv::Mat ink = InkMask(smooth, block, o.threshold_offset);
  cv::Mat labels, stats, centroids;
  const int n = ConnectedComponentsWithStats(ink, 8, &labels, &stats, &centroids);
  const double extent = std::max(o.min_extent_px, o.min_extent_chars * std::max(0.0, char_height));
  std::vector<uint8_t> figure(n, 0);
  bool any = false;
  for (int i = 1; i < n; ++i) {
    const int w = stats.at<int>(i, cv::CC_STAT_WIDTH), h = stats.at<int>(i, cv::CC_STAT_HEIGHT);
    if (std::max(w, h) >= extent) figure[i] = any = 255;
  }
  if (!any) return corners;
  cv::Mat mask(gray.size(), CV_8UC1);
  for (int y = 0; y < gray.rows; ++y) {
    const int *l = labels.ptr<int>(y);
    uint8_t *m = mask.ptr<uint8_t>(y);
    for (int x = 0; x < gray.cols; ++x) m[x] = figure[l[x]];
  }
  // A corner's response peaks beside the ink too (a bar's corner on the paper side).
  const int grow = o.block_size / 2 + 1;
  cv::dilate(mask, mask, cv::getStructuringElement(cv::MORPH_RECT, {2 * grow + 1, 2 * grow + 1}));
  if (char_height > 0 && o.text_exclusion_chars > 0) {
    const int radius = static_cast<int>(std::lround(o.text_exclusion_chars * char_height));
    for (const cv::Point2f &w : words)
      cv::circle(mask, cv::Point(cvRound(w.x), cvRound(w.y)), radius, cv::Scalar(0), cv::FILLED);
  }
  mask.rowRange(0, margin).setTo(0);
  mask.rowRange(gray.rows - margin, gray.rows).setTo(0);
  mask.colRange(0, margin).setTo(0);
  mask.colRange(gray.cols - margin, gray.cols).setTo(0);

  cv::Mat eigen;
  cv::cornerMinEigenVal(smooth, eigen, o.block_size, 3);
  // OpenCV scales the 8-bit gradients to 1 per 255 levels and 1/8 of Sobel's sum; undo it so
  // that min_eigenvalue is in grey levels^2 per pixel^2.
  eigen *= 255.0 * 255.0 * 16.0;
  double strongest = 0;
  cv::minMaxLoc(eigen, nullptr, &strongest, nullptr, nullptr, mask);
  const double floor = std::max(o.min_eigenvalue, o.min_quality * strongest);
  if (strongest < floor) return corners;

  // Candidates, strongest first, then spaced min_distance_px apart (cv::goodFeaturesToTrack's
  // selection, which takes only a floor relative to the strongest corner and would compute
  // the eigenvalue map a second time for the absolute one):
  // - each blob of cornerness (connected pixels above the floor) at most
  //   centroid_max_blob_px across gives its centroid, weighted by the eigenvalue;
  // - the pixels of larger blobs give their local maxima (3x3), refined to sub-pixel.
  cv::Mat dilated;
  cv::dilate(eigen, dilated, cv::Mat());
  struct Candidate {
    float value;
    cv::Point2f p;
    bool centroid;  // a blob's centroid (sub-pixel already), else a local maximum
  };
  std::vector<Candidate> candidates;
  cv::Mat above = (eigen >= floor) & mask;
  std::vector<uint8_t> small_blob;
  std::vector<cv::Vec4d> moments;  // per blob: sum e, sum e x, sum e y, max e
  cv::Mat blob_labels;
  if (o.centroid_max_blob_px > 0) {
    cv::Mat blob_stats, blob_centroids;
    const int blobs =
        ConnectedComponentsWithStats(above, 8, &blob_labels, &blob_stats, &blob_centroids);
    small_blob.assign(blobs, 0);
    moments.assign(blobs, cv::Vec4d(0, 0, 0, 0));
    for (int b = 1; b < blobs; ++b)
      small_blob[b] = std::max(blob_stats.at<int>(b, cv::CC_STAT_WIDTH),
                               blob_stats.at<int>(b, cv::CC_STAT_HEIGHT)) <= o.centroid_max_blob_px;
  }
  for (int y = margin; y < gray.rows - margin; ++y) {
    const float *e = eigen.ptr<float>(y);
    const float *d = dilated.ptr<float>(y);
    const uint8_t *a = above.ptr<uint8_t>(y);
    const int *b = blob_labels.empty() ? nullptr : blob_labels.ptr<int>(y);
    for (int x = margin; x < gray.cols - margin; ++x) {
      if (!a[x]) continue;
      if (b != nullptr && small_blob[b[x]]) {
        cv::Vec4d &mo = moments[b[x]];
        mo[0] += e[x];
        mo[1] += static_cast<double>(e[x]) * x;
        mo[2] += static_cast<double>(e[x]) * y;
        mo[3] = std::max<double>(mo[3], e[x]);
      } else if (e[x] == d[x]) {
        candidates.push_back(
            {e[x], cv::Point2f(static_cast<float>(x), static_cast<float>(y)), false});
      }
    }
  }
  for (size_t b = 1; b < moments.size(); ++b)
    if (small_blob[b] && moments[b][0] > 0)
      candidates.push_back({static_cast<float>(moments[b][3]),
                            cv::Point2f(static_cast<float>(moments[b][1] / moments[b][0]),
                                        static_cast<float>(moments[b][2] / moments[b][0])),
                            true});
  std::sort(candidates.begin(), candidates.end(),
            [](const Candidate &a, const Candidate &b) { return a.value > b.value; });
  // Spacing through a coarse grid of cells min_distance_px wide.
  const double r2 = o.min_distance_px * o.min_distance_px;
  const int cell = std::max(1, static_cast<int>(std::ceil(o.min_distance_px)));
  const int gw = gray.cols / cell + 1, gh = gray.rows / cell + 1;
  std::vector<std::vector<cv::Point2f>> grid(static_cast<size_t>(gw) * gh);
  std::vector<char> refine;  // local maxima are refined to sub-pixel
  for (const Candidate &c : candidates) {
    const int gx = static_cast<int>(c.p.x) / cell, gy = static_cast<int>(c.p.y) / cell;
    bool free = true;
    for (int yy = std::max(0, gy - 1); free && yy <= std::min(gh - 1, gy + 1); ++yy)
      for (int xx = std::max(0, gx - 1); free && xx <= std::min(gw - 1, gx + 1); ++xx)
        for (const cv::Point2f &q : grid[static_cast<size_t>(yy) * gw + xx]) {
          const double dx = q.x - c.p.x, dy = q.y - c.p.y;
          if (dx * dx + dy * dy < r2) {
            free = false;
            break;
          }
        }
    if (!free) continue;
    grid[static_cast<size_t>(gy) * gw + gx].push_back(c.p);
    corners.push_back(c.p);
    refine.push_back(!c.centroid);
    if (static_cast<int>(corners.size()) >= o.max_keypoints) break;
  }
  if (!corners.empty()) {
    const int win = std::max(2, o.block_size / 2);
    std::vector<cv::Point2f> refined = corners;
    cv::cornerSubPix(smooth, refined, {win, win}, {-1, -1},
                     cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 20, 0.03));
    // A weak or rounded corner can drift along an edge; such a refinement is not kept.
    for (size_t i = 0; i < corners.size(); ++i)
      if (refine[i] && cv::norm(refined[i] - corners[i]) <= win) corners[i] = refined[i];
  }
  return corners;
}

}  // namespace texfree
