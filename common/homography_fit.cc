// Homography fitting in fixed-size arithmetic: normalised DLT, Levenberg-Marquardt on the
// reprojection error, and RANSAC over four-point samples.
#include "common/homography_fit.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cfloat>
#include <cmath>
#include <limits>

namespace texfree {
namespace {

using Mat8 = Eigen::Matrix<double, 8, 8>;
using Vec8 = Eigen::Matrix<double, 8, 1>;
using Mat9 = Eigen::Matrix<double, 9, 9>;

// Hartley's normalisation of a point set: centroid to the origin, mean distance sqrt(2).
struct Normalisation {
  cv::Point2d centre;
  double scale = 1;
  cv::Point2d Apply(const cv::Point2f &p) const {
    return {(p.x - centre.x) * scale, (p.y - centre.y) * scale};
  }
  // The matrix that Apply is.
  cv::Matx33d Matrix() const {
    return {scale, 0, -scale * centre.x, 0, scale, -scale * centre.y, 0, 0, 1};
  }
};

Normalisation Normalise(const std::vector<cv::Point2f> &points) {
  Normalisation n;
  for (const auto &p : points) n.centre += cv::Point2d(p);
  n.centre *= 1.0 / points.size();
  double mean = 0;
  for (const auto &p : points) mean += cv::norm(cv::Point2d(p) - n.centre);
  mean /= points.size();
  n.scale = mean > 0 ? std::sqrt(2.0) / mean : 1;
  return n;
}

// The pairs in the coordinates of their own set's normalisation.
void NormalisePairs(const std::vector<cv::Point2f> &src, const std::vector<cv::Point2f> &dst,
                    Normalisation *ns, Normalisation *nd, std::vector<cv::Point2d> *s,
                    std::vector<cv::Point2d> *d) {
  *ns = Normalise(src);
  *nd = Normalise(dst);
  s->resize(src.size());
  d->resize(dst.size());
  for (size_t i = 0; i < src.size(); ++i) {
    (*s)[i] = ns->Apply(src[i]);
    (*d)[i] = nd->Apply(dst[i]);
  }
}

// Projection of p by the 8 parameters of a homography with H(2, 2) = 1.
inline bool Project(const Vec8 &h, const cv::Point2d &p, cv::Point2d *out, double *w) {
  *w = h[6] * p.x + h[7] * p.y + 1;
  if (std::abs(*w) < 1e-12) return false;
  *out = {(h[0] * p.x + h[1] * p.y + h[2]) / *w, (h[3] * p.x + h[4] * p.y + h[5]) / *w};
  return true;
}

// Sum of squared reprojection errors; infinity when a point maps to infinity.
double Cost(const Vec8 &h, const std::vector<cv::Point2d> &s, const std::vector<cv::Point2d> &d) {
  double cost = 0;
  for (size_t i = 0; i < s.size(); ++i) {
    cv::Point2d q;
    double w;
    if (!Project(h, s[i], &q, &w)) return std::numeric_limits<double>::infinity();
    const cv::Point2d e = q - d[i];
    cost += e.dot(e);
  }
  return cost;
}

// The DLT on normalised pairs: the eigenvector of the smallest eigenvalue of AᵀA, false
// when the second smallest is as small (no unique solution).
bool Dlt(const std::vector<cv::Point2d> &s, const std::vector<cv::Point2d> &d, cv::Matx33d *Hn) {
  Mat9 M = Mat9::Zero();
  for (size_t i = 0; i < s.size(); ++i) {
    const double x = s[i].x, y = s[i].y, u = d[i].x, v = d[i].y;
    Eigen::Matrix<double, 9, 1> r1, r2;
    r1 << x, y, 1, 0, 0, 0, -u * x, -u * y, -u;
    r2 << 0, 0, 0, x, y, 1, -v * x, -v * y, -v;
    M.noalias() += r1 * r1.transpose() + r2 * r2.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Mat9> eigen(M);
  if (eigen.info() != Eigen::Success) return false;
  const auto &values = eigen.eigenvalues();  // ascending
  if (!(values[1] > 1e-12 * std::max(1.0, values[8]))) return false;
  const auto h = eigen.eigenvectors().col(0);
  *Hn = cv::Matx33d(h[0], h[1], h[2], h[3], h[4], h[5], h[6], h[7], h[8]);
  return true;
}

// Levenberg-Marquardt on the 8 parameters (H(2, 2) = 1) of normalised pairs.
void Refine(const std::vector<cv::Point2d> &s, const std::vector<cv::Point2d> &d, int iterations,
            Vec8 *h) {
  double cost = Cost(*h, s, d);
  double lambda = 1e-3;
  for (int it = 0; it < iterations && std::isfinite(cost) && cost > 0; ++it) {
    Mat8 JtJ = Mat8::Zero();
    Vec8 Jtr = Vec8::Zero();
    for (size_t i = 0; i < s.size(); ++i) {
      cv::Point2d q;
      double w;
      Project(*h, s[i], &q, &w);
      const double x = s[i].x / w, y = s[i].y / w, iw = 1 / w;
      Vec8 jx, jy;
      jx << x, y, iw, 0, 0, 0, -q.x * x, -q.x * y;
      jy << 0, 0, 0, x, y, iw, -q.y * x, -q.y * y;
      JtJ.noalias() += jx * jx.transpose() + jy * jy.transpose();
      Jtr += jx * (q.x - d[i].x) + jy * (q.y - d[i].y);
    }
    bool improved = false;
    for (int attempt = 0; attempt < 8 && !improved; ++attempt) {
      Mat8 A = JtJ;
      A.diagonal() *= 1 + lambda;
      const Vec8 step = A.ldlt().solve(-Jtr);
      const Vec8 next = *h + step;
      const double next_cost = Cost(next, s, d);
      if (next_cost < cost) {
        const bool small =
            step.norm() < 1e-10 * (h->norm() + 1e-10) || cost - next_cost < 1e-12 * cost;
        *h = next;
        cost = next_cost;
        lambda = std::max(lambda * 0.1, 1e-12);
        improved = true;
        if (small) return;
      } else {
        lambda *= 10;
      }
    }
    if (!improved) return;
  }
}

// Fits normalised pairs: DLT, then refinement. Hn is the normalised homography.
bool FitNormalised(const std::vector<cv::Point2d> &s, const std::vector<cv::Point2d> &d,
                   int iterations, cv::Matx33d *Hn) {
  if (!Dlt(s, d, Hn)) return false;
  const double h22 = (*Hn)(2, 2);
  // Normalised coordinates put the points around the origin, where a view's homography
  // has H(2, 2) well away from 0.
  if (!(std::abs(h22) > 1e-8 * cv::norm(*Hn))) return true;
  *Hn *= 1.0 / h22;
  if (iterations <= 0) return true;
  Vec8 h;
  h << (*Hn)(0, 0), (*Hn)(0, 1), (*Hn)(0, 2), (*Hn)(1, 0), (*Hn)(1, 1), (*Hn)(1, 2), (*Hn)(2, 0),
      (*Hn)(2, 1);
  Refine(s, d, iterations, &h);
  *Hn = cv::Matx33d(h[0], h[1], h[2], h[3], h[4], h[5], h[6], h[7], 1);
  return true;
}

// From normalised back to pixel coordinates, scaled to H(2, 2) = 1 where possible.
cv::Matx33d Denormalise(const cv::Matx33d &Hn, const Normalisation &ns, const Normalisation &nd) {
  cv::Matx33d H = nd.Matrix().inv() * Hn * ns.Matrix();
  if (std::abs(H(2, 2)) > 1e-12 * cv::norm(H)) H *= 1.0 / H(2, 2);
  return H;
}

// The minimal sample's homography in normalised coordinates (H(2, 2) = 1), as the product of
// two projective bases (Hartley and Zisserman, 2.7; Heckbert, 1989): B maps the canonical
// basis (e1, e2, e3, e1 + e2 + e3) onto the four points, and H = B_dst B_src⁻¹. Two 3x3
// solves instead of an 8x8 one; false when three points of either set are collinear.
bool ProjectiveBasis(const cv::Point2d *p, cv::Matx33d *B) {
  const cv::Matx33d M(p[0].x, p[1].x, p[2].x, p[0].y, p[1].y, p[2].y, 1, 1, 1);
  const double det = cv::determinant(M);
  double scale = 0;
  for (int i = 0; i < 3; ++i) scale = std::max(scale, std::abs(p[i].x) + std::abs(p[i].y) + 1);
  if (!(std::abs(det) > 1e-12 * scale * scale * scale)) return false;
  const cv::Vec3d lambda = M.inv() * cv::Vec3d(p[3].x, p[3].y, 1);
  for (int i = 0; i < 3; ++i) {
    if (!(std::abs(lambda[i]) > 1e-12)) return false;
    for (int r = 0; r < 3; ++r) (*B)(r, i) = M(r, i) * lambda[i];
  }
  return true;
}

bool SolveFour(const cv::Point2d *s, const cv::Point2d *d, Vec8 *h) {
  cv::Matx33d Bs, Bd;
  if (!ProjectiveBasis(s, &Bs) || !ProjectiveBasis(d, &Bd)) return false;
  const cv::Matx33d H = Bd * Bs.inv();
  if (!(std::abs(H(2, 2)) > 1e-12 * cv::norm(H))) return false;
  const double k = 1 / H(2, 2);
  *h << H(0, 0) * k, H(0, 1) * k, H(0, 2) * k, H(1, 0) * k, H(1, 1) * k, H(1, 2) * k, H(2, 0) * k,
      H(2, 1) * k;
  return h->allFinite();
}

// Whether the last of a sample's points lies on a line through two earlier ones (or on
// one of them), in pixels, as OpenCV checks a sample as it is drawn.
bool LastPointCollinear(const cv::Point2f *p, int count) {
  const int i = count - 1;
  for (int j = 0; j < i; ++j) {
    const double dx1 = p[j].x - p[i].x, dy1 = p[j].y - p[i].y;
    for (int k = 0; k < j; ++k) {
      const double dx2 = p[k].x - p[i].x, dy2 = p[k].y - p[i].y;
      if (std::abs(dx2 * dy1 - dy2 * dx1) <=
          FLT_EPSILON * (std::abs(dx1) + std::abs(dy1) + std::abs(dx2) + std::abs(dy2)))
        return true;
    }
  }
  return false;
}

// A usable sample (OpenCV's test): its last point not collinear with two others in either
// set, and the four triangles' orientations all kept or all reversed (Marquez-Neila et al.,
// "Speeding-up homography estimation in mobile devices", 2013).
bool GoodSample(const cv::Point2f *s, const cv::Point2f *d) {
  if (LastPointCollinear(s, 4) || LastPointCollinear(d, 4)) return false;
  static constexpr int kTriangles[4][3] = {{0, 1, 2}, {1, 2, 3}, {0, 2, 3}, {0, 1, 3}};
  const auto det = [](const cv::Point2f *p, const int *t) {
    const cv::Matx33d m(p[t[0]].x, p[t[0]].y, 1, p[t[1]].x, p[t[1]].y, 1, p[t[2]].x, p[t[2]].y, 1);
    return cv::determinant(m);
  };
  int reversed = 0;
  for (const auto &t : kTriangles) reversed += det(s, t) * det(d, t) < 0;
  return reversed == 0 || reversed == 4;
}

// Samples needed to draw a good sample with `confidence`, given the chance `good` that one
// sample is (cv::RANSACUpdateNumIters with good = (1 - outlier share)^4).
int SamplesFor(double confidence, double good, int max_iterations) {
  const double num = std::log(std::max(1 - confidence, DBL_MIN));
  const double denom_arg = 1 - good;
  if (denom_arg < DBL_MIN) return 0;
  const double denom = std::log(denom_arg);
  if (denom >= 0 || -num >= max_iterations * (-denom)) return max_iterations;
  return static_cast<int>(std::lround(num / denom));
}

}  // namespace

bool FitHomography(const std::vector<cv::Point2f> &src, const std::vector<cv::Point2f> &dst,
                   cv::Matx33d *H, int max_refine_iterations) {
  if (src.size() != dst.size() || src.size() < 4) return false;
  Normalisation ns, nd;
  std::vector<cv::Point2d> s, d;
  NormalisePairs(src, dst, &ns, &nd, &s, &d);
  cv::Matx33d Hn;
  if (!FitNormalised(s, d, max_refine_iterations, &Hn)) return false;
  *H = Denormalise(Hn, ns, nd);
  return std::isfinite(cv::norm(*H));
}

namespace {

// What RANSAC and PROSAC share: the pairs normalised, a hypothesis from four of them, its
// consensus, and the final refit.
class HypothesisTester {
 public:
  HypothesisTester(const std::vector<cv::Point2f> &src, const std::vector<cv::Point2f> &dst,
                   double threshold)
      : src_(src), dst_(dst) {
    NormalisePairs(src, dst, &ns_, &nd_, &s_, &d_);
    gate2_ = threshold * nd_.scale * threshold * nd_.scale;
  }

