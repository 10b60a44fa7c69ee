// Tracking benchmark: the seed's experiment (3.1.5) with rendered pages. A page is
// registered (with distractor pages) in a real DocumentRegistry; a 640x480 camera orbits
// from a top view to 80 deg tilt around the page centre in 0.5 deg steps at two distances
// (the whole page in view; about a third of it), plus the close orbit with half the page
// covered by a hand once tracking has started, and a camera moving along the page at 30 deg
// tilt. For every frame
// and method it measures inliers and the pose error (mean distance between where the
// estimate and the truth put an 11 x 11 grid of page points, over those in view) and the
// time per frame: wall and CPU, on one core (OpenCV single-threaded), with keypoints
// extracted as the server's stream does (VideoKeypointExtractor). Methods:
//   track+learn  DocumentTracker, default options (prediction, LLAH, on-line learning)
//   track        the same without learning
//   llah+learn   no prediction: LLAH against the session index every frame + learning
//                (the seed's method)
//   llah         no prediction, no learning (plain LLAH, the seed's baseline)
//   orb, sift    OpenCV features matched to the registered page image, RANSAC homography
// Then, unless --no-grpc, the throughput of TrackingService over loopback gRPC: one
// stream sending JPEG frames as fast as results come back, and N streams at 30 fps.
//
//   texfree-bench-tracking [--step 0.5] [--print-every 5] [--distractors 20]
//                          [--streams 8] [--fps 30] [--seconds 10] [--only SEQUENCE]
//                          [--no-grpc] [--no-baselines] [--trace-from DEG [--trace-dir D]]
//                          [--seed N] [--frame-letter-graph] [--rectify-above F]
//                          [--rectified-height PX] [--max-upsampling F]
//                          [--max-frame-age-ms MS] [--queue-frames N]
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <map>
#include <memory>
#include <opencv2/calib3d.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <thread>
#include <vector>

#include "common/document_tracker.h"
#include "common/timing.h"
#include "common/video_keypoints.h"
#include "common/word_keypoints.h"
#include "server/document_registry.h"
#include "server/document_store.h"
#include "tests/bench/tracking_bench_grpc.h"
#include "tests/data/camera_sequence.h"
#include "tests/data/page_renderer.h"

namespace fs = std::filesystem;
using texfree::MillisecondsSince;
using texfree::SteadyClock;
using texfree::TrackedDocument;
using texfree::testdata::CameraSequenceOptions;

namespace {

constexpr double kCorrectPx = 3.0;  // a pose is correct within this mean error

double Percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(q * (v.size() - 1) + 0.5))];
}

struct Sample {
  bool found = false;
  int inliers = 0;
  double error = 1e9;
  double ms = 0;
  double cpu_ms = 0;
};

struct Sequence {
  std::string name;
  std::vector<texfree::testdata::SequenceFrame> frames;
  std::vector<texfree::testdata::CameraView> views;
};

// Texture baseline: features of the registered page image matched to each frame.
class FeatureBaseline {
 public:
  FeatureBaseline(cv::Ptr<cv::Feature2D> detector, cv::Ptr<cv::DescriptorMatcher> matcher,
                  const cv::Mat& page_gray)
      : detector_(std::move(detector)), matcher_(std::move(matcher)) {
    detector_->detectAndCompute(page_gray, cv::noArray(), page_keypoints_, page_descriptors_);
    matcher_->add(std::vector<cv::Mat>{page_descriptors_});
    matcher_->train();  // the page's index is built once
  }
  Sample Run(const cv::Mat& gray, const texfree::testdata::CameraView& truth,
             const texfree::testdata::CameraViewOptions& truth_options, const cv::Size& page_size) {
    Sample s;
    const auto t0 = SteadyClock::now();
    const double c0 = texfree::ThreadCpuMilliseconds();
    std::vector<cv::KeyPoint> keypoints;
    cv::Mat descriptors;
    detector_->detectAndCompute(gray, cv::noArray(), keypoints, descriptors);
    std::vector<cv::Point2f> src, dst;
    if (!descriptors.empty() && page_descriptors_.rows >= 2) {
      std::vector<std::vector<cv::DMatch>> knn;
      matcher_->knnMatch(descriptors, knn, 2);
      for (const auto& m : knn) {
        if (m.size() == 2 && m[0].distance < 0.8f * m[1].distance) {
          src.push_back(page_keypoints_[m[0].trainIdx].pt);
          dst.push_back(keypoints[m[0].queryIdx].pt);
        }
      }
    }
    if (src.size() >= 8) {
      std::vector<uchar> mask;
      cv::Mat H = cv::findHomography(src, dst, cv::RANSAC, 3.0, mask, 2000, 0.995);
      if (!H.empty()) {
        s.inliers = cv::countNonZero(mask);
        if (s.inliers >= 12) {
          s.found = true;
          s.error = texfree::testdata::MeanProjectionError(cv::Matx33d(H), truth, truth_options,
                                                           page_size);
        }
      }
    }
    s.ms = MillisecondsSince(t0);
    s.cpu_ms = texfree::ThreadCpuMilliseconds() - c0;
    return s;
  }

