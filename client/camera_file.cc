// CAMERA.yml loading and saving with cv::FileStorage.
#include "client/camera_file.h"

#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/core/persistence.hpp>
#include <opencv2/imgproc.hpp>

namespace texfree::client {
namespace {

[[noreturn]] void Fail(const std::filesystem::path& path,
                       const std::string& what) {
  throw CameraFileError(path.string() + ": " + what);
}

int ReadPositiveInt(const cv::FileNode& node, const std::filesystem::path& path,
                    const char* key) {
  if (node.empty() || node.isNone())
    Fail(path, std::string("missing key '") + key + "'");
  if (!node.isInt() && !node.isReal()) {
    Fail(path, std::string("key '") + key + "' must be a number");
  }
  double value = node.real();
  if (!(value > 0) || value != std::floor(value)) {
    Fail(path, std::string("key '") + key + "' must be a positive integer");
  }
  return static_cast<int>(value);
}

cv::Mat ReadMatrix(const cv::FileNode& node, const std::filesystem::path& path,
                   const char* key) {
  cv::Mat matrix;
  try {
    node >> matrix;
  } catch (const cv::Exception& e) {
    Fail(path, std::string("key '") + key + "' is not a matrix: " + e.err);
  }
  if (matrix.empty())
    Fail(path, std::string("key '") + key + "' is not a matrix");
  if (matrix.channels() != 1) {
    Fail(path,
         std::string("key '") + key + "' must be a single-channel matrix");
  }
  matrix.convertTo(matrix, CV_64F);
  return matrix;
}

}  // namespace

CameraFile LoadCameraFile(const std::filesystem::path& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec))
    Fail(path, "cannot read camera file");
  cv::FileStorage storage;
  try {
    if (!storage.open(path.string(), cv::FileStorage::READ)) {
      Fail(path, "cannot read camera file");
    }
  } catch (const cv::Exception& e) {
    Fail(path, "not an OpenCV FileStorage file (YAML/XML/JSON): " + e.err);
  }

  CameraFile camera;
  cv::FileNode matrix_node = storage["camera_matrix"];
  if (matrix_node.empty() || matrix_node.isNone())
    Fail(path, "missing key 'camera_matrix'");
  cv::Mat matrix = ReadMatrix(matrix_node, path, "camera_matrix");
  if (matrix.rows != 3 || matrix.cols != 3) {
    Fail(path, "key 'camera_matrix' must be 3x3 (got " +
                   std::to_string(matrix.rows) + "x" +
                   std::to_string(matrix.cols) + ")");
  }
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c)
      camera.camera_matrix(r, c) = matrix.at<double>(r, c);
  }
  if (!(camera.fx() > 0) || !(camera.fy() > 0)) {
    Fail(path, "key 'camera_matrix' must have positive focal lengths fx, fy");
  }

  cv::FileNode distortion_node = storage["distortion_coefficients"];
  if (!distortion_node.empty() && !distortion_node.isNone()) {
    cv::Mat distortion =
        ReadMatrix(distortion_node, path, "distortion_coefficients");
    int count = static_cast<int>(distortion.total());
    if ((distortion.rows != 1 && distortion.cols != 1) ||
        (count != 4 && count != 5 && count != 8 && count != 12 &&
         count != 14)) {
      Fail(path,
           "key 'distortion_coefficients' must be 1xN or Nx1 with N = 4, 5, 8, "
           "12 "
           "or 14 (got " +
               std::to_string(distortion.rows) + "x" +
               std::to_string(distortion.cols) + ")");
    }
    distortion = distortion.reshape(1, 1);
    camera.distortion.assign(distortion.ptr<double>(),
                             distortion.ptr<double>() + count);
  }

  camera.image_width =
      ReadPositiveInt(storage["image_width"], path, "image_width");
  camera.image_height =
      ReadPositiveInt(storage["image_height"], path, "image_height");
  return camera;
}

void SaveCameraFile(const std::filesystem::path& path,
                    const CameraFile& camera) {
  cv::FileStorage storage(path.string(), cv::FileStorage::WRITE);
  if (!storage.isOpened())
    throw CameraFileError(path.string() + ": cannot write camera file");
  storage << "image_width" << camera.image_width;
  storage << "image_height" << camera.image_height;
  storage << "camera_matrix" << cv::Mat(camera.camera_matrix);
  cv::Mat distortion(1, static_cast<int>(camera.distortion.size()), CV_64F);
  for (size_t i = 0; i < camera.distortion.size(); ++i) {
    distortion.at<double>(0, static_cast<int>(i)) = camera.distortion[i];
  }
  if (!camera.distortion.empty())
    storage << "distortion_coefficients" << distortion;
  storage.release();
}

FrameUndistorter::FrameUndistorter(const CameraFile& camera) : camera_(camera) {
  for (double d : camera_.distortion) distorted_ |= d != 0;
}

cv::Mat FrameUndistorter::Apply(const cv::Mat& frame) {
  if (!distorted_) return frame;
  if (camera_.image_width > 0 &&
      (frame.cols != camera_.image_width || frame.rows != camera_.image_height))
    throw CameraFileError("frames are " + std::to_string(frame.cols) + "x" +
                          std::to_string(frame.rows) + " but the intrinsics are for " +
                          std::to_string(camera_.image_width) + "x" +
                          std::to_string(camera_.image_height) +
                          ": undistortion needs frames at the calibrated size");
  if (map1_.empty() || frame.size() != size_) {
    size_ = frame.size();
    cv::initUndistortRectifyMap(cv::Mat(camera_.camera_matrix), cv::Mat(camera_.distortion),
                                cv::Mat(), cv::Mat(camera_.camera_matrix), size_, CV_16SC2, map1_,
                                map2_);
  }
  cv::Mat out;
  cv::remap(frame, out, map1_, map2_, cv::INTER_LINEAR, cv::BORDER_CONSTANT);
  return out;
}

CameraFile FrameUndistorter::ideal() const {
  CameraFile out = camera_;
  out.distortion.clear();
  return out;
}

}  // namespace texfree::client