  // Whether the four pairs `idx` are a usable sample (GoodSample).
  bool Usable(const int *idx) const {
    cv::Point2f ps[4], pd[4];
    for (int k = 0; k < 4; ++k) {
      ps[k] = src_[idx[k]];
      pd[k] = dst_[idx[k]];
    }
    return GoodSample(ps, pd);
  }

  // The homography of the four pairs `idx`, false when their system is singular.
  bool Solve(const int *idx, Vec8 *h) const {
    cv::Point2d ss[4], sd[4];
    for (int k = 0; k < 4; ++k) {
      ss[k] = s_[idx[k]];
      sd[k] = d_[idx[k]];
    }
    return SolveFour(ss, sd, h);
  }

  // The pairs `h` maps within the threshold (mask), their number, and their MSAC cost (the
  // squared errors, each capped at the threshold's square, in normalised units).
  // With `widen` > 1 the threshold is that many times wider.
  int Consensus(const Vec8 &h, std::vector<char> *mask, double *msac = nullptr,
                double widen = 1) const {
    int checked, agreed;
    double cost;
    const int found =
        CheckPairs(h, gate2_ * widen * widen, 1, 1, std::numeric_limits<double>::infinity(), mask,
                   &cost, &checked, &agreed);
    if (msac) *msac = cost;
    return found;
  }

