// Pool ball physics on the table plane (seed 4.4: "ball behaviour follows particle
// dynamics with friction on the table and reflectance at the cushion"), made a little
// more faithful: each ball slides (cloth friction acting on the contact-point slip, so a
// struck ball turns to natural roll at 5/7 of its speed) then rolls (rolling resistance);
// balls collide with restitution along the line of centres; cushions reflect with
// restitution; pocket jaws are points the ball can hit; a ball whose centre crosses a
// pocket mouth is pocketed. Event-driven: collisions are resolved at their exact time
// within each step.
//
// Constants, with sources (typical values for pool balls on a cloth):
//   ball-ball restitution 0.95  (W. C. Marlow, "The Physics of Pocket Billiards", 1995:
//                                0.92-0.98; D. G. Alciatore, "Pool and Billiards Physics
//                                Principles", TP A.4 / billiards.colostate.edu: ~0.93-0.96)
//   cushion restitution   0.75  (Marlow: 0.6-0.9; Alciatore: ~0.7-0.8)
//   sliding friction      0.2   (Marlow; Alciatore: ball-cloth 0.2)
//   rolling resistance    0.01  (Marlow: 0.005-0.015; Alciatore: ~0.01)
// Ball-ball friction (throw), spin transfer and cushion height effects are neglected.
#pragma once

#include <array>
#include <vector>

#include <opencv2/core.hpp>

#include "absl/status/status.h"
#include "common/pool_profile.h"

namespace texfree {

struct PoolPhysicsConstants {
  double ball_restitution = 0.95;
  double cushion_restitution = 0.75;
  double sliding_friction = 0.2;
  double rolling_friction = 0.01;
  double gravity_mm_s2 = 9810;
  double max_time_s = 12;    // a simulation stops after this much table time
  double time_step_s = 0.002;  // integration step between exactly-timed events
  double path_interval_s = 0.02;  // spacing of the recorded path points

  absl::Status Validate() const;
};

struct PoolBallState {
  int number = 0;  // 0 = cue
  cv::Point2d position;  // mm, table frame
  cv::Point2d velocity;  // mm/s
  // Horizontal angular velocity (rad/s) about the table's X and Y axes.
  cv::Point2d spin;
  bool pocketed = false;
};

struct PoolSimulation {
  std::vector<PoolBallState> final_state;
  // Path of every ball that moved, in the order of final_state (empty if it never moved).
  std::vector<std::vector<cv::Point2d>> paths;
  std::vector<int> pocket_of;       // per ball: pocket index 0..5 or -1
  int first_contact = -1;           // number of the first ball the cue ball touched
  int cushion_hits_after_contact = 0;
  double duration_s = 0;
  // Kinetic energy (translation + rotation, J for balls of mass 1 kg) at each path sample:
  // never grows in a correct simulation.
  std::vector<double> energy;
};

// The six pockets: corners (0,0), (L,0), (L,W), (0,W), then the side pockets at
// (L/2,0), (L/2,W).
std::array<cv::Point2d, 6> PoolPocketPositions(const PoolTableProfile& table);

// Simulates until every ball stops (or max_time_s). The cue ball (number 0) starts with
// `cue_velocity` (mm/s) and no spin (a centre-ball hit); the others are at rest.
PoolSimulation SimulatePoolShot(const PoolTableProfile& table,
                                const std::vector<PoolBallState>& balls,
                                const cv::Point2d& cue_velocity,
                                const PoolPhysicsConstants& constants = {});

}  // namespace texfree
