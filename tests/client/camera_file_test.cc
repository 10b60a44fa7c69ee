// Tests of the CAMERA.yml loader.
#include "client/camera_file.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>
#include <string>

namespace texfree::client {
namespace {

class CameraFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           ("texfree_camera_test_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  std::string ErrorOf(const std::filesystem::path& path) {
    try {
      LoadCameraFile(path);
    } catch (const CameraFileError& e) {
      return e.what();
    }
    return "";
  }

  std::filesystem::path dir_;
};

TEST_F(CameraFileTest, ReadsWhatOpenCvWrites) {
  auto path = dir_ / "camera.yml";
  {
    cv::FileStorage fs(path.string(), cv::FileStorage::WRITE);
    fs << "image_width" << 1280 << "image_height" << 720;
    fs << "camera_matrix"
       << cv::Mat(cv::Matx33d(1000, 0, 640, 0, 1001, 360, 0, 0, 1));
    fs << "distortion_coefficients"
       << cv::Mat(cv::Matx<double, 5, 1>(0.1, -0.2, 0.001, 0.002, 0.05));
    fs << "avg_reprojection_error" << 0.3;
  }
  CameraFile camera = LoadCameraFile(path);
  EXPECT_DOUBLE_EQ(camera.fx(), 1000);
  EXPECT_DOUBLE_EQ(camera.fy(), 1001);
  EXPECT_DOUBLE_EQ(camera.cx(), 640);
  EXPECT_DOUBLE_EQ(camera.cy(), 360);
  ASSERT_EQ(camera.distortion.size(), 5u);
  EXPECT_DOUBLE_EQ(camera.distortion[0], 0.1);
  EXPECT_DOUBLE_EQ(camera.distortion[4], 0.05);
  EXPECT_EQ(camera.image_width, 1280);
  EXPECT_EQ(camera.image_height, 720);
}

TEST_F(CameraFileTest, SaveLoadRoundTripWithRowDistortion) {
  CameraFile camera;
  camera.camera_matrix = cv::Matx33d(800, 0, 320, 0, 800, 240, 0, 0, 1);
  camera.distortion = {0.01, 0.02, 0, 0, 0.03};
  camera.image_width = 640;
  camera.image_height = 480;
  auto path = dir_ / "round.yml";
  SaveCameraFile(path, camera);
  CameraFile loaded = LoadCameraFile(path);
  EXPECT_EQ(loaded.distortion, camera.distortion);
  EXPECT_DOUBLE_EQ(loaded.fx(), 800);
  EXPECT_EQ(loaded.image_height, 480);
}

TEST_F(CameraFileTest, MissingKeyIsNamed) {
  auto path = dir_ / "no_matrix.yml";
  {
    cv::FileStorage fs(path.string(), cv::FileStorage::WRITE);
    fs << "image_width" << 640 << "image_height" << 480;
  }
  EXPECT_NE(ErrorOf(path).find("camera_matrix"), std::string::npos)
      << ErrorOf(path);

  auto path2 = dir_ / "no_width.yml";
  {
    cv::FileStorage fs(path2.string(), cv::FileStorage::WRITE);
    fs << "image_height" << 480;
    fs << "camera_matrix" << cv::Mat(cv::Matx33d::eye());
  }
  EXPECT_NE(ErrorOf(path2).find("image_width"), std::string::npos)
      << ErrorOf(path2);
}

TEST_F(CameraFileTest, WrongSizes) {
  auto path = dir_ / "bad_matrix.yml";
  {
    cv::FileStorage fs(path.string(), cv::FileStorage::WRITE);
    fs << "image_width" << 640 << "image_height" << 480;
    fs << "camera_matrix" << cv::Mat(cv::Matx22d(1, 0, 0, 1));
  }
  EXPECT_NE(ErrorOf(path).find("3x3"), std::string::npos) << ErrorOf(path);

  auto path2 = dir_ / "bad_distortion.yml";
  {
    cv::FileStorage fs(path2.string(), cv::FileStorage::WRITE);
    fs << "image_width" << 640 << "image_height" << 480;
    fs << "camera_matrix"
       << cv::Mat(cv::Matx33d(500, 0, 320, 0, 500, 240, 0, 0, 1));
    fs << "distortion_coefficients" << cv::Mat(cv::Matx<double, 1, 3>(0, 0, 0));
  }
  EXPECT_NE(ErrorOf(path2).find("distortion_coefficients"), std::string::npos)
      << ErrorOf(path2);
}

TEST_F(CameraFileTest, UnreadableFile) {
  EXPECT_NE(ErrorOf(dir_ / "missing.yml").find("cannot read"),
            std::string::npos);
  auto path = dir_ / "garbage.yml";
  std::ofstream(path) << "this is: [not: valid";
  EXPECT_NE(ErrorOf(path), "");
}

}  // namespace
}  // namespace texfree::client