  // Consensus under Wald's sequential test (SPRT; Matas and Chum, "Randomized RANSAC with
  // Sequential Probability Ratio Test", ICCV 2005): the pairs are checked in order and the
  // model given up, returning -1, as soon as the likelihood ratio of "bad model" (each pair
  // agrees with `delta`) over "good model" (with `epsilon`) passes `decision` (never when
  // it is infinite). `*checked` and `*agreed` receive how many pairs were checked and agreed.
  int SequentialConsensus(const Vec8 &h, double epsilon, double delta, double decision,
                          std::vector<char> *mask, double *msac, int *checked, int *agreed) const {
    if (!std::isfinite(decision))
      return CheckPairs(h, gate2_, 1, 1, decision, mask, msac, checked, agreed);
    return CheckPairs(h, gate2_, delta / epsilon, (1 - delta) / (1 - epsilon), decision, mask, msac,
                      checked, agreed);
  }

  // Least squares (with `iterations` of refinement) on the pairs of `mask`: normalised
  // parameters in `h`, false when they do not fit.
  bool FitMask(const std::vector<char> &mask, int iterations, Vec8 *h) const {
    cv::Matx33d Hn;
    if (!FitNormalisedMask(mask, iterations, &Hn) || !(std::abs(Hn(2, 2)) > 0)) return false;
    Hn *= 1.0 / Hn(2, 2);
    *h << Hn(0, 0), Hn(0, 1), Hn(0, 2), Hn(1, 0), Hn(1, 1), Hn(1, 2), Hn(2, 0), Hn(2, 1);
    return h->allFinite();
  }

