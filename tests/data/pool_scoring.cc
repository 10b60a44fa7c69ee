// Scoring of pool analyses against ground truth.
#include "tests/data/pool_scoring.h"

#include <algorithm>
#include <cmath>

namespace texfree::testdata {

PoolScore ScorePoolAnalysis(const PoolScene& scene, const PoolView& view,
                            const std::array<cv::Point2d, 4>& corners,
                            const std::vector<EstimatedPoolBall>& estimated) {
  PoolScore score;
  double direct = 0, rotated = 0;
  for (int i = 0; i < 4; ++i) {
    direct = std::max(direct, cv::norm(corners[i] - view.cloth_corners[i]));
    rotated = std::max(rotated, cv::norm(corners[i] - view.cloth_corners[(i + 2) % 4]));
  }
  score.rotated = rotated < direct;
  score.max_corner_error_px = std::min(direct, rotated);
  const double L = scene.table.length_mm, W = scene.table.width_mm;
  const double r = scene.table.ball_radius_mm;
  std::vector<EstimatedPoolBall> est = estimated;
  if (score.rotated)
    for (auto& e : est) {
      e.x_mm = L - e.x_mm;
      e.y_mm = W - e.y_mm;
    }
  std::vector<bool> used(est.size(), false);
  for (const auto& truth : view.balls) {
    int best = -1;
    double best_d = r;
    for (size_t i = 0; i < est.size(); ++i) {
      const double d = std::hypot(est[i].x_mm - truth.x_mm, est[i].y_mm - truth.y_mm);
      if (!used[i] && d < best_d) {
        best_d = d;
        best = static_cast<int>(i);
      }
    }
    if (truth.separated) ++score.separated;
    PoolBallMatch match;
    match.truth_number = truth.number;
    match.separated = truth.separated;
    match.pixel = truth.pixel;
    if (best >= 0) {
      match.estimated_number = est[best].number;
      match.estimated_index = best;
      match.error_mm = best_d;
      match.dx_mm = est[best].x_mm - truth.x_mm;
      match.dy_mm = est[best].y_mm - truth.y_mm;
    }
    score.matches.push_back(match);
    if (best < 0) continue;
    used[best] = true;
    score.position_errors_mm.push_back(best_d);
    if (truth.separated) {
      ++score.separated_found;
      if (est[best].number == truth.number) ++score.separated_identified;
    }
  }
  for (bool u : used)
    if (!u) ++score.false_balls;
  return score;
}

}  // namespace texfree::testdata
