// Light codec: the seed's Table 3.3 packet, round trips of every ID, and decoding when the
// LED clock drifts (a sample seen twice or lost), transition frames, idle samples, noise, and
// the lamps that must never decode (steady, flickering, regular blinkers).
#include "common/light_codec.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

namespace texfree::lights {
namespace {

// Soft samples a camera sees of `id`: frame k shows stream sample floor(phase + k * ratio).
std::vector<float> CameraSamples(uint32_t id, int idle, double phase, double ratio, int frames) {
  const int needed = static_cast<int>(std::ceil(phase + frames * ratio)) + 2;
  const std::vector<uint8_t> stream = *EncodeLightStream(id, idle, 0, needed);
  std::vector<float> soft(frames);
  for (int k = 0; k < frames; ++k) {
    soft[k] = stream[static_cast<int>(std::floor(phase + k * ratio))] ? 1.f : -1.f;
  }
  return soft;
}

TEST(LightCodecTest, SeedTable33Example) {
  EXPECT_EQ(LightIdBits(10), "001010");
  EXPECT_EQ(LightCrc3(10), 0b011u);
  auto packet = EncodeLightPacket(10);
  ASSERT_TRUE(packet.ok());
  EXPECT_EQ(SamplesToString(*packet), "111111000000001100111100001111000011001111001100");
}

TEST(LightCodecTest, CrcDetectsEverySingleBitError) {
  for (uint32_t id = 0; id <= kMaxLightId; ++id) {
    const uint32_t word = (id << kCrcBits) | LightCrc3(id);
    for (int bit = 0; bit < kIdBits + kCrcBits; ++bit) {
      const uint32_t corrupted = word ^ (1u << bit);
      EXPECT_NE(corrupted & 0b111, LightCrc3(corrupted >> kCrcBits)) << id << " bit " << bit;
    }
  }
}

TEST(LightCodecTest, RejectsIdsOverSixBits) {
  EXPECT_EQ(EncodeLightPacket(64).status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(EncodeLightStream(1, -1, 0, 10).status().code(), absl::StatusCode::kInvalidArgument);
}

TEST(LightCodecTest, StreamRepeatsPacketWithIdleSamples) {
  auto stream = EncodeLightStream(10, 2, 0, 100);
  ASSERT_TRUE(stream.ok());
  const std::string s = SamplesToString(*stream);
  EXPECT_EQ(s.substr(0, 48), "111111000000001100111100001111000011001111001100");
  EXPECT_EQ(s.substr(48, 2), "00");
  EXPECT_EQ(s.substr(50, 48), s.substr(0, 48));
}

TEST(LightCodecTest, RoundTripEveryIdAtEveryPhaseAndIdle) {
  SequenceDecoderOptions options;
  for (uint32_t id = 0; id <= kMaxLightId; ++id) {
    for (int idle = 0; idle <= 4; ++idle) {
      for (double phase : {0.3, 13.5, 29.7, 47.2}) {
        const auto soft = CameraSamples(id, idle, phase, 1.0, 100);
        auto decoded = DecodeLightSequence(soft.data(), 100, options);
        ASSERT_TRUE(decoded.ok()) << id << " idle " << idle << " phase " << phase << ": "
                                  << decoded.status();
        EXPECT_EQ(decoded->id, id);
        EXPECT_GE(decoded->agreement, 0.99);
      }
    }
  }
}

// Seed Table 3.5: the camera clock runs slightly fast, one sample is seen twice.
TEST(LightCodecTest, SampleSeenTwice) {
  const std::vector<uint8_t> stream = *EncodeLightStream(37, 2, 5, 120);
  std::vector<float> soft;
  for (int j = 0; j < 99; ++j) {
    soft.push_back(stream[j] ? 1.f : -1.f);
    if (j == 40) soft.push_back(stream[j] ? 1.f : -1.f);  // duplicated sample
  }
  auto decoded = DecodeLightSequence(soft.data(), static_cast<int>(soft.size()), {});
  ASSERT_TRUE(decoded.ok()) << decoded.status();
  EXPECT_EQ(decoded->id, 37u);
}

TEST(LightCodecTest, SampleLost) {
  const std::vector<uint8_t> stream = *EncodeLightStream(21, 1, 9, 120);
  std::vector<float> soft;
  for (int j = 0; j < 101; ++j) {
    if (j == 55) continue;  // camera clock slow: this LED sample is never exposed
    soft.push_back(stream[j] ? 1.f : -1.f);
  }
  auto decoded = DecodeLightSequence(soft.data(), static_cast<int>(soft.size()), {});
  ASSERT_TRUE(decoded.ok()) << decoded.status();
  EXPECT_EQ(decoded->id, 21u);
}

// A fixed-rate decoder (the seed's) loses lights at 1% drift; the clock search loses none.
TEST(LightCodecTest, OnePercentDriftEitherWay) {
  SequenceDecoderOptions fixed_rate;
  fixed_rate.max_clock_drift = 0;
  int fixed_rate_lost = 0;
  for (uint32_t id = 0; id <= kMaxLightId; ++id) {
    for (double ratio : {0.99, 0.995, 1.005, 1.01}) {
      const double phase = std::fmod(id * 7.31, 50.0);
      const auto soft = CameraSamples(id, 2, phase, ratio, 100);
      auto decoded = DecodeLightSequence(soft.data(), 100, {});
      ASSERT_TRUE(decoded.ok()) << id << " ratio " << ratio << ": " << decoded.status();
      EXPECT_EQ(decoded->id, id);
      EXPECT_GE(decoded->agreement, 0.97);
      auto seed_style = DecodeLightSequence(soft.data(), 100, fixed_rate);
      if (!seed_style.ok() || seed_style->id != id) ++fixed_rate_lost;
    }
  }
  EXPECT_GT(fixed_rate_lost, 0);
}

TEST(LightCodecTest, TransitionFramesAndNoise) {
  std::mt19937 rng(5);
  std::normal_distribution<float> noise(0.f, 0.3f);
  int decoded_ok = 0;
  for (uint32_t id = 0; id <= kMaxLightId; ++id) {
    auto soft = CameraSamples(id, 3, id * 0.77, 1.0 + (static_cast<int>(id % 5) - 2) * 0.004, 100);
    // Frames exposed across a switch read half-way; every sixth switch here.
    int switches = 0;
    for (int k = 1; k < 100; ++k) {
      if (soft[k] != soft[k - 1] && ++switches % 6 == 0) soft[k] = 0.1f * soft[k];
    }
    for (float& v : soft) v += noise(rng);
    auto decoded = DecodeLightSequence(soft.data(), 100, {});
    if (decoded.ok() && decoded->id == id) ++decoded_ok;
    if (decoded.ok()) {
      EXPECT_EQ(decoded->id, id);  // never a wrong ID
    }
  }
  EXPECT_EQ(decoded_ok, kMaxLightId + 1);
}

TEST(LightCodecTest, SteadyFlickeringAndRegularLampsNeverDecode) {
  std::vector<float> steady(100, 1.f);
  EXPECT_EQ(DecodeLightSequence(steady.data(), 100, {}).status().code(), absl::StatusCode::kNotFound);
  for (int half_period : {1, 2, 3, 4, 6, 8}) {
    std::vector<float> blink(100);
    for (int k = 0; k < 100; ++k) blink[k] = (k / half_period) % 2 ? 1.f : -1.f;
    EXPECT_FALSE(DecodeLightSequence(blink.data(), 100, {}).ok()) << half_period;
  }
  std::mt19937 rng(11);
  std::bernoulli_distribution coin(0.5);
  int false_lights = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    std::vector<float> flicker(100);
    for (float& v : flicker) v = coin(rng) ? 1.f : -1.f;
    if (DecodeLightSequence(flicker.data(), 100, {}).ok()) ++false_lights;
  }
  EXPECT_EQ(false_lights, 0);
}

TEST(LightCodecTest, TooShortAndBadOptions) {
  std::vector<float> soft(40, 1.f);
  EXPECT_EQ(DecodeLightSequence(soft.data(), 40, {}).status().code(),
            absl::StatusCode::kInvalidArgument);
  SequenceDecoderOptions bad;
  bad.max_idle_samples = -1;
  EXPECT_FALSE(bad.Validate().ok());
}

TEST(LightCodecTest, SoftLevelsIgnoreTransitionFrames) {
  std::vector<uint16_t> values = {10, 10, 200, 200, 105, 10, 200, 12, 198, 11};
  std::vector<float> soft(values.size());
  const double amplitude = IntensitiesToSoft(values.data(), 10, soft.data());
  EXPECT_NEAR(amplitude, 189.5, 2);
  EXPECT_NEAR(soft[4], 0, 0.05);
  EXPECT_NEAR(soft[2], 1, 0.05);
  EXPECT_NEAR(soft[0], -1, 0.05);
}

}  // namespace
}  // namespace texfree::lights