  // The final homography: the least-squares fit of `mask`'s pairs, in pixels.
  bool Finish(const std::vector<char> &mask, cv::Matx33d *H) const {
    cv::Matx33d Hn;
    if (!FitNormalisedMask(mask, 10, &Hn)) return false;
    *H = Denormalise(Hn, ns_, nd_);
    return std::isfinite(cv::norm(*H));
  }

 private:
  // FitNormalised on the pairs of `mask`.
  bool FitNormalisedMask(const std::vector<char> &mask, int iterations, cv::Matx33d *Hn) const {
    std::vector<cv::Point2d> is, id;
    for (size_t i = 0; i < s_.size(); ++i)
      if (mask[i]) {
        is.push_back(s_[i]);
        id.push_back(d_[i]);
      }
    return FitNormalised(is, id, iterations, Hn);
  }

  // The pairs within sqrt(gate2) of h's projection, checked in order with the likelihood
  // ratio multiplied by `agree_ratio` or `disagree_ratio` at each; -1 once it passes
  // `decision`.
  int CheckPairs(const Vec8 &h, double gate2, double agree_ratio, double disagree_ratio,
                 double decision, std::vector<char> *mask, double *msac, int *checked,
                 int *agreed) const {
    double lambda = 1, cost = 0;
    int found = 0;
    for (size_t i = 0; i < s_.size(); ++i) {
      cv::Point2d q;
      double w, e2 = gate2;
      bool in = false;
      if (Project(h, s_[i], &q, &w)) {
        const double r2 = (q - d_[i]).dot(q - d_[i]);
        in = r2 <= gate2;
        if (in) e2 = r2;
      }
      (*mask)[i] = in;
      found += in;
      cost += e2;
      lambda *= in ? agree_ratio : disagree_ratio;
      if (lambda > decision) {
        *checked = static_cast<int>(i + 1);
        *agreed = found;
        return -1;
      }
    }
    *checked = static_cast<int>(s_.size());
    *agreed = found;
    *msac = cost;
    return found;
  }

