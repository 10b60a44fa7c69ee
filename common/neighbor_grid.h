// NeighborGrid: k-nearest-neighbour queries over 2D keypoints through a uniform grid
// of square cells (seed 3.1.2), so that collecting neighbours costs O(k) instead of O(N).
#pragma once

#include <vector>

#include <opencv2/core.hpp>

namespace texfree {

// Immutable after construction; concurrent queries are safe.
class NeighborGrid {
 public:
  // Cell size is chosen so that a cell holds about `points_per_cell` points on average.
  explicit NeighborGrid(const std::vector<cv::Point2f>& points, double points_per_cell = 2.0);

  // Indices of the k points nearest to points[index] (excluding itself), nearest first.
  // Fewer than k when the set is smaller. Rings of cells are searched outward until no
  // unvisited cell can hold a point closer than the current k-th.
  void Nearest(int index, int k, std::vector<int>* out) const;

  // Indices of the k points nearest to an arbitrary location, nearest first.
  void NearestTo(const cv::Point2f& p, int k, int exclude, std::vector<int>* out) const;

  double cell_size() const { return cell_; }

 private:
  const std::vector<cv::Point2f>& points_;
  cv::Point2f origin_;
  double cell_ = 1.0;
  int cols_ = 1, rows_ = 1;
  std::vector<int> cell_start_;  // CSR layout: points of cell c are order_[start[c]..start[c+1])
  std::vector<int> order_;
};

}  // namespace texfree
