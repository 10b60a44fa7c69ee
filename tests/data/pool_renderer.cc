// Ray-cast pool table photographs with exact ground truth (see pool_renderer.h).
#include "tests/data/pool_renderer.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "tests/data/camera_view.h"

namespace texfree::testdata {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;
constexpr double kFloorZ = -760;   // floor below the cloth
constexpr double kApronDepth = 180;  // rail outer face height
constexpr double kLampHeight = 900;
// The lamp radius the materials' shininess is given for (PoolScene::lamp_radius_mm's
// default): a larger lamp widens the highlights from there.
constexpr double kMaterialLampRadius = 70;
constexpr int kSupersample = 3;

double Unit(std::mt19937_64& rng) { return static_cast<double>(rng() >> 11) * 0x1.0p-53; }
double Uniform(std::mt19937_64& rng, double lo, double hi) { return lo + (hi - lo) * Unit(rng); }

// The sRGB transfer curve and its inverse, on 0..255 values.
double SrgbDecode(double v) {
  const double x = std::clamp(v / 255, 0.0, 1.0);
  return 255 * (x <= 0.04045 ? x / 12.92 : std::pow((x + 0.055) / 1.055, 2.4));
}
double SrgbEncode(double v) {
  const double x = std::clamp(v / 255, 0.0, 1.0);
  return 255 * (x <= 0.0031308 ? 12.92 * x : 1.055 * std::pow(x, 1 / 2.4) - 0.055);
}

double SmoothStep(double x) {
  x = std::clamp(x, 0.0, 1.0);
  return x * x * (3 - 2 * x);
}

struct Ray {
  cv::Vec3d o, d;  // d unit
};

struct Pocket {
  cv::Point2d centre;
  double radius;
};

// Ball surface pattern: solids have two white number discs on opposite poles of a random
// axis; the 9 is white with a yellow band around a random axis and number discs on it.
struct BallModel {
  int number;
  cv::Vec3d centre;
  cv::Vec3d axis;    // stripe / number-disc axis (unit)
  cv::Vec3d albedo;  // RGB
};

enum class Surface {
  kNone,
  kBall,
  kCloth,
  kCushionTop,
  kCushionFace,
  kRail,
  kRailFace,
  kFloor,
  kPocket,
  kCueShaft,
  kCueButt
};

// A finite cylinder (a cue stick's shaft or butt).
struct Cylinder {
  cv::Vec3d a, axis;  // start and unit axis
  double length, radius;
};

// Ray parameter of the first hit on the cylinder's side (-1: none).
double CylinderT(const Ray& ray, const Cylinder& c, cv::Vec3d* normal) {
  const cv::Vec3d oa = ray.o - c.a;
  const cv::Vec3d d_perp = ray.d - ray.d.dot(c.axis) * c.axis;
  const cv::Vec3d o_perp = oa - oa.dot(c.axis) * c.axis;
  const double qa = d_perp.dot(d_perp), qb = 2 * d_perp.dot(o_perp),
               qc = o_perp.dot(o_perp) - c.radius * c.radius;
  if (qa < 1e-12) return -1;
  const double disc = qb * qb - 4 * qa * qc;
  if (disc < 0) return -1;
  for (double t : {(-qb - std::sqrt(disc)) / (2 * qa), (-qb + std::sqrt(disc)) / (2 * qa)}) {
    if (t <= 1e-6) continue;
    const cv::Vec3d p = ray.o + t * ray.d;
    const double along = (p - c.a).dot(c.axis);
    if (along < 0 || along > c.length) continue;
    const cv::Vec3d n = p - (c.a + along * c.axis);
    *normal = n / std::max(1e-9, cv::norm(n));
    return t;
  }
  return -1;
}

// Shortest distance between segments p0-p1 and q0-q1.
double SegmentDistance(const cv::Vec3d& p0, const cv::Vec3d& p1, const cv::Vec3d& q0,
                       const cv::Vec3d& q1) {
  const cv::Vec3d u = p1 - p0, v = q1 - q0, w = p0 - q0;
  const double a = u.dot(u), b = u.dot(v), c = v.dot(v), d = u.dot(w), e = v.dot(w);
  const double den = a * c - b * b;
  double s = den > 1e-12 ? std::clamp((b * e - c * d) / den, 0.0, 1.0) : 0.0;
  double t = c > 1e-12 ? std::clamp((b * s + e) / c, 0.0, 1.0) : 0.0;
  s = a > 1e-12 ? std::clamp((b * t - d) / a, 0.0, 1.0) : 0.0;
  return cv::norm(w + s * u - t * v);
}

struct Hit {
  Surface surface = Surface::kNone;
  double t = std::numeric_limits<double>::infinity();
  cv::Vec3d p, n;
  int ball = -1;
};

class Scene {
 public:
  Scene(const PoolScene& scene, uint64_t seed) : s_(scene), t_(scene.table) {
    std::mt19937_64 rng(seed ^ 0x706f6f6c72656e64ULL);
    const double L = t_.length_mm, W = t_.width_mm;
    const double rc = t_.corner_pocket_mm / 2, rs = t_.side_pocket_mm / 2;
    const double a = 0.3 * rc, b = 0.35 * rs;
    pockets_ = {{{-a, -a}, rc},       {{L + a, -a}, rc}, {{L + a, W + a}, rc},
                {{-a, W + a}, rc},    {{L / 2, -b}, rs}, {{L / 2, W + b}, rs}};
    for (const auto& placement : scene.balls) {
      BallModel m;
      m.number = placement.number;
      m.centre = {placement.x_mm, placement.y_mm, t_.ball_radius_mm};
      cv::Vec3d axis(Uniform(rng, -1, 1), Uniform(rng, -1, 1), Uniform(rng, -1, 1));
      m.axis = axis / std::max(1e-9, cv::norm(axis));
      m.albedo = PoolBallRgb(placement.number, scene.ball_set);
      balls_.push_back(m);
    }
    const int lamps = std::clamp(scene.lamps, 1, 3);
    for (int i = 0; i < lamps; ++i)
      lamps_.push_back(cv::Vec3d(L * (i + 1) / (lamps + 1), W / 2, kLampHeight) +
                       scene.lamp_shift_mm);
    lamp_power_ = 1.0 / lamps * (lamps == 1 ? 1.0 : 1.25);
    texture_.create(256, 256, CV_32FC1);
    cv::RNG cvrng(rng());
    cvrng.fill(texture_, cv::RNG::NORMAL, 0, 1);
    cv::GaussianBlur(texture_, texture_, cv::Size(0, 0), 0.7, 0, cv::BORDER_REFLECT);
    cv::normalize(texture_, texture_, 1, 0, cv::NORM_L2);
    texture_ *= 256.0;  // unit variance
    for (int i = 0; i < 3; ++i) cloth_cast_[i] = Uniform(rng, 0.97, 1.03);
    if (scene.cue_stick) {
      const PoolCueStick& c = *scene.cue_stick;
      const cv::Vec3d axis = c.toward_butt / std::max(1e-9, cv::norm(c.toward_butt));
      cue_ = {{c.tip_mm, axis, c.shaft_length_mm, c.shaft_radius_mm},
              {c.tip_mm + c.shaft_length_mm * axis, axis, c.butt_length_mm, c.butt_radius_mm}};
    }
  }

