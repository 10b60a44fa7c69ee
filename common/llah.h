// LLAH descriptors (seed 2.3): for each keypoint, its n nearest neighbours
// ordered by angle, every m-subset of them, and for every 4-subset of those an
// affine invariant (ratio of two triangle areas), quantised into k levels with
// thresholds learned from data. Each m-subset gives one descriptor, made
// independent of the cyclic start point by taking the lexicographically
// smallest of its m rotations, and hashed to 64 bits.
#pragma once

#include <array>
#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "common/neighbor_grid.h"

namespace texfree {

struct LlahOptions {
  // Neighbours per keypoint. More neighbours tolerate more keypoints appearing
  // or vanishing between views, at C(n, m) descriptors per keypoint.
  int n = 7;
  // Neighbours per descriptor: C(m, 4) invariants per descriptor.
  int m = 6;
  // Quantisation levels per invariant.
  int k = 8;

  absl::Status Validate() const;
  int DescriptorsPerPoint() const;      // C(n, m)
  int InvariantsPerDescriptor() const;  // C(m, 4)
};

// Maps an invariant value to one of k levels with k-1 learned thresholds,
// placed at the quantiles of training samples so that every level is used
// equally often.
class InvariantQuantizer {
 public:
  InvariantQuantizer() = default;
  explicit InvariantQuantizer(std::vector<float> thresholds) : thresholds_(std::move(thresholds)) {}

  // Learns k-1 thresholds from samples (needs at least 50 * k samples).
  static absl::StatusOr<InvariantQuantizer> Learn(std::vector<float> samples, int k);

  int Quantize(float value) const;
  // This quantiser with every (levels() / k)-th threshold: k levels at the same quantiles
  // (k must divide levels(); otherwise, or for k >= levels(), this quantiser).
  InvariantQuantizer Coarser(int k) const;
  int levels() const { return static_cast<int>(thresholds_.size()) + 1; }
  const std::vector<float> &thresholds() const { return thresholds_; }
  bool empty() const { return thresholds_.empty(); }

 private:
  std::vector<float> thresholds_;
};

// Affine invariant of four points: the angle atan2(area(a,c,d), area(a,b,c)).
// It is a monotone function of the area ratio, bounded, signed and defined when
// an area is 0.
float AffineInvariant(const cv::Point2f &a, const cv::Point2f &b, const cv::Point2f &c,
                      const cv::Point2f &d);

// Computes descriptor hashes. Immutable after construction; safe for concurrent
// use.
class LlahDescriber {
 public:
  LlahDescriber(LlahOptions options, InvariantQuantizer quantizer);

  // hashes->size() == points.size() * DescriptorsPerPoint(); hash 0 means "no
  // descriptor" (the point has fewer than n neighbours).
  void Describe(const std::vector<cv::Point2f> &points, std::vector<uint64_t> *hashes) const;

  // Query-side multi-probe: for every descriptor, also the descriptors obtained
  // by moving its `probes` least certain invariants (closest to a level
  // boundary) across that boundary: 2^probes hashes per descriptor, laid out
  // per point as [subset 0: exact, probe 1, ...][subset 1: ...]. probes is
  // clamped to [0, kMaxProbes]. Index memory is unchanged; quantisation noise
  // in the query is forgiven.
  // Points with skip[i] set are not described (hashes 0), though still neighbours.
  static constexpr int kMaxProbes = 3;
  void DescribeWithProbes(const std::vector<cv::Point2f> &points, int probes,
                          std::vector<uint64_t> *hashes,
                          const std::vector<char> *skip = nullptr) const;

  // Describes only the points with indices in `which`, into hashes laid out as
  // Describe's (other slots untouched). Neighbours are still searched among all
  // points.
  void DescribeSubset(const std::vector<cv::Point2f> &points, const std::vector<int> &which,
                      std::vector<uint64_t> *hashes) const;

  // Raw invariant values of every (4-subset, cyclic order) around every point:
  // training data for InvariantQuantizer::Learn.
  void CollectInvariants(const std::vector<cv::Point2f> &points, std::vector<float> *out) const;

  const LlahOptions &options() const { return options_; }
  const InvariantQuantizer &quantizer() const { return quantizer_; }
  int descriptors_per_point() const { return static_cast<int>(subsets_m_.size()); }
  // The positions, among a keypoint's n neighbours ordered by angle, of the m that
  // descriptor `s` (0 <= s < descriptors_per_point()) is computed from.
  const std::vector<int> &subset(int s) const { return subsets_m_[s]; }

 private:
  void DescribePoint(const std::vector<cv::Point2f> &points, int index, const NeighborGrid &grid,
                     int probes, std::vector<int> &scratch, uint64_t *out) const;
  // quantizer_.Quantize(AffineInvariant(a, b, c, d)), without the atan2.
  int QuantizedInvariant(const cv::Point2f &a, const cv::Point2f &b, const cv::Point2f &c,
                         const cv::Point2f &d) const;

  LlahOptions options_;
  InvariantQuantizer quantizer_;
  std::vector<std::vector<int>> subsets_m_;    // C(n, m) increasing index lists
  std::vector<std::array<int, 4>> subsets_4_;  // C(m, 4) increasing position lists
  struct Quad {
    int slot, a, b, c, d;  // slot in the level table; neighbour positions
  };
  std::vector<int> rotation_slots_;        // per m-subset, rotation, 4-subset: its slot
  std::vector<Quad> quads_;                // every distinct quadruple those read
  std::vector<double> pseudo_thresholds_;  // the quantizer's, as pseudo-angles
  bool packed_keys_ = true;                // k^C(m, 4) fits in 64 bits
};

}  // namespace texfree
