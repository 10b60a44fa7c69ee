// texfree-gen-sequence: writes a rendered page and a camera sequence over it, to try
// `texfree track` without a camera:
//
//   texfree-gen-sequence --out DIR [--seed S] [--frames N] [--step DEG] [--scale S]
//                        [--pan] [--occlude]
//
// Output: DIR/page.png (register it), DIR/frames/frame_XXXX.jpg with
// DIR/frames/frame_XXXX.json (ground truth), DIR/camera.yml (the intrinsics, OpenCV
// FileStorage as calibration tools write it).
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <opencv2/core/persistence.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>

#include "tests/data/camera_sequence.h"
#include "tests/data/page_renderer.h"

int main(int argc, char** argv) {
  std::string out;
  uint64_t seed = 4242;
  int frames = 161;
  double step = 0.5, scale = 0.85;
  bool pan = false, occlude = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::cerr << a << " needs a value\n";
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--out") out = value();
    else if (a == "--seed") seed = std::stoull(value());
    else if (a == "--frames") frames = std::stoi(value());
    else if (a == "--step") step = std::stod(value());
    else if (a == "--scale") scale = std::stod(value());
    else if (a == "--pan") pan = true;
    else if (a == "--occlude") occlude = true;
    else {
      std::cerr << "usage: texfree-gen-sequence --out DIR [--seed S] [--frames N] [--step DEG] "
                   "[--scale S] [--pan] [--occlude]\n";
      return 2;
    }
  }
  if (out.empty() || frames < 1) {
    std::cerr << "texfree-gen-sequence: --out DIR is required\n";
    return 2;
  }
  namespace fs = std::filesystem;
  fs::create_directories(fs::path(out) / "frames");
  const auto page = texfree::testdata::RenderTextPage(seed);
  cv::imwrite((fs::path(out) / "page.png").string(), page.image);
  const cv::Mat seen = occlude ? texfree::testdata::OccludePageHalf(page.image, 0, seed) : page.image;
  texfree::testdata::CameraSequenceOptions o;
  o.scale = scale;
  o.step_deg = step;
  o.end_tilt_deg = step * (frames - 1);
  if (pan) {
    o.motion = texfree::testdata::CameraSequenceOptions::Motion::kPan;
    o.start_tilt_deg = 30;
    o.pan_frames = frames;
  }
  const auto sequence = texfree::testdata::MakeCameraSequence(page.image.size(), o, seed);
  for (size_t i = 0; i < sequence.size(); ++i) {
    const auto view = texfree::testdata::RenderSequenceFrame(seen, sequence[i], seed,
                                                             static_cast<int>(i));
    char name[64];
    std::snprintf(name, sizeof(name), "frame_%04zu", i);
    cv::imwrite((fs::path(out) / "frames" / (std::string(name) + ".jpg")).string(), view.image);
    std::ofstream((fs::path(out) / "frames" / (std::string(name) + ".json")).string())
        << texfree::testdata::CameraViewGroundTruthJson(view, sequence[i].options);
    if (i == 0) {
      cv::FileStorage fs_out((fs::path(out) / "camera.yml").string(), cv::FileStorage::WRITE);
      fs_out << "camera_matrix" << cv::Mat(view.camera_matrix);
      fs_out << "distortion_coefficients" << cv::Mat::zeros(1, 5, CV_64F);
      fs_out << "image_width" << view.image.cols << "image_height" << view.image.rows;
    }
  }
  std::cout << "wrote " << out << "/page.png, " << sequence.size() << " frames in " << out
            << "/frames and " << out << "/camera.yml\n";
  return 0;
}
