// FrameSource: video files, image folders and cameras through OpenCV.
#include "client/frame_source.h"

#include <algorithm>
#include <cctype>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <ostream>

#include "client/command_context.h"

namespace texfree::client {
namespace fs = std::filesystem;

std::vector<fs::path> ListImageFiles(const fs::path& folder) {
  static const char* kExtensions[] = {".jpg", ".jpeg", ".png", ".bmp", ".tif", ".tiff", ".webp"};
  std::vector<fs::path> files;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(folder, ec)) {
    if (!entry.is_regular_file()) continue;
    std::string ext = entry.path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    for (const char* known : kExtensions) {
      if (ext == known) {
        files.push_back(entry.path());
        break;
      }
    }
  }
  std::sort(files.begin(), files.end());
  return files;
}

std::unique_ptr<FrameSource> FrameSource::Open(const std::string& input) {
  std::unique_ptr<FrameSource> source(new FrameSource());
  source->name_ = input;
  if (input.rfind("cam:", 0) == 0) {
    const std::string number = input.substr(4);
    if (number.empty() || !std::all_of(number.begin(), number.end(), ::isdigit))
      throw UsageError("camera input must be cam:N with N a device number, got '" + input + "'");
    const int device = std::stoi(number);
    try {
      source->capture_.open(device);
    } catch (const cv::Exception&) {
    }
    if (!source->capture_.isOpened())
      throw UsageError("cannot open camera " + number + " (" + input + ")");
    source->live_ = true;
    const double fps = source->capture_.get(cv::CAP_PROP_FPS);
    if (fps > 1 && fps < 500) source->fps_ = fps;
    return source;
  }
  std::error_code ec;
  if (fs::is_directory(input, ec)) {
    source->files_ = ListImageFiles(input);
    if (source->files_.empty())
      throw UsageError("folder '" + input + "' holds no image (JPEG, PNG, BMP, TIFF, WebP)");
    source->use_files_ = true;
    source->frame_count_ = static_cast<int64_t>(source->files_.size());
    return source;
  }
  if (!fs::exists(input, ec))
    throw UsageError("input '" + input + "' does not exist (a video file, a folder of images "
                     "or cam:N)");
  try {
    source->capture_.open(input);
  } catch (const cv::Exception&) {
  }
  if (!source->capture_.isOpened())
    throw UsageError("cannot read video '" + input + "' (is it a video file OpenCV can decode?)");
  const double fps = source->capture_.get(cv::CAP_PROP_FPS);
  if (fps > 1 && fps < 500) source->fps_ = fps;
  const double count = source->capture_.get(cv::CAP_PROP_FRAME_COUNT);
  if (count > 0) source->frame_count_ = static_cast<int64_t>(count);
  return source;
}

bool FrameSource::Next(cv::Mat* bgr, std::ostream& warnings) {
  if (use_files_) {
    while (next_file_ < files_.size()) {
      const fs::path& path = files_[next_file_++];
      cv::Mat image;
      try {
        image = cv::imread(path.string(), cv::IMREAD_COLOR);
      } catch (const cv::Exception&) {
      }
      if (!image.empty()) {
        *bgr = image;
        return true;
      }
      warnings << "warning: skipping '" << path.string() << "': not a readable image\n";
    }
    return false;
  }
  try {
    if (!capture_.read(*bgr) || bgr->empty()) return false;
  } catch (const cv::Exception&) {
    return false;
  }
  if (bgr->channels() == 1) cv::cvtColor(*bgr, *bgr, cv::COLOR_GRAY2BGR);
  return true;
}

}  // namespace texfree::client
