// Burst decoder: activity tracking over the first N frames, candidate test, per-pixel
// decoding, regions per ID, centroids; and the pipelined image-decoding front end.
#include "common/light_decoder.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <unordered_map>

#include <csetjmp>
#include <cstdio>

#include <jpeglib.h>
#include <opencv2/imgproc.hpp>

#include "absl/strings/str_cat.h"
#include "common/timing.h"

namespace texfree::lights {
namespace {

// Longest run of equal samples a light may show, in frames (idle zeros follow "00").
int MaxRunFrames(const SequenceDecoderOptions& o) {
  return std::max(kLongestRun, 2 + o.max_idle_samples) + 1;
}

// Seed 3.2.3 candidate test on the first N samples binarised at `threshold`: switching at
// regular intervals, i.e. enough switches, no run longer than a light can show, and almost
// no one-frame runs (noise and flicker are full of them; a light shows one at most where a
// frame was exposed during a transition or a sample was lost).
bool SwitchesRegularly(const uint16_t* samples, int n, double threshold, int max_run) {
  int transitions = 0, interior_runs = 0, single_frame_runs = 0;
  int run_start = 0;
  bool previous = samples[0] > threshold;
  for (int k = 1; k <= n; ++k) {
    const bool end = k == n;
    const bool current = end ? !previous : samples[k] > threshold;
    if (current == previous) continue;
    const int length = k - run_start;
    if (length > max_run) return false;
    if (run_start > 0 && !end) {
      ++interior_runs;
      if (length == 1) ++single_frame_runs;
    }
    if (!end) ++transitions;
    run_start = k;
    previous = current;
  }
  return transitions >= 3 && single_frame_runs <= 1 + interior_runs / 8;
}

struct JpegError {
  jpeg_error_mgr manager;
  std::jmp_buf jump;
};

void OnJpegError(j_common_ptr cinfo) {
  std::longjmp(reinterpret_cast<JpegError*>(cinfo->err)->jump, 1);
}

// Decodes only the rows marked in `rows` of an 8-bit JPEG to gray (libjpeg-turbo skips the
// inverse DCT of the others); the other rows are left unset. False when the bytes are not a
// JPEG this path handles (the caller then decodes the whole image).
bool DecodeJpegRows(const std::string& bytes, const std::vector<uint8_t>& rows,
                    const ImageLimits& limits, cv::Mat* out) {
  if (bytes.size() < 4 || static_cast<uint8_t>(bytes[0]) != 0xFF ||
      static_cast<uint8_t>(bytes[1]) != 0xD8) {
    return false;
  }
  jpeg_decompress_struct cinfo;
  JpegError error;
  cinfo.err = jpeg_std_error(&error.manager);
  error.manager.error_exit = OnJpegError;
  if (setjmp(error.jump)) {
    jpeg_destroy_decompress(&cinfo);
    return false;
  }
  jpeg_create_decompress(&cinfo);
  jpeg_mem_src(&cinfo, reinterpret_cast<const unsigned char*>(bytes.data()),
               static_cast<unsigned long>(bytes.size()));
  jpeg_read_header(&cinfo, TRUE);
  const int64_t pixels = static_cast<int64_t>(cinfo.image_width) * cinfo.image_height;
  if (cinfo.image_height != rows.size() || pixels > limits.max_pixels ||
      cinfo.data_precision != 8) {
    jpeg_destroy_decompress(&cinfo);
    return false;
  }
  cinfo.out_color_space = JCS_GRAYSCALE;
  jpeg_start_decompress(&cinfo);
  out->create(static_cast<int>(cinfo.output_height), static_cast<int>(cinfo.output_width), CV_8UC1);
  const JDIMENSION height = cinfo.output_height;
  while (cinfo.output_scanline < height) {
    const JDIMENSION y = cinfo.output_scanline;
    if (rows[y]) {
      JSAMPROW row = out->ptr<uint8_t>(static_cast<int>(y));
      jpeg_read_scanlines(&cinfo, &row, 1);
      continue;
    }
    JDIMENSION skip = 0;
    while (y + skip < height && !rows[y + skip]) ++skip;
    if (jpeg_skip_scanlines(&cinfo, skip) == 0) break;
  }
  jpeg_abort_decompress(&cinfo);
  jpeg_destroy_decompress(&cinfo);
  return true;
}

struct PixelDecode {
  int id = -1;
  float agreement = 0;
  float amplitude = 0;
  float clock_ratio = 1;
};

}  // namespace

absl::Status BurstDecoderOptions::Validate() const {
  if (absl::Status s = sequence.Validate(); !s.ok()) return s;
  if (min_frames < kPacketSamples) {
    return absl::InvalidArgumentError(
        absl::StrCat("min_frames must be at least ", kPacketSamples, " (one packet)"));
  }
  if (candidate_frames != 0 && (candidate_frames < 2 * kLongestRun || candidate_frames > min_frames)) {
    return absl::InvalidArgumentError(absl::StrCat("candidate_frames must be 0 (automatic) or in [",
                                                   2 * kLongestRun, ", min_frames]"));
  }
  if (!(min_contrast > 0 && min_contrast < 1)) {
    return absl::InvalidArgumentError("min_contrast must be in (0, 1)");
  }
  if (!(noise_sigmas >= 0)) return absl::InvalidArgumentError("noise_sigmas must be >= 0");
  if (max_active_pixels < 1) return absl::InvalidArgumentError("max_active_pixels must be >= 1");
  if (max_region_pixels < 1) return absl::InvalidArgumentError("max_region_pixels must be >= 1");
  if (merge_gap_px < 0) return absl::InvalidArgumentError("merge_gap_px must be >= 0");
  if (threads < 1 || threads > 64) return absl::InvalidArgumentError("threads must be in [1, 64]");
  return absl::OkStatus();
}

int BurstDecoderOptions::CandidateFrames() const {
  if (candidate_frames > 0) return candidate_frames;
  const int automatic =
      2 * std::max(kLongestRun, 2 + sequence.max_idle_samples) + kHeaderSamples;
  return std::min(automatic, min_frames);
}

absl::StatusOr<std::unique_ptr<BurstDecoder>> BurstDecoder::Create(
    const BurstDecoderOptions& options) {
  if (absl::Status s = options.Validate(); !s.ok()) return s;
  std::unique_ptr<BurstDecoder> decoder(new BurstDecoder(options));
  decoder->candidate_frames_ = options.CandidateFrames();
  decoder->stats_.candidate_frames = decoder->candidate_frames_;
  return decoder;
}

size_t BurstDecoder::MemoryBytes() const {
  size_t bytes = min_.total() * min_.elemSize() + max_.total() * max_.elemSize() +
                 state_.total() + first_frame_.total() * first_frame_.elemSize();
  bytes += active_index_.capacity() * sizeof(int32_t);
  for (const auto& s : samples_) bytes += s.capacity() * sizeof(uint16_t) + sizeof(s);
  return bytes;
}

void BurstDecoder::EstimateNoise(const cv::Mat& frame1) {
  // Robust sigma from the median absolute frame difference (most pixels do not blink).
  cv::Mat a, b, diff;
  first_frame_.convertTo(a, CV_32S);
  frame1.convertTo(b, CV_32S);
  cv::absdiff(a, b, diff);
  std::vector<int64_t> histogram(65536, 0);
  for (int y = 0; y < diff.rows; ++y) {
    const int32_t* row = diff.ptr<int32_t>(y);
    for (int x = 0; x < diff.cols; ++x) ++histogram[std::min(row[x], 65535)];
  }
  const int64_t half = static_cast<int64_t>(diff.total()) / 2;
  int64_t seen = 0;
  int median = 0;
  for (; median < 65535; ++median) {
    seen += histogram[median];
    if (seen > half) break;
  }
  // Quantised (JPEG) dark images often have a median difference of 0: count it as 0.5.
  const double mad = std::max(0.5, static_cast<double>(median));
  stats_.noise_sigma = 1.4826 * mad / std::sqrt(2.0);
  const double threshold = std::max(options_.min_contrast * full_scale_,
                                    options_.noise_sigmas * stats_.noise_sigma);
  contrast_threshold_ = static_cast<uint16_t>(std::min(65535.0, std::ceil(threshold)));
  stats_.contrast_threshold = contrast_threshold_;
  first_frame_.release();
}

template <typename Pixel>
void BurstDecoder::Activate(const cv::Mat& frame) {
  const int k = frames_;
  const int stripes = options_.threads;
  std::vector<std::vector<std::pair<int32_t, uint16_t>>> activated(stripes);
  const uint16_t c = contrast_threshold_;
  cv::parallel_for_(cv::Range(0, stripes), [&](const cv::Range& range) {
    for (int s = range.start; s < range.end; ++s) {
      const int y0 = frame.rows * s / stripes, y1 = frame.rows * (s + 1) / stripes;
      auto& out = activated[s];
      for (int y = y0; y < y1; ++y) {
        const Pixel* src = frame.ptr<Pixel>(y);
        uint16_t* lo_row = min_.ptr<uint16_t>(y);
        uint16_t* hi_row = max_.ptr<uint16_t>(y);
        uint8_t* st = state_.ptr<uint8_t>(y);
        for (int x = 0; x < frame.cols; ++x) {
          if (st[x]) continue;
          const uint16_t v = src[x];
          const uint16_t lo = lo_row[x], hi = hi_row[x];
          const uint16_t new_lo = v < lo ? v : lo, new_hi = v > hi ? v : hi;
          if (new_hi - new_lo >= c) {
            st[x] = 1;
            out.emplace_back(y * frame.cols + x, static_cast<uint16_t>((lo + hi + 1) / 2));
          } else {
            lo_row[x] = new_lo;
            hi_row[x] = new_hi;
          }
        }
      }
    }
  }, stripes);
  for (auto& list : activated) {
    for (const auto& [index, earlier] : list) {
      if (static_cast<int64_t>(active_index_.size()) >= options_.max_active_pixels) {
        stats_.active_limit_reached = true;
        state_.ptr<uint8_t>()[index] = 2;
        continue;
      }
      active_index_.push_back(index);
      // Earlier frames were all inside the noise band: restore them as its middle.
      std::vector<uint16_t> samples;
      samples.reserve(std::max(options_.min_frames, 100));
      samples.assign(k, earlier);
      samples_.push_back(std::move(samples));
    }
  }
}

template <typename Pixel>
void BurstDecoder::Gather(const cv::Mat& frame) {
  const Pixel* pixels = frame.ptr<Pixel>();
  const bool in_window = frames_ < candidate_frames_;
  uint16_t* lo = min_.ptr<uint16_t>();
  uint16_t* hi = max_.ptr<uint16_t>();
  for (size_t i = 0; i < active_index_.size(); ++i) {
    const int32_t index = active_index_[i];
    const uint16_t v = pixels[index];
    samples_[i].push_back(v);
    if (in_window) {
      lo[index] = std::min(lo[index], v);
      hi[index] = std::max(hi[index], v);
    }
  }
}

void BurstDecoder::PruneIrregular() {
  const int n = candidate_frames_;
  const int max_run = MaxRunFrames(options_.sequence);
  const uint16_t* lo = min_.ptr<uint16_t>();
  const uint16_t* hi = max_.ptr<uint16_t>();
  uint8_t* state = state_.ptr<uint8_t>();
  size_t kept = 0;
  for (size_t i = 0; i < active_index_.size(); ++i) {
    const int32_t index = active_index_[i];
    const double threshold = 0.5 * (static_cast<double>(lo[index]) + hi[index]);  // seed (3.2)
    if (SwitchesRegularly(samples_[i].data(), n, threshold, max_run)) {
      if (kept != i) {  // (self-move-assignment would empty the vector)
        active_index_[kept] = index;
        samples_[kept] = std::move(samples_[i]);
      }
      ++kept;
    } else {
      state[index] = 2;
    }
  }
  active_index_.resize(kept);
  samples_.resize(kept);
  active_index_.shrink_to_fit();
  samples_.shrink_to_fit();
  stats_.candidate_pixels = static_cast<int64_t>(kept);
  auto rows = std::make_shared<std::vector<uint8_t>>(size_.height, 0);
  for (int32_t index : active_index_) (*rows)[index / size_.width] = 1;
  candidate_rows_ = std::move(rows);
}

absl::Status BurstDecoder::AddFrame(const cv::Mat& input) {
  if (input.empty()) return absl::InvalidArgumentError("frame is empty");
  cv::Mat frame = input;
  if (frame.channels() == 3 || frame.channels() == 4) {
    cv::cvtColor(input, frame, frame.channels() == 4 ? cv::COLOR_BGRA2GRAY : cv::COLOR_BGR2GRAY);
  }
  if (frame.channels() != 1 || (frame.depth() != CV_8U && frame.depth() != CV_16U)) {
    return absl::InvalidArgumentError("frames must be 8- or 16-bit gray or colour images");
  }
  if (!frame.isContinuous()) frame = frame.clone();
  if (frames_ == 0) {
    size_ = frame.size();
    depth_ = frame.depth();
    full_scale_ = depth_ == CV_8U ? 255.0 : 65535.0;
    if (static_cast<int64_t>(size_.area()) >= (int64_t{1} << 31)) {
      return absl::InvalidArgumentError("frame is too large");
    }
    frame.convertTo(min_, CV_16U);
    max_ = min_.clone();
    state_ = cv::Mat::zeros(size_, CV_8UC1);
    first_frame_ = frame.clone();
    ++frames_;
    stats_.frames = frames_;
    return absl::OkStatus();
  }
  if (frame.size() != size_) {
    return absl::InvalidArgumentError(absl::StrCat(
        "frame ", frames_, " is ", frame.cols, "x", frame.rows, " but the burst's first frame is ",
        size_.width, "x", size_.height, ": every frame of a view must have the same size"));
  }
  if (frame.depth() != depth_) {
    return absl::InvalidArgumentError(
        absl::StrCat("frame ", frames_, " has a different bit depth from the first frame"));
  }
  if (frames_ == 1) EstimateNoise(frame);
  if (frames_ < candidate_frames_) {
    if (depth_ == CV_8U) {
      Activate<uint8_t>(frame);
    } else {
      Activate<uint16_t>(frame);
    }
  }
  if (depth_ == CV_8U) {
    Gather<uint8_t>(frame);
  } else {
    Gather<uint16_t>(frame);
  }
  ++frames_;
  stats_.frames = frames_;
  if (frames_ == candidate_frames_) {
    stats_.active_pixels = static_cast<int64_t>(active_index_.size());
    PruneIrregular();
  }
  return absl::OkStatus();
}

absl::StatusOr<BurstResult> BurstDecoder::Finish() {
  const auto t0 = SteadyClock::now();
  if (frames_ < options_.min_frames) {
    return absl::InvalidArgumentError(absl::StrCat(
        "a view needs at least ", options_.min_frames, " frames (one whole ", kPacketSamples,
        "-sample packet of every light; 100 recommended); got ", frames_));
  }
  const int count = frames_;
  const int64_t n = static_cast<int64_t>(active_index_.size());
  std::vector<PixelDecode> decoded(n);
  std::atomic<int64_t> next{0};
  auto work = [&] {
    std::vector<float> soft(count);
    for (int64_t i; (i = next.fetch_add(1)) < n;) {
      const double amplitude = IntensitiesToSoft(samples_[i].data(), count, soft.data());
      if (amplitude < contrast_threshold_) continue;
      auto result = DecodeLightSequence(soft.data(), count, options_.sequence);
      if (!result.ok()) continue;
      decoded[i] = {static_cast<int>(result->id), static_cast<float>(result->agreement),
                    static_cast<float>(amplitude), static_cast<float>(result->clock_ratio)};
    }
  };
  std::vector<std::thread> workers;
  for (int t = 1; t < options_.threads; ++t) workers.emplace_back(work);
  work();
  for (auto& w : workers) w.join();

  // Connected regions (8-neighbourhood) of pixels with the same ID.
  const int width = size_.width, height = size_.height;
  std::unordered_map<int32_t, int64_t> slot_of_pixel;
  for (int64_t i = 0; i < n; ++i) {
    if (decoded[i].id >= 0) slot_of_pixel.emplace(active_index_[i], i);
  }
  stats_.decoded_pixels = static_cast<int64_t>(slot_of_pixel.size());
  struct Region {
    int id;
    std::vector<int32_t> pixels;
    cv::Rect bounds;
  };
  std::vector<Region> regions;
  std::unordered_map<int32_t, int> region_of_pixel;
  for (int64_t i = 0; i < n; ++i) {
    if (decoded[i].id < 0 || region_of_pixel.count(active_index_[i])) continue;
    Region region{decoded[i].id, {}, {}};
    std::vector<int32_t> stack = {active_index_[i]};
    region_of_pixel[active_index_[i]] = static_cast<int>(regions.size());
    int x0 = width, y0 = height, x1 = -1, y1 = -1;
    while (!stack.empty()) {
      const int32_t p = stack.back();
      stack.pop_back();
      region.pixels.push_back(p);
      const int px = p % width, py = p / width;
      x0 = std::min(x0, px), x1 = std::max(x1, px), y0 = std::min(y0, py), y1 = std::max(y1, py);
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
          const int qx = px + dx, qy = py + dy;
          if ((dx == 0 && dy == 0) || qx < 0 || qy < 0 || qx >= width || qy >= height) continue;
          const int32_t q = qy * width + qx;
          auto it = slot_of_pixel.find(q);
          if (it == slot_of_pixel.end() || decoded[it->second].id != region.id) continue;
          if (region_of_pixel.emplace(q, static_cast<int>(regions.size())).second) {
            stack.push_back(q);
          }
        }
      }
    }
    region.bounds = cv::Rect(x0, y0, x1 - x0 + 1, y1 - y0 + 1);
    regions.push_back(std::move(region));
  }
  // Same ID within merge_gap_px: one light split by a pixel that failed; merge.
  for (size_t a = 0; a < regions.size(); ++a) {
    for (size_t b = a + 1; b < regions.size(); ++b) {
      if (regions[a].pixels.empty() || regions[b].pixels.empty() || regions[a].id != regions[b].id)
        continue;
      const int g = options_.merge_gap_px + 1;
      const cv::Rect grown(regions[a].bounds.x - g, regions[a].bounds.y - g,
                           regions[a].bounds.width + 2 * g, regions[a].bounds.height + 2 * g);
      if ((grown & regions[b].bounds).area() == 0) continue;
      for (int32_t p : regions[b].pixels) region_of_pixel[p] = static_cast<int>(a);
      regions[a].pixels.insert(regions[a].pixels.end(), regions[b].pixels.begin(),
                               regions[b].pixels.end());
      regions[a].bounds |= regions[b].bounds;
      regions[b].pixels.clear();
      b = a;  // the grown region may now touch earlier ones
    }
  }

  BurstResult result;
  const uint16_t* lo = min_.ptr<uint16_t>();
  const uint16_t* hi = max_.ptr<uint16_t>();
  std::map<uint32_t, int> regions_per_id;
  for (size_t r = 0; r < regions.size(); ++r) {
    const Region& region = regions[r];
    if (region.pixels.empty() || static_cast<int>(region.pixels.size()) > options_.max_region_pixels)
      continue;
    LightSpot spot;
    spot.id = static_cast<uint32_t>(region.id);
    spot.pixels = static_cast<int>(region.pixels.size());
    spot.bounds = region.bounds;
    double quality = 0, amplitude = 0, ratio = 0;
    for (int32_t p : region.pixels) {
      const PixelDecode& d = decoded[slot_of_pixel[p]];
      quality += d.agreement;
      amplitude += d.amplitude;
      ratio += d.clock_ratio;
    }
    spot.quality = quality / spot.pixels;
    spot.amplitude = amplitude / spot.pixels;
    spot.clock_ratio = ratio / spot.pixels;
    // Centroid weighted by on-off intensity (max - min over the first N frames) above the
    // window border's level, so the dark background and its noise do not pull it; the dim
    // rim that did not decode still counts. Pixels of other lights are left out.
    const cv::Rect window = cv::Rect(region.bounds.x - 2, region.bounds.y - 2,
                                     region.bounds.width + 4, region.bounds.height + 4) &
                            cv::Rect(0, 0, width, height);
    std::vector<int> border;
    for (int y = window.y; y < window.br().y; ++y) {
      for (int x = window.x; x < window.br().x; ++x) {
        if (y == window.y || x == window.x || y == window.br().y - 1 || x == window.br().x - 1) {
          const int32_t p = y * width + x;
          border.push_back(hi[p] - lo[p]);
        }
      }
    }
    std::nth_element(border.begin(), border.begin() + border.size() / 2, border.end());
    const double background = border[border.size() / 2];
    double peak = 0;
    for (int32_t p : region.pixels) peak = std::max(peak, hi[p] - lo[p] - background);
    double sw = 0, sx = 0, sy = 0;
    for (int y = window.y; y < window.br().y; ++y) {
      for (int x = window.x; x < window.br().x; ++x) {
        const int32_t p = y * width + x;
        auto other = region_of_pixel.find(p);
        if (other != region_of_pixel.end() && other->second != static_cast<int>(r)) continue;
        const double w = hi[p] - lo[p] - background;
        if (w < 0.05 * peak) continue;
        sw += w;
        sx += w * x;
        sy += w * y;
      }
    }
    if (sw > 0) {
      spot.center = cv::Point2d(sx / sw, sy / sw);
    } else {
      for (int32_t p : region.pixels) spot.center += cv::Point2d(p % width, p / width);
      spot.center /= spot.pixels;
    }
    ++regions_per_id[spot.id];
    result.lights.push_back(spot);
  }
  for (auto& spot : result.lights) spot.conflict = regions_per_id[spot.id] > 1;
  std::sort(result.lights.begin(), result.lights.end(), [](const LightSpot& a, const LightSpot& b) {
    return a.id != b.id ? a.id < b.id : a.center.x < b.center.x;
  });
  stats_.decode_ms = MillisecondsSince(t0);
  result.stats = stats_;
  return result;
}

