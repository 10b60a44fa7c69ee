// Shot suggestions for 9-ball (seed 4.4): pocket shots on the lowest-numbered ball
// (direct, one-cushion bank, combination through another ball), each simulated at a few
// speeds with the physics of pool_physics.h and ranked by how forgiving it is (cut angle,
// distances, pocket size) and by the position the cue ball is left in for the next ball;
// when no pocket shot is sensible, safety shots that hit the lowest ball first and leave
// the opponent the poorest best shot.
#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "absl/status/statusor.h"
#include "common/pool_physics.h"
#include "common/pool_profile.h"

namespace texfree {

struct PoolShotOptions {
  PoolPhysicsConstants physics;
  // Cue speeds tried for each candidate, mm/s.
  std::vector<double> speeds_mm_s = {700, 1000, 1400, 2000, 2800, 3800};
  // Standard deviation of a player's aim (degrees of cue direction): turns each shot's
  // angular margin into a chance of success.
  double aim_sigma_deg = 0.6;
  // Largest cut angle tried, degrees.
  double max_cut_deg = 75;
  // Below this chance of success a pocket shot is not "sensible" and safeties are added.
  double min_pocket_chance = 0.3;
  int max_shots = 3;

  absl::Status Validate() const;
};

struct PoolBallPath {
  int number = 0;
  std::vector<cv::Point2d> points_mm;
};

struct PoolShot {
  enum class Type { kPocket, kSafety };
  enum class Kind { kDirect, kBank, kCombination, kSafety };
  Type type = Type::kPocket;
  Kind kind = Kind::kDirect;
  int target_ball = 0;    // the lowest ball, the one the cue ball must hit first
  int pocketed_ball = -1;  // pocket shots: the ball that goes in (the target, or the
                           // second ball of a combination)
  int pocket = -1;         // 0..5 as PoolPocketPositions
  double cue_direction_deg = 0;  // in the table frame, from +X towards +Y
  double speed_mm_s = 0;
  double cut_angle_deg = 0;
  double chance = 0;        // of making the shot with aim_sigma_deg
  double next_chance = 0;   // best chance on the next ball from where the cue ball stops
  double opponent_chance = 0;  // safeties: the opponent's best chance afterwards
  double difficulty = 0;    // 1 - chance
  double score = 0;         // ranking
  std::vector<PoolBallPath> paths;  // every ball that moves
  std::string Describe() const;
};

struct PoolBallOnTable {
  int number = 0;  // 0 = cue
  double x_mm = 0, y_mm = 0;
};

// Shots for the arrangement, best first. Errors: FAILED_PRECONDITION without a cue ball
// or without an object ball; INVALID_ARGUMENT for bad options/profile.
absl::StatusOr<std::vector<PoolShot>> SuggestPoolShots(const PoolTableProfile& table,
                                                       const std::vector<PoolBallOnTable>& balls,
                                                       const PoolShotOptions& options = {});

// The best chance of any direct pocket shot from the cue position on `target` (0 if
// none): how easy a layout is for whoever shoots next.
double BestDirectChance(const PoolTableProfile& table, const std::vector<PoolBallOnTable>& balls,
                        int target, const PoolShotOptions& options);

// True when a ball of radius r moving from `from` to `to` would touch any of `balls`
// (numbers in `ignore` excluded).
bool PoolPathBlocked(const cv::Point2d& from, const cv::Point2d& to, double radius,
                     const std::vector<PoolBallOnTable>& balls, const std::vector<int>& ignore);

}  // namespace texfree