  Hit Intersect(const Ray& ray, bool balls_only = false) const;
  cv::Vec3d Shade(const Ray& ray, const Hit& hit) const;
  // An sRGB colour in the units light adds up in (PoolScene::srgb_tone).
  cv::Vec3d Linear(const cv::Vec3d& c) const {
    return s_.srgb_tone ? cv::Vec3d(SrgbDecode(c[0]), SrgbDecode(c[1]), SrgbDecode(c[2])) : c;
  }
  int ball_count() const { return static_cast<int>(balls_.size()); }
  // Does the ray meet ball i at all (occluded or not)?
  bool Meets(const Ray& ray, int i) const { return SphereT(ray, balls_[i].centre) > 0; }

 private:
  double SphereT(const Ray& ray, const cv::Vec3d& c) const {
    const cv::Vec3d oc = c - ray.o;
    const double b = oc.dot(ray.d);
    const double c2 = oc.dot(oc) - b * b;
    const double r2 = t_.ball_radius_mm * t_.ball_radius_mm;
    if (b <= 0 || c2 >= r2) return -1;
    return b - std::sqrt(r2 - c2);
  }
  bool InPocket(double x, double y) const {
    for (const auto& p : pockets_) {
      const double dx = x - p.centre.x, dy = y - p.centre.y;
      if (dx * dx + dy * dy < p.radius * p.radius) return true;
    }
    return false;
  }
  double Texture(double u, double v, double texel_mm) const {
    const int x = static_cast<int>(std::floor(u / texel_mm)) & 255;
    const int y = static_cast<int>(std::floor(v / texel_mm)) & 255;
    return texture_.at<float>(y, x);
  }
  // Fraction of lamp `l` seen from p (soft shadows of the balls and of the cue stick),
  // excluding ball `self`, and the stick when p is on it.
  double LampVisibility(const cv::Vec3d& p, const cv::Vec3d& lamp, int self, bool on_stick) const;
  double AmbientOcclusion(const cv::Vec3d& p, const cv::Vec3d& n, int self) const;
  cv::Vec3d BallAlbedo(const BallModel& ball, const cv::Vec3d& n) const;

