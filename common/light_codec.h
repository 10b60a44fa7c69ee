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
  // clock difference a user may leave after setting the LED rate to the camera's. The drift
  // shows as slips: every 1/drift frames one LED sample is seen twice (camera faster) or
  // lost (camera slower); the decoder tries every slip position, so slips may also come
  // from jitter rather than a constant rate.
  double max_clock_drift = 0.012;
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

// One decoded sequence. The model: frame k shows LED sample k + (slips before k) * direction.
struct SequenceDecode {
  uint32_t id = 0;
  // Slips found: > 0 samples lost (camera slower than the LED), < 0 samples seen twice.
  int slips = 0;
  std::vector<int> slip_frames;  // frames at which a slip happened
  double clock_ratio = 1.0;      // rough: 1 + slips / frames
  int packet_start = 0;          // LED sample index of the first full header
  int idle_samples = 0;
  int packets = 0;        // complete packets inside the burst
  int valid_packets = 0;  // of those, with a valid CRC and the decoded ID
  double agreement = 0;   // share of frames matching the model, 0..1
};

// Decodes soft samples (one per camera frame; > 0 means on, < 0 off, magnitude = confidence,
// about +-1 for clear samples, near 0 for frames exposed during a transition). Searches the
// slips (clock drift), finds headers, decides each bit by the nearest code (0011/1100) and
// checks the CRC, then verifies the whole burst against the periodic stream of that ID. The
// slip hypotheses are tried after the no-slip one only when it does not fit cleanly.
// NOT_FOUND when no ID fits; INVALID_ARGUMENT for bad options or fewer than 48 samples.
absl::StatusOr<SequenceDecode> DecodeLightSequence(const float* soft, int count,
                                                   const SequenceDecoderOptions& options);

// Soft samples from raw intensities: levels by 2-means (robust to transition frames), then
// (v - mid) / half_range clamped to [-1.5, 1.5]. Returns the on-off amplitude.
double IntensitiesToSoft(const uint16_t* values, int count, float* soft);

}  // namespace texfree::lights
