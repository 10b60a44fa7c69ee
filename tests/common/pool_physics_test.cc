// Pool physics and shot search: stopping distances against the slide/roll formulas,
// energy never grows, the reflection angle at a cushion, a straight shot at a pocket
// goes in, a blocked path is detected and avoided, combinations and safeties.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "common/pool_physics.h"
#include "common/pool_shots.h"

namespace texfree {
namespace {

constexpr double kPi = 3.14159265358979323846;

PoolBallState Ball(int number, double x, double y) {
  PoolBallState b;
  b.number = number;
  b.position = {x, y};
  return b;
}

TEST(PoolPhysics, LoneBallStopsWhereSlideAndRollFormulasSay) {
  const PoolTableProfile table = BenchPoolProfile();
  PoolPhysicsConstants k;
  const double v0 = 500;  // mm/s along +X, centre-ball hit: slides, then rolls at 5/7 v0
  const double g = k.gravity_mm_s2;
  const double v_roll = 5.0 / 7.0 * v0;
  const double slide = (v0 * v0 - v_roll * v_roll) / (2 * k.sliding_friction * g);
  const double roll = v_roll * v_roll / (2 * k.rolling_friction * g);
  const double start = 100;
  ASSERT_LT(start + slide + roll, table.length_mm - table.ball_radius_mm)
      << "test must stop before the cushion";
  const PoolSimulation sim =
      SimulatePoolShot(table, {Ball(0, start, table.width_mm / 2)}, {v0, 0}, k);
  EXPECT_NEAR(sim.final_state[0].position.x, start + slide + roll, 3.0);
  EXPECT_NEAR(sim.final_state[0].position.y, table.width_mm / 2, 1e-6);
}

TEST(PoolPhysics, EnergyNeverGrows) {
  const PoolTableProfile table = BenchPoolProfile();
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> ux(60, table.length_mm - 60), uy(60, table.width_mm - 60);
  for (int trial = 0; trial < 5; ++trial) {
    std::vector<PoolBallState> balls;
    while (balls.size() < 10) {
      const PoolBallState b = Ball(static_cast<int>(balls.size()), ux(rng), uy(rng));
      bool free = true;
      for (const auto& o : balls)
        if (cv::norm(o.position - b.position) < 2 * table.ball_radius_mm + 1) free = false;
      if (free) balls.push_back(b);
    }
    const double angle = std::uniform_real_distribution<double>(0, 2 * kPi)(rng);
    const PoolSimulation sim =
        SimulatePoolShot(table, balls, {5000 * std::cos(angle), 5000 * std::sin(angle)});
    ASSERT_GT(sim.energy.size(), 10u);
    for (size_t i = 1; i < sim.energy.size(); ++i)
      ASSERT_LE(sim.energy[i], sim.energy[i - 1] * (1 + 1e-9) + 1e-12) << "sample " << i;
    EXPECT_NEAR(sim.energy.back(), 0, 1e-9);
    // No two balls left overlapping.
    for (size_t i = 0; i < sim.final_state.size(); ++i)
      for (size_t j = i + 1; j < sim.final_state.size(); ++j) {
        if (sim.final_state[i].pocketed || sim.final_state[j].pocketed) continue;
        EXPECT_GT(cv::norm(sim.final_state[i].position - sim.final_state[j].position),
                  2 * table.ball_radius_mm - 0.5);
      }
  }
}

TEST(PoolPhysics, CushionReflectsWithRestitutionOnTheNormalComponent) {
  const PoolTableProfile table = BenchPoolProfile();
  PoolPhysicsConstants k;
  k.time_step_s = k.path_interval_s = 0.0005;
  const double R = table.ball_radius_mm;
  // A ball in natural roll (started far enough to finish sliding) meeting the Y = 0
  // cushion at 45 degrees between the pockets.
  const cv::Point2d start(300, 300);
  const PoolSimulation sim = SimulatePoolShot(table, {Ball(0, start.x, start.y)},
                                              {1500 / std::sqrt(2.0), -1500 / std::sqrt(2.0)}, k);
  const auto& path = sim.paths[0];
  size_t bounce = 0;
  for (size_t i = 1; i < path.size(); ++i)
    if (path[i].y < path[bounce].y) bounce = i;
  ASSERT_NEAR(path[bounce].y, R, 0.5);
  ASSERT_LT(bounce + 3, path.size());
  const cv::Point2d in = path[bounce] - path[bounce - 2];
  const cv::Point2d out = path[bounce + 2] - path[bounce];
  const double angle_in = std::atan2(std::abs(in.x), std::abs(in.y));   // from the normal
  const double angle_out = std::atan2(std::abs(out.x), std::abs(out.y));
  // tan(out) = v_t / (e v_n) = tan(in) / e.
  EXPECT_NEAR(std::tan(angle_out), std::tan(angle_in) / k.cushion_restitution, 0.05);
  EXPECT_GT(out.y, 0);  // bounced back onto the table
}

TEST(PoolPhysics, HeadOnCollisionPassesTheSpeedOn) {
  const PoolTableProfile table = BenchPoolProfile();
  PoolPhysicsConstants k;
  const double y = table.width_mm / 2;
  const PoolSimulation sim =
      SimulatePoolShot(table, {Ball(0, 300, y), Ball(1, 400, y)}, {800, 0}, k);
  EXPECT_EQ(sim.first_contact, 1);
  // Equal masses: the cue ball nearly stops (1 - e)/2 of its speed, then follows with
  // its forward roll; the object ball goes on along the line.
  EXPECT_GT(sim.final_state[1].position.x, sim.final_state[0].position.x + 40);
  EXPECT_NEAR(sim.final_state[1].position.y, y, 1e-6);
}

TEST(PoolShots, StraightShotAtACornerPocketGoesIn) {
  const PoolTableProfile table = BenchPoolProfile();
  // Cue, 1 and the (0,0) corner pocket on one diagonal line.
  const std::vector<PoolBallOnTable> balls = {{0, 500, 500}, {1, 250, 250}, {9, 1100, 600}};
  auto shots = SuggestPoolShots(table, balls);
  ASSERT_TRUE(shots.ok()) << shots.status();
  ASSERT_FALSE(shots->empty());
  const PoolShot& best = shots->front();
  EXPECT_EQ(best.type, PoolShot::Type::kPocket);
  EXPECT_EQ(best.kind, PoolShot::Kind::kDirect);
  EXPECT_EQ(best.target_ball, 1);
  EXPECT_EQ(best.pocket, 0);
  EXPECT_NEAR(best.cue_direction_deg, -135, 1.0);
  EXPECT_NEAR(best.cut_angle_deg, 0, 1.0);
  EXPECT_GT(best.chance, 0.8);
  // Replaying the suggested shot pockets the 1 in pocket 0 and not the cue ball.
  std::vector<PoolBallState> states;
  for (const auto& b : balls) states.push_back(Ball(b.number, b.x_mm, b.y_mm));
  const double a = best.cue_direction_deg * kPi / 180;
  const PoolSimulation sim = SimulatePoolShot(
      table, states, {best.speed_mm_s * std::cos(a), best.speed_mm_s * std::sin(a)});
  EXPECT_EQ(sim.pocket_of[1], 0);
  EXPECT_EQ(sim.pocket_of[0], -1);
  // Paths: the cue ball and the 1 moved, and the 1's path ends in the pocket mouth.
  bool has_one = false;
  for (const auto& p : best.paths)
    if (p.number == 1) {
      has_one = true;
      EXPECT_LT(p.points_mm.back().x + p.points_mm.back().y,
                table.corner_pocket_mm / std::sqrt(2.0) + 1);
    }
  EXPECT_TRUE(has_one);
}

TEST(PoolShots, BlockedPathIsDetectedAndAvoided) {
  const PoolTableProfile table = BenchPoolProfile();
  const std::vector<PoolBallOnTable> balls = {{0, 500, 500}, {1, 250, 250}, {5, 375, 375}};
  EXPECT_TRUE(PoolPathBlocked({500, 500}, {250, 250}, table.ball_radius_mm, balls, {0, 1}));
  EXPECT_FALSE(PoolPathBlocked({500, 500}, {900, 500}, table.ball_radius_mm, balls, {0, 1}));
  auto shots = SuggestPoolShots(table, balls);
  ASSERT_TRUE(shots.ok()) << shots.status();
  for (const auto& shot : *shots) {
    // Nothing may send the cue ball through the 5 into the 1 along the diagonal.
    EXPECT_FALSE(shot.kind == PoolShot::Kind::kDirect && shot.pocket == 0 &&
                 std::abs(shot.cue_direction_deg + 135) < 5)
        << shot.Describe();
    EXPECT_EQ(shot.target_ball, 1);
  }
}

TEST(PoolShots, SafetyWhenNothingCanBePocketed) {
  const PoolTableProfile table = BenchPoolProfile();
  // The 1 frozen to the far short cushion, straight away from the cue ball: every pot
  // would need a cut of 90 degrees or more.
  const std::vector<PoolBallOnTable> balls = {{0, 1100, 350}, {1, 24.5, 350}, {9, 700, 600}};
  auto shots = SuggestPoolShots(table, balls);
  ASSERT_TRUE(shots.ok()) << shots.status();
  ASSERT_FALSE(shots->empty());
  const PoolShot& best = shots->front();
  EXPECT_EQ(best.type, PoolShot::Type::kSafety) << best.Describe();
  EXPECT_EQ(best.target_ball, 1);
  // The suggestion leaves the opponent worse off than the position the player faced.
  EXPECT_LT(best.opponent_chance, 0.3);
  for (const auto& s : *shots) EXPECT_EQ(s.target_ball, 1);
}

TEST(PoolShots, MissingCueBallIsAClearError) {
  auto shots = SuggestPoolShots(BenchPoolProfile(), {{1, 300, 300}});
  ASSERT_FALSE(shots.ok());
  EXPECT_EQ(shots.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_NE(shots.status().message().find("cue ball"), std::string::npos);
}

}  // namespace
}  // namespace texfree