  const PoolScene& s_;
  const PoolTableSpec& t_;
  std::vector<Pocket> pockets_;
  std::vector<BallModel> balls_;
  std::vector<cv::Vec3d> lamps_;
  double lamp_power_ = 1;
  cv::Mat texture_;
  cv::Vec3d cloth_cast_{1, 1, 1};
  std::vector<Cylinder> cue_;  // shaft, butt (empty: no cue stick)
};

Hit Scene::Intersect(const Ray& ray, bool balls_only) const {
  Hit best;
  for (int i = 0; i < ball_count(); ++i) {
    const double t = SphereT(ray, balls_[i].centre);
    if (t > 0 && t < best.t) {
      best.t = t;
      best.surface = Surface::kBall;
      best.ball = i;
    }
  }
  if (best.surface == Surface::kBall) {
    best.p = ray.o + best.t * ray.d;
    best.n = (best.p - balls_[best.ball].centre) / t_.ball_radius_mm;
  }
  if (balls_only) return best;
  for (size_t k = 0; k < cue_.size(); ++k) {
    cv::Vec3d n;
    const double t = CylinderT(ray, cue_[k], &n);
    if (t > 0 && t < best.t) {
      best.t = t;
      best.surface = k == 0 ? Surface::kCueShaft : Surface::kCueButt;
      best.ball = -1;
      best.p = ray.o + t * ray.d;
      best.n = n;
    }
  }
  const double L = t_.length_mm, W = t_.width_mm, h = t_.cushion_height_mm;
  const double cw = t_.cushion_width_mm, rw = t_.rail_width_mm;
  auto consider = [&](double t, Surface s, const cv::Vec3d& n) {
    if (t > 1e-6 && t < best.t) {
      best.t = t;
      best.surface = s;
      best.n = n;
      best.p = ray.o + t * ray.d;
      best.ball = -1;
    }
  };
  auto inside = [](double x, double y, double x0, double y0, double x1, double y1) {
    return x >= x0 && x <= x1 && y >= y0 && y <= y1;
  };
  // Horizontal planes: cloth (Z = 0), cushion and rail tops (Z = h), floor.
  if (std::abs(ray.d[2]) > 1e-12) {
    const double t0 = -ray.o[2] / ray.d[2];
    const cv::Vec3d p0 = ray.o + t0 * ray.d;
    if (inside(p0[0], p0[1], 0, 0, L, W)) consider(t0, Surface::kCloth, {0, 0, 1});
    const double th = (h - ray.o[2]) / ray.d[2];
    const cv::Vec3d ph = ray.o + th * ray.d;
    if (!inside(ph[0], ph[1], 0, 0, L, W)) {
      if (inside(ph[0], ph[1], -cw, -cw, L + cw, W + cw))
        consider(th, Surface::kCushionTop, {0, 0, 1});
      else if (inside(ph[0], ph[1], -cw - rw, -cw - rw, L + cw + rw, W + cw + rw))
        consider(th, Surface::kRail, {0, 0, 1});
    }
    const double tf = (kFloorZ - ray.o[2]) / ray.d[2];
    consider(tf, Surface::kFloor, {0, 0, 1});
  }
  // Vertical faces: cushion noses (facing the cloth) and rail outer faces.
  auto face_x = [&](double x, double sign, double zlo, double zhi, double ylo, double yhi,
                    Surface s) {
    if (std::abs(ray.d[0]) < 1e-12 || (ray.o[0] - x) * sign <= 0) return;
    const double t = (x - ray.o[0]) / ray.d[0];
    const cv::Vec3d p = ray.o + t * ray.d;
    if (p[2] >= zlo && p[2] <= zhi && p[1] >= ylo && p[1] <= yhi) consider(t, s, {sign, 0, 0});
  };
  auto face_y = [&](double y, double sign, double zlo, double zhi, double xlo, double xhi,
                    Surface s) {
    if (std::abs(ray.d[1]) < 1e-12 || (ray.o[1] - y) * sign <= 0) return;
    const double t = (y - ray.o[1]) / ray.d[1];
    const cv::Vec3d p = ray.o + t * ray.d;
    if (p[2] >= zlo && p[2] <= zhi && p[0] >= xlo && p[0] <= xhi) consider(t, s, {0, sign, 0});
  };
  face_x(0, 1, 0, h, 0, W, Surface::kCushionFace);
  face_x(L, -1, 0, h, 0, W, Surface::kCushionFace);
  face_y(0, 1, 0, h, 0, L, Surface::kCushionFace);
  face_y(W, -1, 0, h, 0, L, Surface::kCushionFace);
  const double e = cw + rw;
  face_x(-e, -1, h - kApronDepth, h, -e, W + e, Surface::kRailFace);
  face_x(L + e, 1, h - kApronDepth, h, -e, W + e, Surface::kRailFace);
  face_y(-e, -1, h - kApronDepth, h, -e, L + e, Surface::kRailFace);
  face_y(W + e, 1, h - kApronDepth, h, -e, L + e, Surface::kRailFace);
  // Pockets cut through cloth, cushions and rails.
  if (best.surface == Surface::kCloth || best.surface == Surface::kCushionTop ||
      best.surface == Surface::kCushionFace || best.surface == Surface::kRail) {
    if (InPocket(best.p[0], best.p[1])) best.surface = Surface::kPocket;
  }
  return best;
}

double Scene::LampVisibility(const cv::Vec3d& p, const cv::Vec3d& lamp, int self,
                             bool on_stick) const {
  const cv::Vec3d to_lamp = lamp - p;
  const double lamp_dist = cv::norm(to_lamp);
  const cv::Vec3d l = to_lamp / lamp_dist;
  const double beta = std::atan(s_.lamp_radius_mm / lamp_dist);  // angular radius of the lamp
  double visible = 1;
  for (int i = 0; i < ball_count(); ++i) {
    if (i == self) continue;
    const cv::Vec3d to_ball = balls_[i].centre - p;
    const double d = cv::norm(to_ball);
    if (d >= lamp_dist || d < 1e-9) continue;
    const double alpha = std::asin(std::min(1.0, t_.ball_radius_mm / d));
    const double theta = std::acos(std::clamp(to_ball.dot(l) / d, -1.0, 1.0));
    // Coverage of the lamp disc by the ball disc (smooth approximation).
    const double covered = 1 - SmoothStep((theta - (alpha - beta)) / (2 * beta));
    visible *= 1 - covered;
  }
  // The cue stick's shadow: soft over the lamp's penumbra at the stick. (Its own lit side
  // faces the lamp: the stick's shading is its normal's.)
  for (const Cylinder& c : cue_) {
    if (on_stick) break;
    const double d = SegmentDistance(p, lamp, c.a, c.a + c.length * c.axis);
    const double to_stick = cv::norm(c.a + 0.5 * c.length * c.axis - p);
    const double penumbra = std::max(1.0, s_.lamp_radius_mm * to_stick / lamp_dist);
    visible *= SmoothStep((d - (c.radius - penumbra)) / (2 * penumbra));
  }
  return visible;
}

double Scene::AmbientOcclusion(const cv::Vec3d& p, const cv::Vec3d& n, int self) const {
  double ao = 1;
  for (int i = 0; i < ball_count(); ++i) {
    if (i == self) continue;
    const cv::Vec3d to_ball = balls_[i].centre - p;
    const double d = cv::norm(to_ball);
    const double c = std::max(0.0, to_ball.dot(n) / d);
    const double rr = t_.ball_radius_mm / d;
    ao *= 1 - std::min(0.9, rr * rr * c);
  }
  return ao;
}

cv::Vec3d Scene::BallAlbedo(const BallModel& ball, const cv::Vec3d& n) const {
  static const cv::Vec3d kWhite(236, 232, 222);
  const double along = n.dot(ball.axis);
  if (ball.number == 0) return kWhite;
  // Number discs: angular radius ~22 degrees around +/- axis (on the stripe for the 9).
  if (ball.number == 9) {
    const cv::Vec3d side = ball.axis.cross(cv::Vec3d(0.3, 0.5, 0.81));
    const cv::Vec3d disc_axis = side / std::max(1e-9, cv::norm(side));
    if (std::abs(n.dot(disc_axis)) > 0.93) return kWhite;
    return std::abs(along) < 0.55 ? ball.albedo : kWhite;
  }
  if (std::abs(along) > 0.93) return kWhite;
  return ball.albedo;
}

cv::Vec3d Scene::Shade(const Ray& ray, const Hit& hit) const {
  const cv::Vec3d& p = hit.p;
  const cv::Vec3d& n = hit.n;
  cv::Vec3d albedo;
  double shininess = 0, specular = 0;
  switch (hit.surface) {
    case Surface::kNone:
      return Linear({40, 40, 45});
    case Surface::kPocket: {
      // Dark hole, a little lighter at its rim.
      return Linear({14, 13, 12});
    }
    case Surface::kBall:
      albedo = BallAlbedo(balls_[hit.ball], n);
      shininess = 90;
      specular = 260;
      break;
    case Surface::kCueShaft:
      albedo = {214, 184, 132};  // maple
      shininess = 40;
      specular = 60;
      break;
    case Surface::kCueButt:
      albedo = {70, 40, 28};  // stained wood
      shininess = 40;
      specular = 80;
      break;
    case Surface::kCloth:
    case Surface::kCushionTop:
    case Surface::kCushionFace: {
      const double tex = 1 + 0.035 * Texture(p[0] + p[2], p[1], 1.3);
      albedo = t_.cloth_rgb.mul(cloth_cast_) * tex;
      break;
    }
    case Surface::kRail:
    case Surface::kRailFace: {
      const double L = t_.length_mm, W = t_.width_mm;
      const bool along_x = p[1] < 0 || p[1] > W;
      const double u = along_x ? p[0] : p[1], v = along_x ? p[1] : p[0];
      const double grain = 1 + 0.08 * std::sin(v * 0.35 + 2.0 * Texture(u, v, 40.0)) +
                           0.04 * Texture(u, v * 4, 3.0);
      albedo = t_.rail_rgb * grain;
      if (hit.surface == Surface::kRail) {
        // Sight diamonds in the middle of the rail.
        const double mid = t_.cushion_width_mm + t_.rail_width_mm / 2;
        for (int k = 1; k < 8; ++k) {
          if (k == 4) continue;
          for (double y : {-mid, W + mid})
            if (std::hypot(p[0] - L * k / 8, p[1] - y) < 6) albedo = {230, 225, 205};
        }
        for (int k = 1; k < 4; ++k)
          for (double x : {-mid, L + mid})
            if (std::hypot(p[0] - x, p[1] - W * k / 4) < 6) albedo = {230, 225, 205};
      }
      specular = 30;
      shininess = 20;
      break;
    }
    case Surface::kFloor: {
      const int tile = (static_cast<int>(std::floor(p[0] / 400)) +
                        static_cast<int>(std::floor(p[1] / 400))) & 1;
      albedo = s_.floor_rgb * (tile ? 1.0 : 0.9) * (1 + 0.05 * Texture(p[0], p[1], 8));
      break;
    }
  }
  albedo = Linear(albedo);
  const int self = hit.surface == Surface::kBall ? hit.ball : -1;
  const double ao = hit.surface == Surface::kFloor ? 1.0 : AmbientOcclusion(p, n, self);
  double diffuse = 0.28 * ao * (0.55 + 0.45 * n[2]);
  double spec = 0;
  const cv::Vec3d view = -ray.d;
  for (const auto& lamp : lamps_) {
    const cv::Vec3d to_lamp = lamp - p;
    const double dist = cv::norm(to_lamp);
    const cv::Vec3d l = to_lamp / dist;
    const double nl = n.dot(l);
    if (nl <= 0) continue;
    // 1 on the cloth under the lamp, at any height: the camera's exposure follows the
    // light's strength.
    const double falloff = lamp[2] * lamp[2] / (dist * dist);
    const bool on_stick = hit.surface == Surface::kCueShaft || hit.surface == Surface::kCueButt;
    const double vis =
        hit.surface == Surface::kFloor ? 0.5 : LampVisibility(p, lamp, self, on_stick);
    diffuse += lamp_power_ * falloff * nl * vis;
    if (specular > 0) {
      cv::Vec3d half = l + view;
      half /= std::max(1e-9, cv::norm(half));
      // A lamp of angular radius b spreads the half vector by b^2 / 16 (variance per axis)
      // over the lobe's 1 / shininess; the lobe keeps its energy (peak times width).
      double lobe = shininess, peak = specular;
      if (s_.lamp_radius_mm != kMaterialLampRadius) {
        const double b = std::atan(s_.lamp_radius_mm / dist);
        const double b0 = std::atan(kMaterialLampRadius / dist);
        lobe = 1 / std::max(1e-6, 1 / shininess + (b * b - b0 * b0) / 16);
        peak = specular * lobe / shininess;
      }
      spec += lamp_power_ * vis * peak * std::pow(std::max(0.0, n.dot(half)), lobe);
    }
  }
  const cv::Vec3d lit = albedo * diffuse + cv::Vec3d(spec, spec, spec);
  return lit.mul(s_.light_rgb) * s_.light_gain;
}

}  // namespace

