// HoughLinesOnPoints: votes angle row by angle row, peaks only among cells over threshold.
#include "common/hough_lines.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <opencv2/core/fast_math.hpp>
#include <opencv2/core/hal/intrin.hpp>

namespace texfree {

std::vector<cv::Vec3f> HoughLinesOnPoints(const std::vector<cv::Point>& points, cv::Size image_size,
                                          double rho_step, double theta_step, int threshold) {
  std::vector<cv::Vec3f> lines;
  if (points.empty() || rho_step <= 0 || theta_step <= 0 || image_size.area() <= 0) return lines;
  // Distinct pixels inside the image, as the non-zero pixels of a drawn outline.
  std::vector<cv::Point> pixels;
  pixels.reserve(points.size());
  for (const cv::Point& p : points)
    if (p.x >= 0 && p.y >= 0 && p.x < image_size.width && p.y < image_size.height)
      pixels.push_back(p);
  std::sort(pixels.begin(), pixels.end(), [](const cv::Point& a, const cv::Point& b) {
    return a.y != b.y ? a.y < b.y : a.x < b.x;
  });
  pixels.erase(std::unique(pixels.begin(), pixels.end()), pixels.end());
  const size_t count = pixels.size();
  std::vector<float> xs(count), ys(count);
  std::vector<int> rs(count);
  for (size_t i = 0; i < count; ++i) {
    xs[i] = static_cast<float>(pixels[i].x);
    ys[i] = static_cast<float>(pixels[i].y);
  }

  const float irho = static_cast<float>(1 / rho_step);
  const float theta = static_cast<float>(theta_step);
  const int num_angles = std::max(1, cvRound(CV_PI / theta_step));
  const int num_rho = cvRound(((image_size.width + image_size.height) * 2 + 1) / rho_step);
  const int stride = num_rho + 2;  // a zero cell either side of each row, and a row either end
  const int rho_offset = (num_rho - 1) / 2;
  thread_local std::vector<int> accumulator;
  const size_t cells = static_cast<size_t>(num_angles + 2) * stride;
  if (accumulator.size() < cells) accumulator.resize(cells);
  std::memset(accumulator.data(), 0, cells * sizeof(int));
  std::vector<int> over;  // cells that passed the threshold, in voting order

  // The angle table accumulates its angle in float, as cv::HoughLines does, so that the
  // rounding of every vote (and so every count) is the same as OpenCV's.
  float angle = 0;
  for (int n = 0; n < num_angles; ++n, angle += theta) {
    const float c = static_cast<float>(std::cos(static_cast<double>(angle)) * irho);
    const float s = static_cast<float>(std::sin(static_cast<double>(angle)) * irho);
    const int row_start = (n + 1) * stride + 1 + rho_offset;  // the cell of rho 0
    int* row = accumulator.data() + row_start;
    // The rounding is done four at a time (round to nearest even, as cvRound), the votes
    // one by one.
    const cv::v_float32x4 vc = cv::v_setall_f32(c), vs = cv::v_setall_f32(s);
    size_t i = 0;
    for (; i + 4 <= count; i += 4)
      cv::v_store(rs.data() + i,
                  cv::v_round(cv::v_load(xs.data() + i) * vc + cv::v_load(ys.data() + i) * vs));
    for (; i < count; ++i) rs[i] = cvRound(xs[i] * c + ys[i] * s);
    for (i = 0; i < count; ++i) {
      const int r = rs[i];
      if (++row[r] == threshold + 1) over.push_back(row_start + r);
    }
  }
  // Peaks: over the threshold, above the cell before and not below the cell after, in rho
  // and in angle (OpenCV's test, so that plateaus give one line).
  const int* acc = accumulator.data();
  std::vector<int> peaks;
  for (int base : over) {
    const int v = acc[base];
    if (v > acc[base - 1] && v >= acc[base + 1] && v > acc[base - stride] &&
        v >= acc[base + stride])
      peaks.push_back(base);
  }
  std::sort(peaks.begin(), peaks.end(),
            [acc](int a, int b) { return acc[a] > acc[b] || (acc[a] == acc[b] && a < b); });
  lines.reserve(peaks.size());
  for (int base : peaks) {
    const int n = base / stride - 1;
    const int r = base - (n + 1) * stride - 1;
    lines.emplace_back((r - (num_rho - 1) * 0.5f) * static_cast<float>(rho_step), n * theta,
                       static_cast<float>(acc[base]));
  }
  return lines;
}

}  // namespace texfree
