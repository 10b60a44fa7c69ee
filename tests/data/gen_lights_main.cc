// texfree-gen-lights: writes a simulated tunnel survey to disk, for trying the CLI by hand:
// DIR/CAMERA.yml, DIR/REFS.csv (references 1-7), DIR/truth.csv (every light's true position),
// and per view DIR/<view>/frame_NNN.jpg with DIR/<view>/truth.csv (projected centres).
//
//   texfree-gen-lights --out DIR [--scale 0.25] [--frames 100] [--seed 1]
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include <opencv2/core/persistence.hpp>

#include "tests/data/light_scene.h"

int main(int argc, char** argv) {
  std::string out;
  texfree::testdata::LightSceneOptions options;
  options.scale = 0.25;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string flag = argv[i], value = argv[i + 1];
    if (flag == "--out") out = value;
    else if (flag == "--scale") options.scale = std::atof(value.c_str());
    else if (flag == "--frames") options.frames = std::atoi(value.c_str());
    else if (flag == "--seed") options.seed = std::strtoull(value.c_str(), nullptr, 10);
  }
  if (out.empty() || !options.Validate().ok()) {
    std::fprintf(stderr, "usage: texfree-gen-lights --out DIR [--scale S] [--frames N] [--seed S]\n");
    return 2;
  }
  namespace fs = std::filesystem;
  fs::create_directories(out);
  const auto scene = texfree::testdata::MakeTunnelScene(options);
  {
    cv::FileStorage fs_out((fs::path(out) / "CAMERA.yml").string(), cv::FileStorage::WRITE);
    fs_out << "camera_matrix" << cv::Mat(scene.camera.K);
    fs_out << "distortion_coefficients" << cv::Mat(scene.camera.distortion).reshape(1, 1);
    fs_out << "image_width" << scene.camera.size.width;
    fs_out << "image_height" << scene.camera.size.height;
  }
  std::ofstream refs(fs::path(out) / "REFS.csv"), truth(fs::path(out) / "truth.csv");
  refs << "id,x,y,z\n";
  truth << "id,x,y,z,reference\n";
  for (const auto& light : scene.lights) {
    if (light.reference) {
      refs << light.id << "," << light.position.x << "," << light.position.y << ","
           << light.position.z << "\n";
    }
    truth << light.id << "," << light.position.x << "," << light.position.y << ","
          << light.position.z << "," << light.reference << "\n";
  }
  for (int v = 0; v < 2; ++v) {
    const fs::path dir = fs::path(out) / (v == 0 ? "left" : "right");
    fs::create_directories(dir);
    texfree::testdata::BurstRenderer renderer(scene, texfree::testdata::TunnelViewPose(v), options,
                                              v + 1);
    for (int k = 0; k < options.frames; ++k) {
      char name[32];
      std::snprintf(name, sizeof(name), "frame_%03d.jpg", k);
      std::ofstream(dir / name, std::ios::binary) << renderer.EncodeFrame(k);
    }
    std::ofstream view_truth(dir / "truth.csv");
    view_truth << "id,u,v\n";
    for (const auto& t : renderer.truth()) view_truth << t.id << "," << t.pixel.x << "," << t.pixel.y << "\n";
  }
  std::printf("wrote %s (%dx%d, %d frames per view)\n", out.c_str(), scene.camera.size.width,
              scene.camera.size.height, options.frames);
  return 0;
}
