// Event-driven pool physics: slide/roll friction, ball and cushion collisions, pockets.
#include "common/pool_physics.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace texfree {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

double Dot(const cv::Point2d& a, const cv::Point2d& b) { return a.x * b.x + a.y * b.y; }

// Earliest t in [0, horizon] at which |d + w t| = distance while closing; kInf if none.
double ContactTime(const cv::Point2d& d, const cv::Point2d& w, double distance, double horizon) {
  const double a = Dot(w, w);
  const double b = 2 * Dot(d, w);
  const double c = Dot(d, d) - distance * distance;
  if (b >= 0 || a < 1e-12) return kInf;  // not closing
  if (c <= 0) return 0;                  // already touching and closing
  const double disc = b * b - 4 * a * c;
  if (disc < 0) return kInf;
  const double t = (-b - std::sqrt(disc)) / (2 * a);
  return t >= 0 && t <= horizon ? t : kInf;
}

struct Cushion {
  // Ball-centre line: coordinate `axis` (0 = x, 1 = y) equals `at`; the ball must move
  // with sign(`normal`) < 0 along the axis to hit it; active where the other coordinate
  // is within [from, to].
  int axis;
  double at, normal, from, to;
};

class Simulator {
 public:
  Simulator(const PoolTableProfile& table, const PoolPhysicsConstants& k)
      : table_(table), k_(k), R_(table.ball_radius_mm) {
    const double L = table.length_mm, W = table.width_mm;
    const double jc = table.corner_pocket_mm / std::sqrt(2.0);  // jaw distance from corner
    const double hs = table.side_pocket_mm / 2;
    corner_jaw_ = jc;
    cushions_ = {{1, R_, 1, jc, L / 2 - hs},         {1, R_, 1, L / 2 + hs, L - jc},
                 {1, W - R_, -1, jc, L / 2 - hs},    {1, W - R_, -1, L / 2 + hs, L - jc},
                 {0, R_, 1, jc, W - jc},             {0, L - R_, -1, jc, W - jc}};
    jaws_ = {{jc, 0}, {0, jc}, {L - jc, 0}, {L, jc}, {L - jc, W}, {L, W - jc}, {jc, W}, {0, W - jc},
             {L / 2 - hs, 0}, {L / 2 + hs, 0}, {L / 2 - hs, W}, {L / 2 + hs, W}};
  }

  PoolSimulation Run(std::vector<PoolBallState> balls, const cv::Point2d& cue_velocity);

 private:
  bool Moving(const PoolBallState& b) const {
    return !b.pocketed && (Dot(b.velocity, b.velocity) > 1e-6 || Dot(b.spin, b.spin) > 1e-6);
  }
  // Contact-point slip velocity.
  cv::Point2d Slip(const PoolBallState& b) const {
    return {b.velocity.x - R_ * b.spin.y, b.velocity.y + R_ * b.spin.x};
  }
  void Friction(PoolBallState& b, double h) const;
  int Pocket(const cv::Point2d& p) const;
  double Energy(const std::vector<PoolBallState>& balls) const {
    double e = 0;
    for (const auto& b : balls) {
      if (b.pocketed) continue;
      // m = 1 kg, mm -> m.
      e += 0.5 * Dot(b.velocity, b.velocity) * 1e-6 +
           0.5 * 0.4 * R_ * R_ * 1e-6 * Dot(b.spin, b.spin);
    }
    return e;
  }

  const PoolTableProfile& table_;
  PoolPhysicsConstants k_;
  double R_;
  double corner_jaw_;
  std::vector<Cushion> cushions_;
  std::vector<cv::Point2d> jaws_;
};

void Simulator::Friction(PoolBallState& b, double h) const {
  const double g = k_.gravity_mm_s2;
  cv::Point2d u = Slip(b);
  const double slip = std::sqrt(Dot(u, u));
  if (slip > 1e-3) {
    // Sliding: dv/dt = -mu g u^, d(omega)/dt = 5 mu g / (2 R) (-u^_y, u^_x); the slip
    // shrinks at 7/2 mu g until natural roll.
    const cv::Point2d dir = u / slip;
    const double t_slide = std::min(h, slip / (3.5 * k_.sliding_friction * g));
    const double dv = k_.sliding_friction * g * t_slide;
    b.velocity -= dir * dv;
    const double dw = 2.5 * k_.sliding_friction * g * t_slide / R_;
    b.spin += cv::Point2d(-dir.y, dir.x) * dw;
    h -= t_slide;
    if (h <= 0) return;
  }
  // Rolling: the spin follows the velocity.
  const double speed = std::sqrt(Dot(b.velocity, b.velocity));
  const double dv = k_.rolling_friction * g * h;
  if (speed <= dv) {
    b.velocity = {0, 0};
  } else {
    b.velocity *= (speed - dv) / speed;
  }
  b.spin = {-b.velocity.y / R_, b.velocity.x / R_};
}

