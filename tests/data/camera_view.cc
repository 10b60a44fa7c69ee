// Synthetic camera photographs of a page with exact ground truth.
//
// Pipeline (as in a real camera): pinhole projection of the page over a
// textured desk (with trilinear mip-mapping so that minified text is
// anti-aliased like a sensor integrating over its pixel footprint, and a soft
// contact shadow around the sheet), lens defocus, uneven illumination, sensor
// noise, JPEG compression.
#include "tests/data/camera_view.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <vector>

#include "common/planar_pose.h"

namespace texfree::testdata {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

// Portable uniform numbers from raw engine bits (std distributions differ
// between standard libraries).
double Unit(std::mt19937_64 &rng) {
  return static_cast<double>(rng() >> 11) * 0x1.0p-53;
}
double Uniform(std::mt19937_64 &rng, double lo, double hi) {
  return lo + (hi - lo) * Unit(rng);
}

cv::Matx33d AxisAngle(const cv::Vec3d &axis, double angle) {
  cv::Matx33d r;
  cv::Rodrigues(axis * angle, r);
  return r;
}

// Mip level (log2 of page pixels per image pixel) at an image pixel whose
// image->page homography g maps it to page point (x, y) with weight w and
// Jacobian determinant d. The footprint lies between isotropic and worst
// axis (s_max^0.7 * s_min^0.3): close to what a sensor pixel integrates
// without over-blurring strongly tilted views.
float FootprintLevel(const cv::Matx33d &g, double x, double y, double w,
                     double d) {
  const double j00 = (g(0, 0) - x * g(2, 0)) / w;
  const double j01 = (g(0, 1) - x * g(2, 1)) / w;
  const double j10 = (g(1, 0) - y * g(2, 0)) / w;
  const double j11 = (g(1, 1) - y * g(2, 1)) / w;
  const double e = j00 * j00 + j01 * j01 + j10 * j10 + j11 * j11;
  const double disc = std::sqrt(std::max(0.0, e * e - 4 * d * d));
  const double s_max = std::sqrt((e + disc) / 2);
  const double s_min = d / std::max(1e-12, s_max);
  const double level = 0.7 * std::log2(std::max(1e-12, s_max)) +
                       0.3 * std::log2(std::max(1e-12, s_min));
  return static_cast<float>(std::max(0.0, level));
}

// Desk surface: the base colour with blotchy and streaky low-frequency
// texture (wood / laminate) and fine grain.
cv::Mat MakeDesk(const cv::Size &size, const cv::Scalar &colour,
                 std::mt19937_64 &rng) {
  cv::RNG cvrng(rng());
  cv::Mat blotch(std::max(2, size.height / 40), std::max(2, size.width / 40),
                 CV_32FC1);
  cvrng.fill(blotch, cv::RNG::NORMAL, 0, 6);
  cv::resize(blotch, blotch, size, 0, 0, cv::INTER_CUBIC);
  const bool vertical = Unit(rng) < 0.5;
  cv::Mat streak(vertical ? cv::Size(std::max(2, size.width / 3), 4)
                          : cv::Size(4, std::max(2, size.height / 3)),
                 CV_32FC1);
  cvrng.fill(streak, cv::RNG::NORMAL, 0, 5 * Unit(rng));
  cv::resize(streak, streak, size, 0, 0, cv::INTER_CUBIC);
  cv::Mat grain(size, CV_32FC1);
  cvrng.fill(grain, cv::RNG::NORMAL, 0, 2.5);
  cv::Mat desk(size, CV_32FC3);
  for (int y = 0; y < size.height; ++y) {
    const float *b = blotch.ptr<float>(y);
    const float *s = streak.ptr<float>(y);
    const float *g = grain.ptr<float>(y);
    cv::Vec3f *d = desk.ptr<cv::Vec3f>(y);
    for (int x = 0; x < size.width; ++x) {
      const float v = b[x] + s[x] + g[x];
      for (int c = 0; c < 3; ++c) {
        d[x][c] = static_cast<float>(colour[c] * (1.0 + v / 128.0));
      }
    }
  }
  return desk;
}

// Normalised disk kernel of the given radius (anti-aliased edge).
cv::Mat DiskKernel(double radius) {
  const int r = std::max(1, static_cast<int>(std::ceil(radius)));
  cv::Mat k(2 * r + 1, 2 * r + 1, CV_32FC1, cv::Scalar(0));
  for (int y = -r; y <= r; ++y) {
    for (int x = -r; x <= r; ++x) {
      const double d = std::sqrt(static_cast<double>(x * x + y * y));
      k.at<float>(y + r, x + r) =
          static_cast<float>(std::clamp(radius + 0.5 - d, 0.0, 1.0));
    }
  }
  k /= cv::sum(k)[0];
  return k;
}

// Multiplicative light field: linear ramp + vignette + a soft shadow (hand
// or phone between lamp and page) + a slight colour cast, all scaled by
// strength. strength = 0 gives exactly 1.
cv::Mat LightField(const cv::Size &full_size, double strength,
                   std::mt19937_64 &rng) {
  // The field is smooth: compute it on a coarse grid and upsample.
  constexpr int kStep = 8;
  const cv::Size size(full_size.width / kStep + 2,
                      full_size.height / kStep + 2);
  const double dir = Uniform(rng, 0, 2 * kPi);
  const double ramp = strength * Uniform(rng, 0.5, 1.0);
  const double vignette = strength * Uniform(rng, 0.3, 0.8);
  const bool shadow = Unit(rng) < 0.5;
  const double shadow_dir = Uniform(rng, 0, 2 * kPi);
  const double shadow_offset = Uniform(rng, 0.15, 0.45);
  const double shadow_soft = Uniform(rng, 0.03, 0.15);
  const double shadow_depth = strength * Uniform(rng, 0.4, 0.9);
  cv::Vec3d cast;
  for (int c = 0; c < 3; ++c)
    cast[c] = 1.0 + strength * Uniform(rng, -0.08, 0.08);
  const double cx = (full_size.width - 1) / 2.0,
               cy = (full_size.height - 1) / 2.0;
  const double half_diag = std::hypot(cx, cy) + 1e-9;
  const double dx = std::cos(dir), dy = std::sin(dir);
  const double sx = std::cos(shadow_dir), sy = std::sin(shadow_dir);
  cv::Mat field(size, CV_32FC3);
  for (int y = 0; y < size.height; ++y) {
    cv::Vec3f *f = field.ptr<cv::Vec3f>(y);
    for (int x = 0; x < size.width; ++x) {
      const double nx = (x * kStep - cx) / half_diag,
                   ny = (y * kStep - cy) / half_diag;
      double gain = 1.0 - ramp * 0.5 * (1.0 + nx * dx + ny * dy) -
                    vignette * (nx * nx + ny * ny);
      if (shadow) {
        const double s = (nx * sx + ny * sy - shadow_offset) / shadow_soft;
        gain -= shadow_depth / (1.0 + std::exp(-s));
      }
      gain = std::max(0.08, gain);
      for (int c = 0; c < 3; ++c) f[x][c] = static_cast<float>(gain * cast[c]);
    }
  }
  // Grid point (x, y) sits at full-resolution pixel (kStep x, kStep y).
  const cv::Matx23d to_full(kStep, 0, 0, 0, kStep, 0);
  cv::Mat full;
  cv::warpAffine(field, full, to_full, full_size, cv::INTER_LINEAR,
                 cv::BORDER_REPLICATE);
  return full;
}

// Lift of the curled sheet towards the camera (page pixels) at page point
// (x, y), on the sheet's surface extended past its edges; and its gradient.
double CurlLift(const CameraViewOptions &o, const cv::Size &page, double x, double y,
                cv::Point2d *gradient = nullptr) {
  const double az = o.curl_azimuth_deg * kDeg;
  const double ca = std::cos(az), sa = std::sin(az);
  const double half = 0.5 * (std::abs(page.width * ca) + std::abs(page.height * sa));
  const double d = ((x - (page.width - 1) / 2.0) * ca + (y - (page.height - 1) / 2.0) * sa) /
                   std::max(1.0, half);
  const double lift = o.page_curl * page.width;
  double value, slope;  // slope: d(value)/d(d)
  if (o.curl_one_sided) {
    value = lift * 0.25 * (d + 1) * (d + 1);
    slope = lift * 0.5 * (d + 1);
  } else {
    value = lift * d * d;
    slope = lift * 2 * d;
  }
  if (gradient) {
    *gradient = cv::Point2d(slope * ca, slope * sa) / std::max(1.0, half);
  }
  return value;
}

bool OnPage(const cv::Size &page, double x, double y) {
  return x >= -0.5 && y >= -0.5 && x <= page.width - 0.5 && y <= page.height - 0.5;
}

// Normalised camera coordinates of the ideal ray that the lens bends onto
// normalised distorted coordinates (xd, yd) (OpenCV's radial k1, inverted by
// fixed-point iteration: the factor is near 1 over a camera's field).
cv::Point2d UndistortK1(double xd, double yd, double k1) {
  double x = xd, y = yd;
  for (int i = 0; i < 20 && k1 != 0; ++i) {
    const double f = 1 + k1 * (x * x + y * y);
    x = xd / f;
    y = yd / f;
  }
  return {x, y};
}

// The page (or desk) point a pixel's ray meets, for a curled sheet seen
// through a distorting lens, and the Lambertian gain of the sheet's slope
// there (1 on the desk and on a flat sheet). false when the ray meets neither.
bool TraceRay(const CameraView &view, const CameraViewOptions &o, const cv::Size &page, double u,
              double v, cv::Point2d *point, float *gain) {
  const cv::Matx33d &k = view.camera_matrix;
  const cv::Point2d n = UndistortK1((u - k(0, 2)) / k(0, 0), (v - k(1, 2)) / k(1, 1), o.radial_k1);
  const cv::Matx33d rt = view.rotation.t();
  const cv::Vec3d dir = rt * cv::Vec3d(n.x, n.y, 1);
  const cv::Vec3d c = -(rt * view.translation);
  if (dir[2] <= 1e-12) return false;
  const double s_desk = -c[2] / dir[2];
  *gain = 1;
  if (o.page_curl > 0) {
    // The sheet is Z = -lift(X, Y): fixed-point iteration on the ray's depth
    // from the desk plane (the lift's slope along a ray stays well under 1).
    double s = s_desk;
    for (int i = 0; i < 30; ++i) {
      const cv::Vec3d p = c + s * dir;
      const double next = (-CurlLift(o, page, p[0], p[1]) - c[2]) / dir[2];
      const bool converged = std::abs(next - s) < 1e-9 * s;
      s = next;
      if (converged) break;
    }
    const cv::Vec3d p = c + s * dir;
    if (OnPage(page, p[0], p[1])) {
      cv::Point2d g;
      CurlLift(o, page, p[0], p[1], &g);
      // Light from 35 deg off the desk's normal, across the curl.
      const double la = (o.curl_azimuth_deg + 60) * kDeg;
      const cv::Vec3d light(std::sin(35 * kDeg) * std::cos(la), std::sin(35 * kDeg) * std::sin(la),
                            -std::cos(35 * kDeg));
      const cv::Vec3d normal = cv::normalize(cv::Vec3d(-g.x, -g.y, -1));
      *gain = static_cast<float>(std::max(0.2, normal.dot(light)) / std::cos(35 * kDeg));
      *point = {p[0], p[1]};
      return true;
    }
  }
  const cv::Vec3d p = c + s_desk * dir;
  *point = {p[0], p[1]};
  return true;
}

void AppendMatrix(std::ostringstream &os, const double *v, int n) {
  os << "[";
  char buf[40];
  for (int i = 0; i < n; ++i) {
    std::snprintf(buf, sizeof(buf), "%.17g", v[i]);
    os << (i ? ", " : "") << buf;
  }
  os << "]";
}

// The page over the desk as an ideal camera with page -> image homography
// `homography` sees it (float BGR, `size`): mip-mapped page, anti-aliased
// sheet edge, soft contact shadow.
cv::Mat ComposeFlat(const cv::Mat &page, const cv::Matx33d &homography, const cv::Size &size,
                    const cv::Scalar &background, std::mt19937_64 &rng) {
  const cv::Matx33d g = homography.inv();  // image -> page

  // Per-pixel footprint (page pixels per image pixel) and page coverage.
  constexpr int kMaxLevel = 6;
  cv::Mat coarse_level(size.height / 4 + 2, size.width / 4 + 2, CV_32FC1,
                       cv::Scalar(0));
  cv::Mat alpha_map(size, CV_32FC1), shadow_map(size, CV_32FC1);
  const double page_w = page.cols, page_h = page.rows;
  const double det_g = cv::determinant(g);
  for (int v = 0; v < size.height; ++v) {
    float *al = alpha_map.ptr<float>(v);
    float *sh = shadow_map.ptr<float>(v);
    for (int u = 0; u < size.width; ++u) {
      const double w = g(2, 0) * u + g(2, 1) * v + g(2, 2);
      if (w <= 1e-12) {  // ray does not meet the page plane
        al[u] = 0;
        sh[u] = 1;
        continue;
      }
      const double x = (g(0, 0) * u + g(0, 1) * v + g(0, 2)) / w;
      const double y = (g(1, 0) * u + g(1, 1) * v + g(1, 2)) / w;
      const double d = std::abs(det_g / (w * w * w));
      const double inside = std::min(std::min(x + 0.5, page_w - 0.5 - x),
                                     std::min(y + 0.5, page_h - 0.5 - y));
      const double inside_px = inside / std::sqrt(std::max(1e-12, d));
      al[u] = static_cast<float>(std::clamp(inside_px + 0.5, 0.0, 1.0));
      // Soft contact shadow of the sheet on the desk.
      sh[u] = inside_px >= 0 || inside_px < -40
                  ? 1.0f
                  : static_cast<float>(1.0 - 0.3 * std::exp(inside_px / 4.0));
    }
  }
  // Mip level on a grid of every 4th pixel (the footprint varies smoothly),
  // then upsampled to full resolution.
  for (int gv = 0; gv < coarse_level.rows; ++gv) {
    for (int gu = 0; gu < coarse_level.cols; ++gu) {
      const double u = 4.0 * gu, v = 4.0 * gv;
      const double w = g(2, 0) * u + g(2, 1) * v + g(2, 2);
      if (w <= 1e-12) continue;
      const double x = (g(0, 0) * u + g(0, 1) * v + g(0, 2)) / w;
      const double y = (g(1, 0) * u + g(1, 1) * v + g(1, 2)) / w;
      const double d = std::abs(det_g / (w * w * w));
      coarse_level.at<float>(gv, gu) = std::min(static_cast<float>(kMaxLevel),
                                                FootprintLevel(g, x, y, w, d));
    }
  }
  cv::Mat level_map;
  cv::warpAffine(coarse_level, level_map, cv::Matx23d(4, 0, 0, 0, 4, 0), size,
                 cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  float max_level = 0;
  for (int v = 0; v < size.height; ++v) {
    const float *lv = level_map.ptr<float>(v);
    const float *al = alpha_map.ptr<float>(v);
    for (int u = 0; u < size.width; ++u) {
      if (al[u] > 0) max_level = std::max(max_level, lv[u]);
    }
  }

  // Mip levels of the page, each warped with its own homography.
  const int levels = static_cast<int>(std::ceil(max_level)) + 1;
  std::vector<cv::Mat> warped(static_cast<size_t>(levels));
  cv::Mat level_image = page;
  for (int k = 0; k < levels; ++k) {
    if (k > 0) cv::pyrDown(level_image, level_image);
    const double f = std::ldexp(1.0, k);
    const cv::Matx33d hk = homography * cv::Matx33d(f, 0, 0, 0, f, 0, 0, 0, 1);
    cv::warpPerspective(level_image, warped[static_cast<size_t>(k)], hk, size,
                        cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  }

  cv::Mat image = MakeDesk(size, background, rng);
  for (int v = 0; v < size.height; ++v) {
    const float *lv = level_map.ptr<float>(v);
    const float *al = alpha_map.ptr<float>(v);
    const float *sh = shadow_map.ptr<float>(v);
    cv::Vec3f *out = image.ptr<cv::Vec3f>(v);
    for (int u = 0; u < size.width; ++u) {
      out[u] *= sh[u];
      if (al[u] <= 0) continue;
      const int k0 = std::min(levels - 1, static_cast<int>(lv[u]));
      const int k1 = std::min(levels - 1, k0 + 1);
      const float frac = lv[u] - static_cast<float>(k0);
      const cv::Vec3b &p0 = warped[static_cast<size_t>(k0)].at<cv::Vec3b>(v, u);
      const cv::Vec3b &p1 = warped[static_cast<size_t>(k1)].at<cv::Vec3b>(v, u);
      for (int c = 0; c < 3; ++c) {
        const float p = p0[c] + frac * (static_cast<float>(p1[c]) - p0[c]);
        out[u][c] = al[u] * p + (1 - al[u]) * out[u][c];
      }
    }
  }

  return image;
}

}  // namespace

CameraView ComputeCameraGeometry(const cv::Size &page_size, const CameraViewOptions &options) {
  CameraView view;
  const cv::Size size = options.image_size;
  const double fx = (size.width / 2.0) / std::tan(options.horizontal_fov_deg * kDeg / 2.0);
  const double cx = (size.width - 1) / 2.0, cy = (size.height - 1) / 2.0;
  view.camera_matrix = cv::Matx33d(fx, 0, cx, 0, fx, cy, 0, 0, 1);

  cv::Point2d look_at = options.look_at;
  if (look_at.x == -1 && look_at.y == -1) {
    look_at = {(page_size.width - 1) / 2.0, (page_size.height - 1) / 2.0};
  }
  // Camera axes in world coordinates: start aligned with the page (x right,
  // y down, z into the page), roll about the optical axis, then tilt about an
  // in-plane axis perpendicular to the azimuth direction so that the optical
  // axis leans towards the azimuth direction.
  const double az = options.tilt_azimuth_deg * kDeg;
  const cv::Vec3d tilt_axis(-std::sin(az), std::cos(az), 0);
  const cv::Matx33d cam_to_world = AxisAngle(tilt_axis, options.tilt_deg * kDeg) *
                                   AxisAngle(cv::Vec3d(0, 0, 1), options.roll_deg * kDeg);
  const cv::Vec3d axis(cam_to_world(0, 2), cam_to_world(1, 2), cam_to_world(2, 2));
  const double distance = fx / std::max(1e-9, options.scale);
  const cv::Vec3d centre = cv::Vec3d(look_at.x, look_at.y, 0) - distance * axis;
  view.rotation = cam_to_world.t();
  view.translation = -(view.rotation * centre);

  const cv::Matx33d &r = view.rotation;
  const cv::Vec3d &t = view.translation;
  const cv::Matx33d rt(r(0, 0), r(0, 1), t[0], r(1, 0), r(1, 1), t[1], r(2, 0), r(2, 1), t[2]);
  cv::Matx33d h = view.camera_matrix * rt;
  // Scale to h22 = 1 unless that flips the sign: when the camera is close and
  // steeply tilted, the page origin lies behind the camera (h22 < 0) and the
  // visible part of the page must keep w > 0 (w is the depth of a page point).
  h *= 1.0 / (std::abs(h(2, 2)) > 1e-9 ? std::abs(h(2, 2)) : cv::norm(h));
  view.homography = h;
  return view;
}

CameraView RenderCameraView(const cv::Mat &page_in, const CameraViewOptions &options,
                            uint64_t seed) {
  CV_Assert(!page_in.empty() && page_in.depth() == CV_8U);
  cv::Mat page;
  if (page_in.channels() == 1) {
    cv::cvtColor(page_in, page, cv::COLOR_GRAY2BGR);
  } else if (page_in.channels() == 4) {
    cv::cvtColor(page_in, page, cv::COLOR_BGRA2BGR);
  } else {
    page = page_in;
  }
  std::mt19937_64 rng(seed ^ 0x63616d6572613031ULL);
  CameraView view = ComputeCameraGeometry(page.size(), options);
  const cv::Size size = options.image_size;
  cv::Mat image;
  if (options.page_curl <= 0 && options.radial_k1 == 0) {
    image = ComposeFlat(page, view.homography, size, options.background, rng);
  } else {
    // The flat page seen through an ideal lens, over a larger frame (a barrel
    // lens sees past the ideal frame's edges), then each pixel's ray traced
    // through the lens onto the curled sheet and looked up there.
    const int pad_x = size.width / 4, pad_y = size.height / 4;
    const cv::Matx33d to_flat = cv::Matx33d(1, 0, pad_x, 0, 1, pad_y, 0, 0, 1) * view.homography;
    const cv::Mat flat =
        ComposeFlat(page, to_flat, cv::Size(size.width + 2 * pad_x, size.height + 2 * pad_y),
                    options.background, rng);
    cv::Mat map_x(size, CV_32FC1), map_y(size, CV_32FC1), gain(size, CV_32FC3);
    for (int v = 0; v < size.height; ++v) {
      for (int u = 0; u < size.width; ++u) {
        cv::Point2d point;
        float g = 1;
        cv::Point2d q(-1e4, -1e4);
        if (TraceRay(view, options, page.size(), u, v, &point, &g))
          q = ApplyHomography(to_flat, point);
        map_x.at<float>(v, u) = static_cast<float>(q.x);
        map_y.at<float>(v, u) = static_cast<float>(q.y);
        gain.at<cv::Vec3f>(v, u) = cv::Vec3f(g, g, g);
      }
    }
    cv::remap(flat, image, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
    cv::multiply(image, gain, image);
  }

  // Lens defocus: Gaussian or disk (chosen by the seed).
  const bool disk = Unit(rng) < 0.5;
  if (options.blur_sigma > 0.05) {
    if (disk) {
      cv::filter2D(image, image, -1, DiskKernel(2.0 * options.blur_sigma),
                   cv::Point(-1, -1), 0, cv::BORDER_REFLECT);
    } else {
      cv::GaussianBlur(image, image, cv::Size(0, 0), options.blur_sigma, 0,
                       cv::BORDER_REFLECT);
    }
  }
  // Camera shake during the exposure: a line kernel (anti-aliased ends).
  if (options.motion_blur_px > 0.5) {
    cv::filter2D(image, image, -1,
                 MotionBlurKernel(options.motion_blur_px, options.motion_blur_angle_deg),
                 cv::Point(-1, -1), 0, cv::BORDER_REFLECT);
  }
  // Uneven light.
  const uint64_t light_seed = rng();
  if (options.illumination_gradient > 0) {
    std::mt19937_64 light_rng(light_seed);
    cv::multiply(image,
                 LightField(size, std::min(0.9, options.illumination_gradient),
                            light_rng),
                 image);
  }
  // Glare: the veil is light the paper reflects, added before the sensor's
  // noise and clipped with it where it passes white.
  if (options.glare > 0) {
    cv::Mat veil(size, CV_32FC3);
    const double sigma = std::max(1.0, options.glare_radius * std::hypot(size.width, size.height));
    const double cx = options.glare_centre.x * size.width;
    const double cy = options.glare_centre.y * size.height;
    for (int y = 0; y < size.height; ++y) {
      cv::Vec3f *row = veil.ptr<cv::Vec3f>(y);
      for (int x = 0; x < size.width; ++x) {
        const double d2 = (x - cx) * (x - cx) + (y - cy) * (y - cy);
        const float v =
            static_cast<float>(255 * options.glare * std::exp(-d2 / (2 * sigma * sigma)));
        row[x] = cv::Vec3f(v, v, v);
      }
    }
    image += veil;
  }
  // Sensor noise.
  const uint64_t noise_seed = rng();
  if (options.noise_sigma > 0) {
    cv::Mat noise(size, CV_32FC3);
    cv::RNG cvrng(noise_seed);
    cvrng.fill(noise, cv::RNG::NORMAL, 0, options.noise_sigma);
    image += noise;
  }
  image.convertTo(view.image, CV_8UC3);
  // Compression.
  if (options.jpeg_quality > 0) {
    std::vector<uint8_t> jpeg;
    cv::imencode(
        ".jpg", view.image, jpeg,
        {cv::IMWRITE_JPEG_QUALITY, std::clamp(options.jpeg_quality, 1, 100)});
    view.image = cv::imdecode(jpeg, cv::IMREAD_COLOR);
  }
  return view;
}

CameraViewOptions RandomViewOptions(std::mt19937_64 &rng,
                                    const cv::Size &page_size,
                                    double max_tilt_deg, double min_scale,
                                    double max_scale) {
  CameraViewOptions o;
  o.horizontal_fov_deg = Uniform(rng, 50, 70);
  o.tilt_deg = Uniform(rng, 0, max_tilt_deg);
  o.tilt_azimuth_deg = Uniform(rng, -180, 180);
  o.roll_deg = Uniform(rng, -180, 180);
  o.scale = Uniform(rng, min_scale, max_scale);
  o.look_at.x = Uniform(rng, 0.3, 0.7) * (page_size.width - 1);
  o.look_at.y = Uniform(rng, 0.3, 0.7) * (page_size.height - 1);
  o.blur_sigma = Uniform(rng, 0, 1.5);
  o.noise_sigma = Uniform(rng, 0, 6);
  o.illumination_gradient = Uniform(rng, 0, 0.5);
  o.jpeg_quality = static_cast<int>(rng() % 36) + 60;
  // Desk colours: wood, grey laminate, dark, near-white, green felt.
  static const cv::Scalar kDesks[] = {
      {40, 80, 130},   {55, 105, 160}, {90, 90, 90},  {40, 40, 45},
      {170, 175, 180}, {60, 110, 60},  {120, 100, 90}};
  const int desk = static_cast<int>(rng() % 7);
  for (int c = 0; c < 3; ++c) {
    o.background[c] =
        std::clamp(kDesks[desk][c] * Uniform(rng, 0.8, 1.2), 0.0, 255.0);
  }
  return o;
}

std::string CameraViewGroundTruthJson(const CameraView &view,
                                      const CameraViewOptions &o) {
  std::ostringstream os;
  os << "{\n  \"homography\": ";
  AppendMatrix(os, view.homography.val, 9);
  os << ",\n  \"camera_matrix\": ";
  AppendMatrix(os, view.camera_matrix.val, 9);
  os << ",\n  \"rotation\": ";
  AppendMatrix(os, view.rotation.val, 9);
  os << ",\n  \"translation\": ";
  AppendMatrix(os, view.translation.val, 3);
  os << ",\n  \"image_width\": " << o.image_size.width
     << ",\n  \"image_height\": " << o.image_size.height;
  const double scalars[] = {o.horizontal_fov_deg,
                            o.tilt_deg,
                            o.tilt_azimuth_deg,
                            o.roll_deg,
                            o.scale,
                            o.look_at.x,
                            o.look_at.y,
                            o.blur_sigma,
                            o.noise_sigma,
                            o.illumination_gradient};
  const char *names[] = {"horizontal_fov_deg",
                         "tilt_deg",
                         "tilt_azimuth_deg",
                         "roll_deg",
                         "scale",
                         "look_at_x",
                         "look_at_y",
                         "blur_sigma",
                         "noise_sigma",
                         "illumination_gradient"};
  os << ",\n  \"options\": {";
  char buf[40];
  for (int i = 0; i < 10; ++i) {
    std::snprintf(buf, sizeof(buf), "%.17g", scalars[i]);
    os << (i ? ", " : "") << "\"" << names[i] << "\": " << buf;
  }
  os << ", \"jpeg_quality\": " << o.jpeg_quality << ", \"background\": ";
  AppendMatrix(os, o.background.val, 3);
  std::snprintf(buf, sizeof(buf), "%.17g", o.page_curl);
  os << ", \"page_curl\": " << buf;
  std::snprintf(buf, sizeof(buf), "%.17g", o.curl_azimuth_deg);
  os << ", \"curl_azimuth_deg\": " << buf
     << ", \"curl_one_sided\": " << (o.curl_one_sided ? "true" : "false");
  std::snprintf(buf, sizeof(buf), "%.17g", o.radial_k1);
  os << ", \"radial_k1\": " << buf;
  std::snprintf(buf, sizeof(buf), "%.17g", o.motion_blur_px);
  os << ", \"motion_blur_px\": " << buf;
  std::snprintf(buf, sizeof(buf), "%.17g", o.motion_blur_angle_deg);
  os << ", \"motion_blur_angle_deg\": " << buf;
  std::snprintf(buf, sizeof(buf), "%.17g", o.glare);
  os << ", \"glare\": " << buf;
  std::snprintf(buf, sizeof(buf), "%.17g", o.glare_radius);
  os << ", \"glare_radius\": " << buf << ", \"glare_centre\": ";
  const double centre[2] = {o.glare_centre.x, o.glare_centre.y};
  AppendMatrix(os, centre, 2);
  os << "}\n}\n";
  return os.str();
}

namespace {

// Mean distance in image pixels between where `estimated` and `truth(p)` put an 11 x 11
// grid of page points p, over the points `truth` places inside the image (finite).
template <typename Truth>
double MeanGridError(const cv::Matx33d &estimated, const cv::Size &page_size,
                     const cv::Size &image_size, const Truth &truth) {
  double sum = 0;
  int n = 0;
  for (int y = 0; y <= 10; ++y) {
    for (int x = 0; x <= 10; ++x) {
      const cv::Point2d p(page_size.width * x / 10.0, page_size.height * y / 10.0);
      const cv::Point2d t = truth(p);
      if (!std::isfinite(t.x) || !std::isfinite(t.y) || t.x < 0 || t.y < 0 ||
          t.x >= image_size.width || t.y >= image_size.height)
        continue;
      sum += cv::norm(ApplyHomography(estimated, p) - t);
      ++n;
    }
  }
  return n ? sum / n : 1e9;
}

}  // namespace

double MeanHomographyError(const cv::Matx33d &estimated, const cv::Matx33d &truth,
                           const cv::Size &page_size, const cv::Size &image_size) {
  return MeanGridError(estimated, page_size, image_size,
                       [&truth](const cv::Point2d &p) { return ApplyHomography(truth, p); });
}

cv::Point2d ProjectPagePoint(const CameraView &view, const CameraViewOptions &options,
                             const cv::Size &page_size, const cv::Point2d &page_point) {
  const double lift =
      options.page_curl > 0 ? CurlLift(options, page_size, page_point.x, page_point.y) : 0.0;
  const cv::Vec3d c =
      view.rotation * cv::Vec3d(page_point.x, page_point.y, -lift) + view.translation;
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  if (c[2] <= 1e-9) return {kNaN, kNaN};
  double x = c[0] / c[2], y = c[1] / c[2];
  // Past r^2 = -1 / (3 k1) a barrel polynomial folds back towards the centre:
  // no lens images such rays into the frame.
  const double r2 = x * x + y * y;
  if (options.radial_k1 < 0 && r2 >= -1 / (3 * options.radial_k1)) return {kNaN, kNaN};
  const double f = 1 + options.radial_k1 * r2;
  x *= f;
  y *= f;
  const cv::Matx33d &k = view.camera_matrix;
  return {k(0, 0) * x + k(0, 1) * y + k(0, 2), k(1, 1) * y + k(1, 2)};
}

void DrawBends(uint64_t stream_seed, double max_curl, double max_k1, double max_motion_px,
               CameraViewOptions *options) {
  std::mt19937_64 bend(stream_seed);
  options->page_curl = max_curl * Unit(bend);
  options->curl_azimuth_deg = Uniform(bend, -180, 180);
  options->curl_one_sided = Unit(bend) < 0.5;
  options->radial_k1 = max_k1 * (1.5 * Unit(bend) - 1.0);
  options->motion_blur_px = max_motion_px * Unit(bend);
  options->motion_blur_angle_deg = 180 * Unit(bend);
}

void DrawGlare(uint64_t stream_seed, double max_glare, CameraViewOptions *options) {
  std::mt19937_64 glare(stream_seed);
  options->glare = max_glare * Unit(glare);
  options->glare_radius = Uniform(glare, 0.06, 0.18);
  options->glare_centre = {Uniform(glare, 0.15, 0.85), Uniform(glare, 0.15, 0.85)};
}

// Supersampled along the line so that any length and angle integrates smoothly.
cv::Mat MotionBlurKernel(double length, double angle_deg) {
  const int r = static_cast<int>(std::ceil(length / 2)) + 1;
  cv::Mat k(2 * r + 1, 2 * r + 1, CV_32FC1, cv::Scalar(0));
  const double dx = std::cos(angle_deg * kDeg), dy = std::sin(angle_deg * kDeg);
  const int samples = static_cast<int>(std::ceil(length * 8)) + 1;
  for (int i = 0; i < samples; ++i) {
    const double s = length * (static_cast<double>(i) / (samples - 1) - 0.5);
    const double x = r + s * dx, y = r + s * dy;
    const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
    const double fx = x - x0, fy = y - y0;
    k.at<float>(y0, x0) += static_cast<float>((1 - fx) * (1 - fy));
    k.at<float>(y0, x0 + 1) += static_cast<float>(fx * (1 - fy));
    k.at<float>(y0 + 1, x0) += static_cast<float>((1 - fx) * fy);
    k.at<float>(y0 + 1, x0 + 1) += static_cast<float>(fx * fy);
  }
  k /= cv::sum(k)[0];
  return k;
}

cv::Mat UndistortView(const cv::Mat &image, const CameraView &view, CameraViewOptions *options) {
  if (options->radial_k1 == 0) return image;
  cv::Mat ideal;
  cv::undistort(image, ideal, cv::Mat(view.camera_matrix),
                cv::Mat(std::vector<double>{options->radial_k1, 0, 0, 0, 0}));
  options->radial_k1 = 0;
  return ideal;
}

double MeanProjectionError(const cv::Matx33d &estimated, const CameraView &view,
                           const CameraViewOptions &options, const cv::Size &page_size) {
  return MeanGridError(estimated, page_size, options.image_size, [&](const cv::Point2d &p) {
    return ProjectPagePoint(view, options, page_size, p);
  });
}

}  // namespace texfree::testdata