cv::Matx33d PoolCameraRotation(const PoolCamera& cam) {
  cv::Vec3d f = cam.look_at_mm - cam.position_mm;
  f /= cv::norm(f);
  cv::Vec3d x = f.cross(cv::Vec3d(0, 0, 1));
  if (cv::norm(x) < 1e-9) x = {1, 0, 0};
  x /= cv::norm(x);
  cv::Vec3d y = f.cross(x);
  const double c = std::cos(cam.roll_deg * kDeg), s = std::sin(cam.roll_deg * kDeg);
  const cv::Vec3d xr = c * x + s * y, yr = -s * x + c * y;
  return {xr[0], xr[1], xr[2], yr[0], yr[1], yr[2], f[0], f[1], f[2]};
}

namespace {

cv::Matx33d CameraMatrix(const PoolCamera& cam) {
  const double f = (cam.image_size.width / 2.0) / std::tan(cam.horizontal_fov_deg * kDeg / 2);
  return {f, 0, (cam.image_size.width - 1) / 2.0, 0, f, (cam.image_size.height - 1) / 2.0,
          0, 0, 1};
}

void AppendNumbers(std::ostringstream& os, const double* v, int n) {
  os << "[";
  char buf[40];
  for (int i = 0; i < n; ++i) {
    std::snprintf(buf, sizeof(buf), "%.10g", v[i]);
    os << (i ? ", " : "") << buf;
  }
  os << "]";
}

}  // namespace