int Simulator::Pocket(const cv::Point2d& p) const {
  const double L = table_.length_mm, W = table_.width_mm, jc = corner_jaw_;
  const double hs = table_.side_pocket_mm / 2;
  if (p.x + p.y < jc) return 0;
  if ((L - p.x) + p.y < jc) return 1;
  if ((L - p.x) + (W - p.y) < jc) return 2;
  if (p.x + (W - p.y) < jc) return 3;
  if (std::abs(p.x - L / 2) < hs && p.y < 0) return 4;
  if (std::abs(p.x - L / 2) < hs && p.y > W) return 5;
  // Out of the table by a numerical slip: treat as pocketed in the nearest pocket.
  if (p.x < -R_ || p.y < -R_ || p.x > L + R_ || p.y > W + R_) return p.y < W / 2 ? 4 : 5;
  return -1;
}

PoolSimulation Simulator::Run(std::vector<PoolBallState> balls, const cv::Point2d& cue_velocity) {
  PoolSimulation sim;
  const int n = static_cast<int>(balls.size());
  sim.paths.assign(n, {});
  sim.pocket_of.assign(n, -1);
  for (auto& b : balls) {
    b.velocity = b.number == 0 ? cue_velocity : cv::Point2d(0, 0);
    b.spin = {0, 0};
  }
  std::vector<bool> moved(n, false);
  auto record = [&]() {
    for (int i = 0; i < n; ++i)
      if (moved[i] && !balls[i].pocketed) sim.paths[i].push_back(balls[i].position);
    sim.energy.push_back(Energy(balls));
  };
  for (int i = 0; i < n; ++i) {
    moved[i] = Moving(balls[i]);
    if (moved[i]) sim.paths[i].push_back(balls[i].position);
  }
  sim.energy.push_back(Energy(balls));
  double t = 0, next_record = k_.path_interval_s;
  bool contact = false;
  // Events at the same instant are resolved one per iteration; the cap only guards
  // against a numerical livelock.
  for (int iteration = 0; t < k_.max_time_s && iteration < 2000000; ++iteration) {
    bool any = false;
    for (const auto& b : balls) any = any || Moving(b);
    if (!any) break;
    // Earliest event within the step (linear motion at the current velocities).
    double h = k_.time_step_s;
    enum { kNone, kPair, kCushion, kJaw } kind = kNone;
    int ei = -1, ej = -1;
    for (int i = 0; i < n; ++i) {
      if (balls[i].pocketed) continue;
      const auto& bi = balls[i];
      if (Moving(bi)) {
        for (int c = 0; c < static_cast<int>(cushions_.size()); ++c) {
          const Cushion& cu = cushions_[c];
          const double pos = cu.axis == 0 ? bi.position.x : bi.position.y;
          const double vel = cu.axis == 0 ? bi.velocity.x : bi.velocity.y;
          if (vel * cu.normal >= 0) continue;
          const double te = (cu.at - pos) / vel;
          if (te < 0 || te > h) {
            // Already past the line (numerical): bounce now.
            if ((pos - cu.at) * cu.normal < 0 && te < 0) {
              const double along = cu.axis == 0 ? bi.position.y : bi.position.x;
              if (along >= cu.from && along <= cu.to) {
                h = 0;
                kind = kCushion;
                ei = i;
                ej = c;
              }
            }
            continue;
          }
          const cv::Point2d at = bi.position + bi.velocity * te;
          const double along = cu.axis == 0 ? at.y : at.x;
          if (along < cu.from || along > cu.to) continue;
          h = te;
          kind = kCushion;
          ei = i;
          ej = c;
        }
        for (int c = 0; c < static_cast<int>(jaws_.size()); ++c) {
          const double te = ContactTime(bi.position - jaws_[c], bi.velocity, R_, h);
          if (te == kInf) continue;
          if (te < h || (te == 0 && kind == kNone)) {
            h = te;
            kind = kJaw;
            ei = i;
            ej = c;
          }
        }
      }
      for (int j = i + 1; j < n; ++j) {
        if (balls[j].pocketed) continue;
        if (!Moving(bi) && !Moving(balls[j])) continue;
        const double te = ContactTime(bi.position - balls[j].position,
                                      bi.velocity - balls[j].velocity, 2 * R_, h);
        if (te == kInf) continue;
        if (te < h || (te == 0 && kind == kNone)) {
          h = te;
          kind = kPair;
          ei = i;
          ej = j;
        }
      }
    }
    // Advance every moving ball by h (mean velocity over the step), with friction.
    for (auto& b : balls) {
      if (b.pocketed || !Moving(b)) continue;
      const cv::Point2d v0 = b.velocity;
      Friction(b, h);
      b.position += (v0 + b.velocity) * (0.5 * h);
    }
    t += h;
    // Resolve the event.
    if (kind == kPair) {
      PoolBallState& a = balls[ei];
      PoolBallState& b = balls[ej];
      cv::Point2d nrm = b.position - a.position;
      const double len = std::sqrt(Dot(nrm, nrm));
      if (len > 1e-9) {
        nrm /= len;
        const double closing = Dot(a.velocity - b.velocity, nrm);
        if (closing > 0) {
          const double j = 0.5 * (1 + k_.ball_restitution) * closing;
          a.velocity -= nrm * j;
          b.velocity += nrm * j;
          moved[ei] = moved[ej] = true;
          if (!contact && (a.number == 0 || b.number == 0)) {
            contact = true;
            sim.first_contact = a.number == 0 ? b.number : a.number;
          }
          sim.paths[ei].push_back(a.position);
          sim.paths[ej].push_back(b.position);
        }
      }
    } else if (kind == kCushion) {
      PoolBallState& b = balls[ei];
      const Cushion& cu = cushions_[ej];
      double& v = cu.axis == 0 ? b.velocity.x : b.velocity.y;
      if (v * cu.normal < 0) v = -k_.cushion_restitution * v;
      if (contact) ++sim.cushion_hits_after_contact;
      sim.paths[ei].push_back(b.position);
    } else if (kind == kJaw) {
      PoolBallState& b = balls[ei];
      cv::Point2d nrm = b.position - jaws_[ej];
      const double len = std::sqrt(Dot(nrm, nrm));
      if (len > 1e-9) {
        nrm /= len;
        const double vn = Dot(b.velocity, nrm);
        if (vn < 0) b.velocity -= nrm * ((1 + k_.cushion_restitution) * vn);
      }
      sim.paths[ei].push_back(b.position);
    }
    // Pockets.
    for (int i = 0; i < n; ++i) {
      if (balls[i].pocketed) continue;
      const int pocket = Pocket(balls[i].position);
      if (pocket >= 0) {
        sim.paths[i].push_back(balls[i].position);
        balls[i].pocketed = true;
        balls[i].velocity = balls[i].spin = {0, 0};
        sim.pocket_of[i] = pocket;
      }
    }
    if (t >= next_record) {
      record();
      next_record += k_.path_interval_s;
    }
  }
  record();
  sim.duration_s = t;
  for (auto& b : balls) b.velocity = b.spin = {0, 0};
  sim.final_state = balls;
  return sim;
}

}  // namespace

