// Shot search: geometric candidates (ghost ball aiming), chances from angular margins,
// verification and cue-ball position by simulation, safeties.
#include "common/pool_shots.h"

#include <algorithm>
#include <cmath>

#include "absl/strings/str_cat.h"
#include "common/status_macros.h"

namespace texfree {
namespace {

constexpr double kPi = 3.14159265358979323846;

double Dot(const cv::Point2d& a, const cv::Point2d& b) { return a.x * b.x + a.y * b.y; }
double Cross(const cv::Point2d& a, const cv::Point2d& b) { return a.x * b.y - a.y * b.x; }
cv::Point2d Unit(const cv::Point2d& v) {
  const double n = std::sqrt(Dot(v, v));
  return n > 1e-12 ? v / n : cv::Point2d(0, 0);
}

// Pocket geometry: the two jaw points of its mouth and where a ball should be sent.
struct PocketMouth {
  cv::Point2d jaw_a, jaw_b, aim;
};

std::array<PocketMouth, 6> Mouths(const PoolTableProfile& t) {
  const double L = t.length_mm, W = t.width_mm, jc = t.corner_pocket_mm / std::sqrt(2.0);
  const double hs = t.side_pocket_mm / 2, R = t.ball_radius_mm;
  const double in = 0.25 * jc;  // aim a little past the mouth, into the pocket
  return {PocketMouth{{jc, 0}, {0, jc}, {in, in}},
          PocketMouth{{L - jc, 0}, {L, jc}, {L - in, in}},
          PocketMouth{{L, W - jc}, {L - jc, W}, {L - in, W - in}},
          PocketMouth{{0, W - jc}, {jc, W}, {in, W - in}},
          PocketMouth{{L / 2 - hs, 0}, {L / 2 + hs, 0}, {L / 2, -R}},
          PocketMouth{{L / 2 - hs, W}, {L / 2 + hs, W}, {L / 2, W + R}}};
}

// Angular margin (radians) for a ball travelling `distance` towards the mouth along
// `direction`: half the mouth's width across the direction, less the part of a ball
// that would catch a jaw.
double MouthMargin(const PocketMouth& m, const cv::Point2d& direction, double distance,
                   double radius) {
  const double across = std::abs(Cross(m.jaw_b - m.jaw_a, direction));
  const double half = across / 2 - 0.6 * radius;
  if (half <= 0 || distance <= 0) return 0;
  return std::atan(half / distance);
}

double Chance(double margin_rad, double sigma_deg) {
  if (margin_rad <= 0) return 0;
  return std::erf(margin_rad / (sigma_deg * kPi / 180 * std::sqrt(2.0)));
}

// Margin on the cue direction for sending the object ball within `object_margin` of its
// line when cutting it at `cut` from `cue_distance` away (the contact point moves by
// cue_distance * d(aim) and the object's direction by that over 2R cos(cut)).
double CueMargin(double object_margin, double cut, double cue_distance, double radius) {
  return object_margin * 2 * radius * std::cos(cut) / std::max(cue_distance, radius);
}

double DirectionDeg(const cv::Point2d& v) { return std::atan2(v.y, v.x) * 180 / kPi; }

const PoolBallOnTable* Find(const std::vector<PoolBallOnTable>& balls, int number) {
  for (const auto& b : balls)
    if (b.number == number) return &b;
  return nullptr;
}

cv::Point2d At(const PoolBallOnTable& b) { return {b.x_mm, b.y_mm}; }

int Lowest(const std::vector<PoolBallOnTable>& balls) {
  int lowest = -1;
  for (const auto& b : balls)
    if (b.number > 0 && (lowest < 0 || b.number < lowest)) lowest = b.number;
  return lowest;
}

struct Candidate {
  PoolShot::Kind kind;
  int pocketed_ball;
  int pocket;
  cv::Point2d cue_direction;
  double cut;
  double chance;
};

// The geometric chance of a direct shot of `ball` into `pocket` from `cue`, with the
// cue's direction and cut angle; 0 when the paths are blocked or the cut is too thin.
double DirectGeometry(const PoolTableProfile& t, const std::vector<PoolBallOnTable>& balls,
                      const cv::Point2d& cue, const PoolBallOnTable& ball, const PocketMouth& m,
                      const PoolShotOptions& o, cv::Point2d* cue_direction, double* cut,
                      const std::vector<int>& ignore) {
  const double R = t.ball_radius_mm;
  const cv::Point2d target = At(ball);
  const cv::Point2d to_pocket = m.aim - target;
  const double d_obj = std::sqrt(Dot(to_pocket, to_pocket));
  const cv::Point2d h = Unit(to_pocket);
  const cv::Point2d ghost = target - h * (2 * R);
  const cv::Point2d to_ghost = ghost - cue;
  const double d_cue = std::sqrt(Dot(to_ghost, to_ghost));
  if (d_cue < 1e-6) return 0;
  const cv::Point2d d = to_ghost / d_cue;
  const double c = std::acos(std::clamp(Dot(d, h), -1.0, 1.0));
  if (c > o.max_cut_deg * kPi / 180) return 0;
  std::vector<int> skip_cue = ignore;
  skip_cue.push_back(0);
  skip_cue.push_back(ball.number);
  if (PoolPathBlocked(cue, ghost, R, balls, skip_cue)) return 0;
  std::vector<int> skip_obj = ignore;
  skip_obj.push_back(ball.number);
  skip_obj.push_back(0);
  if (PoolPathBlocked(target, m.aim, R, balls, skip_obj)) return 0;
  // The cue ball must also not be in the object ball's way (it will have stopped at the
  // ghost position or moved on, so only the rest of the balls count: done above).
  *cue_direction = d;
  *cut = c;
  return Chance(CueMargin(MouthMargin(m, h, d_obj, R), c, d_cue, R), o.aim_sigma_deg);
}

std::vector<PoolBallState> ToStates(const std::vector<PoolBallOnTable>& balls) {
  std::vector<PoolBallState> states;
  for (const auto& b : balls) {
    PoolBallState s;
    s.number = b.number;
    s.position = At(b);
    states.push_back(s);
  }
  return states;
}

std::vector<PoolBallOnTable> AfterShot(const PoolSimulation& sim) {
  std::vector<PoolBallOnTable> out;
  for (const auto& s : sim.final_state)
    if (!s.pocketed) out.push_back({s.number, s.position.x, s.position.y});
  return out;
}

std::vector<PoolBallPath> Paths(const PoolSimulation& sim) {
  std::vector<PoolBallPath> paths;
  for (size_t i = 0; i < sim.paths.size(); ++i)
    if (sim.paths[i].size() >= 2) paths.push_back({sim.final_state[i].number, sim.paths[i]});
  return paths;
}

}  // namespace

absl::Status PoolShotOptions::Validate() const {
  RETURN_IF_ERROR(physics.Validate());
  if (speeds_mm_s.empty()) return absl::InvalidArgumentError("speeds_mm_s is empty");
  for (double s : speeds_mm_s)
    if (!(s > 0 && s < 15000))
      return absl::InvalidArgumentError("cue speeds must be in (0, 15000) mm/s");
  if (!(aim_sigma_deg > 0)) return absl::InvalidArgumentError("aim_sigma_deg must be positive");
  if (!(max_cut_deg > 0 && max_cut_deg < 90))
    return absl::InvalidArgumentError("max_cut_deg must be in (0, 90)");
  if (!(min_pocket_chance >= 0 && min_pocket_chance <= 1))
    return absl::InvalidArgumentError("min_pocket_chance must be in [0, 1]");
  if (max_shots < 1) return absl::InvalidArgumentError("max_shots must be at least 1");
  return absl::OkStatus();
}

std::string PoolShot::Describe() const {
  const char* kinds[] = {"direct", "bank", "combination", "safety"};
  if (type == Type::kSafety)
    return absl::StrCat("safety on the ", target_ball, ": cue at ",
                        static_cast<int>(std::lround(cue_direction_deg)), " deg, ",
                        static_cast<int>(std::lround(speed_mm_s)), " mm/s; opponent's best chance ",
                        static_cast<int>(std::lround(100 * opponent_chance)), "%");
  return absl::StrCat(kinds[static_cast<int>(kind)], " ", pocketed_ball, " in pocket ", pocket,
                      ": cue at ", static_cast<int>(std::lround(cue_direction_deg)), " deg, ",
                      static_cast<int>(std::lround(speed_mm_s)), " mm/s, cut ",
                      static_cast<int>(std::lround(cut_angle_deg)), " deg, chance ",
                      static_cast<int>(std::lround(100 * chance)), "%");
}

bool PoolPathBlocked(const cv::Point2d& from, const cv::Point2d& to, double radius,
                     const std::vector<PoolBallOnTable>& balls, const std::vector<int>& ignore) {
  const cv::Point2d seg = to - from;
  const double len2 = Dot(seg, seg);
  for (const auto& b : balls) {
    if (std::find(ignore.begin(), ignore.end(), b.number) != ignore.end()) continue;
    const cv::Point2d p = At(b);
    const double s = len2 > 0 ? std::clamp(Dot(p - from, seg) / len2, 0.0, 1.0) : 0;
    const cv::Point2d closest = from + seg * s;
    if (std::sqrt(Dot(p - closest, p - closest)) < 2 * radius - 0.5) return true;
  }
  return false;
}

double BestDirectChance(const PoolTableProfile& table, const std::vector<PoolBallOnTable>& balls,
                        int target, const PoolShotOptions& options) {
  const PoolBallOnTable* cue = Find(balls, 0);
  const PoolBallOnTable* ball = Find(balls, target);
  if (!cue || !ball) return 0;
  double best = 0;
  for (const auto& m : Mouths(table)) {
    cv::Point2d d;
    double cut;
    best = std::max(best, DirectGeometry(table, balls, At(*cue), *ball, m, options, &d, &cut, {}));
  }
  return best;
}

absl::StatusOr<std::vector<PoolShot>> SuggestPoolShots(const PoolTableProfile& table,
                                                       const std::vector<PoolBallOnTable>& balls,
                                                       const PoolShotOptions& options) {
  RETURN_IF_ERROR(table.Validate());
  RETURN_IF_ERROR(options.Validate());
  const PoolBallOnTable* cue = Find(balls, 0);
  if (!cue) return absl::FailedPreconditionError("no cue ball on the table: cannot suggest shots");
  const int target_number = Lowest(balls);
  if (target_number < 0)
    return absl::FailedPreconditionError("no numbered ball on the table: nothing to shoot at");
  const PoolBallOnTable& target = *Find(balls, target_number);
  const double R = table.ball_radius_mm, L = table.length_mm, W = table.width_mm;
  const auto mouths = Mouths(table);
  const cv::Point2d cue_at = At(*cue);

  // 1. Geometric candidates.
  std::vector<Candidate> candidates;
  for (int p = 0; p < 6; ++p) {
    // Direct.
    cv::Point2d d;
    double cut;
    double chance = DirectGeometry(table, balls, cue_at, target, mouths[p], options, &d, &cut, {});
    if (chance > 0) candidates.push_back({PoolShot::Kind::kDirect, target_number, p, d, cut, chance});
    // One-cushion bank: aim the object ball at the pocket mirrored in a cushion line.
    for (int c = 0; c < 4; ++c) {
      const PocketMouth& m = mouths[p];
      PocketMouth mirrored = m;
      auto mirror = [&](const cv::Point2d& q) {
        switch (c) {
          case 0: return cv::Point2d(q.x, 2 * R - q.y);
          case 1: return cv::Point2d(q.x, 2 * (W - R) - q.y);
          case 2: return cv::Point2d(2 * R - q.x, q.y);
          default: return cv::Point2d(2 * (L - R) - q.x, q.y);
        }
      };
      mirrored.aim = mirror(m.aim);
      mirrored.jaw_a = mirror(m.jaw_a);
      mirrored.jaw_b = mirror(m.jaw_b);
      // The bank point on the cushion line must be on a cushion, not in a pocket.
      const cv::Point2d t0 = At(target);
      const cv::Point2d dir = mirrored.aim - t0;
      double s;
      switch (c) {
        case 0: s = (R - t0.y) / dir.y; break;
        case 1: s = (W - R - t0.y) / dir.y; break;
        case 2: s = (R - t0.x) / dir.x; break;
        default: s = (L - R - t0.x) / dir.x; break;
      }
      if (!(s > 0 && s < 1)) continue;
      const cv::Point2d bank = t0 + dir * s;
      const double along = c < 2 ? bank.x : bank.y;
      const double jc = table.corner_pocket_mm / std::sqrt(2.0) + R;
      if (along < jc || along > (c < 2 ? L : W) - jc) continue;
      if (c < 2 && std::abs(bank.x - L / 2) < table.side_pocket_mm / 2 + R) continue;
      // Ghost ball towards the bank point; the object's second leg must be clear too.
      const double chance_geo =
          DirectGeometry(table, balls, cue_at, target,
                         PocketMouth{mirrored.jaw_a, mirrored.jaw_b, mirrored.aim}, options, &d,
                         &cut, {});
      if (chance_geo <= 0) continue;
      if (PoolPathBlocked(bank, m.aim, R, balls, {target_number, 0})) continue;
      // Cushions are less predictable than straight lines.
      candidates.push_back({PoolShot::Kind::kBank, target_number, p, d, cut, 0.6 * chance_geo});
    }
    // Combination: the target sends another ball into the pocket.
    for (const auto& other : balls) {
      if (other.number == 0 || other.number == target_number) continue;
      const cv::Point2d b = At(other);
      const cv::Point2d hb = Unit(mouths[p].aim - b);
      const double d_b = std::sqrt(Dot(mouths[p].aim - b, mouths[p].aim - b));
      const cv::Point2d ghost_b = b - hb * (2 * R);
      const cv::Point2d t0 = At(target);
      const cv::Point2d ht = Unit(ghost_b - t0);
      const double d_tb = std::sqrt(Dot(ghost_b - t0, ghost_b - t0));
      const double cut_b = std::acos(std::clamp(Dot(ht, hb), -1.0, 1.0));
      if (cut_b > 60 * kPi / 180 || d_tb < 1) continue;
      if (PoolPathBlocked(b, mouths[p].aim, R, balls, {other.number})) continue;
      if (PoolPathBlocked(t0, ghost_b, R, balls, {other.number, target_number, 0})) continue;
      const cv::Point2d ghost_t = t0 - ht * (2 * R);
      const cv::Point2d dc = Unit(ghost_t - cue_at);
      const double d_cue = std::sqrt(Dot(ghost_t - cue_at, ghost_t - cue_at));
      const double cut_t = std::acos(std::clamp(Dot(dc, ht), -1.0, 1.0));
      if (cut_t > 60 * kPi / 180) continue;
      if (PoolPathBlocked(cue_at, ghost_t, R, balls, {0, target_number})) continue;
      const double margin_b = MouthMargin(mouths[p], hb, d_b, R);
      const double margin_t = CueMargin(margin_b, cut_b, d_tb, R);
      const double margin_cue = CueMargin(margin_t, cut_t, d_cue, R);
      const double chance_c = Chance(margin_cue, options.aim_sigma_deg);
      if (chance_c > 0.02)
        candidates.push_back(
            {PoolShot::Kind::kCombination, other.number, p, dc, cut_t, chance_c});
    }
  }
  std::sort(candidates.begin(), candidates.end(),
            [](const Candidate& a, const Candidate& b) { return a.chance > b.chance; });
  if (candidates.size() > 12) candidates.resize(12);

  // 2. Each candidate simulated at each speed: it must hit the target first, pocket the
  // intended ball in the intended pocket and keep the cue ball on the table.
  const std::vector<PoolBallState> states = ToStates(balls);
  std::vector<PoolShot> shots;
  for (const auto& c : candidates) {
    PoolShot best;
    best.score = -1;
    for (double speed : options.speeds_mm_s) {
      const PoolSimulation sim =
          SimulatePoolShot(table, states, c.cue_direction * speed, options.physics);
      if (sim.first_contact != target_number) continue;
      bool made = false, scratch = false;
      for (size_t i = 0; i < sim.final_state.size(); ++i) {
        if (sim.final_state[i].number == c.pocketed_ball && sim.pocket_of[i] == c.pocket)
          made = true;
        if (sim.final_state[i].number == 0 && sim.pocket_of[i] >= 0) scratch = true;
      }
      if (!made || scratch) continue;
      const std::vector<PoolBallOnTable> after = AfterShot(sim);
      const int next = Lowest(after);
      const double next_chance =
          next < 0 || !Find(after, 9) ? 1.0 : BestDirectChance(table, after, next, options);
      const double score = c.chance * (0.65 + 0.35 * next_chance);
      if (score > best.score) {
        best.type = PoolShot::Type::kPocket;
        best.kind = c.kind;
        best.target_ball = target_number;
        best.pocketed_ball = c.pocketed_ball;
        best.pocket = c.pocket;
        best.cue_direction_deg = DirectionDeg(c.cue_direction);
        best.speed_mm_s = speed;
        best.cut_angle_deg = c.cut * 180 / kPi;
        best.chance = c.chance;
        best.next_chance = next_chance;
        best.difficulty = 1 - c.chance;
        best.score = score;
        best.paths = Paths(sim);
      }
    }
    if (best.score >= 0) shots.push_back(best);
  }
  std::sort(shots.begin(), shots.end(),
            [](const PoolShot& a, const PoolShot& b) { return a.score > b.score; });

  // 3. Safeties when no pocket shot is sensible: hit the target first, leave the
  // opponent the poorest best shot.
  if (shots.empty() || shots.front().chance < options.min_pocket_chance) {
    std::vector<PoolShot> safeties;
    // Aim points: the target itself, and its mirror images in the four cushion lines
    // (kick safeties when the direct line is blocked); a few contact offsets on each.
    const cv::Point2d t0 = At(target);
    const std::array<cv::Point2d, 5> aims = {t0, cv::Point2d(t0.x, 2 * R - t0.y),
                                             cv::Point2d(t0.x, 2 * (W - R) - t0.y),
                                             cv::Point2d(2 * R - t0.x, t0.y),
                                             cv::Point2d(2 * (L - R) - t0.x, t0.y)};
    for (const auto& aim : aims) {
      const cv::Point2d to_target = aim - cue_at;
      const double d = std::sqrt(Dot(to_target, to_target));
      if (d <= 2 * R) continue;
      for (double offset : {-0.8, -0.5, -0.25, 0.0, 0.25, 0.5, 0.8}) {
        const double angle =
            std::atan2(to_target.y, to_target.x) + std::asin(offset * 2 * R / d);
        const cv::Point2d dir(std::cos(angle), std::sin(angle));
        for (double speed : {500.0, 800.0, 1200.0, 1800.0}) {
          const PoolSimulation sim =
              SimulatePoolShot(table, states, dir * speed, options.physics);
          if (sim.first_contact != target_number) continue;
          bool scratch = false, any_pocketed = false;
          for (size_t i = 0; i < sim.final_state.size(); ++i) {
            if (sim.pocket_of[i] >= 0) any_pocketed = true;
            if (sim.final_state[i].number == 0 && sim.pocket_of[i] >= 0) scratch = true;
          }
          // A legal safety: no scratch, and a ball reaches a cushion after the contact.
          if (scratch || any_pocketed || sim.cushion_hits_after_contact == 0) continue;
          const std::vector<PoolBallOnTable> after = AfterShot(sim);
          PoolShot s;
          s.type = PoolShot::Type::kSafety;
          s.kind = PoolShot::Kind::kSafety;
          s.target_ball = target_number;
          s.cue_direction_deg = DirectionDeg(dir);
          s.speed_mm_s = speed;
          s.opponent_chance = BestDirectChance(table, after, target_number, options);
          s.chance = 1;
          s.score = 1 - s.opponent_chance;
          s.difficulty = s.opponent_chance;
          s.paths = Paths(sim);
          safeties.push_back(s);
        }
      }
    }
    std::sort(safeties.begin(), safeties.end(),
              [](const PoolShot& a, const PoolShot& b) { return a.score > b.score; });
    // Safeties first when the pocket shots are poor.
    std::vector<PoolShot> merged;
    for (size_t i = 0; i < safeties.size() && static_cast<int>(merged.size()) < options.max_shots;
         ++i)
      merged.push_back(safeties[i]);
    for (size_t i = 0; i < shots.size() && static_cast<int>(merged.size()) < options.max_shots; ++i)
      merged.push_back(shots[i]);
    shots = std::move(merged);
  }
  if (static_cast<int>(shots.size()) > options.max_shots) shots.resize(options.max_shots);
  return shots;
}

}  // namespace texfree