PoolTableSpec PoolTableSpec::Bench() { return PoolTableSpec(); }

PoolTableSpec PoolTableSpec::NineFoot() {
  PoolTableSpec t;
  t.length_mm = 2540;
  t.width_mm = 1270;
  t.ball_radius_mm = 28.575;
  t.cushion_height_mm = 36.5;
  t.cushion_width_mm = 50;
  t.rail_width_mm = 130;
  t.corner_pocket_mm = 115;
  t.side_pocket_mm = 130;
  return t;
}

cv::Vec3d PoolBallRgb(int number, PoolBallSet set) {
  // Common ball-set colours (RGB albedo).
  static const cv::Vec3d kCommon[] = {
      {236, 232, 222},  // cue
      {250, 196, 20},   // 1 yellow
      {25, 60, 175},    // 2 blue
      {215, 30, 35},    // 3 red
      {85, 35, 125},    // 4 purple
      {250, 110, 20},   // 5 orange
      {10, 115, 45},    // 6 green
      {125, 30, 32},    // 7 maroon
      {22, 22, 24},     // 8 black
      {250, 196, 20},   // 9 yellow stripe (on white)
  };
  static const cv::Vec3d kSecond[] = {
      {240, 236, 226},  // cue
      {255, 205, 0},    // 1 deeper yellow
      {20, 80, 200},    // 2 lighter blue
      {225, 40, 25},    // 3 red
      {110, 40, 150},   // 4 violet
      {255, 90, 10},    // 5 red-orange
      {0, 95, 60},      // 6 dark teal-green
      {140, 45, 25},    // 7 brown
      {15, 15, 18},     // 8 black
      {255, 205, 0},    // 9 deeper yellow stripe (on white)
  };
  const int k = std::clamp(number, 0, 9);
  return set == PoolBallSet::kSecond ? kSecond[k] : kCommon[k];
}

