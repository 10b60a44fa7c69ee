// Burst decoder of blinking lights (seed 3.2.3), fed frame by frame, and a pipelined
// variant that decodes encoded frames (JPEG/PNG/TIFF) on worker threads while more arrive.
//
// Memory stays bounded: the frames are never all kept. Per pixel the decoder keeps the minimum
// and maximum of the first N frames (N chosen below, seed 3.2.6); a pixel whose range reaches
// the contrast threshold becomes "active" and from then on its samples are stored (its earlier
// samples were all within the noise band, so they are restored as that band's middle). After
// N frames, active pixels that do not switch regularly are dropped and no new ones are taken;
// the remaining candidates are decoded at the end, clustered per ID into connected regions
// and located by their on-off-intensity-weighted sub-pixel centroid.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <opencv2/core.hpp>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "common/image_io.h"
#include "common/light_codec.h"

namespace texfree::lights {

struct BurstDecoderOptions {
  // Frames a burst needs at least: one whole packet must fit.
  int min_frames = kPacketSamples;
  // Frames for the per-pixel threshold and the candidate test. 0 = chosen by the decoder as
  // 2 * (longest run + max idle) + header = 36 with the defaults: the threshold has seen both
  // levels and every light has switched at least 3 times, while the full-image pass (the
  // costly part per frame) stops early.
  int candidate_frames = 0;
  // Smallest on-off contrast a light pixel needs, as a share of full scale (255 or 65535).
  double min_contrast = 0.06;
  // The contrast must also exceed this many noise sigmas (estimated from frames 0 and 1).
  double noise_sigmas = 8.0;
  // Memory bound: at most this many active pixels are followed (each keeps one 16-bit
  // sample per frame). 1e6 pixels * 100 frames = 200 MB at worst.
  int64_t max_active_pixels = 1'000'000;
  // A light larger than this (pixels) is not a light marker (a lit window, a screen).
  int max_region_pixels = 20000;
  // Regions of one ID closer than this (pixels between bounding boxes) are one light split by
  // a pixel that failed to decode; farther apart they are a conflict.
  int merge_gap_px = 2;
  // Worker threads for decoding candidates (and, in StreamingBurstDecoder, images).
  int threads = 2;
  SequenceDecoderOptions sequence;

  absl::Status Validate() const;
  // N actually used.
  int CandidateFrames() const;
};

struct LightSpot {
  uint32_t id = 0;
  cv::Point2d center;    // sub-pixel centroid, image pixels (pixel centres at integers)
  int pixels = 0;        // decoded pixels of the region
  double quality = 0;    // mean share of frames agreeing with the ID's pattern, 0..1
  double amplitude = 0;  // mean on-off intensity of the decoded pixels
  double clock_ratio = 1;  // camera frame interval / LED sample period, as decoded
  bool conflict = false;   // the same ID also decoded in another region
  cv::Rect bounds;
};

struct BurstStats {
  int frames = 0;
  int candidate_frames = 0;
  double noise_sigma = 0;         // intensity units of the input
  double contrast_threshold = 0;  // intensity units of the input
  int64_t active_pixels = 0;      // pixels followed during the first N frames
  int64_t candidate_pixels = 0;   // that passed the switching test
  int64_t decoded_pixels = 0;     // with a valid, verified ID
  bool active_limit_reached = false;
  double decode_ms = 0;  // time in Finish()
};

struct BurstResult {
  std::vector<LightSpot> lights;  // sorted by id, then x
  BurstStats stats;
};

// Not thread-safe: one decoder per burst, frames added in capture order.
class BurstDecoder {
 public:
  static absl::StatusOr<std::unique_ptr<BurstDecoder>> Create(const BurstDecoderOptions& options);

  // CV_8UC1 or CV_16UC1 (colour is converted to gray). Every frame must have the size and
  // depth of the first; otherwise INVALID_ARGUMENT and the frame is ignored.
  absl::Status AddFrame(const cv::Mat& frame);

  // Decodes the candidates. INVALID_ARGUMENT when fewer than min_frames frames were added.
  absl::StatusOr<BurstResult> Finish();

  int frames() const { return frames_; }
  cv::Size frame_size() const { return size_; }
  // Active pixels followed so far (candidates after N frames).
  int64_t active_pixels() const { return static_cast<int64_t>(active_index_.size()); }
  // Bytes held by the per-pixel maps and the samples of active pixels.
  size_t MemoryBytes() const;
  // After the first N frames: per image row, 1 when a candidate pixel lies on it (later
  // frames only need those rows). Null before.
  std::shared_ptr<const std::vector<uint8_t>> CandidateRows() const { return candidate_rows_; }

 private:
  explicit BurstDecoder(const BurstDecoderOptions& options) : options_(options) {}
  template <typename Pixel>
  void Activate(const cv::Mat& frame);
  template <typename Pixel>
  void Gather(const cv::Mat& frame);
  void EstimateNoise(const cv::Mat& frame1);
  void PruneIrregular();

  BurstDecoderOptions options_;
  int candidate_frames_ = 0;
  int frames_ = 0;
  cv::Size size_;
  int depth_ = -1;
  double full_scale_ = 255;
  cv::Mat first_frame_;  // kept until frame 1 for the noise estimate
  cv::Mat min_, max_;    // CV_16UC1, over the first N frames
  cv::Mat state_;        // CV_8UC1: 0 idle, 1 active, 2 dropped
  uint16_t contrast_threshold_ = 0;
  BurstStats stats_;
  std::vector<int32_t> active_index_;             // linear pixel index
  std::vector<std::vector<uint16_t>> samples_;    // per active pixel, one per frame
  std::shared_ptr<const std::vector<uint8_t>> candidate_rows_;
};

// Decodes encoded frames on `options.threads` workers while the caller pushes more, feeding
// them in order to a BurstDecoder. At most threads + 2 frames are in flight (Push blocks).
// Thread-safe for one producer; Finish() once at the end.
class StreamingBurstDecoder {
 public:
  static absl::StatusOr<std::unique_ptr<StreamingBurstDecoder>> Create(
      const BurstDecoderOptions& options, const ImageLimits& limits);
  ~StreamingBurstDecoder();

  // Queues one encoded frame. Returns the first error met so far (undecodable frame, size
  // mismatch), after which further frames are refused.
  absl::Status Push(std::string encoded);
  // Waits for every queued frame, then decodes the burst.
  absl::StatusOr<BurstResult> Finish();

  int frames_pushed() const { return pushed_; }
  // Size of the burst's frames (valid once a frame was decoded; call after Finish()).
  cv::Size frame_size() const;
  int frames_decoded() const;
  int64_t active_pixels() const;
  double image_decode_ms() const;

 private:
  StreamingBurstDecoder() = default;
  void Work();

  std::unique_ptr<BurstDecoder> decoder_;
  ImageLimits limits_;
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<std::pair<int, std::string>> queue_;  // frame number, bytes
  std::map<int, cv::Mat> ready_;                   // decoded, waiting for their turn
  int pushed_ = 0;
  int next_to_feed_ = 0;
  int in_flight_ = 0;
  bool feeding_ = false;
  bool stopping_ = false;
  int max_in_flight_ = 4;
  double decode_ms_ = 0;
  int64_t active_pixels_ = 0;  // copy of decoder_->active_pixels() after each frame
  int candidate_frames_ = 0;
  // Rows later JPEG frames must decode (set once the first N frames are in).
  std::shared_ptr<const std::vector<uint8_t>> rows_;
  absl::Status error_;
  std::vector<std::thread> workers_;
};

}  // namespace texfree::lights
