// LLAH descriptor computation and quantiser learning.
#include "common/llah.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numeric>

#include "absl/strings/str_cat.h"

namespace texfree {
namespace {

uint64_t Mix64(uint64_t x) {  // splitmix64 finaliser
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

void Combinations(int n, int r, std::vector<std::vector<int>>* out) {
  std::vector<int> c(r);
  std::iota(c.begin(), c.end(), 0);
  while (true) {
    out->push_back(c);
    int i = r - 1;
    while (i >= 0 && c[i] == n - r + i) --i;
    if (i < 0) return;
    ++c[i];
    for (int j = i + 1; j < r; ++j) c[j] = c[j - 1] + 1;
  }
}

constexpr int kMaxN = 10;

inline float Cross(const cv::Point2f& a, const cv::Point2f& b, const cv::Point2f& c) {
  return (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
}

}  // namespace

absl::Status LlahOptions::Validate() const {
  if (m < 4 || m > n)
    return absl::InvalidArgumentError(absl::StrCat("LLAH needs 4 <= m <= n, got n=", n, " m=", m));
  if (n > kMaxN) return absl::InvalidArgumentError(absl::StrCat("LLAH n must be <= ", kMaxN));
  if (k < 2 || k > 64)
    return absl::InvalidArgumentError(absl::StrCat("LLAH k must be in [2, 64], got ", k));
  return absl::OkStatus();
}

static int Binomial(int n, int r) {
  long long v = 1;
  for (int i = 1; i <= r; ++i) v = v * (n - r + i) / i;
  return static_cast<int>(v);
}

int LlahOptions::DescriptorsPerPoint() const { return Binomial(n, m); }
int LlahOptions::InvariantsPerDescriptor() const { return Binomial(m, 4); }

absl::StatusOr<InvariantQuantizer> InvariantQuantizer::Learn(std::vector<float> samples, int k) {
  if (k < 2) return absl::InvalidArgumentError("quantizer needs k >= 2");
  if (samples.size() < static_cast<size_t>(50 * k)) {
    return absl::FailedPreconditionError(absl::StrCat(
        "too few invariant samples to learn ", k, " quantisation levels: ", samples.size(),
        " (need ", 50 * k, "); register a page with more text first"));
  }
  std::sort(samples.begin(), samples.end());
  std::vector<float> t(k - 1);
  for (int i = 1; i < k; ++i) t[i - 1] = samples[samples.size() * i / k];
  return InvariantQuantizer(std::move(t));
}

int InvariantQuantizer::Quantize(float value) const {
  return static_cast<int>(std::upper_bound(thresholds_.begin(), thresholds_.end(), value) -
                          thresholds_.begin());
}

float AffineInvariant(const cv::Point2f& a, const cv::Point2f& b, const cv::Point2f& c,
                      const cv::Point2f& d) {
  return std::atan2(Cross(a, c, d), Cross(a, b, c));
}

LlahDescriber::LlahDescriber(LlahOptions options, InvariantQuantizer quantizer)
    : options_(options), quantizer_(std::move(quantizer)) {
  Combinations(options_.n, options_.m, &subsets_m_);
  std::vector<std::vector<int>> c4;
  Combinations(options_.m, 4, &c4);
  for (const auto& c : c4) subsets_4_.push_back({c[0], c[1], c[2], c[3]});
}

namespace {

// Neighbours of points[index] ordered by angle around it. Returns false if too few.
bool OrderedNeighbors(const std::vector<cv::Point2f>& points, int index, int n,
                      const NeighborGrid& grid, std::vector<int>& scratch,
                      cv::Point2f* ordered) {
  grid.Nearest(index, n, &scratch);
  if (static_cast<int>(scratch.size()) < n) return false;
  const cv::Point2f p = points[index];
  std::array<std::pair<float, int>, kMaxN> by_angle;
  for (int i = 0; i < n; ++i) {
    const cv::Point2f d = points[scratch[i]] - p;
    by_angle[i] = {std::atan2(d.y, d.x), scratch[i]};
  }
  std::sort(by_angle.begin(), by_angle.begin() + n);
  for (int i = 0; i < n; ++i) ordered[i] = points[by_angle[i].second];
  return true;
}

}  // namespace

void LlahDescriber::DescribePoint(const std::vector<cv::Point2f>& points, int index,
                                  const NeighborGrid& grid, std::vector<int>& scratch,
                                  uint64_t* out) const {
  const int n = options_.n, m = options_.m;
  const int per = static_cast<int>(subsets_m_.size());
  cv::Point2f q[kMaxN];
  if (!OrderedNeighbors(points, index, n, grid, scratch, q)) {
    std::fill(out, out + per, 0);
    return;
  }
  // Quantised invariant of each ordered quadruple, computed once per keypoint.
  int8_t table[kMaxN * kMaxN * kMaxN * kMaxN];
  std::memset(table, -1, sizeof(int8_t) * n * n * n * n);
  auto level = [&](int a, int b, int c, int d) -> int {
    int8_t& slot = table[((a * n + b) * n + c) * n + d];
    if (slot < 0) slot = static_cast<int8_t>(quantizer_.Quantize(AffineInvariant(q[a], q[b], q[c], q[d])));
    return slot;
  };
  const int dims = static_cast<int>(subsets_4_.size());
  std::array<uint8_t, 256> best{}, cur{};
  for (int s = 0; s < per; ++s) {
    const std::vector<int>& sub = subsets_m_[s];
    bool have_best = false;
    for (int r = 0; r < m; ++r) {
      for (int j = 0; j < dims; ++j) {
        const auto& f = subsets_4_[j];
        cur[j] = static_cast<uint8_t>(level(sub[(f[0] + r) % m], sub[(f[1] + r) % m],
                                            sub[(f[2] + r) % m], sub[(f[3] + r) % m]));
      }
      if (!have_best || std::lexicographical_compare(cur.begin(), cur.begin() + dims,
                                                     best.begin(), best.begin() + dims)) {
        best = cur;
        have_best = true;
      }
    }
    uint64_t h = 0;
    for (int j = 0; j < dims; ++j) h = h * static_cast<uint64_t>(options_.k) + best[j];
    h = Mix64(h ^ (static_cast<uint64_t>(dims) << 58));
    out[s] = h == 0 ? 1 : h;
  }
}

void LlahDescriber::Describe(const std::vector<cv::Point2f>& points,
                             std::vector<uint64_t>* hashes) const {
  std::vector<int> all(points.size());
  std::iota(all.begin(), all.end(), 0);
  hashes->assign(points.size() * subsets_m_.size(), 0);
  DescribeSubset(points, all, hashes);
}

void LlahDescriber::DescribeSubset(const std::vector<cv::Point2f>& points,
                                   const std::vector<int>& which,
                                   std::vector<uint64_t>* hashes) const {
  const size_t per = subsets_m_.size();
  if (hashes->size() < points.size() * per) hashes->resize(points.size() * per, 0);
  if (points.empty()) return;
  NeighborGrid grid(points);
  std::vector<int> scratch;
  for (int i : which) DescribePoint(points, i, grid, scratch, hashes->data() + i * per);
}

void LlahDescriber::CollectInvariants(const std::vector<cv::Point2f>& points,
                                      std::vector<float>* out) const {
  if (points.empty()) return;
  NeighborGrid grid(points);
  std::vector<int> scratch;
  std::vector<std::vector<int>> c4;
  Combinations(options_.n, 4, &c4);
  cv::Point2f q[kMaxN];
  for (int i = 0; i < static_cast<int>(points.size()); ++i) {
    if (!OrderedNeighbors(points, i, options_.n, grid, scratch, q)) continue;
    for (const auto& c : c4) {
      for (int r = 0; r < 4; ++r) {
        out->push_back(AffineInvariant(q[c[r]], q[c[(r + 1) % 4]], q[c[(r + 2) % 4]],
                                       q[c[(r + 3) % 4]]));
      }
    }
  }
}

}  // namespace texfree
