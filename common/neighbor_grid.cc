// NeighborGrid implementation: CSR buckets and ring-by-ring search.
#include "common/neighbor_grid.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

namespace texfree {

NeighborGrid::NeighborGrid(const std::vector<cv::Point2f>& points, double points_per_cell)
    : points_(points) {
  if (points.empty()) {
    cell_start_.assign(2, 0);
    return;
  }
  float min_x = points[0].x, max_x = points[0].x, min_y = points[0].y, max_y = points[0].y;
  for (const auto& p : points) {
    min_x = std::min(min_x, p.x);
    max_x = std::max(max_x, p.x);
    min_y = std::min(min_y, p.y);
    max_y = std::max(max_y, p.y);
  }
  origin_ = {min_x, min_y};
  const double w = std::max(1.0f, max_x - min_x), h = std::max(1.0f, max_y - min_y);
  cell_ = std::max(1e-3, std::sqrt(w * h * points_per_cell / points.size()));
  cols_ = std::min(4096, static_cast<int>(w / cell_) + 1);
  rows_ = std::min(4096, static_cast<int>(h / cell_) + 1);
  std::vector<int> cell_of(points.size());
  cell_start_.assign(static_cast<size_t>(cols_) * rows_ + 1, 0);
  for (size_t i = 0; i < points.size(); ++i) {
    const int cx = std::min(cols_ - 1, static_cast<int>((points[i].x - origin_.x) / cell_));
    const int cy = std::min(rows_ - 1, static_cast<int>((points[i].y - origin_.y) / cell_));
    cell_of[i] = cy * cols_ + cx;
    ++cell_start_[cell_of[i] + 1];
  }
  for (size_t c = 1; c < cell_start_.size(); ++c) cell_start_[c] += cell_start_[c - 1];
  order_.resize(points.size());
  std::vector<int> fill(cell_start_.begin(), cell_start_.end() - 1);
  for (size_t i = 0; i < points.size(); ++i) order_[fill[cell_of[i]]++] = static_cast<int>(i);
}

void NeighborGrid::Nearest(int index, int k, std::vector<int>* out) const {
  NearestTo(points_[index], k, index, out);
}

void NeighborGrid::NearestTo(const cv::Point2f& p, int k, int exclude,
                             std::vector<int>* out) const {
  out->clear();
  if (points_.empty() || k <= 0) return;
  // Small max-heap of (squared distance, index) holding the best k so far; per-thread
  // scratch, as extraction, describing and verification call this thousands of times a query.
  thread_local std::vector<std::pair<float, int>> best;
  best.clear();
  const int cx = std::clamp(static_cast<int>((p.x - origin_.x) / cell_), 0, cols_ - 1);
  const int cy = std::clamp(static_cast<int>((p.y - origin_.y) / cell_), 0, rows_ - 1);
  const int max_ring = std::max(cols_, rows_);
  auto visit = [&](int x, int y) {
    if (x < 0 || y < 0 || x >= cols_ || y >= rows_) return;
    const int c = y * cols_ + x;
    for (int j = cell_start_[c]; j < cell_start_[c + 1]; ++j) {
      const int i = order_[j];
      if (i == exclude) continue;
      const float dx = points_[i].x - p.x, dy = points_[i].y - p.y;
      const float d2 = dx * dx + dy * dy;
      if (static_cast<int>(best.size()) < k) {
        best.emplace_back(d2, i);
        std::push_heap(best.begin(), best.end());
      } else if (d2 < best.front().first) {
        std::pop_heap(best.begin(), best.end());
        best.back() = {d2, i};
        std::push_heap(best.begin(), best.end());
      }
    }
  };
  for (int r = 0; r <= max_ring; ++r) {
    if (r == 0) {
      visit(cx, cy);
    } else {
      for (int x = cx - r; x <= cx + r; ++x) {
        visit(x, cy - r);
        visit(x, cy + r);
      }
      for (int y = cy - r + 1; y <= cy + r - 1; ++y) {
        visit(cx - r, y);
        visit(cx + r, y);
      }
    }
    // Any point not yet visited lies outside the square of cells searched so far, beyond
    // one of its sides that has cells behind it: at least as far from p as the nearest such
    // side (r cells or more; a side at the grid's edge has nothing behind it).
    if (static_cast<int>(best.size()) == k) {
      constexpr double kNothing = std::numeric_limits<double>::infinity();
      const double left = cx - r > 0 ? p.x - (origin_.x + (cx - r) * cell_) : kNothing;
      const double right = cx + r < cols_ - 1 ? origin_.x + (cx + r + 1) * cell_ - p.x : kNothing;
      const double top = cy - r > 0 ? p.y - (origin_.y + (cy - r) * cell_) : kNothing;
      const double bottom = cy + r < rows_ - 1 ? origin_.y + (cy + r + 1) * cell_ - p.y : kNothing;
      const double reach = std::min(std::min(left, right), std::min(top, bottom));
      if (reach * reach >= best.front().first) break;
    }
  }
  std::sort_heap(best.begin(), best.end());
  out->reserve(best.size());
  for (const auto& [d2, i] : best) out->push_back(i);
}

}  // namespace texfree
