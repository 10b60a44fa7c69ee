// Light photogrammetry benchmark on the simulated tunnel (seed Table 7.2 lights 8-14, our
// references 1-7) at full Nikon D300 resolution (4288x2848, 50 mm): two views of 100 JPEG
// frames each with up to 1% LED clock drift and steady/flickering/blinking lamps in view.
// Prints: decoding alone (image decode + burst decode, 2 worker threads), upload-and-decode
// end to end through a real texfree-server, the server's peak memory (VmHWM), the decoded
// lights against ground truth (IDs, false lights, centroid error) and the triangulation error
// of lights 8-14 with and without bundle adjustment.
//
//   texfree-bench-survey [--frames 100] [--scale 1.0] [--seed 7] [--jpeg-quality 92]
#include <CLI/CLI.hpp>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "common/light_decoder.h"
#include "common/timing.h"
#include "tests/data/light_scene.h"
#include "tests/server/server_process.h"
#include "tests/server/survey_requests.h"
#include "texfree/v1/survey.grpc.pb.h"

namespace fs = std::filesystem;
using texfree::MillisecondsSince;
using texfree::SteadyClock;

namespace {

long ProcStatusKiB(pid_t pid, const std::string& key) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind(key + ":", 0) == 0) return std::stol(line.substr(key.size() + 1));
  }
  return 0;
}

struct LightAccuracy {
  int expected = 0, correct = 0, missed = 0, false_lights = 0;
  double max_error_px = 0, mean_error_px = 0;
};

