// Blinking-light packet encoder and drift-tolerant sequence decoder.
#include "common/light_codec.h"

#include <algorithm>
#include <cmath>

#include "absl/strings/str_cat.h"

namespace texfree::lights {
namespace {

constexpr uint32_t kCrcGenerator = 0b1011;  // x^3 + x + 1

// Packet template as +1/-1, built once per ID on demand.
void PacketSigns(uint32_t id, float* out) {
  const std::vector<uint8_t> packet = *EncodeLightPacket(id);
  for (int i = 0; i < kPacketSamples; ++i) out[i] = packet[i] ? 1.f : -1.f;
}

float Clamp1(float v) { return std::max(-1.f, std::min(1.f, v)); }

struct PacketFound {
  int start = 0;
  uint32_t id = 0;
  double score = 0;  // header score + mean bit margin
};

// Share of frames agreeing with the periodic stream of `id` anchored at `anchor` (LED sample
// index) with `idle` samples between packets. Frames with |soft| < 0.25 count half.
double Agreement(const float* soft, int count, const std::vector<int>& sample_of_frame,
                 const float* signs, int anchor, int idle) {
  const int period = kPacketSamples + idle;
  double credit = 0;
  for (int k = 0; k < count; ++k) {
    int m = (sample_of_frame[k] - anchor) % period;
    if (m < 0) m += period;
    const float expected = m < kPacketSamples ? signs[m] : -1.f;
    const float x = soft[k];
    if (std::fabs(x) < 0.25f) {
      credit += 0.5;
    } else if ((x > 0) == (expected > 0)) {
      credit += 1.0;
    }
  }
  return credit / count;
}

}  // namespace

uint32_t LightCrc3(uint32_t id) {
  uint32_t remainder = (id & kMaxLightId) << kCrcBits;
  for (int bit = kIdBits + kCrcBits - 1; bit >= kCrcBits; --bit) {
    if (remainder & (1u << bit)) remainder ^= kCrcGenerator << (bit - kCrcBits);
  }
  return remainder & 0b111;
}

absl::StatusOr<std::vector<uint8_t>> EncodeLightPacket(uint32_t id) {
  if (id > static_cast<uint32_t>(kMaxLightId)) {
    return absl::InvalidArgumentError(
        absl::StrCat("light id ", id, " is out of range: ids are 0..", kMaxLightId,
                     " (6 bits per packet)"));
  }
  std::vector<uint8_t> samples = {1, 1, 1, 1, 1, 1, 0, 0, 0, 0, 0, 0};
  const uint32_t word = (id << kCrcBits) | LightCrc3(id);
  for (int bit = kIdBits + kCrcBits - 1; bit >= 0; --bit) {
    const bool one = (word >> bit) & 1u;
    const uint8_t code[4] = {one, one, !one, !one};  // 1 -> 1100, 0 -> 0011
    samples.insert(samples.end(), code, code + 4);
  }
  return samples;
}

absl::StatusOr<std::vector<uint8_t>> EncodeLightStream(uint32_t id, int idle_samples, int offset,
                                                       int count) {
  if (idle_samples < 0 || offset < 0 || count < 0) {
    return absl::InvalidArgumentError("idle samples, offset and count must not be negative");
  }
  auto packet = EncodeLightPacket(id);
  if (!packet.ok()) return packet.status();
  const int period = kPacketSamples + idle_samples;
  std::vector<uint8_t> out(count);
  for (int i = 0; i < count; ++i) {
    const int m = (offset + i) % period;
    out[i] = m < kPacketSamples ? (*packet)[m] : 0;
  }
  return out;
}

std::string SamplesToString(const std::vector<uint8_t>& samples) {
  std::string s;
  s.reserve(samples.size());
  for (uint8_t v : samples) s.push_back(v ? '1' : '0');
  return s;
}

std::string LightIdBits(uint32_t id) {
  std::string s;
  for (int bit = kIdBits - 1; bit >= 0; --bit) s.push_back(((id >> bit) & 1u) ? '1' : '0');
  return s;
}

absl::Status SequenceDecoderOptions::Validate() const {
  if (!(max_clock_drift >= 0 && max_clock_drift <= 0.05)) {
    return absl::InvalidArgumentError("max_clock_drift must be in [0, 0.05]");
  }
  if (!(clock_step > 0 && clock_step <= 0.01)) {
    return absl::InvalidArgumentError("clock_step must be in (0, 0.01]");
  }
  if (phase_steps < 1 || phase_steps > 64) {
    return absl::InvalidArgumentError("phase_steps must be in [1, 64]");
  }
  if (max_idle_samples < 0 || max_idle_samples > 48) {
    return absl::InvalidArgumentError("max_idle_samples must be in [0, 48]");
  }
  if (!(min_header_score > 0 && min_header_score <= 1)) {
    return absl::InvalidArgumentError("min_header_score must be in (0, 1]");
  }
  if (!(min_bit_margin >= 0 && min_bit_margin <= 1)) {
    return absl::InvalidArgumentError("min_bit_margin must be in [0, 1]");
  }
  if (!(min_agreement > 0.5 && min_agreement <= 1)) {
    return absl::InvalidArgumentError("min_agreement must be in (0.5, 1]");
  }
  return absl::OkStatus();
}

absl::StatusOr<SequenceDecode> DecodeLightSequence(const float* soft, int count,
                                                   const SequenceDecoderOptions& options) {
  if (absl::Status s = options.Validate(); !s.ok()) return s;
  if (count < kPacketSamples) {
    return absl::InvalidArgumentError(absl::StrCat("a light needs at least ", kPacketSamples,
                                                   " frames (one packet); got ", count));
  }
  static const std::vector<std::vector<float>> kSigns = [] {
    std::vector<std::vector<float>> signs(kMaxLightId + 1, std::vector<float>(kPacketSamples));
    for (uint32_t id = 0; id <= kMaxLightId; ++id) PacketSigns(id, signs[id].data());
    return signs;
  }();

  const int ratio_steps = static_cast<int>(std::floor(options.max_clock_drift / options.clock_step));
  const int max_len = static_cast<int>(std::ceil((count - 1) * (1 + options.max_clock_drift))) + 2;
  std::vector<int> sample_of_frame(count);
  std::vector<float> sum(max_len), resampled(max_len);
  std::vector<int> hits(max_len);
  std::vector<float> prefix(max_len + 1);
  std::vector<float> header_score(max_len);
  std::vector<PacketFound> found;

  bool have_best = false;
  SequenceDecode best;
  double best_rank = -1;

  for (int ri = -ratio_steps; ri <= ratio_steps; ++ri) {
    const double ratio = 1.0 + ri * options.clock_step;
    for (int pi = 0; pi < options.phase_steps; ++pi) {
      const double phase = (pi + 0.5) / options.phase_steps;
      // Resample frames onto the LED sample grid: a sample seen twice is averaged, a lost
      // sample is an erasure (weight 0).
      const int length = static_cast<int>(std::floor(phase + (count - 1) * ratio)) + 1;
      std::fill(sum.begin(), sum.begin() + length, 0.f);
      std::fill(hits.begin(), hits.begin() + length, 0);
      for (int k = 0; k < count; ++k) {
        const int j = static_cast<int>(std::floor(phase + k * ratio));
        sample_of_frame[k] = j;
        sum[j] += Clamp1(soft[k]);
        hits[j] += 1;
      }
      prefix[0] = 0;
      for (int j = 0; j < length; ++j) {
        resampled[j] = hits[j] ? sum[j] / hits[j] : 0.f;
        prefix[j + 1] = prefix[j] + resampled[j];
      }
      // Header 111111000000: correlation by prefix sums, normalised to 1.
      const int last_start = length - kPacketSamples;
      if (last_start < 0) continue;
      for (int p = 0; p + kHeaderSamples <= length; ++p) {
        header_score[p] = ((prefix[p + 6] - prefix[p]) - (prefix[p + 12] - prefix[p + 6])) / 12.f;
      }
      found.clear();
      for (int p = 0; p <= last_start; ++p) {
        const float h = header_score[p];
        if (h < options.min_header_score) continue;
        if (p > 0 && header_score[p - 1] > h) continue;
        if (p + 1 + kHeaderSamples <= length && header_score[p + 1] >= h) continue;
        uint32_t word = 0;
        double margin_sum = 0;
        bool clear = true;
        for (int b = 0; b < kIdBits + kCrcBits; ++b) {
          const int q = p + kHeaderSamples + b * kSamplesPerBit;
          // Nearest code: 1100 -> +, 0011 -> -.
          const float s =
              (resampled[q] + resampled[q + 1] - resampled[q + 2] - resampled[q + 3]) / 4.f;
          if (std::fabs(s) < options.min_bit_margin) {
            clear = false;
            break;
          }
          margin_sum += std::fabs(s);
          word = (word << 1) | (s > 0 ? 1u : 0u);
        }
        if (!clear) continue;
        const uint32_t id = word >> kCrcBits;
        if ((word & 0b111) != LightCrc3(id)) continue;
        found.push_back({p, id, h + margin_sum / (kIdBits + kCrcBits)});
      }
      if (found.empty()) continue;
      // Verify each distinct ID over the whole burst with its periodic model.
      for (size_t f = 0; f < found.size(); ++f) {
        bool seen = false;
        for (size_t g = 0; g < f; ++g) seen |= found[g].id == found[f].id;
        if (seen) continue;
        const uint32_t id = found[f].id;
        int valid = 0;
        double score = 0;
        for (const auto& p : found) {
          if (p.id == id) {
            ++valid;
            score += p.score;
          }
        }
        int best_idle = 0;
        double best_agreement = -1;
        for (int idle = 0; idle <= options.max_idle_samples; ++idle) {
          const double a = Agreement(soft, count, sample_of_frame, kSigns[id].data(),
                                     found[f].start, idle);
          if (a > best_agreement) {
            best_agreement = a;
            best_idle = idle;
          }
        }
        // Rank: agreement first, then how clearly the packets decoded.
        const double rank = best_agreement * 100 + valid + score * 0.01;
        if (rank > best_rank) {
          best_rank = rank;
          have_best = true;
          best.id = id;
          best.clock_ratio = ratio;
          best.phase = phase;
          best.packet_start = found[f].start;
          best.idle_samples = best_idle;
          best.valid_packets = valid;
          best.agreement = best_agreement;
          const int period = kPacketSamples + best_idle;
          int first = found[f].start % period;
          int packets = 0;
          for (int p = first; p + kPacketSamples <= length; p += period) ++packets;
          best.packets = std::max(packets, valid);
        }
      }
    }
  }
  if (!have_best) return absl::NotFoundError("no header with a valid CRC");
  if (best.agreement < options.min_agreement) {
    return absl::NotFoundError(absl::StrCat("id ", best.id, " decoded but only ",
                                            best.agreement, " of the burst fits its pattern"));
  }
  return best;
}

double IntensitiesToSoft(const uint16_t* values, int count, float* soft) {
  if (count <= 0) return 0;
  double lo = values[0], hi = values[0];
  for (int k = 1; k < count; ++k) {
    lo = std::min<double>(lo, values[k]);
    hi = std::max<double>(hi, values[k]);
  }
  // 2-means: the on and off levels, so that transition frames and noise do not set them.
  for (int iter = 0; iter < 8 && hi > lo; ++iter) {
    const double mid = 0.5 * (lo + hi);
    double sum_lo = 0, sum_hi = 0;
    int n_lo = 0, n_hi = 0;
    for (int k = 0; k < count; ++k) {
      if (values[k] <= mid) {
        sum_lo += values[k];
        ++n_lo;
      } else {
        sum_hi += values[k];
        ++n_hi;
      }
    }
    if (n_lo == 0 || n_hi == 0) break;
    const double new_lo = sum_lo / n_lo, new_hi = sum_hi / n_hi;
    if (new_lo == lo && new_hi == hi) break;
    lo = new_lo;
    hi = new_hi;
  }
  const double half = 0.5 * (hi - lo);
  const double mid = 0.5 * (hi + lo);
  for (int k = 0; k < count; ++k) {
    soft[k] = half > 0 ? static_cast<float>(std::clamp((values[k] - mid) / half, -1.5, 1.5)) : 0.f;
  }
  return hi - lo;
}

}  // namespace texfree::lights
