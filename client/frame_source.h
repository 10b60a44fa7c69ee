// FrameSource: the frames `texfree track` sends: a video file, a folder of images (sorted
// by file name) or a camera ("cam:N").
#pragma once

#include <filesystem>
#include <memory>
#include <opencv2/core.hpp>
#include <opencv2/videoio.hpp>
#include <string>
#include <vector>

namespace texfree::client {

// Not thread-safe: one reader.
class FrameSource {
 public:
  // Throws a usage CliError naming the input when it cannot be opened or holds no frame.
  static std::unique_ptr<FrameSource> Open(const std::string& input);

  // The next frame as 8-bit BGR; false at the end. Images of a folder that cannot be
  // decoded are skipped with a warning on `warnings`.
  bool Next(cv::Mat* bgr, std::ostream& warnings);

  // Frames per second for an output video (the video's own rate, else 30).
  double fps() const { return fps_; }
  bool live() const { return live_; }        // a camera: frames do not wait for us
  const std::string& name() const { return name_; }
  // Frames in the input when known (folders, most video files), else 0.
  int64_t frame_count() const { return frame_count_; }

 private:
  FrameSource() = default;
  std::string name_;
  cv::VideoCapture capture_;
  std::vector<std::filesystem::path> files_;
  size_t next_file_ = 0;
  bool use_files_ = false;
  bool live_ = false;
  double fps_ = 30;
  int64_t frame_count_ = 0;
};

// Image files of a folder that OpenCV can read (by extension), sorted by name.
std::vector<std::filesystem::path> ListImageFiles(const std::filesystem::path& folder);

}  // namespace texfree::client