PoolView RenderPoolView(const PoolScene& scene, uint64_t seed) {
  const PoolCamera& cam = scene.camera;
  const cv::Size size = cam.image_size;
  PoolView view;
  view.camera_matrix = CameraMatrix(cam);
  view.distortion = {cam.k1, cam.k2, 0, 0, 0};
  view.rotation = PoolCameraRotation(cam);
  view.translation = -(view.rotation * cam.position_mm);
  const Scene world(scene, seed);
  std::mt19937_64 rng(seed ^ 0x63616d706f6f6cULL);

  // Sample positions (sub-pixel grid) -> undistorted normalised rays.
  const int n = kSupersample;
  std::vector<cv::Point2f> samples;
  samples.reserve(static_cast<size_t>(size.area()) * n * n);
  for (int v = 0; v < size.height; ++v)
    for (int u = 0; u < size.width; ++u)
      for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i)
          samples.emplace_back(static_cast<float>(u + (i + 0.5) / n - 0.5),
                               static_cast<float>(v + (j + 0.5) / n - 0.5));
  std::vector<cv::Point2f> normalised;
  const bool distorted = cam.k1 != 0 || cam.k2 != 0;
  if (distorted) {
    cv::undistortPoints(samples, normalised, cv::Mat(view.camera_matrix),
                        cv::Mat(view.distortion),
                        cv::noArray(), cv::noArray(),
                        cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 20,
                                         1e-9));
  } else {
    normalised.resize(samples.size());
    const cv::Matx33d& K = view.camera_matrix;
    for (size_t k = 0; k < samples.size(); ++k)
      normalised[k] = {static_cast<float>((samples[k].x - K(0, 2)) / K(0, 0)),
                       static_cast<float>((samples[k].y - K(1, 2)) / K(1, 1))};
  }
  const cv::Matx33d cam_to_world = view.rotation.t();
  cv::Mat image(size, CV_32FC3);
  cv::Mat first_ball(size, CV_32SC1, cv::Scalar(-1));
  std::vector<int> visible(world.ball_count(), 0), met(world.ball_count(), 0);
  size_t k = 0;
  for (int v = 0; v < size.height; ++v) {
    cv::Vec3f* row = image.ptr<cv::Vec3f>(v);
    for (int u = 0; u < size.width; ++u) {
      cv::Vec3d sum(0, 0, 0);
      for (int s = 0; s < n * n; ++s, ++k) {
        cv::Vec3d d = cam_to_world * cv::Vec3d(normalised[k].x, normalised[k].y, 1.0);
        Ray ray{cam.position_mm, d / cv::norm(d)};
        const Hit hit = world.Intersect(ray);
        sum += world.Shade(ray, hit);
        if (s == (n * n) / 2) {  // centre sample: which ball owns the pixel
          if (hit.surface == Surface::kBall) {
            first_ball.at<int>(v, u) = hit.ball;
            ++visible[hit.ball];
          }
          for (int b = 0; b < world.ball_count(); ++b)
            if (world.Meets(ray, b)) ++met[b];
        }
      }
      sum *= 1.0 / (n * n);
      // Stored as BGR.
      row[u] = cv::Vec3f(static_cast<float>(sum[2]), static_cast<float>(sum[1]),
                         static_cast<float>(sum[0]));
    }
  }
  // Lens vignetting.
  const double cx = (size.width - 1) / 2.0, cy = (size.height - 1) / 2.0;
  const double r2max = cx * cx + cy * cy;
  for (int v = 0; v < size.height; ++v) {
    cv::Vec3f* row = image.ptr<cv::Vec3f>(v);
    for (int u = 0; u < size.width; ++u) {
      const double r2 = ((u - cx) * (u - cx) + (v - cy) * (v - cy)) / r2max;
      row[u] *= static_cast<float>(1 - scene.vignetting * r2);
    }
  }
  if (scene.blur_sigma > 0.05)
    cv::GaussianBlur(image, image, cv::Size(0, 0), scene.blur_sigma, 0, cv::BORDER_REFLECT);
  if (scene.motion_blur_px > 0.5)
    cv::filter2D(image, image, -1,
                 MotionBlurKernel(scene.motion_blur_px, scene.motion_blur_angle_deg),
                 cv::Point(-1, -1), 0, cv::BORDER_REFLECT);
  if (scene.srgb_tone)
    for (int v = 0; v < size.height; ++v) {
      cv::Vec3f* row = image.ptr<cv::Vec3f>(v);
      for (int u = 0; u < size.width; ++u)
        for (int c = 0; c < 3; ++c) row[u][c] = static_cast<float>(SrgbEncode(row[u][c]));
    }
  if (scene.noise_sigma > 0) {
    cv::Mat noise(size, CV_32FC3);
    cv::RNG cvrng(rng());
    cvrng.fill(noise, cv::RNG::NORMAL, 0, scene.noise_sigma);
    image += noise;
  }
  if (scene.sharpen_amount > 0) {  // the phone's unsharp mask, noise and all
    cv::Mat blurred;
    cv::GaussianBlur(image, blurred, cv::Size(0, 0), scene.sharpen_sigma_px, 0, cv::BORDER_REFLECT);
    image += scene.sharpen_amount * (image - blurred);
  }
  image.convertTo(view.image, CV_8UC3);
  if (scene.jpeg_quality > 0) {
    std::vector<uint8_t> jpeg;
    cv::imencode(".jpg", view.image, jpeg,
                 {cv::IMWRITE_JPEG_QUALITY, std::clamp(scene.jpeg_quality, 1, 100)});
    view.image = cv::imdecode(jpeg, cv::IMREAD_COLOR);
  }

  // Ground truth.
  const PoolTableSpec& t = scene.table;
  const double L = t.length_mm, W = t.width_mm, c = t.cushion_width_mm;
  const cv::Vec3d cloth[4] = {{0, 0, 0}, {L, 0, 0}, {L, W, 0}, {0, W, 0}};
  const cv::Vec3d cushion[4] = {{-c, -c, t.cushion_height_mm},
                                {L + c, -c, t.cushion_height_mm},
                                {L + c, W + c, t.cushion_height_mm},
                                {-c, W + c, t.cushion_height_mm}};
  for (int i = 0; i < 4; ++i) {
    view.cloth_corners[i] = ProjectTablePoint(view, cloth[i]);
    view.cushion_corners[i] = ProjectTablePoint(view, cushion[i]);
  }
  for (int b = 0; b < world.ball_count(); ++b) {
    PoolBallTruth truth;
    truth.number = scene.balls[b].number;
    truth.x_mm = scene.balls[b].x_mm;
    truth.y_mm = scene.balls[b].y_mm;
    truth.pixel = ProjectTablePoint(view, {truth.x_mm, truth.y_mm, t.ball_radius_mm});
    truth.visible_pixels = visible[b];
    bool touching = false;
    for (int v = 0; v < size.height && !touching; ++v)
      for (int u = 0; u < size.width && !touching; ++u) {
        if (first_ball.at<int>(v, u) != b) continue;
        for (int dv = -1; dv <= 1 && !touching; ++dv)
          for (int du = -1; du <= 1; ++du) {
            const int vv = v + dv, uu = u + du;
            if (vv < 0 || uu < 0 || vv >= size.height || uu >= size.width) continue;
            const int other = first_ball.at<int>(vv, uu);
            if (other >= 0 && other != b) {
              touching = true;
              break;
            }
          }
      }
    const bool inside = truth.pixel.x > 2 && truth.pixel.y > 2 &&
                        truth.pixel.x < size.width - 3 && truth.pixel.y < size.height - 3;
    truth.separated = inside && visible[b] == met[b] && visible[b] > 0 && !touching;
    view.balls.push_back(truth);
  }
  return view;
}

