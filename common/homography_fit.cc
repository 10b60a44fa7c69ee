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

// The minimal sample's homography in normalised coordinates (H(2, 2) = 1): the 8x8 linear
// system of four pairs.
bool SolveFour(const cv::Point2d *s, const cv::Point2d *d, Vec8 *h) {
  Mat8 A;
  Vec8 b;
  for (int i = 0; i < 4; ++i) {
    const double x = s[i].x, y = s[i].y, u = d[i].x, v = d[i].y;
    A.row(2 * i) << x, y, 1, 0, 0, 0, -u * x, -u * y;
    A.row(2 * i + 1) << 0, 0, 0, x, y, 1, -v * x, -v * y;
    b[2 * i] = u;
    b[2 * i + 1] = v;
  }
  Eigen::FullPivLU<Mat8> lu(A);
  if (!lu.isInvertible()) return false;
  *h = lu.solve(b);
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

// Samples needed to draw an all-inlier sample of 4 with `confidence`, given the outlier
// share (cv::RANSACUpdateNumIters).
int UpdateIterations(double confidence, double outliers, int max_iterations) {
  const double num = std::log(std::max(1 - confidence, DBL_MIN));
  const double denom_arg = 1 - std::pow(1 - outliers, 4);
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
  Normalisation ns, nd;
  std::vector<cv::Point2d> s, d;
  NormalisePairs(src, dst, &ns, &nd, &s, &d);
  const double gate2 = threshold * nd.scale * threshold * nd.scale;
  // The samples are drawn as cv::findHomography draws them (its generator and seed, the
  // same tests), so that both find the same consensus and a caller moving from it keeps
  // its inliers.
  cv::RNG rng(0xffffffffffffffffULL);
  std::vector<char> mask(count), best_mask;
  int best = 0;
  int iterations = max_iterations;
  for (int it = 0; it < iterations; ++it) {
    int idx[4];
    cv::Point2f ps[4], pd[4];
    bool drawn = false;
    for (int attempt = 0; attempt < 10000 && !drawn; ++attempt) {
      for (int k = 0; k < 4; ++k) {
        bool repeated;
        do {
          idx[k] = rng.uniform(0, static_cast<int>(count));
          repeated = false;
          for (int j = 0; j < k; ++j) repeated |= idx[j] == idx[k];
        } while (repeated);
        ps[k] = src[idx[k]];
        pd[k] = dst[idx[k]];
      }
      drawn = GoodSample(ps, pd);
    }
    if (!drawn) break;
    cv::Point2d ss[4], sd[4];
    for (int k = 0; k < 4; ++k) {
      ss[k] = s[idx[k]];
      sd[k] = d[idx[k]];
    }
    Vec8 h;
    if (!SolveFour(ss, sd, &h)) continue;
    int found = 0;
    for (size_t i = 0; i < count; ++i) {
      cv::Point2d q;
      double w;
      const bool in = Project(h, s[i], &q, &w) && (q - d[i]).dot(q - d[i]) <= gate2;
      mask[i] = in;
      found += in;
    }
    if (found > std::max(best, 3)) {
      best = found;
      best_mask = mask;
      iterations = std::min(iterations,
                            UpdateIterations(0.995, double(count - found) / count, max_iterations));
    }
  }
  if (best < 4) return false;
  std::vector<cv::Point2d> is, id;
  for (size_t i = 0; i < count; ++i)
    if (best_mask[i]) {
      is.push_back(s[i]);
      id.push_back(d[i]);
    }
  cv::Matx33d Hn;
  if (!FitNormalised(is, id, 10, &Hn)) return false;
  *H = Denormalise(Hn, ns, nd);
  if (inliers) *inliers = std::move(best_mask);
  return std::isfinite(cv::norm(*H));
}

}  // namespace texfree