template <typename Light>
LightAccuracy Compare(const std::vector<Light>& found,
                      const std::vector<texfree::testdata::LightTruth>& truth,
                      double (*u)(const Light&), double (*v)(const Light&),
                      uint32_t (*id)(const Light&)) {
  LightAccuracy a;
  a.expected = static_cast<int>(truth.size());
  std::map<uint32_t, cv::Point2d> by_id;
  for (const auto& t : truth) by_id[t.id] = t.pixel;
  double sum = 0;
  for (const auto& l : found) {
    auto it = by_id.find(id(l));
    if (it == by_id.end()) {
      ++a.false_lights;
      continue;
    }
    const double e = cv::norm(cv::Point2d(u(l), v(l)) - it->second);
    if (e > 3) {
      ++a.false_lights;
      continue;
    }
    ++a.correct;
    sum += e;
    a.max_error_px = std::max(a.max_error_px, e);
  }
  a.missed = a.expected - a.correct;
  a.mean_error_px = a.correct ? sum / a.correct : 0;
  return a;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app("texfree light photogrammetry benchmark");
  int frames = 100;
  double scale = 1.0;
  uint64_t seed = 7;
  int quality = 92;
  double drift = 0.01;
  std::string server_binary = TEXFREE_SERVER_BINARY;
  app.add_option("--frames", frames, "Frames per view")->capture_default_str();
  app.add_option("--scale", scale, "Image scale of the D300 (1 = 4288x2848)")
      ->capture_default_str();
  app.add_option("--seed", seed, "Scene seed")->capture_default_str();
  app.add_option("--jpeg-quality", quality, "JPEG quality of the frames")->capture_default_str();
  app.add_option("--drift", drift, "Largest LED clock drift")->capture_default_str();
  app.add_option("--server", server_binary, "texfree-server binary")->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  texfree::testdata::LightSceneOptions options;
  options.seed = seed;
  options.scale = scale;
  options.frames = frames;
  options.jpeg_quality = quality;
  options.max_clock_drift = drift;
  const auto scene = texfree::testdata::MakeTunnelScene(options);
  std::vector<std::string> bursts[2];
  std::vector<texfree::testdata::LightTruth> truth[2];
  size_t burst_bytes = 0;
  const auto t_render = SteadyClock::now();
  for (int v = 0; v < 2; ++v) {
    texfree::testdata::BurstRenderer renderer(scene, texfree::testdata::TunnelViewPose(v), options,
                                              1000 + v);
    for (int k = 0; k < frames; ++k) {
      bursts[v].push_back(renderer.EncodeFrame(k));
      burst_bytes += bursts[v].back().size();
    }
    truth[v] = renderer.truth();
  }
  std::fprintf(stderr, "rendered 2 x %d frames %dx%d (%.0f MB of JPEG) in %.1f s\n", frames,
               scene.camera.size.width, scene.camera.size.height, burst_bytes / 1e6,
               MillisecondsSince(t_render) / 1000);

  // 1) Decoding alone: image decode + burst decode with the server's pipeline.
  const auto t_decode = SteadyClock::now();
  auto stream = texfree::lights::StreamingBurstDecoder::Create({}, texfree::ImageLimits{});
  if (!stream.ok()) return 1;
  for (const auto& f : bursts[0]) {
    if (!(*stream)->Push(f).ok()) return 1;
  }
  auto decoded = (*stream)->Finish();
  const double decode_ms = MillisecondsSince(t_decode);
  if (!decoded.ok()) {
    std::fprintf(stderr, "decode failed: %s\n", decoded.status().ToString().c_str());
    return 1;
  }
  const double image_decode_cpu_ms = (*stream)->image_decode_ms();
  const auto local = Compare<texfree::lights::LightSpot>(
      decoded->lights, truth[0], [](const texfree::lights::LightSpot& l) { return l.center.x; },
      [](const texfree::lights::LightSpot& l) { return l.center.y; },
      [](const texfree::lights::LightSpot& l) { return l.id; });

  // 2) Through the server.
  const fs::path dir =
      fs::temp_directory_path() / ("texfree-bench-survey-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  texfree::testing::ServerProcess server(server_binary, dir.string());
  if (server.address().empty()) {
    std::fprintf(stderr, "server did not start:\n%s\n", server.Log().c_str());
    return 1;
  }
  const long idle_kib = ProcStatusKiB(server.pid(), "VmRSS");
  auto stub = texfree::v1::SurveyService::NewStub(server.Channel());
  const texfree::v1::CreateSurveyRequest create =
      texfree::testing::SurveyRequestFor(scene, scene.references, "");
  texfree::v1::Survey survey;
  {
    grpc::ClientContext ctx;
    if (!stub->CreateSurvey(&ctx, create, &survey).ok()) return 1;
  }
  double upload_ms[2] = {0, 0};
  texfree::v1::UploadViewResponse uploads[2];
  for (int v = 0; v < 2; ++v) {
    grpc::ClientContext ctx;
    const auto t0 = SteadyClock::now();
    auto writer = stub->UploadView(&ctx, &uploads[v]);
    texfree::v1::UploadViewRequest header;
    header.mutable_header()->set_survey_id(survey.survey_id());
    header.mutable_header()->set_view_name(v == 0 ? "left" : "right");
    writer->Write(header);
    for (const auto& f : bursts[v]) {
      texfree::v1::UploadViewRequest m;
      m.mutable_frame()->set_encoded(f);
      if (!writer->Write(m)) break;
    }
    writer->WritesDone();
    const grpc::Status status = writer->Finish();
    upload_ms[v] = MillisecondsSince(t0);
    if (!status.ok()) {
      std::fprintf(stderr, "upload failed: %s\n", status.error_message().c_str());
      return 1;
    }
  }
  const long peak_kib = ProcStatusKiB(server.pid(), "VmHWM");
  using ProtoLight = texfree::v1::DecodedLight;
  LightAccuracy served[2];
  for (int v = 0; v < 2; ++v) {
    std::vector<ProtoLight> lights(uploads[v].view().lights().begin(),
                                   uploads[v].view().lights().end());
    served[v] = Compare<ProtoLight>(
        lights, truth[v], [](const ProtoLight& l) { return l.u(); },
        [](const ProtoLight& l) { return l.v(); }, [](const ProtoLight& l) { return l.id(); });
  }
  double mean_mm[2] = {0, 0}, max_mm[2] = {0, 0};
  int points[2] = {0, 0};
  for (int ba = 0; ba < 2; ++ba) {
    grpc::ClientContext ctx;
    texfree::v1::SolveRequest solve;
    solve.set_survey_id(survey.survey_id());
    solve.set_bundle_adjustment(ba == 1);
    texfree::v1::SolveResponse solved;
    const grpc::Status status = stub->Solve(&ctx, solve, &solved);
    if (!status.ok()) {
      std::fprintf(stderr, "solve failed: %s\n", status.error_message().c_str());
      return 1;
    }
    for (const auto& p : solved.points()) {
      const cv::Point3d X(p.position_m().x(), p.position_m().y(), p.position_m().z());
      const double e = cv::norm(X - scene.measured.at(p.id())) * 1000;
      mean_mm[ba] += e;
      max_mm[ba] = std::max(max_mm[ba], e);
      ++points[ba];
    }
    if (points[ba]) mean_mm[ba] /= points[ba];
  }
  server.Stop();
  fs::remove_all(dir);

  std::printf(
      "\nLight photogrammetry benchmark: tunnel, %dx%d, %d JPEG frames per view (q%d), "
      "LED drift up to %.1f%%, 4 distractor lamps, seed %llu\n\n",
      scene.camera.size.width, scene.camera.size.height, frames, quality, drift * 100,
      static_cast<unsigned long long>(seed));
  std::printf("| measure | result | target |\n|---|---|---|\n");
  std::printf(
      "| decode alone, one view (JPEG decode + lights, 2 threads) | %.2f s (JPEG decode cpu %.2f "
      "s, light decode %.2f s) | <= 5 s |\n",
      decode_ms / 1000, image_decode_cpu_ms / 1000, decoded->stats.decode_ms / 1000);
  std::printf(
      "| upload + decode end to end through the server, view 1 / view 2 | %.2f s / %.2f s | <= 10 "
      "s |\n",
      upload_ms[0] / 1000, upload_ms[1] / 1000);
  std::printf("| server peak memory (VmHWM; idle RSS %.0f MB) | %.0f MB | <= 1500 MB |\n",
              idle_kib / 1024.0, peak_kib / 1024.0);
  for (int v = 0; v < 2; ++v) {
    std::printf(
        "| view %d: lights with correct ID / missed / false | %d of %d / %d / %d | all, 0, 0 |\n",
        v + 1, served[v].correct, served[v].expected, served[v].missed, served[v].false_lights);
    std::printf("| view %d: centroid error mean / max | %.3f / %.3f px | <= 0.3 px |\n", v + 1,
                served[v].mean_error_px, served[v].max_error_px);
  }
  std::printf("| decode alone: lights correct / false, centroid max | %d of %d / %d, %.3f px | |\n",
              local.correct, local.expected, local.false_lights, local.max_error_px);
  std::printf("| candidate pixels / decoded pixels (view 1) | %lld / %lld | |\n",
              static_cast<long long>(decoded->stats.candidate_pixels),
              static_cast<long long>(decoded->stats.decoded_pixels));
  std::printf(
      "| triangulation, lights 8-14 (2 views), mean / max error | %.1f / %.1f mm (%d points) | "
      "mean <= 5 mm (seed 7 mm) |\n",
      mean_mm[0], max_mm[0], points[0]);
  std::printf("| same with bundle adjustment | %.1f / %.1f mm | |\n", mean_mm[1], max_mm[1]);
  return 0;
}