absl::Status PoolPhysicsConstants::Validate() const {
  if (!(ball_restitution > 0 && ball_restitution <= 1))
    return absl::InvalidArgumentError("ball_restitution must be in (0, 1]");
  if (!(cushion_restitution > 0 && cushion_restitution <= 1))
    return absl::InvalidArgumentError("cushion_restitution must be in (0, 1]");
  if (!(sliding_friction > 0 && sliding_friction < 1))
    return absl::InvalidArgumentError("sliding_friction must be in (0, 1)");
  if (!(rolling_friction > 0 && rolling_friction < sliding_friction))
    return absl::InvalidArgumentError("rolling_friction must be in (0, sliding_friction)");
  if (!(gravity_mm_s2 > 0)) return absl::InvalidArgumentError("gravity must be positive");
  if (!(max_time_s > 0 && max_time_s <= 120))
    return absl::InvalidArgumentError("max_time_s must be in (0, 120]");
  if (!(time_step_s > 0 && time_step_s <= 0.05))
    return absl::InvalidArgumentError("time_step_s must be in (0, 0.05]");
  if (!(path_interval_s >= time_step_s))
    return absl::InvalidArgumentError("path_interval_s must be at least time_step_s");
  return absl::OkStatus();
}

std::array<cv::Point2d, 6> PoolPocketPositions(const PoolTableProfile& table) {
  const double L = table.length_mm, W = table.width_mm;
  return {cv::Point2d(0, 0), cv::Point2d(L, 0), cv::Point2d(L, W), cv::Point2d(0, W),
          cv::Point2d(L / 2, 0), cv::Point2d(L / 2, W)};
}

PoolSimulation SimulatePoolShot(const PoolTableProfile& table,
                                const std::vector<PoolBallState>& balls,
                                const cv::Point2d& cue_velocity,
                                const PoolPhysicsConstants& constants) {
  Simulator simulator(table, constants);
  return simulator.Run(balls, cue_velocity);
}

}  // namespace texfree
