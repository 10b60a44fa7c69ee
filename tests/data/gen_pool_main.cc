// texfree-gen-pool: writes seeded synthetic photographs of a pool table, each with its
// ground truth (camera, pose, corners, ball numbers and positions) as JSON, and the
// matching CAMERA.yml for `texfree pool analyze`. The pictures are sRGB-encoded, as a
// phone's are and as the server reads them; --linear writes the light in proportion
// instead (the benchmark's default renders, which the server would misread).
//
//   texfree-gen-pool --out DIR [--count N] [--seed S] [--nine-foot] [--linear]
//
// Output: DIR/pool_XXXX.png, DIR/pool_XXXX.json, DIR/pool_XXXX_camera.yml.
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <random>
#include <string>

#include "tests/data/pool_renderer.h"

int main(int argc, char** argv) {
  std::string out_dir;
  long count = 10;
  unsigned long long seed = 1;
  bool nine_foot = false;
  bool linear = false;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    auto value = [&]() -> const char* {
      if (i + 1 >= argc) {
        std::cerr << "texfree-gen-pool: " << arg << " needs a value\n";
        std::exit(2);
      }
      return argv[++i];
    };
    if (arg == "--out") {
      out_dir = value();
    } else if (arg == "--count") {
      count = std::strtol(value(), nullptr, 10);
    } else if (arg == "--seed") {
      seed = std::strtoull(value(), nullptr, 10);
    } else if (arg == "--nine-foot") {
      nine_foot = true;
    } else if (arg == "--linear") {
      linear = true;
    } else {
      std::cerr
          << "usage: texfree-gen-pool --out DIR [--count N] [--seed S] [--nine-foot] [--linear]\n";
      return 2;
    }
  }
  if (out_dir.empty() || count <= 0) {
    std::cerr
        << "usage: texfree-gen-pool --out DIR [--count N] [--seed S] [--nine-foot] [--linear]\n";
    return 2;
  }
  std::filesystem::create_directories(out_dir);
  using namespace texfree::testdata;
  const PoolTableSpec table = nine_foot ? PoolTableSpec::NineFoot() : PoolTableSpec::Bench();
  std::mt19937_64 rng(seed);
  for (long i = 0; i < count; ++i) {
    PoolScene scene = RandomPoolScene(rng, table);
    scene.srgb_tone = !linear;
    const PoolView view = RenderPoolView(scene, seed * 1000 + static_cast<uint64_t>(i));
    char name[32];
    std::snprintf(name, sizeof(name), "pool_%04ld", i);
    const std::filesystem::path base = std::filesystem::path(out_dir) / name;
    // The image already went through the camera's JPEG; PNG keeps it as it is.
    cv::imwrite(base.string() + ".png", view.image);
    std::ofstream(base.string() + ".json") << PoolViewGroundTruthJson(scene, view);
    cv::FileStorage fs(base.string() + "_camera.yml", cv::FileStorage::WRITE);
    fs << "camera_matrix" << cv::Mat(view.camera_matrix);
    fs << "distortion_coefficients" << cv::Mat(view.distortion).reshape(1, 1);
    fs << "image_width" << view.image.cols << "image_height" << view.image.rows;
    std::cout << base.string() << ".png\n";
  }
  return 0;
}