// ---------------------------------------------------------------------------------------------

absl::StatusOr<std::unique_ptr<StreamingBurstDecoder>> StreamingBurstDecoder::Create(
    const BurstDecoderOptions& options, const ImageLimits& limits) {
  if (absl::Status s = limits.Validate(); !s.ok()) return s;
  auto decoder = BurstDecoder::Create(options);
  if (!decoder.ok()) return decoder.status();
  std::unique_ptr<StreamingBurstDecoder> stream(new StreamingBurstDecoder());
  stream->decoder_ = std::move(*decoder);
  stream->limits_ = limits;
  stream->max_in_flight_ = options.threads + 2;
  stream->candidate_frames_ = options.CandidateFrames();
  for (int t = 0; t < options.threads; ++t) stream->workers_.emplace_back([s = stream.get()] { s->Work(); });
  return stream;
}

StreamingBurstDecoder::~StreamingBurstDecoder() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  changed_.notify_all();
  for (auto& w : workers_) w.join();
}

void StreamingBurstDecoder::Work() {
  std::unique_lock<std::mutex> lock(mutex_);
  while (true) {
    changed_.wait(lock, [&] { return stopping_ || !queue_.empty(); });
    if (stopping_) return;
    auto [number, bytes] = std::move(queue_.front());
    queue_.pop_front();
    const bool failed = !error_.ok();
    // Frames after the first N only need the candidates' rows.
    std::shared_ptr<const std::vector<uint8_t>> rows =
        number >= candidate_frames_ ? rows_ : nullptr;
    lock.unlock();
    absl::StatusOr<cv::Mat> image = absl::CancelledError("skipped after an earlier error");
    const auto t0 = SteadyClock::now();
    cv::Mat partial;
    if (!failed && rows && DecodeJpegRows(bytes, *rows, limits_, &partial)) {
      image = std::move(partial);
    } else if (!failed) {
      image = DecodeGrayKeepDepth(bytes, limits_);
      if (!image.ok()) {
        image = absl::InvalidArgumentError(
            absl::StrCat("frame ", number, ": ", image.status().message()));
      }
    }
    std::string().swap(bytes);
    const double ms = MillisecondsSince(t0);
    lock.lock();
    decode_ms_ += ms;
    if (!image.ok()) {
      if (error_.ok() && !absl::IsCancelled(image.status())) error_ = image.status();
      ready_[number] = cv::Mat();
    } else {
      ready_[number] = std::move(*image);
    }
    // Feed in capture order; one thread feeds at a time, the others keep decoding.
    while (!feeding_ && !ready_.empty() && ready_.begin()->first == next_to_feed_) {
      cv::Mat frame = std::move(ready_.begin()->second);
      ready_.erase(ready_.begin());
      feeding_ = true;
      const bool ok_so_far = error_.ok();
      lock.unlock();
      absl::Status s = ok_so_far && !frame.empty() ? decoder_->AddFrame(frame) : absl::OkStatus();
      const int64_t active = decoder_->active_pixels();
      auto candidate_rows = decoder_->CandidateRows();
      frame.release();
      lock.lock();
      active_pixels_ = active;
      if (!rows_ && candidate_rows) rows_ = std::move(candidate_rows);
      if (!s.ok() && error_.ok()) error_ = s;
      feeding_ = false;
      ++next_to_feed_;
      --in_flight_;
    }
    changed_.notify_all();
  }
}

absl::Status StreamingBurstDecoder::Push(std::string encoded) {
  std::unique_lock<std::mutex> lock(mutex_);
  changed_.wait(lock, [&] { return in_flight_ < max_in_flight_ || !error_.ok(); });
  if (!error_.ok()) return error_;
  queue_.emplace_back(pushed_++, std::move(encoded));
  ++in_flight_;
  changed_.notify_all();
  return absl::OkStatus();
}

absl::StatusOr<BurstResult> StreamingBurstDecoder::Finish() {
  {
    std::unique_lock<std::mutex> lock(mutex_);
    changed_.wait(lock, [&] { return in_flight_ == 0; });
    if (!error_.ok()) return error_;
  }
  return decoder_->Finish();
}

cv::Size StreamingBurstDecoder::frame_size() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return feeding_ ? cv::Size() : decoder_->frame_size();
}

int StreamingBurstDecoder::frames_decoded() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return next_to_feed_;
}

int64_t StreamingBurstDecoder::active_pixels() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return active_pixels_;
}

double StreamingBurstDecoder::image_decode_ms() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return decode_ms_;
}

}  // namespace texfree::lights
