// Scoring of a pool analysis against the renderer's ground truth (shared by the tests and
// the benchmark): which origin the estimate used, per-ball position errors, whether each
// separated ball was found and numbered right.
#ifndef TEXFREE_TESTS_DATA_POOL_SCORING_H_
#define TEXFREE_TESTS_DATA_POOL_SCORING_H_

#include <array>
#include <vector>

#include <opencv2/core.hpp>

#include "tests/data/pool_renderer.h"

namespace texfree::testdata {

struct EstimatedPoolBall {
  int number = -1;
  double x_mm = 0, y_mm = 0;
};

struct PoolBallMatch {
  int truth_number = 0;
  bool separated = false;
  int estimated_number = -2;  // -2: not found
  int estimated_index = -1;   // index into the estimates, -1: not found
  double error_mm = -1;
  double dx_mm = 0, dy_mm = 0;  // estimate - truth
  cv::Point2d pixel;  // true centre in the image
};

struct PoolScore {
  std::vector<PoolBallMatch> matches;  // one per true ball
  bool rotated = false;           // the estimate's origin is the opposite corner
  double max_corner_error_px = 0;  // playing-surface corners, image pixels
  std::vector<double> position_errors_mm;  // one per matched true ball
  int separated = 0;             // separated true balls
  int separated_found = 0;       // ... with an estimate within one radius
  int separated_identified = 0;  // ... and the right number
  int false_balls = 0;           // estimates with no true ball within one radius
};

// Matches estimates to the truth (nearest within one ball radius, after undoing the
// table's 180 degree symmetry when the estimated corners say so).
PoolScore ScorePoolAnalysis(const PoolScene& scene, const PoolView& view,
                            const std::array<cv::Point2d, 4>& estimated_corners,
                            const std::vector<EstimatedPoolBall>& estimated);

}  // namespace texfree::testdata

#endif  // TEXFREE_TESTS_DATA_POOL_SCORING_H_
