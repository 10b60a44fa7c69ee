// Burst decoder on simulated tunnel bursts (quarter-size D300 frames, lights the same pixel
// size as at full resolution): every light found with its ID and nothing else (steady,
// flickering, hazard-blinking and mains-beat lamps in view), centroids within 0.3 px of the
// truth, 8-bit JPEG and 16-bit PNG, same-ID conflicts, bad bursts, bounded memory.
#include "common/light_decoder.h"

#include <gtest/gtest.h>

#include "tests/data/light_scene.h"

namespace texfree::lights {
namespace {

using testdata::BurstRenderer;
using testdata::LightSceneOptions;

LightSceneOptions SmallScene(uint64_t seed) {
  LightSceneOptions options;
  options.seed = seed;
  options.scale = 0.25;
  return options;
}

// Decodes a rendered burst frame by frame (raw frames, or encoded through the streaming
// decoder when `encoded`).
BurstResult DecodeBurst(BurstRenderer& renderer, int frames, bool encoded,
                        size_t* memory_bytes = nullptr) {
  BurstDecoderOptions options;
  if (encoded) {
    auto stream = StreamingBurstDecoder::Create(options, ImageLimits{});
    EXPECT_TRUE(stream.ok());
    for (int k = 0; k < frames; ++k) EXPECT_TRUE((*stream)->Push(renderer.EncodeFrame(k)).ok());
    auto result = (*stream)->Finish();
    EXPECT_TRUE(result.ok()) << result.status();
    return result.ok() ? *result : BurstResult{};
  }
  auto decoder = BurstDecoder::Create(options);
  EXPECT_TRUE(decoder.ok());
  for (int k = 0; k < frames; ++k) EXPECT_TRUE((*decoder)->AddFrame(renderer.RenderFrame(k)).ok());
  if (memory_bytes) *memory_bytes = (*decoder)->MemoryBytes();
  auto result = (*decoder)->Finish();
  EXPECT_TRUE(result.ok()) << result.status();
  return result.ok() ? *result : BurstResult{};
}

// Every true light decoded once with its ID within max_error_px; no other light.
void ExpectMatchesTruth(const BurstResult& result, const std::vector<testdata::LightTruth>& truth,
                        double max_error_px) {
  ASSERT_EQ(result.lights.size(), truth.size());
  double worst = 0;
  for (size_t i = 0; i < truth.size(); ++i) {
    const LightSpot& spot = result.lights[i];
    EXPECT_EQ(spot.id, truth[i].id);
    EXPECT_FALSE(spot.conflict);
    const double error = cv::norm(spot.center - truth[i].pixel);
    worst = std::max(worst, error);
    EXPECT_LE(error, max_error_px) << "light " << truth[i].id;
    EXPECT_GE(spot.quality, 0.9);
  }
  ::testing::Test::RecordProperty("worst_centroid_error_px", std::to_string(worst));
}

TEST(LightDecoderTest, TunnelJpegBurstBothViewsWithDrift) {
  auto options = SmallScene(3);
  const auto scene = testdata::MakeTunnelScene(options);
  for (int view = 0; view < 2; ++view) {
    BurstRenderer renderer(scene, testdata::TunnelViewPose(view), options, view + 1);
    ASSERT_EQ(renderer.truth().size(), 14u) << "every light inside view " << view;
    size_t memory = 0;
    const BurstResult result = DecodeBurst(renderer, options.frames, false, &memory);
    ExpectMatchesTruth(result, renderer.truth(), 0.3);
    // Bounded: far less than the 100 frames themselves.
    const size_t frame_bytes = static_cast<size_t>(scene.camera.size.area());
    EXPECT_LT(memory, 10 * frame_bytes);
    EXPECT_LT(result.stats.candidate_pixels, 14 * 200);
  }
}

TEST(LightDecoderTest, StreamingDecoderOnJpegBytes) {
  auto options = SmallScene(8);
  options.max_clock_drift = 0.01;
  const auto scene = testdata::MakeTunnelScene(options);
  BurstRenderer renderer(scene, testdata::TunnelViewPose(1), options, 5);
  ExpectMatchesTruth(DecodeBurst(renderer, options.frames, true), renderer.truth(), 0.3);
}

TEST(LightDecoderTest, SixteenBitBurst) {
  auto options = SmallScene(4);
  options.sixteen_bit = true;
  const auto scene = testdata::MakeTunnelScene(options);
  BurstRenderer renderer(scene, testdata::TunnelViewPose(0), options, 2);
  ASSERT_EQ(renderer.RenderFrame(0).depth(), CV_16U);
  ExpectMatchesTruth(DecodeBurst(renderer, options.frames, false), renderer.truth(), 0.3);
  // 16-bit PNG bytes keep their depth through decoding.
  auto decoded = DecodeGrayKeepDepth(renderer.EncodeFrame(0), ImageLimits{});
  ASSERT_TRUE(decoded.ok());
  EXPECT_EQ(decoded->depth(), CV_16U);
}

TEST(LightDecoderTest, ManySeeds) {
  // Several seeds: clocks (up to 1% drift), phases, idle samples and brightness all vary.
  for (uint64_t seed : {11u, 12u, 13u}) {
    auto options = SmallScene(seed);
    const auto scene = testdata::MakeTunnelScene(options);
    BurstRenderer renderer(scene, testdata::TunnelViewPose(seed % 2), options, seed);
    ExpectMatchesTruth(DecodeBurst(renderer, options.frames, false), renderer.truth(), 0.3);
  }
}

TEST(LightDecoderTest, SameIdInTwoPlacesIsAConflict) {
  auto options = SmallScene(6);
  auto scene = testdata::MakeTunnelScene(options);
  for (auto& light : scene.lights) {
    if (light.id == 13) light.id = 9;  // two LEDs programmed with the same ID
  }
  BurstRenderer renderer(scene, testdata::TunnelViewPose(0), options, 1);
  const BurstResult result = DecodeBurst(renderer, options.frames, false);
  int conflicts = 0;
  for (const auto& spot : result.lights) {
    if (spot.id == 9) {
      EXPECT_TRUE(spot.conflict);
      ++conflicts;
    } else {
      EXPECT_FALSE(spot.conflict);
    }
  }
  EXPECT_EQ(conflicts, 2);
  EXPECT_EQ(result.lights.size(), 14u);
}

TEST(LightDecoderTest, TooFewFramesAndMismatchedSizes) {
  auto options = SmallScene(2);
  options.frames = 47;
  const auto scene = testdata::MakeTunnelScene(options);
  BurstRenderer renderer(scene, testdata::TunnelViewPose(0), options, 1);
  auto decoder = *BurstDecoder::Create({});
  for (int k = 0; k < 47; ++k) ASSERT_TRUE(decoder->AddFrame(renderer.RenderFrame(k)).ok());
  auto result = decoder->Finish();
  EXPECT_EQ(result.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(result.status().message().find("at least 48 frames"), std::string::npos);

  const cv::Mat other(100, 120, CV_8UC1, cv::Scalar(3));
  auto status = decoder->AddFrame(other);
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(status.message().find("same size"), std::string::npos);
}

TEST(LightDecoderTest, UndecodableFrameStopsTheStream) {
  auto stream = *StreamingBurstDecoder::Create({}, ImageLimits{});
  // The frame is decoded on a worker: Push may accept it; Finish reports the error.
  (void)stream->Push(std::string("not an image"));
  auto result = stream->Finish();
  EXPECT_EQ(result.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(result.status().message().find("frame 0"), std::string::npos);
}

}  // namespace
}  // namespace texfree::lights
