// LetterKeypointExtractor implementation.
#include "common/letter_keypoints.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <opencv2/imgproc.hpp>

#include "absl/strings/str_cat.h"
#include "common/connected_components.h"
#include "common/neighbor_grid.h"
#include "common/word_keypoints.h"

namespace texfree {

absl::Status LetterKeypointOptions::Validate() const {
  auto bad = [](const std::string &what) { return absl::InvalidArgumentError(what); };
  if (!(ink_window_share > 0 && ink_window_share <= 1))
    return bad(absl::StrCat("ink_window_share must be in (0, 1], got ", ink_window_share));
  if (!(threshold_offset >= 0 && threshold_offset < 255))
    return bad(absl::StrCat("threshold_offset must be in [0, 255), got ", threshold_offset));
  if (!(min_letter_px >= 2))
    return bad(absl::StrCat("min_letter_px must be >= 2, got ", min_letter_px));
  if (!(max_letter_share > 0 && max_letter_share <= 1))
    return bad(absl::StrCat("max_letter_share must be in (0, 1], got ", max_letter_share));
  if (!(min_fill >= 0 && min_fill < 1))
    return bad(absl::StrCat("min_fill must be in [0, 1), got ", min_fill));
  if (!(max_aspect >= 1)) return bad(absl::StrCat("max_aspect must be >= 1, got ", max_aspect));
  if (!(neighbour_reach > 0))
    return bad(absl::StrCat("neighbour_reach must be > 0, got ", neighbour_reach));
  if (size_neighbours < 0 || size_neighbours > 32)
    return bad(absl::StrCat("size_neighbours must be in [0, 32], got ", size_neighbours));
  if (!(min_size_ratio >= 0 && min_size_ratio < 1))
    return bad(absl::StrCat("min_size_ratio must be in [0, 1), got ", min_size_ratio));
  if (max_keypoints < 1)
    return bad(absl::StrCat("max_keypoints must be >= 1, got ", max_keypoints));
  return absl::OkStatus();
}

LetterKeypointExtractor::LetterKeypointExtractor(LetterKeypointOptions options)
    : options_(std::move(options)) {}

LetterKeypoints LetterKeypointExtractor::Extract(const cv::Mat &gray, double min_type_px) const {
  CV_Assert(gray.empty() || gray.type() == CV_8UC1);
  const LetterKeypointOptions &o = options_;
  LetterKeypoints out;
  const int shorter = std::min(gray.cols, gray.rows);
  if (shorter < 16) return out;
  const int block = std::max(15, static_cast<int>(std::lround(shorter * o.ink_window_share))) | 1;
  const cv::Mat ink = InkMask(gray, block, o.threshold_offset);
  cv::Mat labels, stats, centroids;
  const int n = ConnectedComponentsWithStats(ink, 8, &labels, &stats, &centroids);
  const double max_size = o.max_letter_share * shorter;
  std::vector<cv::Point2f> points;
  std::vector<float> sizes;
  for (int i = 1; i < n; ++i) {
    const int x = stats.at<int>(i, cv::CC_STAT_LEFT), y = stats.at<int>(i, cv::CC_STAT_TOP);
    const int w = stats.at<int>(i, cv::CC_STAT_WIDTH), h = stats.at<int>(i, cv::CC_STAT_HEIGHT);
    const int area = stats.at<int>(i, cv::CC_STAT_AREA);
    // A letter cut by the frame has its centroid moved with it.
    if (x <= 1 || y <= 1 || x + w >= gray.cols - 1 || y + h >= gray.rows - 1) continue;
    const int size = std::max(w, h);
    if (size < o.min_letter_px * o.min_size_ratio || size > max_size) continue;
    if (area < o.min_fill * w * h) continue;
    if (size > o.max_aspect * std::max(1, std::min(w, h))) continue;
    points.emplace_back(static_cast<float>(centroids.at<double>(i, 0)),
                        static_cast<float>(centroids.at<double>(i, 1)));
    sizes.push_back(static_cast<float>(size));
  }
  if (points.empty()) return out;

  // Each component's type size: the median over itself and its nearest components within
  // reach (a heading's letters are farther apart than the body text below is from them).
  std::vector<float> type(points.size());
  const NeighborGrid grid(points);
  std::vector<int> near;
  std::vector<float> local;
  for (size_t i = 0; i < points.size(); ++i) {
    local.assign(1, sizes[i]);
    if (o.size_neighbours > 0 && points.size() > 1) {
      grid.Nearest(static_cast<int>(i),
                   std::min<int>(o.size_neighbours, static_cast<int>(points.size()) - 1), &near);
      const double reach = o.neighbour_reach * sizes[i];
      for (int j : near)
        if (std::hypot(points[j].x - points[i].x, points[j].y - points[i].y) <= reach)
          local.push_back(sizes[j]);
    }
    std::nth_element(local.begin(), local.begin() + local.size() / 2, local.end());
    type[i] = local[local.size() / 2];
  }
  const double floor = std::max(o.min_letter_px, min_type_px);
  std::vector<size_t> kept;
  for (size_t i = 0; i < points.size(); ++i)
    if (type[i] >= floor && sizes[i] >= o.min_size_ratio * type[i]) kept.push_back(i);
  if (kept.size() > static_cast<size_t>(o.max_keypoints)) {
    std::stable_sort(kept.begin(), kept.end(),
                     [&](size_t a, size_t b) { return type[a] > type[b]; });
    kept.resize(static_cast<size_t>(o.max_keypoints));
    std::sort(kept.begin(), kept.end());
  }
  std::vector<float> kept_types;
  for (size_t i : kept) {
    out.points.push_back(points[i]);
    kept_types.push_back(type[i]);
  }
  if (!kept_types.empty()) {
    std::nth_element(kept_types.begin(), kept_types.begin() + kept_types.size() / 2,
                     kept_types.end());
    out.letter_size = kept_types[kept_types.size() / 2];
  }
  return out;
}

}  // namespace texfree
