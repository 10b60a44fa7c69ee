// Blinking-light codec (seed 3.2.2): the 48-sample packet of a light ID, and decoding of one
// pixel's (or region's) sample sequence when the LED and camera clocks differ.
//
// Packet: header 111111000000, then 6 ID bits and 3 CRC bits (generator x^3 + x + 1), MSB
// first, each bit as 4 samples (0 -> 0011, 1 -> 1100). The LED repeats the packet without
// end, optionally with idle samples (LED off) between packets.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace texfree::lights {

inline constexpr int kSamplesPerBit = 4;
inline constexpr int kHeaderSamples = 12;
inline constexpr int kIdBits = 6;
inline constexpr int kCrcBits = 3;
inline constexpr int kPacketSamples = kHeaderSamples + (kIdBits + kCrcBits) * kSamplesPerBit;
inline constexpr int kMaxLightId = (1 << kIdBits) - 1;
// Longest run of equal samples inside a packet stream without idle samples (0011|111111 or
// 000000|0011).
inline constexpr int kLongestRun = 8;

// CRC-3 of the 6 ID bits with generator x^3 + x + 1 (polynomial division of id * x^3).
uint32_t LightCrc3(uint32_t id);

// The 48 samples (0 or 1) of one packet. INVALID_ARGUMENT when id > 63.
absl::StatusOr<std::vector<uint8_t>> EncodeLightPacket(uint32_t id);

// The continuous stream an LED emits: packets separated by `idle_samples` zeros, `count`
// samples starting `offset` samples into the first packet.
absl::StatusOr<std::vector<uint8_t>> EncodeLightStream(uint32_t id, int idle_samples, int offset,
                                                       int count);

// "0101..." from samples, and ID bits as text ("001010" for 10).
std::string SamplesToString(const std::vector<uint8_t>& samples);
std::string LightIdBits(uint32_t id);

struct SequenceDecoderOptions {
  // Largest |camera frame interval / LED sample period - 1| searched. 0.012 covers the 1%
  // clock difference a user may leave after setting the LED rate to the camera's.
  double max_clock_drift = 0.012;
  // Steps of the clock ratio and of the sub-sample phase. Over 100 frames a ratio step of
  // 0.002 shifts the last sample by 0.2 samples at most.
  double clock_step = 0.002;
  int phase_steps = 8;
  // Idle (off) samples the LED may put between packets. At most 4 keeps a whole packet
  // inside any 100-frame burst.
  int max_idle_samples = 4;
  // Normalised header correlation (1 = perfect) a packet start needs.
  double min_header_score = 0.75;
  // Smallest |soft bit| (mean of the 4 samples' agreement, 0..1) accepted per bit.
  double min_bit_margin = 0.35;
  // Share of frames that must agree with the periodic model of the decoded ID over the whole
  // burst; rejects flickering lamps that form one valid-looking packet by chance.
  double min_agreement = 0.9;

  absl::Status Validate() const;
};

// One decoded sequence. The model: frame k shows LED sample floor(phase + k * clock_ratio).
struct SequenceDecode {
  uint32_t id = 0;
  double clock_ratio = 1.0;  // camera frame interval / LED sample period
  double phase = 0.0;        // LED sample position of frame 0, in [0, 1)
  int packet_start = 0;      // LED sample index (from floor(phase)) of the first full header
  int idle_samples = 0;
  int packets = 0;        // complete packets inside the burst
  int valid_packets = 0;  // of those, with a valid CRC and the decoded ID
  double agreement = 0;   // share of frames matching the model, 0..1
};

// Decodes soft samples (one per camera frame; > 0 means on, < 0 off, magnitude = confidence,
// about +-1 for clear samples, near 0 for frames exposed during a transition). Searches the
// clock ratio and phase, finds headers, decides each bit by the nearest code (0011/1100) and
// checks the CRC, then verifies the whole burst against the periodic stream of that ID.
// Returns nullopt-like NOT_FOUND when no ID fits; INVALID_ARGUMENT for bad options.
absl::StatusOr<SequenceDecode> DecodeLightSequence(const float* soft, int count,
                                                   const SequenceDecoderOptions& options);

// Soft samples from raw intensities: levels by 2-means (robust to transition frames), then
// (v - mid) / half_range clamped to [-1.5, 1.5]. Returns the on-off amplitude.
double IntensitiesToSoft(const uint16_t* values, int count, float* soft);

}  // namespace texfree::lights
