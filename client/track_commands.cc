// `texfree track INPUT`: streams a video, a folder of images or a camera to
// TrackingService.Track, prints one line (or JSON object) per frame, optionally writes
// the frames with the tracked pages drawn in perspective, and ends with a summary.
//
// A sender thread reads, encodes (JPEG) and sends frames while the main thread reads
// results. For files it keeps at most `window` frames in flight, so the server's two
// pipeline stages stay busy without ever dropping a frame; a camera does not wait: when
// the window is full its frame is skipped here (and counted).
#include "client/track_commands.h"

#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <exception>
#include <functional>
#include <iomanip>
#include <map>
#include <mutex>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "client/camera_file.h"
#include "client/command_context.h"
#include "client/file_util.h"
#include "client/frame_source.h"
#include "client/json_output.h"
#include "client/overlay_renderer.h"
#include "client/proto_convert.h"
#include "texfree/v1/tracking.grpc.pb.h"

namespace texfree::client {
namespace {

using nlohmann::json;
using Clock = std::chrono::steady_clock;

struct TrackOptions {
  std::string input;
  std::string intrinsics;
  std::string output;
  bool no_learning = false;
  bool undistort = false;
  int64_t max_frames = 0;
  int jpeg_quality = 90;
  int window = 2;  // the server queues 2 frames per stream: a file never loses one
};

const char* StateName(v1::TrackedTarget::State state) {
  switch (state) {
    case v1::TrackedTarget::INITIALIZING:
      return "INITIALIZING";
    case v1::TrackedTarget::TRACKING:
      return "TRACKING";
    case v1::TrackedTarget::LOST:
      return "LOST";
    default:
      return "UNSPECIFIED";
  }
}

bool Drawn(const v1::TrackedTarget& t) {
  return t.state() == v1::TrackedTarget::TRACKING ||
         t.state() == v1::TrackedTarget::INITIALIZING;
}

json ResponseToJson(const v1::TrackResponse& r) {
  json documents = json::array();
  for (const auto& t : r.targets()) {
    json d{{"document_id", t.id()},
           {"title", t.title()},
           {"state", StateName(t.state())},
           {"inliers", t.inliers()},
           {"llah_inliers", t.llah_inliers()},
           {"learned_entries", t.learned_entries()}};
    d["homography"] = Drawn(t) ? HomographyToJson(t.homography()) : json(nullptr);
    if (t.has_pose()) d["pose"] = PoseToJson(t.pose());
    if (!t.method().empty()) d["method"] = t.method();
    if (Drawn(t)) {
      json outline = json::array();
      for (const auto& p : t.outline()) outline.push_back(PointToJson(p));
      d["outline"] = outline;
      json annotations = json::array();
      for (const auto& a : t.annotations()) annotations.push_back(MappedAnnotationToJson(a));
      d["annotations"] = annotations;
    }
    documents.push_back(std::move(d));
  }
  json timings = json::object();
  for (const auto& t : r.timings()) timings[t.stage()] = t.ms();
  json out{{"frame", r.frame_index()},
           {"documents", documents},
           {"server_ms", r.server_ms()},
           {"latency_ms", r.latency_ms()},
           {"keypoints", r.keypoints()},
           {"timings", timings}};
  if (r.dropped_frames() > 0) out["dropped_frames"] = r.dropped_frames();
  if (!r.error().empty()) out["error"] = r.error();
  return out;
}

// A tracked page as the overlay renderer draws it.
bool OverlayPageFromTarget(const v1::TrackedTarget& target, OverlayPage* page) {
  if (!Drawn(target) || !HomographyFromProto(target.homography(), &page->homography))
    return false;
  page->page_size = cv::Size2d(target.width(), target.height());
  page->title = target.title().empty() ? target.id() : target.title();
  page->annotations.clear();
  for (const auto& mapped : target.annotations())
    page->annotations.push_back(AnnotationFromProto(mapped.annotation()));
  return true;
}

struct Summary {
  int64_t results = 0, tracked = 0, errors = 0, dropped = 0, skipped = 0;
  std::vector<double> server_ms;
};

double Median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

int RunTrack(CommandContext& ctx, const TrackOptions& options) {
  // Everything local is checked before the server is contacted.
  std::optional<CameraFile> camera = LoadIntrinsicsOption(options.intrinsics, options.undistort);
  std::optional<FrameUndistorter> undistorter;
  if (options.undistort) {
    undistorter.emplace(*camera);
    camera = undistorter->ideal();  // the server sees an ideal pinhole
  }
  if (!options.output.empty()) {
    const std::string ext = std::filesystem::path(options.output).extension().string();
    if (ext != ".mp4" && ext != ".avi" && ext != ".mkv" && ext != ".mov")
      throw UsageError("--output: write a video file (.mp4, .avi, .mkv or .mov), got '" +
                       options.output + "'");
  }
  auto source = FrameSource::Open(options.input);

  auto stub = v1::TrackingService::NewStub(ctx.Channel());
  grpc::ClientContext context;  // no deadline: a stream lasts as long as the input
  auto stream = stub->Track(&context);
  v1::TrackRequest config;
  if (camera) *config.mutable_config()->mutable_intrinsics() = IntrinsicsToProto(*camera);
  auto* track_options = config.mutable_config()->mutable_options();
  track_options->set_track_documents(true);
  track_options->set_update_policy(options.no_learning ? v1::TrackOptions::NEVER
                                                       : v1::TrackOptions::BELOW_THRESHOLD);
  if (!stream->Write(config)) ctx.Check(stream->Finish());

  // Shared between the sender and the reader.
  std::mutex mutex;
  std::condition_variable window_cv;
  int64_t in_flight = 0;
  bool reader_done = false;  // no more results: the sender stops
  std::map<uint64_t, cv::Mat> pending_images;  // sent, kept for drawing (with --output)
  Summary summary;
  std::ostringstream warnings;
  const bool keep_images = !options.output.empty();
  std::string sender_error;  // a frame the sender could not send: the run fails

  std::thread sender([&] {
    cv::Mat frame;
    uint64_t index = 0;
    std::ostringstream local_warnings;
    while ((options.max_frames <= 0 || static_cast<int64_t>(index) < options.max_frames) &&
           source->Next(&frame, local_warnings)) {
      if (camera && camera->image_width > 0 &&
          (frame.cols != camera->image_width || frame.rows != camera->image_height)) {
        local_warnings << "warning: frame " << index << " is " << frame.cols << "x" << frame.rows
                       << " but " << options.intrinsics << " is for " << camera->image_width
                       << "x" << camera->image_height << "\n";
      }
      if (undistorter) {
        try {
          frame = undistorter->Apply(frame);
        } catch (const CameraFileError& e) {
          std::lock_guard lock(mutex);
          sender_error = "--undistort: frame " + std::to_string(index) + ": " + e.what();
          break;
        }
      }
      {
        std::unique_lock lock(mutex);
        if (reader_done) break;
        if (source->live()) {
          if (in_flight >= options.window) {  // a camera does not wait
            ++summary.skipped;
            continue;
          }
        } else {
          window_cv.wait(lock, [&] { return in_flight < options.window || reader_done; });
          if (reader_done) break;
        }
        ++in_flight;
        if (keep_images) pending_images[index] = frame.clone();
      }
      std::vector<uchar> jpeg;
      cv::imencode(".jpg", frame, jpeg, {cv::IMWRITE_JPEG_QUALITY, options.jpeg_quality});
      v1::TrackRequest request;
      request.mutable_frame()->set_frame_index(index);
      request.mutable_frame()->set_timestamp_us(
          std::chrono::duration_cast<std::chrono::microseconds>(
              Clock::now().time_since_epoch())
              .count());
      request.mutable_frame()->mutable_image()->set_encoded(
          std::string(jpeg.begin(), jpeg.end()));
      if (!stream->Write(request)) break;
      ++index;
    }
    stream->WritesDone();
    std::lock_guard lock(mutex);
    warnings << local_warnings.str();
  });

  // However the reading ends (an exception included), the sender is stopped and joined.
  struct StopSender {
    std::function<void()> stop;
    ~StopSender() { stop(); }
  } stop_sender{[&] {
    {
      std::lock_guard lock(mutex);
      if (reader_done) return;
      reader_done = true;
    }
    window_cv.notify_all();
    if (std::uncaught_exceptions() > 0) context.TryCancel();
    sender.join();
  }};

  OverlayRenderer renderer;
  cv::VideoWriter writer;
  auto write_frame = [&](cv::Mat image) {
    if (!writer.isOpened()) {
      try {
        writer.open(options.output, cv::VideoWriter::fourcc('m', 'p', '4', 'v'), source->fps(),
                    image.size());
      } catch (const cv::Exception&) {
      }
      if (!writer.isOpened()) {
        context.TryCancel();
        throw CliError(kExitFailure, "cannot write video '" + options.output + "'");
      }
    }
    writer.write(image);
  };

  const auto t0 = Clock::now();
  auto last_progress = t0;
  v1::TrackResponse response;
  while (stream->Read(&response)) {
    cv::Mat image;
    std::vector<cv::Mat> dropped_images;
    {
      std::lock_guard lock(mutex);
      in_flight -= 1 + static_cast<int64_t>(response.dropped_frames());
      // Frames answered or dropped leave the window; their images go out in order.
      for (auto it = pending_images.begin();
           it != pending_images.end() && it->first <= response.frame_index();) {
        if (it->first == response.frame_index())
          image = it->second;
        else
          dropped_images.push_back(it->second);
        it = pending_images.erase(it);
      }
    }
    window_cv.notify_all();
    ++summary.results;
    summary.dropped += response.dropped_frames();
    if (!response.error().empty()) ++summary.errors;
    int drawn = 0;
    for (const auto& t : response.targets()) drawn += Drawn(t);
    if (drawn > 0) ++summary.tracked;
    if (response.error().empty()) summary.server_ms.push_back(response.server_ms());

    if (keep_images) {
      for (const cv::Mat& d : dropped_images) write_frame(d);
      if (!image.empty()) {
        int page_index = 0;
        for (const auto& t : response.targets()) {
          OverlayPage page;
          if (OverlayPageFromTarget(t, &page)) renderer.DrawPage(image, page, page_index);
          ++page_index;
        }
        write_frame(image);
      }
    }
    if (ctx.json) {
      ctx.PrintJson(ResponseToJson(response));
    } else {
      std::ostream& out = ctx.out();
      out << "frame " << response.frame_index() << ":";
      if (!response.error().empty()) out << " error: " << response.error();
      if (response.targets_size() == 0 && response.error().empty()) out << " no page";
      for (const auto& t : response.targets()) {
        out << "  " << (t.title().empty() ? t.id() : t.title()) << " " << StateName(t.state());
        if (Drawn(t)) out << " (" << t.inliers() << " inliers)";
      }
      out << std::fixed << std::setprecision(1) << "  server " << response.server_ms() << " ms\n";
    }
    if (Clock::now() - last_progress > std::chrono::seconds(2)) {
      last_progress = Clock::now();
      const double s = std::chrono::duration<double>(last_progress - t0).count();
      ctx.err() << "track: " << summary.results << " frames";
      if (source->frame_count() > 0) ctx.err() << " of " << source->frame_count();
      ctx.err() << ", " << std::fixed << std::setprecision(1) << summary.results / s
                << " fps\n";
    }
  }
  stop_sender.stop();
  const grpc::Status status = stream->Finish();
  if (keep_images) {
    for (auto& [index, image] : pending_images) write_frame(image);
    writer.release();
  }
  ctx.err() << warnings.str();
  if (!sender_error.empty()) throw UsageError(sender_error);
  ctx.Check(status);

  const double seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  const double share = summary.results ? static_cast<double>(summary.tracked) / summary.results : 0;
  double mean_ms = 0;
  for (double ms : summary.server_ms) mean_ms += ms;
  if (!summary.server_ms.empty()) mean_ms /= summary.server_ms.size();
  json s{{"frames", summary.results},
         {"tracked_share", share},
         {"fps", seconds > 0 ? summary.results / seconds : 0.0},
         {"server_ms_mean", mean_ms},
         {"server_ms_median", Median(summary.server_ms)},
         {"dropped_by_server", summary.dropped},
         {"skipped_by_client", summary.skipped},
         {"errors", summary.errors}};
  if (!options.output.empty()) s["output"] = options.output;
  if (ctx.json) {
    // stdout holds one object per frame: the summary goes to stderr.
    ctx.err() << json{{"summary", s}}.dump() << "\n";
  } else {
    std::ostream& out = ctx.out();
    out << std::fixed << std::setprecision(1) << summary.results << " frames, "
        << 100.0 * share << "% tracked, " << s["fps"].get<double>() << " fps, server "
        << mean_ms << " ms/frame (median " << Median(summary.server_ms) << ")";
    if (summary.dropped) out << ", " << summary.dropped << " dropped by the server";
    if (summary.skipped) out << ", " << summary.skipped << " camera frames skipped";
    if (summary.errors) out << ", " << summary.errors << " errors";
    out << "\n";
    if (!options.output.empty()) out << "video written to " << options.output << "\n";
  }
  return kExitOk;
}

}  // namespace

void AddTrackCommands(CLI::App& app, CommandContext& ctx) {
  auto options = std::make_shared<TrackOptions>();
  CLI::App* cmd = app.add_subcommand(
      "track", "Track registered pages through a video, a folder of images or a camera");
  cmd->add_option("INPUT", options->input,
                  "Video file, folder of images (sorted by name) or cam:N")
      ->required();
  cmd->add_option("--intrinsics", options->intrinsics,
                  "CAMERA.yml (OpenCV calibration file): also return each page's pose");
  cmd->add_option("--output", options->output,
                  "Write the frames with outlines and annotations to this video (.mp4)");
  cmd->add_flag("--undistort", options->undistort,
                "Undo the lens distortion of --intrinsics on each frame before sending it: "
                "homographies, overlays and --output are then in the undistorted frames, where "
                "a flat page is exactly a homography");
  cmd->add_flag("--no-learning", options->no_learning,
                "Do not learn new views of the pages (on-line learning off)");
  cmd->add_option("--max-frames", options->max_frames, "Stop after this many frames (0 = all)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--jpeg-quality", options->jpeg_quality, "JPEG quality of the sent frames")
      ->check(CLI::Range(30, 100))
      ->capture_default_str();
  cmd->add_option("--window", options->window, "Frames in flight to the server")
      ->check(CLI::Range(1, 16))
      ->capture_default_str();
  cmd->callback([&ctx, options] {
    ctx.action = [&ctx, options] { return RunTrack(ctx, *options); };
  });
}

}  // namespace texfree::client
