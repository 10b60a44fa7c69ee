// texfree-gen-pages: writes seeded synthetic pages and camera views of them,
// each view with its ground truth (homography, K, R, t, options) as JSON.
//
//   texfree-gen-pages --out DIR --count N --seed S [--views V] [--color]
//                     [--width W] [--height H] [--max-tilt DEG]
//                     [--curl MAX] [--lens-k1 MAX] [--motion-blur PX]
//
// --curl, --lens-k1 and --motion-blur draw, per view and from a stream of their
// own (the views are otherwise the same), a sheet lifted by up to MAX page
// widths, a radial k1 in [-MAX, MAX/2] and a smear of up to PX pixels. The
// JSON's homography is then the flat page's (nominal); its options say how the
// page curls and the lens bends (tests/data/camera_view.h: ProjectPagePoint).
//
// Output: DIR/page_XXXX.png, DIR/page_XXXX_boxes.json (word boxes) and per
// view DIR/page_XXXX_view_YY.jpg + DIR/page_XXXX_view_YY.json.
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <opencv2/imgcodecs.hpp>
#include <random>
#include <string>

#include "tests/data/camera_view.h"
#include "tests/data/page_renderer.h"

namespace {

void Usage() {
  std::cerr << "usage: texfree-gen-pages --out DIR --count N --seed S "
               "[--views V] [--color] [--width W] [--height H] "
               "[--max-tilt DEG] [--fonts dejavu|liberation|freefont|latinmodern|all] "
               "[--curl MAX] [--lens-k1 MAX] [--motion-blur PX]\n";
}

bool WriteText(const std::filesystem::path& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
  return static_cast<bool>(out);
}

}  // namespace

int main(int argc, char** argv) {
  std::string out_dir;
  long count = -1;
  unsigned long long seed = 0;
  bool have_seed = false;
  long views = 0;
  double max_tilt = 40;
  double max_curl = 0, max_k1 = 0, max_motion = 0;
  texfree::testdata::PageOptions page_options;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    auto value = [&](const char* name) -> const char* {
      if (i + 1 >= argc) {
        std::cerr << "texfree-gen-pages: " << name << " needs a value\n";
        std::exit(2);
      }
      return argv[++i];
    };
    if (arg == "--out") {
      out_dir = value("--out");
    } else if (arg == "--count") {
      count = std::strtol(value("--count"), nullptr, 10);
    } else if (arg == "--seed") {
      seed = std::strtoull(value("--seed"), nullptr, 10);
      have_seed = true;
    } else if (arg == "--views") {
      views = std::strtol(value("--views"), nullptr, 10);
    } else if (arg == "--color") {
      page_options.color = true;
    } else if (arg == "--width") {
      page_options.width = std::atoi(value("--width"));
    } else if (arg == "--height") {
      page_options.height = std::atoi(value("--height"));
    } else if (arg == "--fonts") {
      const auto set = texfree::testdata::ParseFontSet(value("--fonts"));
      if (!set.ok()) {
        std::cerr << "texfree-gen-pages: " << set.status().message() << "\n";
        return 2;
      }
      page_options.fonts = *set;
    } else if (arg == "--curl") {
      max_curl = std::strtod(value("--curl"), nullptr);
    } else if (arg == "--lens-k1") {
      max_k1 = std::strtod(value("--lens-k1"), nullptr);
    } else if (arg == "--motion-blur") {
      max_motion = std::strtod(value("--motion-blur"), nullptr);
    } else if (arg == "--max-tilt") {
      max_tilt = std::strtod(value("--max-tilt"), nullptr);
    } else if (arg == "-h" || arg == "--help") {
      Usage();
      return 0;
    } else {
      std::cerr << "texfree-gen-pages: unknown argument " << arg << "\n";
      Usage();
      return 2;
    }
  }
  if (out_dir.empty() || count < 0 || !have_seed || views < 0 || views > 100 ||
      page_options.width < 16 || page_options.height < 16 || !(max_curl >= 0 && max_curl <= 0.3) ||
      !(max_k1 >= 0 && max_k1 <= 0.5) || !(max_motion >= 0 && max_motion <= 30)) {
    Usage();
    return 2;
  }
  if (const auto available = texfree::testdata::CheckFontSet(page_options.fonts); !available.ok()) {
    std::cerr << "texfree-gen-pages: " << available.message() << "\n";
    return 1;
  }
  std::error_code ec;
  std::filesystem::create_directories(out_dir, ec);
  if (ec) {
    std::cerr << "texfree-gen-pages: cannot create " << out_dir << ": "
              << ec.message() << "\n";
    return 1;
  }
  const auto start = std::chrono::steady_clock::now();
  for (long p = 0; p < count; ++p) {
    const uint64_t page_seed = seed * 1000003ULL + static_cast<uint64_t>(p);
    const auto page =
        texfree::testdata::RenderTextPage(page_seed, page_options);
    char name[64];
    std::snprintf(name, sizeof(name), "page_%04ld", p);
    const std::filesystem::path base = std::filesystem::path(out_dir) / name;
    if (!cv::imwrite(base.string() + ".png", page.image)) {
      std::cerr << "texfree-gen-pages: cannot write " << base << ".png\n";
      return 1;
    }
    std::string boxes = "{\"seed\": " + std::to_string(page.seed) +
                        ", \"width\": " + std::to_string(page.image.cols) +
                        ", \"height\": " + std::to_string(page.image.rows) +
                        ", \"word_boxes\": [";
    for (size_t i = 0; i < page.word_boxes.size(); ++i) {
      const cv::Rect& b = page.word_boxes[i];
      boxes += (i ? ", [" : "[") + std::to_string(b.x) + ", " +
               std::to_string(b.y) + ", " + std::to_string(b.width) + ", " +
               std::to_string(b.height) + "]";
    }
    boxes += "]}\n";
    WriteText(base.string() + "_boxes.json", boxes);
    std::mt19937_64 rng(page_seed ^ 0x5eed5eed5eedULL);
    for (long v = 0; v < views; ++v) {
      auto options = texfree::testdata::RandomViewOptions(rng, page.image.size(), max_tilt);
      if (max_curl > 0 || max_k1 > 0 || max_motion > 0)
        texfree::testdata::DrawBends(page_seed * 131 + static_cast<uint64_t>(v) + 0xb3e7, max_curl,
                                     max_k1, max_motion, &options);
      // Render without the JPEG round trip and let the file itself be the
      // single JPEG compression at the chosen quality.
      auto raw_options = options;
      raw_options.jpeg_quality = 0;
      const auto view =
          texfree::testdata::RenderCameraView(page.image, raw_options, rng());
      char suffix[32];
      std::snprintf(suffix, sizeof(suffix), "_view_%02ld", v);
      cv::imwrite(base.string() + suffix + ".jpg", view.image,
                  {cv::IMWRITE_JPEG_QUALITY, options.jpeg_quality});
      if (!WriteText(
              base.string() + suffix + ".json",
              texfree::testdata::CameraViewGroundTruthJson(view, options))) {
        std::cerr << "texfree-gen-pages: cannot write " << base << suffix
                  << ".json\n";
        return 1;
      }
    }
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
          .count();
  std::cerr << "texfree-gen-pages: " << count << " pages, " << count * views
            << " views in " << seconds << " s\n";
  return 0;
}