 private:
  cv::Ptr<cv::Feature2D> detector_;
  cv::Ptr<cv::DescriptorMatcher> matcher_;
  std::vector<cv::KeyPoint> page_keypoints_;
  cv::Mat page_descriptors_;
};

struct Method {
  std::string name;
  texfree::TrackerOptions options;  // tracker methods
  int baseline = 0;                 // 1 ORB, 2 SIFT
};

struct Report {
  std::vector<std::vector<Sample>> samples;  // [method][frame]
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"texfree tracking benchmark"};
  double step = 0.5, print_every = 5;
  int distractors = 20, streams = 8;
  double fps = 30, seconds = 10;
  bool no_grpc = false, no_baselines = false;
  // Per process: two runs at once must not remove each other's database.
  std::string dir =
      (fs::temp_directory_path() / ("texfree-bench-tracking-" + std::to_string(::getpid())))
          .string();
  std::string only;
  double trace_from = 1e9;
  std::string trace_dir;
  texfree::VideoKeypointOptions video;
  uint64_t sequence_seed = 77;
  texfree::TrackerOptions tracking;  // of the track methods
  app.add_option("--step", step, "tilt step per frame, degrees");
  double curl = 0, lens_k1 = 0;
  app.add_option("--curl", curl,
                 "the page lifts off the desk by this many page widths, bowed across its width "
                 "(0: flat)")
      ->check(CLI::Range(0.0, 0.3));
  bool undistort = false;
  app.add_flag("--undistort", undistort,
               "undo the lens distortion of each frame first (texfree track --undistort)");
  double motion_blur = 0;
  app.add_option("--motion-blur", motion_blur,
                 "each frame is smeared by camera shake of up to this many pixels (0: none)")
      ->check(CLI::Range(0.0, 30.0));
  app.add_option("--lens-k1", lens_k1, "radial distortion k1 of the camera (0: ideal pinhole)")
      ->check(CLI::Range(-0.5, 0.5));
  app.add_option("--print-every", print_every, "print a row every this many degrees");
  app.add_option("--distractors", distractors, "other pages registered besides the tracked one");
  app.add_option("--streams", streams, "concurrent streams of the throughput test");
  texfree::server::TrackingServiceOptions service;
  app.add_option("--max-frame-age-ms", service.max_frame_age_ms,
                 "throughput test: a frame waiting longer is stale (dropped if a newer waits)");
  app.add_option("--queue-frames", service.queue_frames,
                 "throughput test: frames waiting per stream at most");
  bool no_stagger = false;
  app.add_flag("--no-stagger", no_stagger,
               "throughput test: every stream measures and retrieves on the same frames "
               "(TrackingServiceOptions::stagger_streams off)");
  int grpc_opencv_threads = -1;
  app.add_option("--grpc-opencv-threads", grpc_opencv_threads,
                 "throughput test: OpenCV's threads (cv::setNumThreads; -1: its default)");
  app.add_option("--fps", fps, "frame rate of each concurrent stream");
  app.add_option("--seconds", seconds, "duration of each throughput test");
  app.add_option("--only", only, "run only the sequence with this name");
  app.add_option("--trace-from", trace_from,
                 "print every tracker frame from this tilt (or frame) on, to stderr");
  app.add_option("--trace-dir", trace_dir,
                 "with --trace-from: write each traced frame with its keypoints (red), the "
                 "page keypoints where the truth puts them (green) and the estimate (blue)");
  app.add_option("--measure-every", video.measure_every_frames,
                 "measure the text size on one frame in this many (1: every frame)");
  app.add_option("--half-resolution-above", video.half_resolution_above_char_height,
                 "group words at half resolution when the text is taller (px; 0: never)");
  app.add_option("--rectify-above", video.rectify_above_perspective,
                 "extract pages rectified when the frame's magnification of them varies by "
                 "more than this factor (0: never)");
  app.add_option("--rectified-height", video.rectified_char_height,
                 "text height in rectified page images, px");
  app.add_option("--max-upsampling", video.max_rectify_upsampling,
                 "rectified images enlarge the frame at most this much");
  app.add_option("--max-median-upsampling", video.max_median_upsampling,
                 "pages are not rectified when that enlarges the frame more than this at the "
                 "median magnification");
  app.add_option("--seed", sequence_seed, "seed of the camera paths' hand shake and noise");
  app.add_option("--llah-interval", tracking.llah_interval,
                 "track methods: LLAH matching every this many frames while projection holds");
  app.add_option("--min-separation", tracking.min_separation_inliers,
                 "track methods: projection skips reference keypoints closer than this many "
                 "inlier distances");
  bool frame_letter_graph = false;
  app.add_flag("--frame-letter-graph", frame_letter_graph,
               "track methods: cut frames into words by the letter graph (as pages are "
               "registered) instead of the registry's tracking_keypoints");
  app.add_flag("--no-grpc", no_grpc, "skip the gRPC throughput test");
  app.add_flag("--no-baselines", no_baselines, "skip ORB and SIFT");
  app.add_option("--dir", dir, "working directory for the database");
  CLI11_PARSE(app, argc, argv);
  service.stagger_streams = !no_stagger;
  spdlog::set_level(spdlog::level::warn);

  std::error_code ignored;
  fs::remove_all(dir, ignored);
  fs::create_directories(dir);
  auto store = texfree::server::DocumentStore::Open(dir + "/texfree.db");
  if (!store.ok()) {
    std::fprintf(stderr, "%s\n", store.status().ToString().c_str());
    return 1;
  }
  auto registry = texfree::server::DocumentRegistry::Open(std::move(*store), {});
  if (!registry.ok()) {
    std::fprintf(stderr, "%s\n", registry.status().ToString().c_str());
    return 1;
  }
  // The tracked page, then distractors.
  const auto page = texfree::testdata::RenderTextPage(4242);
  cv::Mat page_gray;
  cv::cvtColor(page.image, page_gray, cv::COLOR_BGR2GRAY);
  auto record = (*registry)->Register(page_gray, "tracked page", {});
  if (!record.ok()) {
    std::fprintf(stderr, "register: %s\n", record.status().ToString().c_str());
    return 1;
  }
  for (int i = 0; i < distractors; ++i) {
    auto other = texfree::testdata::RenderTextPage(9000 + i);
    cv::Mat gray;
    cv::cvtColor(other.image, gray, cv::COLOR_BGR2GRAY);
    (*registry)->Register(gray, "distractor", {}).IgnoreError();
  }
  const uint32_t tracked_id = record->index_id;
  auto shared = (*registry)->retriever();
  std::printf("registered page %dx%d with %zu keypoints, %d distractors\n", page_gray.cols,
              page_gray.rows, record->keypoints.size(), distractors);

  // Sequences.
  std::vector<Sequence> sequences;
  // `later` (when given) replaces the page from frame `clear_frames` on.
  auto add = [&](const std::string& name, CameraSequenceOptions o, const cv::Mat& page_image,
                 const cv::Mat& later = cv::Mat(), size_t clear_frames = 0) {
    if (!only.empty() && only != name) return;
    Sequence s;
    s.name = name;
    s.frames = texfree::testdata::MakeCameraSequence(page_gray.size(), o, sequence_seed);
    for (size_t i = 0; i < s.frames.size(); ++i)
      s.views.push_back(texfree::testdata::RenderSequenceFrame(
          later.empty() || i < clear_frames ? page_image : later, s.frames[i], sequence_seed,
          static_cast<int>(i)));
    std::fprintf(stderr, "rendered %s: %zu frames\n", name.c_str(), s.views.size());
    sequences.push_back(std::move(s));
  };
  CameraSequenceOptions near;
  near.step_deg = step;
  near.page_curl = curl;
  near.curl_azimuth_deg = 20;
  near.radial_k1 = lens_k1;
  near.max_motion_blur_px = motion_blur;
  near.scale = 0.85;  // about a third of the page in view
  CameraSequenceOptions far = near;
  far.scale = 0.32;  // the whole page in view
  add("orbit-near", near, page.image);
  add("orbit-far", far, page.image);
  // As in the seed (3.1.6): tracking starts on the whole page, then a hand covers half of
  // it from 2 deg of tilt on (in this close view it hides half of what the camera sees).
  add("orbit-near-occluded", near, page.image, texfree::testdata::OccludePageHalf(page.image, 0, 5),
      4);
  CameraSequenceOptions pan = near;
  pan.motion = CameraSequenceOptions::Motion::kPan;
  pan.start_tilt_deg = 30;
  pan.pan_frames = 160;
  add("pan-30deg", pan, page.image);

  std::vector<Method> methods;
  {
    Method m{"track+learn", tracking, 0};
    methods.push_back(m);
    m.name = "track";
    m.options.update_policy = texfree::UpdatePolicy::kNever;
    methods.push_back(m);
    m.name = "llah+learn";
    m.options = tracking;
    m.options.predict = false;
    methods.push_back(m);
    m.name = "llah";
    m.options.update_policy = texfree::UpdatePolicy::kNever;
    methods.push_back(m);
    if (!no_baselines) {
      methods.push_back({"orb", {}, 1});
      methods.push_back({"sift", {}, 2});
    }
  }

  std::map<std::string, std::vector<double>> all_ms, all_cpu_ms;
  cv::setNumThreads(1);  // one core per frame, as the targets count it
  for (const Sequence& seq : sequences) {
    std::printf("\n### %s (%zu frames)\n\n", seq.name.c_str(), seq.views.size());
    std::vector<std::vector<Sample>> samples(methods.size());
    std::vector<size_t> learned(methods.size(), 0);
    for (size_t m = 0; m < methods.size(); ++m) {
      const Method& method = methods[m];
      std::unique_ptr<texfree::DocumentTracker> tracker;
      std::unique_ptr<FeatureBaseline> baseline;
      // As the server's stream: the text is measured now and then, not on every frame.
      texfree::WordKeypointOptions frame_keypoints = (*registry)->options().tracking_keypoints;
      if (frame_letter_graph) frame_keypoints.grouping = texfree::WordGrouping::kLetterGraph;
      texfree::VideoKeypointExtractor extractor(frame_keypoints, video);
      if (method.baseline == 1)
        baseline = std::make_unique<FeatureBaseline>(
            cv::ORB::create(3000), cv::makePtr<cv::BFMatcher>(cv::NORM_HAMMING), page_gray);
      else if (method.baseline == 2)
        baseline = std::make_unique<FeatureBaseline>(  // KD-tree: the page has ~10^4 SIFTs
            cv::SIFT::create(), cv::makePtr<cv::FlannBasedMatcher>(), page_gray);
      else
        tracker = std::make_unique<texfree::DocumentTracker>(method.options);
      for (size_t v = 0; v < seq.views.size(); ++v) {
        const auto& view = seq.views[v];
        auto frame_options = seq.frames[v].options;
        cv::Mat gray;
        cv::cvtColor(view.image, gray, cv::COLOR_BGR2GRAY);
        // As `texfree track --undistort`: the frame remapped to the ideal pinhole of the same
        // camera matrix, scored against the page seen through that pinhole.
        if (undistort) gray = texfree::testdata::UndistortView(gray, view, &frame_options);
        Sample s;
        if (baseline) {
          s = baseline->Run(gray, view, frame_options, page_gray.size());
        } else {
          const auto t0 = SteadyClock::now();
          const double c0 = texfree::ThreadCpuMilliseconds();
          // The pages the tracker expects: extracted rectified when seen at a slant.
          texfree::VideoFrameInfo extracted;
          const auto keypoints = extractor.Extract(gray, tracker->PredictedPages(), &extracted);
          const auto result =
              tracker->Track(keypoints, gray.size(), shared, extracted.whole_frame);
          const auto& rectified = extracted.rectified;
          s.ms = MillisecondsSince(t0);
          s.cpu_ms = texfree::ThreadCpuMilliseconds() - c0;
          const TrackedDocument* doc = nullptr;
          for (const auto& d : result.documents) {
            if (d.document != tracked_id) continue;
            doc = &d;
            if (d.state == texfree::TrackState::kLost) continue;
            s.found = true;
            s.inliers = d.llah_inliers >= 0 ? d.llah_inliers : d.inliers;
            s.error = texfree::testdata::MeanProjectionError(d.homography, view, frame_options,
                                                             page_gray.size());
          }
          const size_t i = samples[m].size();
          const double where = seq.frames[0].nominal_tilt_deg != seq.frames.back().nominal_tilt_deg
                                   ? seq.frames[i].nominal_tilt_deg
                                   : static_cast<double>(i);
          if (where >= trace_from)
            std::fprintf(stderr,
                         "%s %s %.1f: %zu keypoints, h %.1f px, %s, inliers %d, llah %d, "
                         "learned %d, error %.2f px, %.1f ms (match %.1f pose %.1f update %.1f)\n",
                         seq.name.c_str(), method.name.c_str(), where, keypoints.points.size(),
                         keypoints.char_height,
                         doc ? (doc->method.empty() ? "lost" : doc->method.c_str()) : "-",
                         doc ? doc->inliers : 0, doc ? doc->llah_inliers : -1,
                         doc ? doc->learned : 0, s.found ? s.error : -1.0, s.ms,
                         result.timings.match_ms, result.timings.pose_ms, result.timings.update_ms);
          if (where >= trace_from) {
            for (const auto& r : rectified)
              std::fprintf(stderr,
                           "   rectified: %dx%d at %.3f px per page px, text %.1f px, %d "
                           "keypoints replacing %d\n",
                           r.size.width, r.size.height, r.scale, r.char_height, r.keypoints,
                           r.replaced);
            // Oracle: frame keypoints within 1.5 px of a reference keypoint placed by the
            // truth, and the homography they give.
            const auto reference = shared->Keypoints(tracked_id);
            std::vector<cv::Point2f> src, dst;
            for (const auto& p : reference) {
              const cv::Vec3d t = view.homography * cv::Vec3d(p.x, p.y, 1);
              if (t[2] <= 0) continue;
              const cv::Point2f q(t[0] / t[2], t[1] / t[2]);
              int best = -1;
              double bd = 1.5;
              for (size_t k = 0; k < keypoints.points.size(); ++k) {
                const double d = cv::norm(keypoints.points[k] - q);
                if (d < bd) {
                  bd = d;
                  best = static_cast<int>(k);
                }
              }
              if (best >= 0) {
                src.push_back(p);
                dst.push_back(keypoints.points[best]);
              }
            }
            double oracle = -1;
            if (src.size() >= 8) {
              cv::Mat H = cv::findHomography(src, dst, 0);
              if (!H.empty())
                oracle = texfree::testdata::MeanProjectionError(cv::Matx33d(H), view, frame_options,
                                                                page_gray.size());
            }
            std::fprintf(stderr, "   oracle: %zu true keypoints, error %.2f px\n", src.size(),
                         oracle);
            if (doc) {
              std::fprintf(stderr, "   inliers (truth residual px):");
              for (const auto& [q, r] : doc->matches) {
                const cv::Vec3d t = view.homography * cv::Vec3d(reference[r].x, reference[r].y, 1);
                const cv::Vec3d e = doc->homography * cv::Vec3d(reference[r].x, reference[r].y, 1);
                std::fprintf(stderr, " (%.0f,%.0f) %.1f/%.1f", t[0] / t[2], t[1] / t[2],
                             cv::norm(keypoints.points[q] - cv::Point2f(t[0] / t[2], t[1] / t[2])),
                             cv::norm(cv::Point2d(e[0] / e[2], e[1] / e[2]) -
                                      cv::Point2d(t[0] / t[2], t[1] / t[2])));
              }
              std::fprintf(stderr, "\n");
            }
          }
          if (where >= trace_from && !trace_dir.empty()) {
            cv::Mat canvas = view.image.clone();
            const auto reference = shared->Keypoints(tracked_id);
            for (const auto& p : reference) {
              const cv::Vec3d t = view.homography * cv::Vec3d(p.x, p.y, 1);
              if (t[2] > 0)
                cv::circle(canvas, {cvRound(t[0] / t[2]), cvRound(t[1] / t[2])}, 3, {0, 200, 0}, 1);
              if (s.found) {
                const cv::Vec3d e = doc->homography * cv::Vec3d(p.x, p.y, 1);
                if (e[2] > 0)
                  cv::circle(canvas, {cvRound(e[0] / e[2]), cvRound(e[1] / e[2])}, 5, {255, 0, 0},
                             1);
              }
            }
            for (const auto& p : keypoints.points) cv::circle(canvas, p, 1, {0, 0, 255}, -1);
            fs::create_directories(trace_dir);
            cv::imwrite(trace_dir + "/" + seq.name + "-" + method.name + "-" +
                            std::to_string(where).substr(0, 5) + ".png",
                        canvas);
          }
        }
        samples[m].push_back(s);
        all_ms[method.name].push_back(s.ms);
        all_cpu_ms[method.name].push_back(s.cpu_ms);
      }
      if (tracker) learned[m] = tracker->session_index().learned_entries();
    }

    // Per-tilt rows.
    std::printf("| %s |", seq.frames[0].nominal_tilt_deg == seq.frames.back().nominal_tilt_deg
                              ? "frame"
                              : "tilt");
    for (const auto& m : methods) std::printf(" %s inl / err px |", m.name.c_str());
    std::printf("\n|---:|");
    for (size_t m = 0; m < methods.size(); ++m) std::printf("---:|");
    std::printf("\n");
    const bool orbit = seq.frames[0].nominal_tilt_deg != seq.frames.back().nominal_tilt_deg;
    for (size_t i = 0; i < seq.views.size(); ++i) {
      const double tilt = seq.frames[i].nominal_tilt_deg;
      const bool row = orbit ? std::abs(std::fmod(tilt + 1e-9, print_every)) < 1e-6
                             : i % 20 == 0 || i + 1 == seq.views.size();
      if (!row) continue;
      if (orbit)
        std::printf("| %.0f |", tilt);
      else
        std::printf("| %zu |", i);
      for (size_t m = 0; m < methods.size(); ++m) {
        const Sample& s = samples[m][i];
        if (s.found)
          std::printf(" %d / %.1f |", s.inliers, std::min(s.error, 999.0));
        else
          std::printf(" - |");
      }
      std::printf("\n");
    }
    // Summary per method.
    std::printf(
        "\n| method | correct frames (<= %.0f px) | holds to | median err px | median ms | "
        "median CPU ms | learned entries |\n|---|---:|---:|---:|---:|---:|---:|\n",
        kCorrectPx);
    for (size_t m = 0; m < methods.size(); ++m) {
      int correct = 0;
      double holds = -1;
      bool broken = false;
      std::vector<double> errors, ms, cpu_ms;
      for (size_t i = 0; i < samples[m].size(); ++i) {
        const Sample& s = samples[m][i];
        const bool ok = s.found && s.error <= kCorrectPx;
        correct += ok;
        if (ok) errors.push_back(s.error);
        ms.push_back(s.ms);
        cpu_ms.push_back(s.cpu_ms);
        if (!ok) broken = true;
        if (!broken) holds = orbit ? seq.frames[i].nominal_tilt_deg : static_cast<double>(i);
      }
      std::string holds_text = holds < 0
                                   ? "-"
                                   : (orbit ? std::to_string(holds).substr(0, 4) + " deg"
                                            : "frame " + std::to_string(static_cast<int>(holds)));
      if (!broken) holds_text = "all";
      std::printf("| %s | %d / %zu | %s | %.2f | %.1f | %.1f | %zu |\n", methods[m].name.c_str(),
                  correct, samples[m].size(), holds_text.c_str(), Percentile(errors, 0.5),
                  Percentile(ms, 0.5), Percentile(cpu_ms, 0.5), learned[m]);
    }
    std::fflush(stdout);
  }

  std::printf(
      "\n### time per frame over all sequences (extraction included, one core)\n\n"
      "| method | median ms | p95 ms | median CPU ms | mean CPU ms | p95 CPU ms |\n"
      "|---|---:|---:|---:|---:|---:|\n");
  for (const auto& m : methods) {
    const auto& cpu = all_cpu_ms[m.name];
    double mean = 0;
    for (double v : cpu) mean += v / std::max<size_t>(1, cpu.size());
    std::printf("| %s | %.1f | %.1f | %.2f | %.2f | %.1f |\n", m.name.c_str(),
                Percentile(all_ms[m.name], 0.5), Percentile(all_ms[m.name], 0.95),
                Percentile(cpu, 0.5), mean, Percentile(cpu, 0.95));
  }
  std::fflush(stdout);

  cv::setNumThreads(grpc_opencv_threads);  // the server as deployed: OpenCV's default
  if (!no_grpc && !sequences.empty()) {
    std::vector<std::string> jpegs;
    for (const auto& v : sequences[0].views) {
      std::vector<uchar> bytes;
      cv::imencode(".jpg", v.image, bytes, {cv::IMWRITE_JPEG_QUALITY, 85});
      jpegs.emplace_back(bytes.begin(), bytes.end());
    }
    texfree::bench::RunGrpcThroughput(registry->get(), jpegs, sequences[0].name, streams, fps,
                                      seconds, service);
  }
  fs::remove_all(dir, ignored);
  return 0;
}
