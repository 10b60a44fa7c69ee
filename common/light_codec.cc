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

  // Slip hypotheses: none first, then one slip at every frame, then (when the drift allows a
  // second within the burst) two slips at least 1/max_drift frames apart; either direction.
  std::vector<std::vector<int>> hypotheses = {{}};
  if (options.max_clock_drift > 0) {
    const int min_spacing = static_cast<int>(std::floor(1.0 / options.max_clock_drift));
    for (int direction : {1, -1}) {
      for (int s1 = 1; s1 < count; ++s1) {
        hypotheses.push_back({direction * s1});
        for (int s2 = s1 + min_spacing; s2 < count; ++s2) {
          hypotheses.push_back({direction * s1, direction * s2});
        }
      }
    }
  }
  const int max_len = count + 3;
  std::vector<int> sample_of_frame(count);
  std::vector<float> sum(max_len), resampled(max_len);
  std::vector<int> hits(max_len);
  std::vector<float> prefix(max_len + 1);
  std::vector<float> header_score(max_len);
  std::vector<PacketFound> found;

  bool have_best = false;
  SequenceDecode best;
  double best_rank = -1;

  for (size_t hi = 0; hi < hypotheses.size(); ++hi) {
    // A clean fit without slips ends the search.
    if (hi == 1 && have_best && best.agreement >= 0.985) break;
    const std::vector<int>& slips = hypotheses[hi];
    // Map frames onto LED samples: a sample seen twice is averaged, a lost one is an erasure.
    int shift = 1;  // room for one sample seen twice before frame 0's sample
    size_t next_slip = 0;
    for (int k = 0; k < count; ++k) {
      while (next_slip < slips.size() && std::abs(slips[next_slip]) == k) {
        shift += slips[next_slip] > 0 ? 1 : -1;
        ++next_slip;
      }
      sample_of_frame[k] = k + shift;
    }
    const int length = sample_of_frame[count - 1] + 1;
    std::fill(sum.begin(), sum.begin() + length, 0.f);
    std::fill(hits.begin(), hits.begin() + length, 0);
    for (int k = 0; k < count; ++k) {
      sum[sample_of_frame[k]] += Clamp1(soft[k]);
      hits[sample_of_frame[k]] += 1;
    }
    prefix[0] = 0;
    for (int j = 0; j < length; ++j) {
      resampled[j] = hits[j] ? sum[j] / hits[j] : 0.f;
      prefix[j + 1] = prefix[j] + resampled[j];
    }
    const int first_sample = sample_of_frame[0];
    const int last_start = length - kPacketSamples;
    if (last_start < first_sample) continue;
    // Header 111111000000: correlation by prefix sums, normalised to 1.
    for (int p = first_sample; p + kHeaderSamples <= length; ++p) {
      header_score[p] = ((prefix[p + 6] - prefix[p]) - (prefix[p + 12] - prefix[p + 6])) / 12.f;
    }
    found.clear();
    for (int p = first_sample; p <= last_start; ++p) {
      const float h = header_score[p];
      if (h < options.min_header_score) continue;
      if (p > first_sample && header_score[p - 1] > h) continue;
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
        const double a =
            Agreement(soft, count, sample_of_frame, kSigns[id].data(), found[f].start, idle);
        if (a > best_agreement) {
          best_agreement = a;
          best_idle = idle;
        }
      }
      // Rank: agreement first, then fewer slips (simpler model), then packet clarity.
      const double rank = best_agreement * 100 - 0.01 * slips.size() + valid * 1e-3 + score * 1e-5;
      if (rank > best_rank) {
        best_rank = rank;
        have_best = true;
        best.id = id;
        best.slips = 0;
        best.slip_frames.clear();
        for (int s : slips) {
          best.slips += s > 0 ? 1 : -1;
          best.slip_frames.push_back(std::abs(s));
        }
        best.clock_ratio = 1.0 + static_cast<double>(best.slips) / count;
        best.packet_start = found[f].start - first_sample;
        best.idle_samples = best_idle;
        best.valid_packets = valid;
        best.agreement = best_agreement;
        const int period = kPacketSamples + best_idle;
        int packets = 0;
        for (int p = first_sample + (found[f].start - first_sample) % period;
             p + kPacketSamples <= length; p += period) {
          ++packets;
        }
        best.packets = std::max(packets, valid);
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
  // 2-medians: the on and off levels, so that transition frames and noise do not set them.
  std::vector<uint16_t> low, high;
  for (int iter = 0; iter < 8 && hi > lo; ++iter) {
    const double mid = 0.5 * (lo + hi);
    low.clear();
    high.clear();
    for (int k = 0; k < count; ++k) (values[k] <= mid ? low : high).push_back(values[k]);
    if (low.empty() || high.empty()) break;
    std::nth_element(low.begin(), low.begin() + low.size() / 2, low.end());
    std::nth_element(high.begin(), high.begin() + high.size() / 2, high.end());
    const double new_lo = low[low.size() / 2], new_hi = high[high.size() / 2];
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
