// LLAH descriptor computation and quantiser learning.
#include "common/llah.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
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

void Combinations(int n, int r, std::vector<std::vector<int>> *out) {
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

inline float Cross(const cv::Point2f &a, const cv::Point2f &b, const cv::Point2f &c) {
  return (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
}

// A strictly increasing function of atan2(y, x) on (-pi, pi], with values in
// (-2, 2] (the L1 "diamond angle"); (x, y) must not be (0, 0). Comparing it
// orders angles as atan2 does at a fraction of the cost: atan2 was the largest
// single cost of describing a point.
inline double PseudoAngle(double y, double x) {
  const double r = 1 - x / (std::abs(x) + std::abs(y));
  return std::signbit(y) ? -r : r;
}

// Pseudo-angles closer than this may be ordered differently by atan2 on floats
// (its rounding is ~1e-7 rad); there atan2 itself decides, so that hashes are
// exactly those computed with it (they are stored with registered pages).
constexpr double kPseudoAngleTie = 1e-5;

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

InvariantQuantizer InvariantQuantizer::Coarser(int k) const {
  if (k < 1 || k >= levels() || levels() % k != 0) return *this;
  const size_t step = static_cast<size_t>(levels() / k);
  std::vector<float> thresholds;
  for (size_t i = step - 1; i < thresholds_.size(); i += step) thresholds.push_back(thresholds_[i]);
  return InvariantQuantizer(std::move(thresholds));
}

int InvariantQuantizer::Quantize(float value) const {
  return static_cast<int>(std::upper_bound(thresholds_.begin(), thresholds_.end(), value) -
                          thresholds_.begin());
}

float AffineInvariant(const cv::Point2f &a, const cv::Point2f &b, const cv::Point2f &c,
                      const cv::Point2f &d) {
  return std::atan2(Cross(a, c, d), Cross(a, b, c));
}

LlahDescriber::LlahDescriber(LlahOptions options, InvariantQuantizer quantizer)
    : options_(options), quantizer_(std::move(quantizer)) {
  Combinations(options_.n, options_.m, &subsets_m_);
  std::vector<std::vector<int>> c4;
  Combinations(options_.m, 4, &c4);
  for (const auto &c : c4) subsets_4_.push_back({c[0], c[1], c[2], c[3]});
  // The quadruples each (m-subset, cyclic rotation, 4-subset) reads, as slots of
  // the per-point level table: the same for every point.
  const int n = options_.n, m = options_.m;
  std::vector<char> used(static_cast<size_t>(n * n * n * n), 0);
  for (const std::vector<int> &sub : subsets_m_) {
    for (int r = 0; r < m; ++r) {
      for (const auto &f : subsets_4_) {
        const int a = sub[(f[0] + r) % m], b = sub[(f[1] + r) % m], c = sub[(f[2] + r) % m],
                  d = sub[(f[3] + r) % m];
        const int slot = ((a * n + b) * n + c) * n + d;
        rotation_slots_.push_back(slot);
        if (!used[slot]) quads_.push_back({slot, a, b, c, d});
        used[slot] = 1;
      }
    }
  }
  for (float t : quantizer_.thresholds())
    pseudo_thresholds_.push_back(
        PseudoAngle(std::sin(static_cast<double>(t)), std::cos(static_cast<double>(t))));
  // The canonical rotation is the lexicographically smallest sequence of levels,
  // which is the smallest base-k number they spell when k^dims fits in 64 bits.
  unsigned __int128 largest = 1;
  for (size_t j = 0; j < subsets_4_.size() && packed_keys_; ++j) {
    largest *= static_cast<unsigned>(options_.k);
    packed_keys_ = largest <= std::numeric_limits<uint64_t>::max();
  }
}

int LlahDescriber::QuantizedInvariant(const cv::Point2f &a, const cv::Point2f &b,
                                      const cv::Point2f &c, const cv::Point2f &d) const {
  // AffineInvariant's atan2, compared through the pseudo-angle.
  const float y = Cross(a, c, d), x = Cross(a, b, c);
  if (x == 0 && y == 0) return quantizer_.Quantize(std::atan2(y, x));
  const double p = PseudoAngle(y, x);
  const auto above = std::upper_bound(pseudo_thresholds_.begin(), pseudo_thresholds_.end(), p);
  if ((above != pseudo_thresholds_.end() && *above - p < kPseudoAngleTie) ||
      (above != pseudo_thresholds_.begin() && p - above[-1] < kPseudoAngleTie))
    return quantizer_.Quantize(std::atan2(y, x));
  return static_cast<int>(above - pseudo_thresholds_.begin());
}

namespace {

// Neighbours of points[index] ordered by angle around it. Returns false if too
// few.
bool OrderedNeighbors(const std::vector<cv::Point2f> &points, int index, int n,
                      const NeighborGrid &grid, std::vector<int> &scratch, cv::Point2f *ordered) {
  grid.Nearest(index, n, &scratch);
  if (static_cast<int>(scratch.size()) < n) return false;
  const cv::Point2f p = points[index];
  std::array<std::pair<double, int>, kMaxN> by_angle;
  bool exact = true;  // no duplicate point, no near tie: the pseudo-angle orders as atan2
  for (int i = 0; i < n; ++i) {
    const cv::Point2f d = points[scratch[i]] - p;
    exact = exact && (d.x != 0 || d.y != 0);
    by_angle[i] = {exact ? PseudoAngle(d.y, d.x) : 0.0, scratch[i]};
  }
  if (exact) {
    std::sort(by_angle.begin(), by_angle.begin() + n);
    for (int i = 1; i < n && exact; ++i)
      exact = by_angle[i].first - by_angle[i - 1].first >= kPseudoAngleTie;
  }
  if (!exact) {
    for (int i = 0; i < n; ++i) {
      const cv::Point2f d = points[scratch[i]] - p;
      by_angle[i] = {std::atan2(d.y, d.x), scratch[i]};
    }
    std::sort(by_angle.begin(), by_angle.begin() + n);
  }
  for (int i = 0; i < n; ++i) ordered[i] = points[by_angle[i].second];
  return true;
}

}  // namespace

void LlahDescriber::DescribePoint(const std::vector<cv::Point2f> &points, int index,
                                  const NeighborGrid &grid, int probes, std::vector<int> &scratch,
                                  uint64_t *out) const {
  const int n = options_.n, m = options_.m;
  const int per = static_cast<int>(subsets_m_.size());
  const int variants = 1 << probes;
  cv::Point2f q[kMaxN];
  if (!OrderedNeighbors(points, index, n, grid, scratch, q)) {
    std::fill(out, out + per * variants, 0);
    return;
  }
  // Quantised invariant of each ordered quadruple, computed once per keypoint,
  // and its distance to the nearest level boundary (for probing).
  int8_t table[kMaxN * kMaxN * kMaxN * kMaxN];
  float margin[kMaxN * kMaxN * kMaxN * kMaxN];
  int8_t other[kMaxN * kMaxN * kMaxN * kMaxN];  // the level across the nearest boundary
  const std::vector<float> &t = quantizer_.thresholds();
  const int k = options_.k;
  for (const Quad &u : quads_) {
    if (probes == 0) {
      table[u.slot] = static_cast<int8_t>(QuantizedInvariant(q[u.a], q[u.b], q[u.c], q[u.d]));
      continue;
    }
    const float v = AffineInvariant(q[u.a], q[u.b], q[u.c], q[u.d]);
    const int lv = quantizer_.Quantize(v);
    table[u.slot] = static_cast<int8_t>(lv);
    if (!t.empty()) {
      // The invariant is an angle: level 0 and level k-1 meet at +-pi.
      const float below = lv > 0 ? v - t[lv - 1] : v + static_cast<float>(CV_PI);
      const float above = lv < k - 1 ? t[lv] - v : static_cast<float>(CV_PI) - v;
      margin[u.slot] = std::min(below, above);
      other[u.slot] = static_cast<int8_t>(below < above ? (lv + k - 1) % k : (lv + 1) % k);
    }
  }
  const int dims = static_cast<int>(subsets_4_.size());
  const int *slots = nullptr;  // slots[r * dims + j]: of rotation r, 4-subset j
  int best_rotation = 0;
  auto canonical_hash = [&]() {
    if (packed_keys_) {
      uint64_t best = 0;
      for (int r = 0; r < m; ++r) {
        uint64_t key = 0;
        for (int j = 0; j < dims; ++j)
          key = key * static_cast<uint64_t>(k) + static_cast<uint8_t>(table[slots[r * dims + j]]);
        if (r == 0 || key < best) {
          best = key;
          best_rotation = r;
        }
      }
      const uint64_t h = Mix64(best ^ (static_cast<uint64_t>(dims) << 58));
      return h == 0 ? uint64_t{1} : h;
    }
    std::array<uint8_t, 256> best{}, cur{};
    bool have_best = false;
    for (int r = 0; r < m; ++r) {
      for (int j = 0; j < dims; ++j) cur[j] = static_cast<uint8_t>(table[slots[r * dims + j]]);
      if (!have_best || std::lexicographical_compare(cur.begin(), cur.begin() + dims, best.begin(),
                                                     best.begin() + dims)) {
        best = cur;
        have_best = true;
        best_rotation = r;
      }
    }
    uint64_t h = 0;
    for (int j = 0; j < dims; ++j) h = h * static_cast<uint64_t>(k) + best[j];
    h = Mix64(h ^ (static_cast<uint64_t>(dims) << 58));
    return h == 0 ? uint64_t{1} : h;
  };
  for (int s = 0; s < per; ++s) {
    slots = rotation_slots_.data() + static_cast<size_t>(s) * m * dims;
    uint64_t *dst = out + s * variants;
    dst[0] = canonical_hash();
    if (variants == 1) continue;
    // Probes: the descriptors obtained by moving the `probes` least certain
    // invariants (closest to a level boundary) to the level across that
    // boundary. Noise in the query most often moves exactly those. Only the
    // canonical rotation's invariants make the hash.
    std::array<int, 4> uncertain{};
    std::array<float, 4> worst{};
    int found = 0;
    {
      const int r = best_rotation;
      for (int j = 0; j < dims; ++j) {
        const int slot = slots[r * dims + j];
        bool seen = false;
        for (int u = 0; u < found; ++u) seen |= uncertain[u] == slot;
        if (seen) continue;
        const float mg = margin[slot];
        if (found < probes) {
          uncertain[found] = slot;
          worst[found++] = mg;
        } else {
          int w = 0;
          for (int u = 1; u < found; ++u)
            if (worst[u] > worst[w]) w = u;
          if (mg < worst[w]) {
            uncertain[w] = slot;
            worst[w] = mg;
          }
        }
      }
    }
    for (int v = 1; v < variants; ++v) {
      int8_t saved[4];
      for (int u = 0; u < found; ++u) {
        saved[u] = table[uncertain[u]];
        if (v >> u & 1) table[uncertain[u]] = other[uncertain[u]];
      }
      dst[v] = v < (1 << found) ? canonical_hash() : 0;
      for (int u = 0; u < found; ++u) table[uncertain[u]] = saved[u];
    }
  }
}

void LlahDescriber::Describe(const std::vector<cv::Point2f> &points,
                             std::vector<uint64_t> *hashes) const {
  DescribeWithProbes(points, 0, hashes);
}

void LlahDescriber::DescribeWithProbes(const std::vector<cv::Point2f> &points, int probes,
                                       std::vector<uint64_t> *hashes,
                                       const std::vector<char> *skip) const {
  probes = std::clamp(probes, 0, kMaxProbes);
  const size_t per = subsets_m_.size() << probes;
  hashes->assign(points.size() * per, 0);
  if (points.empty()) return;
  NeighborGrid grid(points);
  std::vector<int> scratch;
  for (int i = 0; i < static_cast<int>(points.size()); ++i)
    if (skip == nullptr || !(*skip)[i])
      DescribePoint(points, i, grid, probes, scratch, hashes->data() + i * per);
}

void LlahDescriber::DescribeSubset(const std::vector<cv::Point2f> &points,
                                   const std::vector<int> &which,
                                   std::vector<uint64_t> *hashes) const {
  const size_t per = subsets_m_.size();
  if (hashes->size() < points.size() * per) hashes->resize(points.size() * per, 0);
  if (points.empty()) return;
  NeighborGrid grid(points);
  std::vector<int> scratch;
  for (int i : which) DescribePoint(points, i, grid, 0, scratch, hashes->data() + i * per);
}

void LlahDescriber::CollectInvariants(const std::vector<cv::Point2f> &points,
                                      std::vector<float> *out) const {
  if (points.empty()) return;
  NeighborGrid grid(points);
  std::vector<int> scratch;
  std::vector<std::vector<int>> c4;
  Combinations(options_.n, 4, &c4);
  cv::Point2f q[kMaxN];
  for (int i = 0; i < static_cast<int>(points.size()); ++i) {
    if (!OrderedNeighbors(points, i, options_.n, grid, scratch, q)) continue;
    for (const auto &c : c4) {
      for (int r = 0; r < 4; ++r) {
        out->push_back(
            AffineInvariant(q[c[r]], q[c[(r + 1) % 4]], q[c[(r + 2) % 4]], q[c[(r + 3) % 4]]));
      }
    }
  }
}

}  // namespace texfree
