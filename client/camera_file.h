// Loader for CAMERA.yml: the OpenCV FileStorage file written by OpenCV's
// calibration tools (camera_matrix, distortion_coefficients, image_width,
// image_height).
#pragma once

#include <filesystem>
#include <opencv2/core/mat.hpp>
#include <opencv2/core/matx.hpp>
#include <stdexcept>
#include <string>
#include <vector>

namespace texfree::client {

class CameraFileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct CameraFile {
  cv::Matx33d camera_matrix = cv::Matx33d::eye();
  // OpenCV order: k1 k2 p1 p2 [k3 [k4 k5 k6 [s1 s2 s3 s4 [tx ty]]]].
  std::vector<double> distortion;
  int image_width = 0;
  int image_height = 0;

  double fx() const { return camera_matrix(0, 0); }
  double fy() const { return camera_matrix(1, 1); }
  double cx() const { return camera_matrix(0, 2); }
  double cy() const { return camera_matrix(1, 2); }
};

// Reads a YAML/XML/JSON FileStorage file. Throws CameraFileError, naming the
// file and the key, when the file is unreadable, a key is missing or a matrix
// has a wrong size. distortion_coefficients may be 1xN or Nx1 with N in {4, 5,
// 8, 12, 14}; a missing distortion_coefficients node means no distortion.
CameraFile LoadCameraFile(const std::filesystem::path& path);

// Undoes a camera's lens distortion on its frames: each frame is remapped to the ideal
// pinhole image of the same camera matrix, in which a flat page is exactly a homography
// of itself. Maps are built for the first frame size seen. Not thread-safe.
class FrameUndistorter {
 public:
  explicit FrameUndistorter(const CameraFile& camera);
  // The frame as the ideal pinhole sees it (a view of `frame` when there is no distortion).
  // Throws CameraFileError when the frame's size is not the calibration's.
  cv::Mat Apply(const cv::Mat& frame);
  // The camera of the undistorted frames: the same matrix, no distortion.
  CameraFile ideal() const;

 private:
  CameraFile camera_;
  bool distorted_ = false;  // any distortion coefficient non-zero
  cv::Size size_;
  cv::Mat map1_, map2_;
};

// Writes the same format (used by tests and tools).
void SaveCameraFile(const std::filesystem::path& path,
                    const CameraFile& camera);

}  // namespace texfree::client
