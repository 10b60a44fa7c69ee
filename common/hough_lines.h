// HoughLinesOnPoints: the standard (rho, theta) Hough transform over a list of edge pixels.
#pragma once

#include <opencv2/core.hpp>
#include <vector>

namespace texfree {

// The lines that cv::HoughLines(image, lines, rho_step, theta_step, threshold) returns as
// cv::Vec3f (rho, theta, votes), strongest first, for an image of `image_size` whose
// non-zero pixels are `points` (duplicates count once). theta runs over [0, pi).
//
// Why not cv::HoughLines: OpenCV votes point by point across every angle row of a
// freshly allocated accumulator (1.6 MB for a 320x240 image at half a degree) and then
// scans all of it for peaks. Here the votes go angle row by angle row (one row stays in
// cache), the accumulator is reused per thread, and only cells that passed the threshold
// while voting are tested as peaks. Same votes, same peaks, same order; the table
// outline's transform costs a fraction of OpenCV's.
// Thread-safe (the accumulator is per thread).
std::vector<cv::Vec3f> HoughLinesOnPoints(const std::vector<cv::Point>& points, cv::Size image_size,
                                          double rho_step, double theta_step, int threshold);

}  // namespace texfree