  const std::vector<cv::Point2f> &src_, &dst_;
  Normalisation ns_, nd_;
  std::vector<cv::Point2d> s_, d_;
  double gate2_ = 0;
};

}  // namespace

bool FitHomographyRansac(const std::vector<cv::Point2f> &src, const std::vector<cv::Point2f> &dst,
                         double threshold, int max_iterations, cv::Matx33d *H,
                         std::vector<char> *inliers) {
  const size_t count = src.size();
  if (dst.size() != count || count < 4) return false;
  if (count == 4) {
    if (!FitHomography(src, dst, H)) return false;
    if (inliers) inliers->assign(4, 1);
    return true;
  }
  const HypothesisTester tester(src, dst, threshold);
  // The samples are drawn as cv::findHomography draws them (its generator and seed, the
  // same tests), so that both find the same consensus and a caller moving from it keeps
  // its inliers.
  cv::RNG rng(0xffffffffffffffffULL);
  std::vector<char> mask(count), best_mask;
  int best = 0;
  int iterations = max_iterations;
  for (int it = 0; it < iterations; ++it) {
    int idx[4];
    bool drawn = false;
    for (int attempt = 0; attempt < 10000 && !drawn; ++attempt) {
      for (int k = 0; k < 4; ++k) {
        bool repeated;
        do {
          idx[k] = rng.uniform(0, static_cast<int>(count));
          repeated = false;
          for (int j = 0; j < k; ++j) repeated |= idx[j] == idx[k];
        } while (repeated);
      }
      drawn = tester.Usable(idx);
    }
    if (!drawn) break;
    Vec8 h;
    if (!tester.Solve(idx, &h)) continue;
    const int found = tester.Consensus(h, &mask);
    if (found > std::max(best, 3)) {
      best = found;
      best_mask = mask;
      iterations = std::min(iterations,
                            SamplesFor(0.995, std::pow(double(found) / count, 4), max_iterations));
    }
  }
  if (best < 4 || !tester.Finish(best_mask, H)) return false;
  if (inliers) *inliers = std::move(best_mask);
  return true;
}

namespace {

// SPRT's decision threshold A for the chances `epsilon` (a pair agrees with a good model)
// and `delta` (with a bad one): the fixed point of A = t_M C + 1 + log A (Chum and Matas,
// "Optimal Randomized RANSAC", PAMI 2008, eq. 16), t_M a model's cost in pair checks.
double SprtDecisionThreshold(double epsilon, double delta) {
  constexpr double kModelCost = 200;  // a 4-pair solve against one pair's projection
  const double c =
      (1 - delta) * std::log((1 - delta) / (1 - epsilon)) + delta * std::log(delta / epsilon);
  double a = kModelCost * c + 1;
  for (int i = 0; i < 10; ++i) a = kModelCost * c + 1 + std::log(a);
  return a;
}

}  // namespace

bool FitHomographyProsac(const std::vector<cv::Point2f> &src, const std::vector<cv::Point2f> &dst,
                         double threshold, int max_iterations, cv::Matx33d *H,
                         std::vector<char> *inliers, double confidence) {
  constexpr int m = 4;
  // Samples drawn at least (budget permitting): the confidence bound assumes that every
  // all-inlier sample gathers the whole consensus, which noisy pairs do not (among 11 figure
  // corners a 7-consensus stopped the search after 30 samples while a 9 existed).
  constexpr int kMinSamples = 100;
  const int count = static_cast<int>(src.size());
  if (static_cast<int>(dst.size()) != count || count < m || max_iterations < 1) return false;
  if (count == m) return FitHomographyRansac(src, dst, threshold, max_iterations, H, inliers);
  const HypothesisTester tester(src, dst, threshold);

  // Chance of an unrelated pair falling within the threshold (SPRT's first guess of a bad
  // model's agreement): the threshold's disc over the area the dst points spread over.
  float x0 = dst[0].x, x1 = x0, y0 = dst[0].y, y1 = y0;
  for (const cv::Point2f &p : dst) {
    x0 = std::min(x0, p.x), x1 = std::max(x1, p.x);
    y0 = std::min(y0, p.y), y1 = std::max(y1, p.y);
  }
  const double area = std::max((double(x1) - x0) * (double(y1) - y0), 1.0);
  const double beta = std::min(1.0, CV_PI * threshold * threshold / area);

  // PROSAC's growth schedule (Chum and Matas, "Matching with PROSAC", CVPR 2005): T_n of
  // the T_N samples that uniform sampling would draw from the first n pairs. T_N is the
  // sample budget, so that sampling has grown to every pair when the budget is spent (with
  // the paper's 200,000 and 1,000 samples, 20 pairs whose 5th-7th are wrong never gave a
  // sample without one of them).
  int n = m;
  double t_n = max_iterations;
  for (int i = 0; i < m; ++i) t_n *= double(n - i) / (count - i);
  int t_n_prime = 2;  // the first sample is the four best pairs (the paper's T'_m = 1 grows
                      // the set to five before it is drawn)

  // SPRT's chances. epsilon, a good model's agreement rate, is bounded from below by the
  // best consensus' share; until a consensus of more than 4 is found there is no bound and
  // every model is checked in full. delta, a bad model's rate, is the mean agreement of the
  // models that were not the best. The test runs only while epsilon is well above delta.
  constexpr double kMinDelta = 1e-3;
  double delta = std::max(beta, kMinDelta), epsilon = 0;
  double decision = std::numeric_limits<double>::infinity();
  int64_t bad_checked = 0, bad_agreed = 0;
  auto update_test = [&] {
    decision = epsilon > 1.5 * delta ? SprtDecisionThreshold(epsilon, delta)
                                     : std::numeric_limits<double>::infinity();
  };

  cv::RNG rng(0x9e3779b97f4a7c15ULL);
  std::vector<char> mask(count), lo_mask(count), best_mask;
  int best = 0;
  double best_cost = std::numeric_limits<double>::infinity();
  int k_max = max_iterations;
  for (int t = 1; t <= k_max; ++t) {
    if (t == t_n_prime && n < count) {
      const double t_next = t_n * (n + 1) / (n + 1 - m);
      t_n_prime += static_cast<int>(std::ceil(t_next - t_n));
      t_n = t_next;
      ++n;
    }
    // While the schedule has not caught up, the newest pair is in every sample.
    const bool with_newest = t <= t_n_prime;
    const int pool = with_newest ? n - 1 : n;
    const int draw = with_newest ? m - 1 : m;
    // An unusable sample counts as drawn: among few pairs, most of which disagree, redrawing
    // until one passes would cost more than the models.
    int idx[m];
    for (int k = 0; k < draw; ++k) {
      bool repeated;
      do {
        idx[k] = rng.uniform(0, pool);
        repeated = false;
        for (int j = 0; j < k; ++j) repeated |= idx[j] == idx[k];
      } while (repeated);
    }
    if (with_newest) idx[m - 1] = n - 1;
    Vec8 h;
    if (!tester.Usable(idx) || !tester.Solve(idx, &h)) continue;
    double cost;
    int checked, agreed;
    int found =
        tester.SequentialConsensus(h, epsilon, delta, decision, &mask, &cost, &checked, &agreed);
    const bool new_best = found > m && (found > best || (found == best && cost < best_cost));
    if (!new_best) {
      // A rejected or lesser model: its agreement updates the bad models' rate.
      bad_checked += checked;
      bad_agreed += agreed;
      const double estimate = std::max(double(bad_agreed) / bad_checked, kMinDelta);
      if (bad_checked >= 50 && std::abs(estimate - delta) > 0.05 * delta) {
        delta = estimate;
        update_test();
      }
      continue;
    }
    // Local optimisation (Chum, Matas and Kittler, "Locally optimized RANSAC", 2003, its
    // iterative form): least squares on the consensus of a threshold that narrows from 3
    // times to the real one, each refit kept when it gathers a better real consensus. A
    // model that fits one corner of the view well grows into the whole view's.
    Vec8 current = h;
    for (const double widen : {3.0, 2.0, 1.5, 1.0}) {
      Vec8 refit;
      double refit_cost;
      // At the real threshold the current model's consensus is `mask` already.
      if (widen > 1) tester.Consensus(current, &lo_mask, nullptr, widen);
      if (!tester.FitMask(widen > 1 ? lo_mask : mask, 3, &refit)) continue;
      const int refit_found = tester.Consensus(refit, &lo_mask, &refit_cost);
      if (refit_found < found || (refit_found == found && refit_cost >= cost)) continue;
      current = refit;
      found = refit_found;
      cost = refit_cost;
      mask.swap(lo_mask);
    }
    best = found;
    best_cost = cost;
    best_mask = mask;
    epsilon = double(best) / count;
    update_test();
    // Termination by the whole list's inlier share, as RANSAC's. PROSAC's own rule (stop
    // once the first n* pairs hold a non-random consensus with enough samples drawn for
    // their share) stops among a few dozen pairs at the first model that fits the head of
    // the list, while a larger consensus of the whole list is still to be drawn; under
    // SPRT the extra samples are cheap.
    // A good model is drawn with share^4 and kept by the test with 1 - 1/A.
    const double good = std::pow(double(best) / count, 4) * (1 - 1 / decision);
    const int k_best = SamplesFor(confidence, good, max_iterations);
    k_max = std::min(k_max, std::max({k_best, t, kMinSamples}));
  }
  // Four pairs fit any sample's homography: a consensus of four is no evidence.
  if (best <= m || !tester.Finish(best_mask, H)) return false;
  if (inliers) *inliers = std::move(best_mask);
  return true;
}

}  // namespace texfree