cv::Point2d ProjectTablePoint(const PoolView& view, const cv::Vec3d& point_mm) {
  std::vector<cv::Point3d> object{{point_mm[0], point_mm[1], point_mm[2]}};
  std::vector<cv::Point2d> pixels;
  cv::Mat rvec;
  cv::Rodrigues(cv::Mat(view.rotation), rvec);
  cv::projectPoints(object, rvec, cv::Mat(view.translation), cv::Mat(view.camera_matrix),
                    cv::Mat(view.distortion), pixels);
  return pixels[0];
}

PoolCamera FramedPoolCamera(const PoolTableSpec& table, PoolViewSide side, double elevation_deg,
                            double horizontal_fov_deg, double azimuth_offset_deg,
                            double roll_deg, double margin, cv::Size image_size) {
  PoolCamera cam;
  cam.image_size = image_size;
  cam.horizontal_fov_deg = horizontal_fov_deg;
  cam.roll_deg = roll_deg;
  const double L = table.length_mm, W = table.width_mm;
  cam.look_at_mm = {L / 2, W / 2, 0};
  double az = 0;
  switch (side) {
    case PoolViewSide::kLongNear: az = -90; break;
    case PoolViewSide::kLongFar: az = 90; break;
    case PoolViewSide::kShortLeft: az = 180; break;
    case PoolViewSide::kShortRight: az = 0; break;
  }
  az = (az + azimuth_offset_deg) * kDeg;
  const double el = elevation_deg * kDeg;
  const cv::Vec3d back(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
  const double e = table.cushion_width_mm + table.rail_width_mm;
  const cv::Vec3d outer[4] = {{-e, -e, table.cushion_height_mm},
                              {L + e, -e, table.cushion_height_mm},
                              {L + e, W + e, table.cushion_height_mm},
                              {-e, W + e, table.cushion_height_mm}};
  const cv::Matx33d K = CameraMatrix(cam);
  for (double dist = 300; dist < 50000; dist *= 1.01) {
    cam.position_mm = cam.look_at_mm + dist * back;
    const cv::Matx33d R = PoolCameraRotation(cam);
    bool fits = true;
    for (const auto& p : outer) {
      const cv::Vec3d q = K * (R * (p - cam.position_mm));
      if (q[2] <= 0) {
        fits = false;
        break;
      }
      const double u = q[0] / q[2], v = q[1] / q[2];
      if (u < margin * image_size.width || u > (1 - margin) * image_size.width ||
          v < margin * image_size.height || v > (1 - margin) * image_size.height) {
        fits = false;
        break;
      }
    }
    if (fits) break;
  }
  return cam;
}

std::vector<PoolBallPlacement> RandomPoolLayout(std::mt19937_64& rng, const PoolTableSpec& table,
                                                int count, bool allow_touching) {
  const double r = table.ball_radius_mm, L = table.length_mm, W = table.width_mm;
  std::vector<int> numbers = {0, 9};
  std::vector<int> others = {1, 2, 3, 4, 5, 6, 7, 8};
  for (size_t i = others.size(); i > 1; --i) std::swap(others[i - 1], others[rng() % i]);
  for (int i = 0; i < count - 2 && i < 8; ++i) numbers.push_back(others[i]);
  const double rc = table.corner_pocket_mm / 2, rs = table.side_pocket_mm / 2;
  const cv::Point2d pockets[6] = {{0, 0}, {L, 0}, {L, W}, {0, W}, {L / 2, 0}, {L / 2, W}};
  std::vector<PoolBallPlacement> balls;
  for (int number : numbers) {
    for (int attempt = 0; attempt < 500; ++attempt) {
      PoolBallPlacement b;
      b.number = number;
      const double mode = Unit(rng);
      if (allow_touching && !balls.empty() && mode < 0.2) {
        const auto& other = balls[rng() % balls.size()];
        const double a = Uniform(rng, 0, 2 * kPi);
        b.x_mm = other.x_mm + (2 * r + 0.3) * std::cos(a);
        b.y_mm = other.y_mm + (2 * r + 0.3) * std::sin(a);
      } else {
        b.x_mm = Uniform(rng, r + 0.5, L - r - 0.5);
        b.y_mm = Uniform(rng, r + 0.5, W - r - 0.5);
        if (mode > 0.85) {  // frozen against a cushion
          switch (rng() % 4) {
            case 0: b.x_mm = r + 0.5; break;
            case 1: b.x_mm = L - r - 0.5; break;
            case 2: b.y_mm = r + 0.5; break;
            default: b.y_mm = W - r - 0.5; break;
          }
        }
      }
      if (b.x_mm < r || b.x_mm > L - r || b.y_mm < r || b.y_mm > W - r) continue;
      bool ok = true;
      for (const auto& p : pockets) {
        const double pr = (p.y == 0 || p.y == W) && p.x == L / 2 ? rs : rc;
        if (std::hypot(b.x_mm - p.x, b.y_mm - p.y) < pr + r + 10) ok = false;
      }
      for (const auto& o : balls)
        if (std::hypot(b.x_mm - o.x_mm, b.y_mm - o.y_mm) < 2 * r + 0.2) ok = false;
      if (!ok) continue;
      balls.push_back(b);
      break;
    }
  }
  return balls;
}

PoolCueStick AimedCueStick(std::mt19937_64& rng, const PoolTableSpec& table,
                           const std::vector<PoolBallPlacement>& balls) {
  cv::Point2d cue(table.length_mm / 2, table.width_mm / 2);
  std::vector<cv::Point2d> others;
  for (const auto& b : balls) {
    if (b.number == 0)
      cue = {b.x_mm, b.y_mm};
    else
      others.emplace_back(b.x_mm, b.y_mm);
  }
  cv::Point2d aim;
  if (others.empty()) {
    const double a = Uniform(rng, 0, 2 * kPi);
    aim = {std::cos(a), std::sin(a)};
  } else {
    aim = others[rng() % others.size()] - cue;
    aim /= std::max(1e-9, cv::norm(aim));
  }
  const double rise = Uniform(rng, 4, 10) * kDeg;
  PoolCueStick stick;
  const double back = table.ball_radius_mm + Uniform(rng, 30, 80);
  stick.tip_mm = {cue.x - back * aim.x, cue.y - back * aim.y, table.ball_radius_mm};
  stick.toward_butt = {-aim.x * std::cos(rise), -aim.y * std::cos(rise), std::sin(rise)};
  return stick;
}

void DrawPoolShake(uint64_t stream_seed, double max_px, PoolScene* scene) {
  std::mt19937_64 shake(stream_seed);
  scene->motion_blur_px = max_px * Unit(shake);
  scene->motion_blur_angle_deg = 180 * Unit(shake);
}

void ScalePoolCamera(PoolScene* scene, double scale) {
  if (scale == 1) return;
  const cv::Size& size = scene->camera.image_size;
  scene->camera.image_size = cv::Size(static_cast<int>(std::lround(size.width * scale)),
                                      static_cast<int>(std::lround(size.height * scale)));
  scene->blur_sigma *= scale;
  scene->sharpen_sigma_px *= scale;
}

PoolScene RandomPoolScene(std::mt19937_64& rng, const PoolTableSpec& table, bool allow_touching,
                          double min_elevation_deg, double max_elevation_deg, double max_roll_deg) {
  PoolScene scene;
  scene.table = table;
  scene.balls = RandomPoolLayout(rng, table, 6 + static_cast<int>(rng() % 5), allow_touching);
  const PoolViewSide side = static_cast<PoolViewSide>(rng() % 4);
  scene.camera = FramedPoolCamera(
      table, side, Uniform(rng, min_elevation_deg, max_elevation_deg), Uniform(rng, 55, 70),
      Uniform(rng, -20, 20), Uniform(rng, -max_roll_deg, max_roll_deg), Uniform(rng, 0.02, 0.1));
  scene.camera.k1 = Uniform(rng, -0.08, 0.05);
  scene.camera.k2 = Uniform(rng, -0.02, 0.02);
  scene.lamps = 1 + static_cast<int>(rng() % 3);
  scene.light_gain = Uniform(rng, 0.8, 1.2);
  scene.vignetting = Uniform(rng, 0.1, 0.35);
  scene.blur_sigma = Uniform(rng, 0.3, 1.0);
  scene.noise_sigma = Uniform(rng, 1, 4);
  scene.jpeg_quality = 70 + static_cast<int>(rng() % 26);
  return scene;
}

std::string PoolViewGroundTruthJson(const PoolScene& scene, const PoolView& view) {
  std::ostringstream os;
  const PoolTableSpec& t = scene.table;
  os << "{\n  \"table\": {\"length_mm\": " << t.length_mm << ", \"width_mm\": " << t.width_mm
     << ", \"ball_radius_mm\": " << t.ball_radius_mm
     << ", \"cushion_height_mm\": " << t.cushion_height_mm
     << ", \"cushion_width_mm\": " << t.cushion_width_mm << "},\n  \"camera_matrix\": ";
  AppendNumbers(os, view.camera_matrix.val, 9);
  os << ",\n  \"distortion\": ";
  AppendNumbers(os, view.distortion.data(), static_cast<int>(view.distortion.size()));
  os << ",\n  \"image_width\": " << view.image.cols << ", \"image_height\": " << view.image.rows;
  // How the picture encodes the light (PoolScene::srgb_tone).
  os << ",\n  \"pixel_encoding\": \"" << (scene.srgb_tone ? "srgb" : "linear") << "\"";
  os << ",\n  \"rotation\": ";
  AppendNumbers(os, view.rotation.val, 9);
  os << ",\n  \"translation\": ";
  AppendNumbers(os, view.translation.val, 3);
  os << ",\n  \"cloth_corners\": [";
  for (int i = 0; i < 4; ++i) {
    const double p[2] = {view.cloth_corners[i].x, view.cloth_corners[i].y};
    os << (i ? ", " : "");
    AppendNumbers(os, p, 2);
  }
  os << "],\n  \"balls\": [";
  for (size_t i = 0; i < view.balls.size(); ++i) {
    const auto& b = view.balls[i];
    char buf[200];
    std::snprintf(buf, sizeof(buf),
                  "%s\n    {\"number\": %d, \"x_mm\": %.3f, \"y_mm\": %.3f, \"u\": %.3f, "
                  "\"v\": %.3f, \"separated\": %s}",
                  i ? "," : "", b.number, b.x_mm, b.y_mm, b.pixel.x, b.pixel.y,
                  b.separated ? "true" : "false");
    os << buf;
  }
  os << "\n  ]\n}\n";
  return os.str();
}

}  // namespace texfree::testdata
