// Pool vision against the renderer's ground truth: table corners, ball numbers and
// positions from views at both long and both short sides, the origin chosen by the ball
// arrangement (seed 4.5), clear errors without a table or with part of it, the empty-table
// background, the eq. 4.3 number votes, profile validation and colour calibration.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <random>
#include <tuple>
#include <utility>

#include "absl/strings/str_format.h"
#include "common/pool_analyzer.h"
#include "common/pool_balls.h"
#include "common/pool_profile.h"
#include "common/pool_table.h"
#include "tests/data/pool_renderer.h"
#include "tests/data/pool_scoring.h"

namespace texfree {
namespace {

using testdata::PoolScene;
using testdata::PoolTableSpec;
using testdata::PoolView;
using testdata::PoolViewSide;

PoolTableProfile ProfileFor(const PoolTableSpec& spec) {
  PoolTableProfile p = BenchPoolProfile();
  p.length_mm = spec.length_mm;
  p.width_mm = spec.width_mm;
  p.ball_radius_mm = spec.ball_radius_mm;
  p.cushion_height_mm = spec.cushion_height_mm;
  p.cushion_width_mm = spec.cushion_width_mm;
  p.corner_pocket_mm = spec.corner_pocket_mm;
  p.side_pocket_mm = spec.side_pocket_mm;
  return p;
}

CameraModel CameraOf(const PoolView& view) {
  CameraModel camera;
  camera.K = view.camera_matrix;
  camera.distortion = view.distortion;
  camera.size = view.image.size();
  return camera;
}

// The renderer writes its light unencoded (PoolScene::srgb_tone off): the analysis is told
// so, as it is told a user's camera.
PoolAnalyzerOptions ForLinearRender(PoolAnalyzerOptions options = {}) {
  options.balls.pixel_encoding = options.table.pixel_encoding = PixelEncoding::kLinear;
  return options;
}

// A rendered view analysed with its table's profile and its camera (told how the renderer
// encoded it: PoolScene::srgb_tone), and scored against the renderer's truth.
struct ScoredAnalysis {
  PoolAnalysis analysis;
  testdata::PoolScore score;
};
// `profile`: the table profile the user gave (ProfileFor(scene.table) when null).
absl::StatusOr<ScoredAnalysis> AnalyzeAndScore(const PoolScene& scene, const PoolView& view,
                                               const PoolAnalyzerOptions& options = {},
                                               const PoolTableProfile* profile = nullptr) {
  PoolAnalyzerOptions told = options;
  told.balls.pixel_encoding = told.table.pixel_encoding =
      scene.srgb_tone ? PixelEncoding::kSrgb : PixelEncoding::kLinear;
  auto analyzer =
      PoolAnalyzer::Create(profile ? *profile : ProfileFor(scene.table), CameraOf(view), told);
  if (!analyzer.ok()) return analyzer.status();
  auto analysis = analyzer->Analyze(view.image);
  if (!analysis.ok()) return analysis.status();
  std::vector<testdata::EstimatedPoolBall> estimated;
  for (const auto& b : analysis->balls) estimated.push_back({b.number, b.x_mm, b.y_mm});
  testdata::PoolScore score =
      testdata::ScorePoolAnalysis(scene, view, analysis->cloth_corners, estimated);
  return ScoredAnalysis{std::move(*analysis), std::move(score)};
}

// Every ball of the view located, each within `max_error_mm`.
void ExpectEveryBallLocatedWithin(const testdata::PoolScore& score, const PoolView& view,
                                  double max_error_mm) {
  EXPECT_EQ(score.position_errors_mm.size(), view.balls.size());
  for (const auto& m : score.matches) {
    EXPECT_GE(m.error_mm, 0) << "ball " << m.truth_number;
    EXPECT_LT(m.error_mm, max_error_mm) << "ball " << m.truth_number;
  }
}

// The match of true ball `number` in `score` (null when the view has no such ball).
const testdata::PoolBallMatch* FindMatch(const testdata::PoolScore& score, int number) {
  for (const auto& m : score.matches)
    if (m.truth_number == number) return &m;
  return nullptr;
}

// Ball `number` is in view, separated, found within `max_error_mm` and named.
void ExpectSeparatedBallNamed(const testdata::PoolScore& score, int number, double max_error_mm) {
  const testdata::PoolBallMatch* m = FindMatch(score, number);
  ASSERT_NE(m, nullptr) << "no " << number << " in view";
  EXPECT_TRUE(m->separated);
  EXPECT_GE(m->error_mm, 0) << "the " << number << " not found";
  EXPECT_LT(m->error_mm, max_error_mm);
  EXPECT_EQ(m->estimated_number, number);
}

// Frame `frame` of the benchmark's seed-7 set (texfree-bench-pool --frames 60), rendered
// as the benchmark does; at `scale` times 640x480 as its --scale does, with a cue stick as
// its --cue-stick puts in, under lamps of the colour its --light gives.
struct BenchFrame {
  PoolScene scene;
  PoolView view;
};
// The scene of benchmark frame `frame` of `seed` (as texfree-bench-pool draws it).
PoolScene BenchScene(int frame, uint64_t seed = 7, bool nine_foot = false) {
  const testdata::PoolTableSpec spec =
      nine_foot ? testdata::PoolTableSpec::NineFoot() : testdata::PoolTableSpec::Bench();
  std::mt19937_64 rng(seed);
  PoolScene scene;
  for (int i = 0; i <= frame; ++i) scene = testdata::RandomPoolScene(rng, spec);
  return scene;
}

// `scene` rendered as the benchmark renders frame `frame` of its set `seed` (its noise).
PoolView RenderAsBench(const PoolScene& scene, int frame, uint64_t seed) {
  return testdata::RenderPoolView(scene, seed * 100003 + static_cast<uint64_t>(frame));
}

BenchFrame RenderBenchFrame(int frame, uint64_t seed = 7, double scale = 1, bool nine_foot = false,
                            bool cue_stick = false, const cv::Vec3d& light_rgb = {1, 1, 1},
                            bool srgb = false) {
  BenchFrame out;
  out.scene = BenchScene(frame, seed, nine_foot);
  if (cue_stick) {
    std::mt19937_64 stick_rng(seed * 7919 + static_cast<uint64_t>(frame));
    out.scene.cue_stick = testdata::AimedCueStick(stick_rng, out.scene.table, out.scene.balls);
  }
  testdata::ScalePoolCamera(&out.scene, scale);
  out.scene.light_rgb = light_rgb;
  out.scene.srgb_tone = srgb;
  out.view = RenderAsBench(out.scene, frame, seed);
  return out;
}

// The position error of the ball numbered `number` in the view (mm; -1 when not found).
double ErrorOf(const testdata::PoolScore& score, int number) {
  const testdata::PoolBallMatch* m = FindMatch(score, number);
  return m ? m->error_mm : -1;
}

// Frame `frame` of the benchmark's set `seed` rendered sRGB-encoded (texfree-bench-pool
// --srgb), as a phone's picture is.
BenchFrame SrgbBenchFrame(int frame, uint64_t seed = 7) {
  return RenderBenchFrame(frame, seed, 1, false, false, {1, 1, 1}, /*srgb=*/true);
}

// For each (seed, frame) of the benchmark's sets rendered sRGB: the separated ball numbered
// `number` is named and within `max_error_mm` with `with`, and with `without` (the options
// that turn the change under test off) it is read as `read_as`.
void ExpectSrgbBallNamedAndReadAsWithout(const std::vector<std::pair<uint64_t, int>>& cases,
                                         int number, double max_error_mm,
                                         const PoolAnalyzerOptions& without, int read_as,
                                         const PoolAnalyzerOptions& with = {}) {
  for (const auto& [seed, frame] : cases) {
    SCOPED_TRACE("seed " + std::to_string(seed) + " frame " + std::to_string(frame));
    const auto [scene, view] = SrgbBenchFrame(frame, seed);
    auto scored = AnalyzeAndScore(scene, view, with);
    ASSERT_TRUE(scored.ok()) << scored.status();
    ExpectSeparatedBallNamed(scored->score, number, max_error_mm);
    auto before = AnalyzeAndScore(scene, view, without);
    ASSERT_TRUE(before.ok()) << before.status();
    const testdata::PoolBallMatch* m = FindMatch(before->score, number);
    EXPECT_NE(m, nullptr) << "no " << number << " in view";
    if (m) {
      EXPECT_EQ(m->estimated_number, read_as);
    }
  }
}

// For each (seed, frame, number) of the benchmark's sets rendered sRGB: the separated ball
// numbered `number` is named and within `max_error_mm`, and every ball of the view within
// 10 mm; then check(score, score_without, number) judges the view as analysed with and
// with `without` (the options that turn the change under test off).
template <typename Check>
void ExpectSrgbBallPlaced(const std::vector<std::tuple<uint64_t, int, int>>& cases,
                          double max_error_mm, const PoolAnalyzerOptions& without,
                          const Check& check) {
  for (const auto& [seed, frame, number] : cases) {
    SCOPED_TRACE("seed " + std::to_string(seed) + " frame " + std::to_string(frame));
    const auto [scene, view] = SrgbBenchFrame(frame, seed);
    auto scored = AnalyzeAndScore(scene, view);
    ASSERT_TRUE(scored.ok()) << scored.status();
    ExpectSeparatedBallNamed(scored->score, number, max_error_mm);
    ExpectEveryBallLocatedWithin(scored->score, view, 10.0);
    auto before = AnalyzeAndScore(scene, view, without);
    ASSERT_TRUE(before.ok()) << before.status();
    check(scored->score, before->score, number);
  }
}
// ExpectSrgbBallPlaced, and without the change the ball is more than
// `min_error_without_mm` off.
void ExpectSrgbBallPlacedAndOffWithout(const std::vector<std::tuple<uint64_t, int, int>>& cases,
                                       double max_error_mm, const PoolAnalyzerOptions& without,
                                       double min_error_without_mm) {
  ExpectSrgbBallPlaced(
      cases, max_error_mm, without,
      [&](const testdata::PoolScore&, const testdata::PoolScore& before, int number) {
        EXPECT_GT(ErrorOf(before, number), min_error_without_mm);
      });
}

// Options::Validate() rejects each of `values` in `field`, the others at their defaults.
template <typename Options>
void ExpectRejected(double Options::*field, std::initializer_list<double> values) {
  for (double value : values) {
    Options options;
    options.*field = value;
    EXPECT_FALSE(options.Validate().ok()) << value;
  }
}

// A fixed, well-spread layout of all ten balls (none touching).
std::vector<testdata::PoolBallPlacement> SpreadLayout() {
  return {{0, 300, 350}, {1, 520, 200}, {2, 700, 520}, {3, 900, 180},  {4, 1050, 450},
          {5, 200, 560}, {6, 450, 470}, {7, 800, 330}, {8, 1150, 250}, {9, 620, 110}};
}

PoolScene Scene(PoolViewSide side, double elevation, double azimuth_offset = 0) {
  PoolScene scene;
  scene.balls = SpreadLayout();
  scene.camera = testdata::FramedPoolCamera(scene.table, side, elevation, 60, azimuth_offset, 3);
  scene.camera.k1 = -0.04;
  scene.blur_sigma = 0.6;
  scene.noise_sigma = 2;
  scene.jpeg_quality = 88;
  return scene;
}

struct ViewCase {
  PoolViewSide side;
  double elevation;
  const char* name;
};

class PoolViewsTest : public ::testing::TestWithParam<ViewCase> {};

TEST_P(PoolViewsTest, CornersNumbersAndPositionsMatchTheTruth) {
  const ViewCase c = GetParam();
  const PoolScene scene = Scene(c.side, c.elevation, 8);
  const PoolView view = testdata::RenderPoolView(scene, 1234);
  auto scored = AnalyzeAndScore(scene, view);
  ASSERT_TRUE(scored.ok()) << scored.status();
  const PoolAnalysis& analysis = scored->analysis;
  const testdata::PoolScore& score = scored->score;
  EXPECT_LT(score.max_corner_error_px, 1.5) << c.name;
  EXPECT_EQ(analysis.long_side_view,
            c.side == PoolViewSide::kLongNear || c.side == PoolViewSide::kLongFar);
  // Every ball found, each within 12 mm, 5 mm on average (the seed: 16 mm max, 10 mean).
  EXPECT_EQ(score.position_errors_mm.size(), view.balls.size()) << c.name;
  double sum = 0, worst = 0;
  for (double e : score.position_errors_mm) {
    sum += e;
    worst = std::max(worst, e);
  }
  std::string detail;
  for (const auto& m : score.matches)
    detail += " " + std::to_string(m.truth_number) + ":" + std::to_string(m.error_mm) + "(" +
              std::to_string(m.dx_mm) + "," + std::to_string(m.dy_mm) + ")";
  EXPECT_LT(worst, 12.0) << c.name << detail;
  EXPECT_LT(sum / std::max<size_t>(1, score.position_errors_mm.size()), 5.0) << c.name;
  // Separated balls identified (one slip allowed per view: the 1 and the 9 seen with
  // the 9's stripe towards the camera are alike).
  EXPECT_GE(score.separated_identified, score.separated - 1) << c.name;
  EXPECT_GE(score.separated, 8) << c.name;
  EXPECT_EQ(score.false_balls, 0) << c.name;
}

// The rendered scene analysed: every ball within 12 mm, no false ball, the separated balls
// named (one slip allowed).
void ExpectSceneAnalysed(const PoolScene& scene, uint64_t render_seed) {
  const PoolView view = testdata::RenderPoolView(scene, render_seed);
  auto scored = AnalyzeAndScore(scene, view);
  ASSERT_TRUE(scored.ok()) << scored.status();
  ExpectEveryBallLocatedWithin(scored->score, view, 12.0);
  EXPECT_EQ(scored->score.false_balls, 0);
  EXPECT_GE(scored->score.separated_identified, scored->score.separated - 1);
}

// Live video from a handheld phone is smeared by its shake. A smear of 4 px along and
// across the table: the spread layout's balls are all still found, each within 12 mm, with
// no false ball, and named (the benchmark with --motion-blur 6: mean error 2.64 -> 3.05 mm
// on seed 7).
TEST(PoolShake, HandheldShakeKeepsEveryBallFoundAndNamed) {
  for (double angle : {0.0, 90.0}) {
    SCOPED_TRACE("smear at " + std::to_string(angle) + " degrees");
    PoolScene scene = Scene(PoolViewSide::kLongNear, 45, 8);
    scene.motion_blur_px = 4;
    scene.motion_blur_angle_deg = angle;
    ExpectSceneAnalysed(scene, 77);
  }
}

// A phone sharpens its pictures (dark and light rings along every edge, the noise too),
// and a billiard lamp's shade is 150-250 mm in radius, not a bulb's 70 mm (softer shadows,
// wider and dimmer highlights). Both on an sRGB picture from a long and a short side: every
// ball within 12 mm, no false ball, the separated balls named (the benchmark on seeds 7-19,
// sRGB: --sharpen 1 15 balls over 10 mm of 2,352 against 19, --lamp-radius 200 25).
TEST(PoolPhone, SharpenedPictureUnderABilliardLampKeepsEveryBallFoundAndNamed) {
  const ViewCase cases[] = {{PoolViewSide::kLongNear, 40, "long near"},
                            {PoolViewSide::kShortLeft, 50, "short left"}};
  for (const ViewCase& c : cases) {
    SCOPED_TRACE(c.name);
    PoolScene scene = Scene(c.side, c.elevation, 8);
    scene.srgb_tone = true;
    scene.sharpen_amount = 1.2;
    scene.lamp_radius_mm = 200;
    ExpectSceneAnalysed(scene, 2468);
  }
}

// The spread layout in frames of `size` (a horizontal field of view of `fov_deg`) from a
// long and a short side: the table within 2 px, every ball within 12 mm, no false ball,
// the separated balls named.
void ExpectFramesOfSizeAnalysed(cv::Size size, double fov_deg, uint64_t render_seed) {
  const ViewCase cases[] = {{PoolViewSide::kLongNear, 45, "long near"},
                            {PoolViewSide::kShortRight, 55, "short right"}};
  for (const ViewCase& c : cases) {
    SCOPED_TRACE(c.name);
    PoolScene scene = Scene(c.side, c.elevation, 8);
    scene.camera =
        testdata::FramedPoolCamera(scene.table, c.side, c.elevation, fov_deg, 8, 3, 0.04, size);
    scene.camera.k1 = -0.04;
    const PoolView view = testdata::RenderPoolView(scene, render_seed);
    auto scored = AnalyzeAndScore(scene, view);
    ASSERT_TRUE(scored.ok()) << scored.status();
    const testdata::PoolScore& score = scored->score;
    EXPECT_LT(score.max_corner_error_px, 2.0);
    ExpectEveryBallLocatedWithin(score, view, 12.0);
    EXPECT_GE(score.separated_identified, score.separated - 1);
    EXPECT_EQ(score.false_balls, 0);
  }
}

// Phone video is 16:9 (1280x720 here): the table fills a wider frame than the 4:3 views'.
TEST(PoolWideFrames, SixteenByNineVideoFramesAreAnalysed) {
  ExpectFramesOfSizeAnalysed({1280, 720}, 65, 4321);
}

// A phone held upright takes 480x640 pictures (50 degrees across): the table fills the
// frame's width and leaves floor above and below.
TEST(PoolWideFrames, UprightPhonePicturesAreAnalysed) {
  ExpectFramesOfSizeAnalysed({480, 640}, 50, 4322);
}

std::string ViewName(const ::testing::TestParamInfo<ViewCase>& info) {
  static const char* kNames[] = {"LongNear", "LongFar", "ShortLeft", "ShortRight"};
  return kNames[static_cast<int>(info.param.side)];
}

INSTANTIATE_TEST_SUITE_P(
    BothLongAndBothShortSides, PoolViewsTest,
    ::testing::Values(ViewCase{PoolViewSide::kLongNear, 50, "long near, 50 deg"},
                      ViewCase{PoolViewSide::kLongFar, 38, "long far, 38 deg"},
                      ViewCase{PoolViewSide::kShortLeft, 55, "short left, 55 deg"},
                      ViewCase{PoolViewSide::kShortRight, 45, "short right, 45 deg"}),
    ViewName);

TEST(PoolOrigin, OppositeShortSideKeepsTheOriginByTheBallArrangement) {
  // Seed 4.5: after an analysis from one end, a view from the other end must pick the
  // same origin, found by matching the balls.
  const PoolScene left = Scene(PoolViewSide::kShortLeft, 50);
  const PoolScene right = Scene(PoolViewSide::kShortRight, 50);
  const PoolView left_view = testdata::RenderPoolView(left, 77);
  const PoolView right_view = testdata::RenderPoolView(right, 78);
  const PoolTableProfile profile = ProfileFor(left.table);
  auto first = PoolAnalyzer::Create(profile, CameraOf(left_view), ForLinearRender());
  ASSERT_TRUE(first.ok());
  auto reference = first->Analyze(left_view.image);
  ASSERT_TRUE(reference.ok()) << reference.status();
  auto second = PoolAnalyzer::Create(profile, CameraOf(right_view), ForLinearRender());
  ASSERT_TRUE(second.ok());
  auto alone = second->Analyze(right_view.image);
  ASSERT_TRUE(alone.ok()) << alone.status();
  auto matched = second->Analyze(right_view.image, &reference->balls);
  ASSERT_TRUE(matched.ok()) << matched.status();
  EXPECT_TRUE(matched->origin_from_arrangement);
  // Alone, each end puts the origin at its own near corner: the frames differ by 180
  // degrees. With the reference, the balls land where the reference has them.
  const double cap = 1000;
  EXPECT_GT(ArrangementDistance(alone->balls, reference->balls, cap) / alone->balls.size(), 100);
  EXPECT_LT(ArrangementDistance(matched->balls, reference->balls, cap) / matched->balls.size(), 8);
  // The corners follow: corner i of the matched view is the same table corner as corner i
  // of the reference, i.e. of the truth in the left view's frame.
  for (int i = 0; i < 4; ++i)
    EXPECT_LT(cv::norm(matched->cloth_corners[i] - right_view.cloth_corners[i]), 2.0) << i;
}

// Analysing the rendered view fails with FAILED_PRECONDITION and a message containing
// `message`.
void ExpectAnalysisRefused(const PoolScene& scene, uint64_t seed, const std::string& message) {
  const PoolView view = testdata::RenderPoolView(scene, seed);
  auto analyzer = PoolAnalyzer::Create(ProfileFor(scene.table), CameraOf(view), ForLinearRender());
  ASSERT_TRUE(analyzer.ok());
  auto analysis = analyzer->Analyze(view.image);
  ASSERT_FALSE(analysis.ok());
  EXPECT_EQ(analysis.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_NE(analysis.status().message().find(message), std::string::npos) << analysis.status();
}

TEST(PoolErrors, NoTableInView) {
  PoolScene scene = Scene(PoolViewSide::kLongNear, 40);
  // Look at the floor beside the table.
  scene.camera.look_at_mm = {-2500, -1500, -760};
  ExpectAnalysisRefused(scene, 5, "no pool table in view");
}

// A blue or a red cloth with a profile left at the default green (the user did not set
// cloth_color): the table is found in the image's own dominant colour. On blue cloth the
// balls are located and numbered as on green (within the seed's 16 mm; the purple 4 on blue
// is the hardest, 12 mm in the short-side view); on a burgundy cloth every ball but the red
// 3 and the maroon 7, of the cloth's own hue, is.
TEST(PoolClothColour, ClothOfAnotherColourThanTheProfileIsFound) {
  struct Cloth {
    const char* name;
    cv::Vec3d rgb;
    std::vector<int> of_the_cloth_hue;
  };
  for (const Cloth& cloth :
       {Cloth{"tournament blue", {20, 95, 160}, {}}, Cloth{"burgundy", {125, 30, 40}, {3, 7}}})
    for (const PoolViewSide side : {PoolViewSide::kLongNear, PoolViewSide::kShortLeft}) {
      SCOPED_TRACE(std::string(cloth.name) +
                   (side == PoolViewSide::kLongNear ? ", long side" : ", short side"));
      PoolScene scene = Scene(side, 50, 8);
      scene.table.cloth_rgb = cloth.rgb;
      const PoolView view = testdata::RenderPoolView(scene, 1234);
      auto scored = AnalyzeAndScore(scene, view);
      ASSERT_TRUE(scored.ok()) << scored.status();
      const testdata::PoolScore& score = scored->score;
      EXPECT_LT(score.max_corner_error_px, 1.5);
      EXPECT_EQ(score.false_balls, 0);
      std::vector<int> located;
      double sum = 0, worst = 0;
      std::string detail;
      for (const auto& m : score.matches) {
        if (m.estimated_index < 0) continue;  // not found
        located.push_back(m.truth_number);
        sum += m.error_mm;
        worst = std::max(worst, m.error_mm);
        detail += " " + std::to_string(m.truth_number) + ":" + std::to_string(m.error_mm);
      }
      for (const auto& ball : view.balls) {
        const bool hidden_by_hue =
            std::count(cloth.of_the_cloth_hue.begin(), cloth.of_the_cloth_hue.end(), ball.number);
        if (!hidden_by_hue) {
          EXPECT_TRUE(std::count(located.begin(), located.end(), ball.number))
              << "ball " << ball.number << " not located";
        }
      }
      EXPECT_LT(worst, 16.0) << detail;
      EXPECT_LT(sum / std::max<size_t>(1, located.size()), 5.0) << detail;
      if (cloth.of_the_cloth_hue.empty()) {
        EXPECT_GE(score.separated_identified, score.separated - 1);
      }
    }
  // Told to look for the profile's colour only, it finds no table.
  PoolScene scene = Scene(PoolViewSide::kLongNear, 50, 8);
  scene.table.cloth_rgb = {20, 95, 160};
  const PoolView view = testdata::RenderPoolView(scene, 1234);
  PoolTableOptions only_profile;
  only_profile.other_cloth_colours = 0;
  only_profile.pixel_encoding = PixelEncoding::kLinear;  // the renderer's
  auto table =
      DetectPoolTable(view.image, view.camera_matrix, ProfileFor(scene.table), only_profile);
  ASSERT_FALSE(table.ok());
  EXPECT_EQ(table.status().code(), absl::StatusCode::kFailedPrecondition);
}

// A brown cloth merges with the renderer's beige floor, and the cloth-coloured region runs
// into the image's border: "only part of the table" then also says that the floor may have
// the cloth's colour, since the whole table is in view. (A cloth of nearly no colour is
// refused by the profile: PoolProfile.ValidateSaysWhatIsWrong.)
// A cloth beside a floor of nearly its colour: a purple (told to the profile) 18 degrees
// from grey beside the renderer's grey floor 21 degrees from it, and a burgundy 18 degrees
// from a wooden floor. The wide search for the cloth took the floor in, and the table was
// "only part of the table is in view" (the benchmark's seeds 7 and 11: purple 1 table in 120
// frames, burgundy on wood none). Now the wide search takes only the colours nearer to the
// cloth's than to grey and to the picture's other dominant colours
// (PoolTableOptions::nearest_colour_cloth_search): the table within 1.5 px, and every ball
// but those of the cloth's hue located within 16 mm, the separated ones named; over the
// whole cone, refused. Not told the cloth's colour, the table is found in the picture's own
// the same way.
TEST(PoolClothColour, ClothBesideAFloorOfNearlyItsColourIsFound) {
  struct Case {
    const char* name;
    cv::Vec3d cloth_rgb;
    std::optional<cv::Vec3d> floor_rgb;
    std::vector<int> of_the_cloth_hue;
  };
  const Case cases[] = {
      {"purple beside a grey floor", {90, 50, 120}, std::nullopt, {4}},
      {"burgundy on a wooden floor", {125, 30, 40}, cv::Vec3d(150, 95, 55), {3, 7}}};
  for (const Case& c : cases)
    for (const PoolViewSide side : {PoolViewSide::kLongNear, PoolViewSide::kShortLeft}) {
      SCOPED_TRACE(std::string(c.name) +
                   (side == PoolViewSide::kLongNear ? ", long side" : ", short side"));
      PoolScene scene = Scene(side, 45, 8);
      scene.srgb_tone = true;
      scene.table.cloth_rgb = c.cloth_rgb;
      if (c.floor_rgb) scene.floor_rgb = *c.floor_rgb;
      PoolTableProfile profile = ProfileFor(scene.table);
      profile.cloth_bgr = cv::Vec3b(cv::saturate_cast<uchar>(c.cloth_rgb[2]),
                                    cv::saturate_cast<uchar>(c.cloth_rgb[1]),
                                    cv::saturate_cast<uchar>(c.cloth_rgb[0]));
      const PoolView view = testdata::RenderPoolView(scene, 1357);
      auto scored = AnalyzeAndScore(scene, view, {}, &profile);
      ASSERT_TRUE(scored.ok()) << scored.status();
      const testdata::PoolScore& score = scored->score;
      EXPECT_LT(score.max_corner_error_px, 1.5);
      EXPECT_EQ(score.false_balls, 0);
      int separated = 0, named = 0;
      for (const auto& m : score.matches) {
        if (std::count(c.of_the_cloth_hue.begin(), c.of_the_cloth_hue.end(), m.truth_number))
          continue;
        EXPECT_GE(m.estimated_index, 0) << "ball " << m.truth_number << " not located";
        if (m.estimated_index >= 0) {
          EXPECT_LT(m.error_mm, 16.0) << "ball " << m.truth_number;
        }
        separated += m.separated;
        named += m.separated && m.estimated_number == m.truth_number;
      }
      EXPECT_GE(separated, 6);
      EXPECT_GE(named, separated - 1);
      PoolAnalyzerOptions whole_cone;
      whole_cone.table.nearest_colour_cloth_search = false;
      auto before = AnalyzeAndScore(scene, view, whole_cone, &profile);
      ASSERT_FALSE(before.ok());
      EXPECT_NE(before.status().message().find("only part of the table"), std::string::npos);
      // Not told (the profile's default green): found in the picture's own colour.
      auto untold = AnalyzeAndScore(scene, view);
      ASSERT_TRUE(untold.ok()) << untold.status();
      EXPECT_LT(untold->score.max_corner_error_px, 1.5);
    }
}

TEST(PoolErrors, ClothOfTheFloorsColourIsRefusedWithTheReason) {
  PoolScene scene = Scene(PoolViewSide::kLongNear, 40);
  scene.table.cloth_rgb = {90, 60, 40};
  const PoolView view = testdata::RenderPoolView(scene, 5);
  PoolTableProfile profile = ProfileFor(scene.table);
  profile.cloth_bgr = cv::Vec3b(40, 60, 90);
  auto analyzer = PoolAnalyzer::Create(profile, CameraOf(view), ForLinearRender());
  ASSERT_TRUE(analyzer.ok()) << analyzer.status();
  auto analysis = analyzer->Analyze(view.image);
  ASSERT_FALSE(analysis.ok());
  EXPECT_EQ(analysis.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_NE(analysis.status().message().find("only part of the table"), std::string::npos);
  EXPECT_NE(analysis.status().message().find("the floor or the walls around it"), std::string::npos)
      << analysis.status();
}

TEST(PoolErrors, OnlyPartOfTheTable) {
  PoolScene scene = Scene(PoolViewSide::kLongNear, 45);
  // Zoom in on one end: the far cushion and one side leave the frame.
  scene.camera.horizontal_fov_deg = 30;
  scene.camera.look_at_mm = {250, 350, 0};
  ExpectAnalysisRefused(scene, 6, "only part of the table");
}

// A user who leaves out the table's size gets the default 9-ft profile. The analysis of a
// 1330 x 700 mm table with it, or with a profile of a table 1.6 times as large (the same
// balls), goes on but says that the profile is not this table's; with the right profile it
// says nothing, and its two measures sit where PoolAnalyzerOptions documents them.
TEST(PoolProfileNote, AProfileOfAnotherTableIsNamedAndTheRightOneIsNot) {
  for (const PoolViewSide side : {PoolViewSide::kLongNear, PoolViewSide::kShortLeft}) {
    SCOPED_TRACE(side == PoolViewSide::kLongNear ? "long side" : "short side");
    const PoolScene scene = Scene(side, 45);
    const PoolView view = testdata::RenderPoolView(scene, 4242);
    const PoolTableProfile right = ProfileFor(scene.table);

    auto analyzer = PoolAnalyzer::Create(right, CameraOf(view), ForLinearRender());
    ASSERT_TRUE(analyzer.ok()) << analyzer.status();
    auto analysis = analyzer->Analyze(view.image);
    ASSERT_TRUE(analysis.ok()) << analysis.status();
    EXPECT_EQ(analysis->profile_note, "");
    EXPECT_GT(analysis->ball_size_ratio, 0.9);
    EXPECT_LT(analysis->ball_size_ratio, 1.3);
    EXPECT_LT(analysis->rectangle_inconsistency, 0.01);

    PoolTableProfile nine_foot;  // the default profile
    nine_foot.cloth_bgr = right.cloth_bgr;
    PoolTableProfile larger = right;
    larger.length_mm *= 1.6;
    larger.width_mm *= 1.6;
    for (const PoolTableProfile& wrong : {nine_foot, larger}) {
      SCOPED_TRACE(wrong.length_mm);
      auto wrong_analyzer = PoolAnalyzer::Create(wrong, CameraOf(view), ForLinearRender());
      ASSERT_TRUE(wrong_analyzer.ok()) << wrong_analyzer.status();
      auto wrong_analysis = wrong_analyzer->Analyze(view.image);
      ASSERT_TRUE(wrong_analysis.ok()) << wrong_analysis.status();
      EXPECT_NE(wrong_analysis->profile_note.find(
                    absl::StrFormat("%.0f x %.0f mm table", wrong.length_mm, wrong.width_mm)),
                std::string::npos)
          << wrong_analysis->profile_note;
      EXPECT_NE(wrong_analysis->profile_note.find("table.json"), std::string::npos);
    }
  }
}

// Balls 1.6 times as large as the profile's on a table of the profile's size: the
// ball-size ratio alone names it.
// Intrinsics whose focal length is 10% off (a guess from the field of view): the note
// names the focal length the table's corners say, within 3% of the camera's, and how far
// the intrinsics' is from it. 2% off (within what one frame's corners fix): no focal length
// named.
TEST(PoolProfileNote, AFocalLengthFarOffIsNamedWithTheCornersOne) {
  for (const PoolViewSide side : {PoolViewSide::kLongNear, PoolViewSide::kShortLeft}) {
    SCOPED_TRACE(side == PoolViewSide::kLongNear ? "long side" : "short side");
    const PoolScene scene = Scene(side, 45, 8);
    const PoolView view = testdata::RenderPoolView(scene, 4242);
    const double true_focal = view.camera_matrix(0, 0);
    for (const double scale : {1.1, 0.9, 1.02}) {
      SCOPED_TRACE(scale);
      CameraModel camera = CameraOf(view);
      camera.K(0, 0) *= scale;
      camera.K(1, 1) *= scale;
      auto analyzer = PoolAnalyzer::Create(ProfileFor(scene.table), camera, ForLinearRender());
      ASSERT_TRUE(analyzer.ok()) << analyzer.status();
      auto analysis = analyzer->Analyze(view.image);
      ASSERT_TRUE(analysis.ok()) << analysis.status();
      const std::string& note = analysis->profile_note;
      const size_t at = note.find("a focal length of about ");
      if (scale == 1.02) {
        EXPECT_EQ(at, std::string::npos) << note;
        continue;
      }
      ASSERT_NE(at, std::string::npos) << note;
      const double said = std::stod(note.substr(at + std::strlen("a focal length of about ")));
      EXPECT_NEAR(said / true_focal, 1.0, 0.03) << note;
      EXPECT_NE(note.find(scale > 1 ? "shorter than the intrinsics'"
                                    : "longer than the "
                                      "intrinsics'"),
                std::string::npos)
          << note;
    }
  }
}

TEST(PoolProfileNote, BallsLargerThanTheProfilesAreNamed) {
  PoolScene scene = Scene(PoolViewSide::kLongNear, 50);
  const PoolTableProfile profile = ProfileFor(scene.table);
  scene.table.ball_radius_mm *= 1.6;
  const PoolView view = testdata::RenderPoolView(scene, 4243);
  auto analyzer = PoolAnalyzer::Create(profile, CameraOf(view), ForLinearRender());
  ASSERT_TRUE(analyzer.ok()) << analyzer.status();
  auto analysis = analyzer->Analyze(view.image);
  ASSERT_TRUE(analysis.ok()) << analysis.status();
  EXPECT_GT(analysis->ball_size_ratio, 1.45);
  EXPECT_NE(analysis->profile_note.find("the balls look"), std::string::npos)
      << analysis->profile_note;
}

TEST(PoolProfileNote, OptionsOutOfRangeAreRefused) {
  PoolAnalyzerOptions options;
  options.max_ball_size_ratio = 0.9;
  EXPECT_EQ(options.Validate().code(), absl::StatusCode::kInvalidArgument);
  options = {};
  options.note_rectangle_inconsistency = 0;
  EXPECT_EQ(options.Validate().code(), absl::StatusCode::kInvalidArgument);
}

// A detected ball at table point (x, y), mm.
PoolDetectedBall BallAt(double x, double y) {
  PoolDetectedBall b;
  b.x_mm = x;
  b.y_mm = y;
  return b;
}

// Fits closer than two radii are moved apart along their line, each by half the overlap,
// until they touch; their pixels follow. Balls apart are left where they are.
TEST(PoolOverlap, OverlappingFitsAreMovedApartToTouch) {
  constexpr double kR = 24;
  // A camera 2 m above (665, 350) looking straight down.
  PlanarPose pose;
  pose.R = cv::Matx33d(1, 0, 0, 0, -1, 0, 0, 0, -1);
  pose.t = cv::Vec3d(-665, 350, 2000);
  const cv::Matx33d K(800, 0, 320, 0, 800, 240, 0, 0, 1);
  // A pair 40 mm apart along a diagonal, a ball far from both, and a chain of three.
  std::vector<PoolDetectedBall> balls = {
      BallAt(300, 300), BallAt(300 + 40 / std::sqrt(2.0), 300 + 40 / std::sqrt(2.0)),
      BallAt(900, 200), BallAt(600, 500),
      BallAt(640, 500), BallAt(680, 500)};
  SeparateOverlappingBalls(pose, K, kR, &balls);
  // The pair: 48 mm apart, about the same midpoint, along the same line.
  const cv::Point2d a(balls[0].x_mm, balls[0].y_mm), b(balls[1].x_mm, balls[1].y_mm);
  EXPECT_NEAR(cv::norm(b - a), 2 * kR, 1e-9);
  const cv::Point2d mid = 0.5 * (a + b);
  EXPECT_NEAR(mid.x, 300 + 20 / std::sqrt(2.0), 1e-9);
  EXPECT_NEAR(mid.y, 300 + 20 / std::sqrt(2.0), 1e-9);
  EXPECT_NEAR(b.x - a.x, b.y - a.y, 1e-9);
  // The far ball has not moved.
  EXPECT_EQ(balls[2].x_mm, 900);
  EXPECT_EQ(balls[2].y_mm, 200);
  // The chain: no two of its balls overlap by more than a hundredth of a millimetre after
  // the rounds, and it stays on its line.
  for (int i = 3; i < 6; ++i) {
    EXPECT_NEAR(balls[i].y_mm, 500, 1e-9);
    for (int j = i + 1; j < 6; ++j)
      EXPECT_GT(std::abs(balls[j].x_mm - balls[i].x_mm), 2 * kR - 0.011) << i << " " << j;
  }
  // Pixels follow the moved centres: 800 px per 1976 mm of depth at Z = r.
  for (size_t i = 0; i < balls.size(); ++i) {
    if (i == 2) continue;  // not moved, its pixels left as they were
    const PoolDetectedBall& m = balls[i];
    const cv::Point2d p = ProjectIdeal(pose, K, {m.x_mm, m.y_mm, kR});
    EXPECT_NEAR(m.ideal_pixel.x, p.x, 1e-9);
    EXPECT_NEAR(m.ideal_pixel.y, p.y, 1e-9);
    EXPECT_NEAR(m.ideal_pixel.x, 320 + 800 * (m.x_mm - 665) / (2000 - kR), 1e-6);
    EXPECT_NEAR(m.radius_px, 800 * kR / (2000 - kR), 0.5);
  }
}

// A pair seen one behind the other (within line_of_sight_pair_deg of the line of sight)
// is separated by moving the nearer ball alone; a pair across the line of sight by halves.
TEST(PoolOverlap, TheNearerOfAPairAlongTheLineOfSightIsMovedOut) {
  constexpr double kR = 24;
  // A camera beyond the table's long side (Y = -1200), 1.2 m high, looking at the centre.
  const cv::Matx33d K(600, 0, 320, 0, 600, 240, 0, 0, 1);
  testdata::PoolCamera camera;
  camera.position_mm = {665, -1200, 1200};
  camera.look_at_mm = {665, 350, 0};
  PlanarPose pose;
  pose.R = testdata::PoolCameraRotation(camera);
  pose.t = -(pose.R * camera.position_mm);
  // Along the line of sight (the far ball listed first and second), and across it.
  std::vector<PoolDetectedBall> balls = {BallAt(665, 400), BallAt(665, 360), BallAt(300, 300),
                                         BallAt(340, 300)};
  std::vector<PoolDetectedBall> far_second = {balls[1], balls[0]};
  SeparateOverlappingBalls(pose, K, kR, &balls, 45);
  SeparateOverlappingBalls(pose, K, kR, &far_second, 45);
  EXPECT_EQ(balls[0].y_mm, 400);  // the farther ball stays
  EXPECT_NEAR(balls[1].y_mm, 400 - 2 * kR, 1e-9);
  EXPECT_NEAR(balls[1].x_mm, 665, 1e-9);
  EXPECT_NEAR(far_second[0].y_mm, 400 - 2 * kR, 1e-9);
  EXPECT_EQ(far_second[1].y_mm, 400);
  EXPECT_NEAR(balls[2].x_mm, 296, 1e-9);  // across: 4 mm each
  EXPECT_NEAR(balls[3].x_mm, 344, 1e-9);
  // Its pixels follow the moved centre.
  const cv::Point2d p = ProjectIdeal(pose, K, {balls[1].x_mm, balls[1].y_mm, kR});
  EXPECT_NEAR(balls[1].ideal_pixel.y, p.y, 1e-9);
  // At 0 the pair along the line of sight is separated by halves too.
  std::vector<PoolDetectedBall> halves = {BallAt(665, 400), BallAt(665, 360)};
  SeparateOverlappingBalls(pose, K, kR, &halves, 0);
  EXPECT_NEAR(halves[0].y_mm, 404, 1e-9);
  EXPECT_NEAR(halves[1].y_mm, 356, 1e-9);
}

TEST(PoolBackground, BallsAreReplacedByTheCloth) {
  const PoolScene scene = Scene(PoolViewSide::kLongNear, 50);
  const PoolView view = testdata::RenderPoolView(scene, 9);
  auto analyzer = PoolAnalyzer::Create(ProfileFor(scene.table), CameraOf(view), ForLinearRender());
  ASSERT_TRUE(analyzer.ok());
  auto analysis = analyzer->Analyze(view.image);
  ASSERT_TRUE(analysis.ok()) << analysis.status();
  const cv::Mat empty = analyzer->EmptyTable();
  ASSERT_EQ(empty.size(), view.image.size());
  const cv::Vec3f cloth(analysis->cloth_bgr[0], analysis->cloth_bgr[1], analysis->cloth_bgr[2]);
  for (const auto& truth : view.balls) {
    // The ball's centre pixel (the image has distortion; the background is ideal, so
    // project again without it).
    const cv::Point2d p = ProjectIdeal(analysis->pose, view.camera_matrix,
                                       {truth.x_mm, truth.y_mm, scene.table.ball_radius_mm});
    const cv::Vec3b& before =
        view.image.at<cv::Vec3b>(cvRound(truth.pixel.y), cvRound(truth.pixel.x));
    const cv::Vec3b& after = empty.at<cv::Vec3b>(cvRound(p.y), cvRound(p.x));
    EXPECT_LT(ColorAngleDeg(cv::Vec3f(after[0], after[1], after[2]), cloth), 6)
        << "ball " << truth.number;
    if (truth.number == 6) continue;  // the green 6 is close to the cloth to begin with
    EXPECT_GT(ColorAngleDeg(cv::Vec3f(before[0], before[1], before[2]), cloth) +
                  std::abs(before[0] + before[1] + before[2] - cloth[0] - cloth[1] - cloth[2]) / 10,
              6)
        << "ball " << truth.number;
  }
}

TEST(PoolNumbers, Equation43SeparatesCueOneAndNine) {
  PoolBallOptions o;
  PoolVotes cue{}, one{}, nine{}, three{};
  cue[0] = 90, cue[1] = 5, cue[8] = 5;
  one[0] = 8, one[1] = 85, one[8] = 7;
  nine[0] = 45, nine[1] = 50, nine[8] = 5;
  three[3] = 80, three[0] = 10, three[8] = 10;
  auto best = [](const std::array<double, 10>& s) {
    return static_cast<int>(std::max_element(s.begin(), s.end()) - s.begin());
  };
  EXPECT_EQ(best(PoolNumberScores(cue, o)), 0);
  EXPECT_EQ(best(PoolNumberScores(one, o)), 1);
  EXPECT_EQ(best(PoolNumberScores(nine, o)), 9);
  EXPECT_EQ(best(PoolNumberScores(three, o)), 3);
}

// A 9 lying with its stripe towards the camera shows about as much white as a 1 with its
// number circle towards it (white shares 0.25-0.4 both), but at its outline: its two white
// caps. The votes are benchmark seed 37's frame 42, where the two were swapped (9: 26
// white, 55 yellow, its white 0.12 radii farther out than its yellow; 1: 24 and 42, 0.11
// radii farther in), and seed 41's frame 54, a 1 alone.
TEST(PoolNumbers, NineShowingItsStripeIsToldFromTheOneByWhereItsWhiteLies) {
  PoolBallOptions o;
  const PoolVotes nine{26, 55, 0, 0, 4, 0, 0, 0, 0};
  const PoolVotes one{24, 42, 0, 0, 1, 0, 0, 0, 0};
  const std::vector<int> numbers =
      AssignPoolNumbers({PoolNumberScores(nine, o, 0.124), PoolNumberScores(one, o, -0.106)});
  EXPECT_EQ(numbers, (std::vector<int>{9, 1}));
  // Without the position of the white the two are swapped, as they were.
  const std::vector<int> blind =
      AssignPoolNumbers({PoolNumberScores(nine, o), PoolNumberScores(one, o)});
  EXPECT_EQ(blind, (std::vector<int>{1, 9}));
  auto best = [&](const PoolVotes& v, double outward) {
    const std::array<double, 10> s = PoolNumberScores(v, o, outward);
    return static_cast<int>(std::max_element(s.begin(), s.end()) - s.begin());
  };
  EXPECT_EQ(best({13, 44, 0, 0, 0, 0, 0, 0, 0}, 0.10), 1) << "a 1 alone, its white a little out";
  EXPECT_EQ(best({13, 44, 0, 0, 0, 0, 0, 0, 0}, 0.30), 9) << "white caps at the outline";
  o.white_outward_weight = -0.1;
  EXPECT_FALSE(o.Validate().ok());
  o = PoolBallOptions();
  o.white_outward_of_one = 2;
  EXPECT_FALSE(o.Validate().ok());
}

// The orange 5 fades to yellow where blur, JPEG and the cloth mix into it, but nothing
// turns the yellow 1 orange. The votes are benchmark balls (seed 7): frame 0's small 5
// (24 orange against 32 yellow, once read as the 1) and the most orange 1 and 9 of the
// set; a 5 with few pixels left orange is still the 5.
TEST(PoolNumbers, FadedOrangeFiveIsNotTheYellowOne) {
  PoolBallOptions o;
  auto best = [&](const PoolVotes& v) {
    const std::array<double, 10> s = PoolNumberScores(v, o);
    return static_cast<int>(std::max_element(s.begin(), s.end()) - s.begin());
  };
  EXPECT_EQ(best({10, 32, 0, 0, 0, 24, 0, 0, 0}), 5);
  EXPECT_EQ(best({8, 22, 0, 0, 0, 16, 0, 0, 0}), 5);
  EXPECT_EQ(best({10, 80, 0, 0, 0, 3, 0, 0, 0}), 1);
  EXPECT_EQ(best({15, 58, 0, 0, 0, 2, 0, 0, 0}), 1);
  EXPECT_EQ(best({40, 41, 0, 0, 0, 1, 0, 0, 0}), 9);
  EXPECT_EQ(best({90, 3, 0, 0, 0, 0, 0, 0, 4}), 0);
  o.five_orange_share = 0.6;
  EXPECT_FALSE(o.Validate().ok());
}

TEST(PoolNumbers, AssignmentUsesEachNumberOnce) {
  // Two yellow balls: the one with more white is the 9, even though both prefer 1.
  std::array<double, 10> a{}, b{};
  a[1] = 0.9, a[9] = 0.5;
  b[1] = 0.8, b[9] = 0.7;
  const std::vector<int> numbers = AssignPoolNumbers({a, b});
  EXPECT_EQ(numbers[0], 1);
  EXPECT_EQ(numbers[1], 9);
  // Nothing plausible: unknown.
  std::array<double, 10> none{};
  EXPECT_EQ(AssignPoolNumbers({none})[0], -1);
}

// Benchmark seed 17, frame 6: a 5 washed out by the light (4 orange votes of 47, its
// yellow read as the 1/9 group's) beside a clear 9 and a clear 1. With the 1 and the 9
// taken, its own number is all that is left to it, and it scores under the old 0.15.
TEST(PoolNumbers, WashedOutFiveKeepsItsNumberWhenTheOneAndNineAreTaken) {
  const PoolBallOptions o;
  const PoolVotes nine{27, 35, 0, 0, 0, 0, 0, 0, 0};
  const PoolVotes five{18, 22, 0, 0, 2, 4, 0, 1, 0};
  const PoolVotes one{10, 31, 0, 0, 0, 0, 0, 0, 0};
  const std::vector<std::array<double, 10>> scores{PoolNumberScores(nine, o, 0.03),
                                                   PoolNumberScores(five, o, -0.15),
                                                   PoolNumberScores(one, o, 0.04)};
  EXPECT_EQ(AssignPoolNumbers(scores, o.unnamed_score), (std::vector<int>{9, 5, 1}));
  EXPECT_EQ(AssignPoolNumbers(scores, 0.15), (std::vector<int>{9, -1, 1}))
      << "the old threshold left it unnamed";
  PoolBallOptions bad;
  bad.unnamed_score = 1.0;
  EXPECT_FALSE(bad.Validate().ok());
  PoolBallOptions no_weight;
  no_weight.moved_number_weight = 0;
  EXPECT_FALSE(no_weight.Validate().ok());
}

TEST(PoolNumbers, NineShowingMostlyWhiteDoesNotTakeTheCueNumber) {
  // A 9 lying with a white cap towards the camera is mostly white, but never as white as
  // the cue: the cue's score keeps growing up to all white, so the two do not tie.
  PoolBallOptions o;
  PoolVotes cue{}, nine{};
  cue[0] = 97, cue[1] = 2, cue[8] = 1;
  nine[0] = 85, nine[1] = 12, nine[8] = 3;
  for (bool cue_first : {true, false}) {
    const std::vector<std::array<double, 10>> scores =
        cue_first ? std::vector<std::array<double, 10>>{PoolNumberScores(cue, o),
                                                        PoolNumberScores(nine, o)}
                  : std::vector<std::array<double, 10>>{PoolNumberScores(nine, o),
                                                        PoolNumberScores(cue, o)};
    const std::vector<int> numbers = AssignPoolNumbers(scores);
    EXPECT_EQ(numbers[cue_first ? 0 : 1], 0);
    EXPECT_EQ(numbers[cue_first ? 1 : 0], 9);
  }
}

// Benchmark frame 13 (seed 7) before its false ball was dropped: the cue, the 9 showing
// mostly white caps and a yellow 1 whose lower half a false ball had taken, so that its
// highlight made it look a third white. Each number is used once and the cue's is taken:
// the whiter of the two yellow balls is the 9, not left unnamed while the 1 takes the 9.
TEST(PoolNumbers, WhiterOfTwoYellowBallsStaysTheNineWhenTheCueIsTaken) {
  PoolBallOptions o;
  const PoolVotes cue{73, 1, 0, 0, 1, 0, 0, 0, 3};
  const PoolVotes nine{46, 15, 0, 0, 2, 0, 0, 0, 0};
  const PoolVotes one{21, 34, 0, 0, 3, 0, 0, 0, 0};
  const std::vector<int> numbers = AssignPoolNumbers(
      {PoolNumberScores(cue, o), PoolNumberScores(nine, o), PoolNumberScores(one, o)});
  EXPECT_EQ(numbers, (std::vector<int>{0, 9, 1}));
}

TEST(PoolNumbers, TwoRedBallsAreBothNumbered) {
  // Both red balls lean to the 7 (a small 3 loses saturation to the cloth at its edge):
  // the more saturated one is the 3, and neither is left unknown.
  PoolBallOptions o;
  PoolVotes brighter{}, darker{};
  brighter[3] = 0.12 * 44, brighter[7] = 0.88 * 44, brighter[8] = 3;
  darker[3] = 0.05 * 80, darker[7] = 0.95 * 80, darker[8] = 9;
  const std::vector<int> numbers =
      AssignPoolNumbers({PoolNumberScores(darker, o), PoolNumberScores(brighter, o)});
  EXPECT_EQ(numbers[0], 7);
  EXPECT_EQ(numbers[1], 3);
}

TEST(PoolNumbers, RedThreeAndMaroonSevenByBothSaturationAndBrightness) {
  // Saturation and brightness over the cloth as the benchmark measured them on small,
  // blurred balls (the profile's colours: 1.86 / 1.34 saturation, 1.07 / 0.74
  // brightness): clear cases follow both cues; when saturation sits near the middle,
  // brightness decides; a ball far from the lamps (or under one) never overrules a clear
  // saturation.
  const PoolTableProfile profile = BenchPoolProfile();
  constexpr PixelEncoding kLinear = PixelEncoding::kLinear;           // as read on a linear render
  EXPECT_GT(PoolRedShareOfThree(1.90, 1.07, profile, kLinear), 0.9);  // a clear 3
  EXPECT_LT(PoolRedShareOfThree(1.30, 0.80, profile, kLinear), 0.1);  // a clear 7
  EXPECT_GT(PoolRedShareOfThree(1.54, 1.26, profile, kLinear), 0.5);  // a 3 that lost saturation
  EXPECT_GT(PoolRedShareOfThree(1.58, 1.16, profile, kLinear), 0.5);  // ... and another
  EXPECT_LT(PoolRedShareOfThree(1.64, 0.75, profile, kLinear), 0.5);  // a 7 as saturated as a 3
  EXPECT_GT(PoolRedShareOfThree(1.96, 0.60, profile, kLinear), 0.5);  // a clear 3 in the shade
  EXPECT_LT(PoolRedShareOfThree(1.30, 2.00, profile, kLinear), 0.5);  // a clear 7 under a lamp
  // Without a brightness, saturation alone decides.
  EXPECT_GT(PoolRedShareOfThree(1.90, 0, profile, kLinear), 0.8);
  EXPECT_LT(PoolRedShareOfThree(1.35, 0, profile, kLinear), 0.2);
}

// In a phone's sRGB picture the 3's and the 7's brightness over the cloth, and their
// saturation, are the encoding's as much as the balls': the shading is lifted, and both
// read brighter than the profile's colours. The red cues are read in light, the profile's
// colours decoded alike. Seeds 11 and 13 rendered sRGB: a separated 3, 7 and 3 read as
// the other before.
TEST(PoolNumbers, RedThreeAndMaroonSevenOfAnSrgbPictureAreReadInLight) {
  const std::tuple<uint64_t, int, int> cases[] = {{11, 41, 3}, {13, 46, 7}, {13, 36, 3}};
  for (const auto& [seed, frame, number] : cases) {
    SCOPED_TRACE("seed " + std::to_string(seed) + " frame " + std::to_string(frame));
    const auto [scene, view] = SrgbBenchFrame(frame, seed);
    auto scored = AnalyzeAndScore(scene, view);
    ASSERT_TRUE(scored.ok()) << scored.status();
    ExpectSeparatedBallNamed(scored->score, number, 10.0);
  }
  // The calibrated colours' cues in light: the 3's saturation and brightness clear of the
  // 7's.
  const PoolTableProfile profile = BenchPoolProfile();
  EXPECT_GT(PoolRedShareOfThree(3.0, 2.1, profile, PixelEncoding::kSrgb), 0.9);
  EXPECT_LT(PoolRedShareOfThree(2.3, 0.65, profile, PixelEncoding::kSrgb), 0.1);
}

// A small red 3 in an sRGB picture: JPEG's colour smear takes its saturation down to the
// maroon 7's, and it was read as the 7 (seed 11's frame 1: saturation 2.26, brightness over
// the cloth 2.03, in light) or swapped with the 7 beside it (seed 11's frame 43: the 3 2.04
// and 3.02, the 7 2.34 and 0.61). Its brightness stays clear of the 7's: in an sRGB picture
// brightness decides and saturation tips (RedCues).
TEST(PoolNumbers, SmallRedThreeOfAnSrgbPictureIsToldByItsBrightness) {
  const PoolTableProfile profile = BenchPoolProfile();
  constexpr PixelEncoding kSrgb = PixelEncoding::kSrgb;
  EXPECT_GT(PoolRedShareOfThree(2.26, 2.03, profile, kSrgb), 0.5);
  EXPECT_LT(PoolRedShareOfThree(2.34, 0.61, profile, kSrgb), 0.5);
  EXPECT_GT(PoolRedPairShareOfThree(2.04, 3.02, 2.34, 0.61, profile, kSrgb), 0.5);
  // Saturation still tips a ball whose brightness lies near the middle.
  EXPECT_GT(PoolRedShareOfThree(3.0, 1.2, profile, kSrgb), 0.5);
  EXPECT_LT(PoolRedShareOfThree(2.0, 1.2, profile, kSrgb), 0.5);
  // Named, and placed within 10 mm (frame 43's 3 within 10.5: 10.3 mm since the cloth's
  // colour is measured without the greys, round 63).
  const std::tuple<uint64_t, int, int, double> cases[] = {
      {11, 1, 3, 10.0}, {11, 43, 3, 10.5}, {11, 43, 7, 10.0}};
  for (const auto& [seed, frame, number, max_error_mm] : cases) {
    SCOPED_TRACE("seed " + std::to_string(seed) + " frame " + std::to_string(frame));
    const auto [scene, view] = SrgbBenchFrame(frame, seed);
    auto scored = AnalyzeAndScore(scene, view);
    ASSERT_TRUE(scored.ok()) << scored.status();
    ExpectSeparatedBallNamed(scored->score, number, max_error_mm);
  }
}

// The orange 5 of a few pixels in an sRGB picture, lit: its pale pixels (its colour mixed
// with the highlight's and the number disc's white) were nearer the maroon 7's colour,
// which is less saturated, than the 5's own, and it was read as a red ball (seed 83's
// frame 10: 27 votes for the 7, none for the 5, read as the 7; seed 17's frame 6: 19 red
// votes against 4, and as bright as a 3, read as the 3). Taken as the segment from grey to
// each colour (PoolBallOptions::vote_min_colour_share), they vote for the 5.
TEST(PoolNumbers, PaleOrangeFiveOfAnSrgbPictureIsNotARedBall) {
  PoolAnalyzerOptions by_point;
  by_point.balls.vote_min_colour_share = 1;
  ExpectSrgbBallNamedAndReadAsWithout({{83, 10}}, 5, 10.0, by_point, 7);
  ExpectSrgbBallNamedAndReadAsWithout({{17, 6}}, 5, 10.0, by_point, 3);
  PoolBallOptions options;
  options.vote_min_colour_share = 1.5;
  EXPECT_FALSE(options.Validate().ok());
  options.vote_min_colour_share = -0.5;
  EXPECT_FALSE(options.Validate().ok());
}

// The balls the benchmark found hardest, under JPEG: the black 8 (dark against its own
// shadow), the green 6 on green cloth, the red 3 and maroon 7 (told by saturation) and the
// 9 against the 1 and the cue; near and far, from a long and a short side.
TEST(PoolHardBalls, DarkGreenRedAndStripedBallsAreFoundAndNumbered) {
  const std::vector<testdata::PoolBallPlacement> layout = {
      {0, 250, 200},  {1, 420, 520}, {3, 640, 250},  {6, 860, 480},
      {7, 1080, 230}, {8, 330, 420}, {9, 1000, 560}, {2, 1200, 400}};
  int view_index = 0;
  for (const auto& [side, elevation] : std::vector<std::pair<PoolViewSide, double>>{
           {PoolViewSide::kLongNear, 36}, {PoolViewSide::kShortRight, 42}}) {
    PoolScene scene;
    scene.balls = layout;
    scene.camera = testdata::FramedPoolCamera(scene.table, side, elevation, 62, 6, -2);
    scene.camera.k1 = -0.05;
    scene.blur_sigma = 0.7;
    scene.noise_sigma = 3;
    scene.jpeg_quality = 75;
    scene.lamps = 2;
    const PoolView view = testdata::RenderPoolView(scene, 4321 + view_index++);
    auto scored = AnalyzeAndScore(scene, view);
    ASSERT_TRUE(scored.ok()) << scored.status();
    const testdata::PoolScore& score = scored->score;
    EXPECT_EQ(score.false_balls, 0) << view_index;
    double sum = 0;
    for (const auto& m : score.matches) {
      EXPECT_GE(m.error_mm, 0) << "ball " << m.truth_number << " not found, view " << view_index;
      EXPECT_EQ(m.estimated_number, m.truth_number) << "view " << view_index;
      // One pixel is 2-6 mm on this table at 640x480: 10 mm is two pixels at worst.
      EXPECT_LT(m.error_mm, 10.0) << "ball " << m.truth_number << ", view " << view_index;
      sum += std::max(0.0, m.error_mm);
    }
    EXPECT_LT(sum / score.matches.size(), 5.0) << view_index;
  }
}

// Three benchmark frames (seed 7) where a dark ball's own inner edge used to be taken for
// its outline: the black 8 of frame 28 (its highlight) and the green 6 of frame 48 (its
// lit cap above a dark lower half that runs into its shadow) were placed 18 and 22 mm
// towards the camera. Fitted to the outermost step from the cloth, both are within 10 mm
// (one pixel is 4.4-5.5 mm along the line of sight there). The near green 6 of frame 7
// was still 14 mm towards the camera: its lit cap is so near the cloth that the top rim
// was met inside the cap at the whole ball's level; at each point's own level it is not.
TEST(PoolHardBalls, DarkBallsAreFittedOnTheirRimNotTheirHighlight) {
  const testdata::PoolTableSpec spec = testdata::PoolTableSpec::Bench();
  std::mt19937_64 rng(7);
  for (int frame = 0; frame <= 48; ++frame) {
    const PoolScene scene = testdata::RandomPoolScene(rng, spec);
    const int dark_ball = frame == 28 ? 8 : (frame == 48 || frame == 7) ? 6 : -1;
    if (dark_ball < 0) continue;
    const PoolView view = testdata::RenderPoolView(scene, 7 * 100003 + frame);
    auto scored = AnalyzeAndScore(scene, view);
    ASSERT_TRUE(scored.ok()) << scored.status();
    const testdata::PoolScore& score = scored->score;
    bool seen = false;
    for (const auto& m : score.matches) {
      if (m.truth_number != dark_ball) continue;
      seen = true;
      EXPECT_GE(m.error_mm, 0) << "frame " << frame;
      EXPECT_LT(m.error_mm, 10.0) << "frame " << frame;
      EXPECT_EQ(m.estimated_number, dark_ball) << "frame " << frame;
    }
    EXPECT_TRUE(seen) << "frame " << frame << " has no ball " << dark_ball;
  }
}

// A ball darker than the cloth has its own shadow, as dark as itself, joined to the near
// side of its outline; a camera looking steeply down sees it beside the whole lower half.
// Benchmark frames (seed 11, --seed 11): frame 0's separated 8 (camera 2 m above the
// table) was moved 3.5 px down into its shadow by the edge pass, and the rim fit, held by
// the shadow's edge below and unable to reach the far rim 5 px above its outline, brought
// it back 1 px: 17.3 mm off. Frame 18's separated 8: 13.9 mm. Fitted on the far side of
// the outline only, with the scan going on outwards to the cloth there, both are within
// 10 mm.
// Ball `number` of the benchmark's frame `frame` (seed `seed`; the 9-ft set when
// `nine_foot`) is separated, located within `max_error_mm` and numbered; returns the
// frame's false balls.
int ExpectSeparatedBallFound(int number, int frame, uint64_t seed, double max_error_mm,
                             bool nine_foot = false) {
  SCOPED_TRACE("frame " + std::to_string(frame));
  const auto [scene, view] = RenderBenchFrame(frame, seed, 1, nine_foot);
  auto scored = AnalyzeAndScore(scene, view);
  EXPECT_TRUE(scored.ok()) << scored.status();
  if (!scored.ok()) return -1;
  ExpectSeparatedBallNamed(scored->score, number, max_error_mm);
  return scored->score.false_balls;
}

// A shadow fitted as a ball of its own and moved out of the ball that casts it, to touch
// it, holds purer dark votes than the real 8, whose number circle and highlight vote white:
// on benchmark seed 19's frame 34 the shadow under the 9 took the 8 and the separated 8 was
// left unnamed. A ball placed by the overlap rule yields its number to one fitted on its
// own pixels (PoolBallOptions::moved_number_weight).
TEST(PoolHardBalls, ShadowMovedOutOfItsBallYieldsTheEightToTheRealOne) {
  ExpectSeparatedBallFound(8, 34, 19, 5.0);
}

// A player aiming holds a cue stick over the cloth: a long strip of non-cloth thinner than
// a ball, with its shadow beside it. Without PoolBallOptions::stick_opening_radius it
// broke into a row of false balls; with it the stick gives none, and the balls around it
// are found and numbered as before.
TEST(PoolCueStick, StickOverTheClothGivesNoFalseBalls) {
  for (uint64_t seed : {1, 2, 3}) {
    PoolScene scene = Scene(PoolViewSide::kLongNear, 50, 10);
    std::mt19937_64 rng(seed);
    scene.cue_stick = testdata::AimedCueStick(rng, scene.table, scene.balls);
    const PoolView view = testdata::RenderPoolView(scene, 40 + seed);
    auto scored = AnalyzeAndScore(scene, view);
    ASSERT_TRUE(scored.ok()) << scored.status();
    const testdata::PoolScore& score = scored->score;
    EXPECT_EQ(score.false_balls, 0) << "seed " << seed;
    EXPECT_EQ(score.separated_identified, score.separated) << "seed " << seed;
    for (const auto& m : score.matches) {
      if (!m.separated) continue;
      EXPECT_GE(m.error_mm, 0) << "seed " << seed << ": the " << m.truth_number << " not found";
      EXPECT_LT(m.error_mm, 10.0) << "seed " << seed << ", ball " << m.truth_number;
    }
    PoolAnalyzerOptions blind;
    blind.balls.stick_opening_radius = 0;  // nothing is a stick
    auto unaware = AnalyzeAndScore(scene, view, blind);
    ASSERT_TRUE(unaware.ok()) << unaware.status();
    EXPECT_GT(unaware->score.false_balls, 0) << "seed " << seed << ": the stick was no trouble";
  }
  PoolBallOptions bad;
  bad.stick_opening_radius = 1.2;
  EXPECT_FALSE(bad.Validate().ok());
  bad = PoolBallOptions();
  bad.min_stick_elongation = 0.5;
  EXPECT_FALSE(bad.Validate().ok());
}

// With no stick in the picture, what the opening leaves of a dark ball's lower half joined
// to its neighbour's shadow is a strip as long and thin as a short stick's, but bent:
// benchmark seed 47's frame 2, whose separated green 6 beside the 2 was taken out as a
// stick and not found at all. A short strip must be straight to be a stick.
TEST(PoolCueStick, BentStripOfABallAndAShadowIsNotAStick) {
  const auto [scene, view] = RenderBenchFrame(2, 47);
  auto scored = AnalyzeAndScore(scene, view);
  ASSERT_TRUE(scored.ok()) << scored.status();
  const testdata::PoolScore& score = scored->score;
  ExpectSeparatedBallNamed(score, 6, 12.0);
  EXPECT_EQ(score.separated_identified, score.separated);
  EXPECT_EQ(score.false_balls, 0);
}

// The stick points through the cue ball at the object ball, so the stick's line runs on
// to it. Followed without limit over the cloth, the line took the thin pixels of the
// object ball's outline, and a separated ball in the line of aim was lost (benchmark
// --cue-stick: seed 13's frame 5, its 8; seed 19's frame 10 and seed 31's frame 28, their
// 6). Followed only PoolBallOptions::stick_bridge_length past the stick's strips, each is
// found, within 10 mm, and named.
TEST(PoolCueStick, ObjectBallInTheLineOfAimIsFound) {
  const std::tuple<uint64_t, int, int> cases[] = {{13, 5, 8}, {19, 10, 6}, {31, 28, 6}};
  for (const auto& [seed, frame, number] : cases) {
    SCOPED_TRACE("seed " + std::to_string(seed) + " frame " + std::to_string(frame));
    const auto [scene, view] = RenderBenchFrame(frame, seed, 1, false, /*cue_stick=*/true);
    auto scored = AnalyzeAndScore(scene, view);
    ASSERT_TRUE(scored.ok()) << scored.status();
    ExpectSeparatedBallNamed(scored->score, number, 10.0);
    PoolAnalyzerOptions unlimited;
    unlimited.balls.stick_bridge_length = 1000;
    auto eaten = AnalyzeAndScore(scene, view, unlimited);
    ASSERT_TRUE(eaten.ok()) << eaten.status();
    bool seen = false;
    for (const auto& m : eaten->score.matches) {
      if (m.truth_number != number) continue;
      seen = true;
      EXPECT_TRUE(m.separated);
      EXPECT_LT(m.error_mm, 0) << "the " << number << " found with the line unlimited";
    }
    EXPECT_TRUE(seen);
  }
  PoolBallOptions bad;
  bad.stick_bridge_length = 0;
  EXPECT_FALSE(bad.Validate().ok());
}

TEST(PoolHardBalls, DarkBallsAreFittedOnTheirFarRimNotTheirShadow) {
  for (int frame : {0, 18}) ExpectSeparatedBallFound(8, frame, 11, 10.0);
}

// The rim fit of a dark ball can move it where its silhouette is half cloth, and the ball
// is then dropped as not a ball; the edge pass's fit is kept instead. Benchmark frames 6
// and 19 of the 9-ft set (--nine-foot, seed 7): a separated far green 6 was not found.
TEST(PoolHardBalls, RimFitThatLeavesHalfClothKeepsTheEdgeFit) {
  const testdata::PoolTableSpec spec = testdata::PoolTableSpec::NineFoot();
  PoolTableProfile profile = NineFootPoolProfile();
  profile.length_mm = spec.length_mm;
  profile.width_mm = spec.width_mm;
  profile.ball_radius_mm = spec.ball_radius_mm;
  profile.cushion_height_mm = spec.cushion_height_mm;
  profile.cushion_width_mm = spec.cushion_width_mm;
  std::mt19937_64 rng(7);
  for (int frame = 0; frame <= 19; ++frame) {
    const PoolScene scene = testdata::RandomPoolScene(rng, spec);
    if (frame != 6 && frame != 19) continue;
    const PoolView view = testdata::RenderPoolView(scene, 7 * 100003 + frame);
    auto analyzer = PoolAnalyzer::Create(profile, CameraOf(view), ForLinearRender());
    ASSERT_TRUE(analyzer.ok()) << analyzer.status();
    auto analysis = analyzer->Analyze(view.image);
    ASSERT_TRUE(analysis.ok()) << analysis.status();
    std::vector<testdata::EstimatedPoolBall> estimated;
    for (const auto& b : analysis->balls) estimated.push_back({b.number, b.x_mm, b.y_mm});
    const testdata::PoolScore score =
        testdata::ScorePoolAnalysis(scene, view, analysis->cloth_corners, estimated);
    bool seen = false;
    for (const auto& m : score.matches) {
      if (m.truth_number != 6) continue;
      seen = true;
      EXPECT_TRUE(m.separated) << "frame " << frame;
      EXPECT_GE(m.error_mm, 0) << "frame " << frame << ": the 6 not found";
      EXPECT_LT(m.error_mm, 10.0) << "frame " << frame;
      EXPECT_EQ(m.estimated_number, 6) << "frame " << frame;
    }
    EXPECT_TRUE(seen) << "frame " << frame << " has no 6";
  }
}

// A green 6 on green cloth: its lit cap is of nearly the cloth's colour, so the ball-ness
// map sees ball only in its dark lower half and the contact shadow under it. Benchmark
// seed 41's frame 50 (--seed 41): the edge pass moved the separated 6 5 px down into its
// shadow; the rim fit found it 0.8 px from the truth, with a silhouette 49% ball against
// the edge fit's 55%, and was refused for being under half ball. It is kept now that it
// loses no more than edge_max_ballness_drop and stays over min_fit_ballness, the
// measures the edge pass and the final check apply.
// Frame 43 of the same set: a 6 2.6 px down in its shadow, its rim fit 0.1 px from the
// truth but 0.46 ball against 0.68; by colour alone (the shadow is cloth) it loses less.
TEST(PoolHardBalls, GreenSixOnGreenClothIsFittedOnItsRimNotItsShadow) {
  EXPECT_EQ(ExpectSeparatedBallFound(6, 50, 41, 10.0), 0);
  ExpectSeparatedBallFound(6, 43, 41, 10.0);
}

// A green 6 before the far cushion: the cloth sampled around it takes in the cushion's
// shaded face seen beyond it, and against that the 6 was not "darker than the cloth", so
// it was not fitted on its far rim. Benchmark seed 17's frame 2 (12.3 mm off before) and
// seed 59's frame 21 (11.9 mm): each 6 within 10 mm (3.3 and 3.0 mm now), named, and no
// false ball.
TEST(PoolHardBalls, DarkBallBeforeTheFarCushionIsDarkerThanTheClothNotTheFace) {
  EXPECT_EQ(ExpectSeparatedBallFound(6, 2, 17, 10.0), 0);
  EXPECT_EQ(ExpectSeparatedBallFound(6, 21, 59, 10.0), 0);
}

// Two touching balls of different colours give a blob two seeds; the nearer ball, fitted
// first with nothing claimed, can slide onto the other, and the two seeds, then closer than
// seed_merge_distance, were merged. Benchmark seed 19's frame 2: the yellow 9 in front of
// the cue ball was lost, and the separated yellow 1 was named the 9. Seeds that started
// on clearly different colours are two balls: the one that moved goes back to its start
// and is fitted again with the other claimed.
TEST(PoolHardBalls, TouchingBallOfAnotherColourIsNotMergedIntoItsNeighbour) {
  const auto [scene, view] = RenderBenchFrame(2, 19);
  auto scored = AnalyzeAndScore(scene, view);
  ASSERT_TRUE(scored.ok()) << scored.status();
  bool seen = false;
  for (const auto& m : scored->score.matches) {
    if (m.truth_number != 9) continue;
    seen = true;
    EXPECT_GE(m.error_mm, 0) << "the 9 touching the cue ball not found";
    EXPECT_LT(m.error_mm, 10.0);
    EXPECT_EQ(m.estimated_number, 9);
  }
  EXPECT_TRUE(seen);
  ExpectSeparatedBallNamed(scored->score, 1, 5.0);
  EXPECT_EQ(scored->score.false_balls, 0);
}

// Separated balls that were not found, in benchmark frames (seed 7):
// - frame 49's far dark green 6 on green cloth (radius 4.7 px): its dark rim is far from
//   the cloth's chromaticity but was too dark for the chromaticity test, and its lit cap
//   looks like cloth; it broke into fragments too small for a ball. The chromaticity now
//   counts in darker pixels (with a threshold that grows with the noise) and the lit
//   cap, a hole enclosed by the rim, is ball.
// - frame 53's 7 in front of a side pocket: a third of its silhouette lies over the
//   pocket's mask, which was counted as cloth, and the ball was rejected as half cloth.
// - frame 46's 8 frozen on the far cushion: fitted beyond the cushion, half on the dark
//   rail, then rejected; a ball's centre is at least a radius inside the cushions.
TEST(PoolHardBalls, FarDarkGreenBallAndBallsByPocketOrCushionAreFound) {
  for (const auto& [frame, number] : std::vector<std::pair<int, int>>{{49, 6}, {53, 7}, {46, 8}}) {
    const auto [scene, view] = RenderBenchFrame(frame);
    auto scored = AnalyzeAndScore(scene, view);
    ASSERT_TRUE(scored.ok()) << scored.status();
    const testdata::PoolScore& score = scored->score;
    bool seen = false;
    for (const auto& m : score.matches) {
      if (m.truth_number != number) continue;
      seen = true;
      EXPECT_TRUE(m.separated) << "frame " << frame;
      EXPECT_GE(m.error_mm, 0) << "frame " << frame << ": ball " << number << " not found";
      EXPECT_LT(m.error_mm, 10.0) << "frame " << frame;
      EXPECT_EQ(m.estimated_number, number) << "frame " << frame;
    }
    EXPECT_TRUE(seen) << "frame " << frame << " has no ball " << number;
    EXPECT_EQ(score.separated_identified, score.separated) << "frame " << frame;
    EXPECT_EQ(score.false_balls, 0) << "frame " << frame;
  }
}

// Touching balls split into seeds of one blob: the fit of the nearer ball used to count
// the other ball's pixels against its own silhouette and slid to the pair's middle, where
// both seeds met and one was dropped. Benchmark frame 23 (seed 7): the purple 4 and the
// 9 touching beside it; the 4 was lost and the 9 found 17 mm off.
TEST(PoolTouchingBalls, EachBallOfABlobIsFittedOnItsOwnPixels) {
  const auto [scene, view] = RenderBenchFrame(23);
  auto scored = AnalyzeAndScore(scene, view);
  ASSERT_TRUE(scored.ok()) << scored.status();
  const testdata::PoolScore& score = scored->score;
  EXPECT_EQ(score.position_errors_mm.size(), view.balls.size());
  for (const auto& m : score.matches) {
    EXPECT_GE(m.error_mm, 0) << "ball " << m.truth_number << " not found";
    EXPECT_LT(m.error_mm, 10.0) << "ball " << m.truth_number;
  }
  EXPECT_EQ(score.separated_identified, score.separated);
}

// Benchmark frame `frame` of the rendered set `seed`: no false ball, every ball located
// within 10 mm, every separated ball identified.
void ExpectEveryBallWithin10Mm(const PoolScene& scene, const PoolView& view) {
  auto scored = AnalyzeAndScore(scene, view);
  ASSERT_TRUE(scored.ok()) << scored.status();
  const testdata::PoolScore& score = scored->score;
  EXPECT_EQ(score.false_balls, 0);
  ExpectEveryBallLocatedWithin(score, view, 10.0);
  EXPECT_EQ(score.separated_identified, score.separated);
}
void ExpectEveryBallWithin10Mm(int frame, uint64_t seed) {
  SCOPED_TRACE("seed " + std::to_string(seed) + " frame " + std::to_string(frame));
  const auto [scene, view] = RenderBenchFrame(frame, seed);
  ExpectEveryBallWithin10Mm(scene, view);
}

// A small ball's blob, with the blur's and JPEG's halo, has about 1.65 times a ball's area,
// and was tried as a pair seen one behind the other: in a phone's sRGB picture the ball's
// lower half is not dark, and its lit top and lower half were kept as two balls, the real
// one pushed 2-3 px along the picture. Seed 7's frames 15 and 32 rendered sRGB: a 5 and a
// 3 lost or 18-21 mm off and four false balls; now every ball within 10 mm
// (PoolBallOptions::split_hidden_min_unexplained).
TEST(PoolHardBalls, OneBallsHaloIsNotASecondBallBehindIt) {
  int false_without = 0;
  for (int frame : {15, 32}) {
    SCOPED_TRACE("frame " + std::to_string(frame));
    const auto [scene, view] = SrgbBenchFrame(frame);
    ExpectEveryBallWithin10Mm(scene, view);
    PoolAnalyzerOptions unchecked;
    unchecked.balls.split_hidden_min_unexplained = 0;  // off
    auto scored = AnalyzeAndScore(scene, view, unchecked);
    ASSERT_TRUE(scored.ok()) << scored.status();
    false_without += scored->score.false_balls;
  }
  EXPECT_GE(false_without, 3);
  PoolBallOptions bad;
  bad.split_hidden_min_unexplained = 1;
  EXPECT_FALSE(bad.Validate().ok());
}

// In a phone's sRGB picture a shade of a colour is another colour: the lit top of a far
// green 6 on green cloth came within the colour angle of the cloth, and the ball, broken
// up, was not found (seed 7's frame 35 rendered sRGB). The angle is now taken in light.
TEST(PoolDarkBalls, FarGreenSixInAnSrgbPictureIsFound) {
  const auto [scene, view] = SrgbBenchFrame(35);
  auto scored = AnalyzeAndScore(scene, view);
  ASSERT_TRUE(scored.ok()) << scored.status();
  ExpectSeparatedBallNamed(scored->score, 6, 10.0);
  EXPECT_EQ(scored->score.separated_identified, scored->score.separated);
  EXPECT_EQ(scored->score.false_balls, 0);
}

// A ball whose lit top and highlight are as bright as the cloth but whose near half is
// dark against its own shadow: taken for a ball not darker than the cloth, its edge pass
// slid it into that shadow. Judged also by its near half in light
// (PoolBallOptions::near_half_dark_share), it is fitted on its far rim: seed 23's frame
// 42 (a separated 6, 11.9 mm towards the camera before) and seed 7's frame 53 (a
// separated purple 4, 12.4 mm), rendered sRGB.
TEST(PoolDarkBalls, BallWithADarkNearHalfIsFittedAsDarkerThanTheCloth) {
  const std::tuple<uint64_t, int, int> cases[] = {{23, 42, 6}, {7, 53, 4}};
  for (const auto& [seed, frame, number] : cases) {
    SCOPED_TRACE("seed " + std::to_string(seed) + " frame " + std::to_string(frame));
    const auto [scene, view] = SrgbBenchFrame(frame, seed);
    auto scored = AnalyzeAndScore(scene, view);
    ASSERT_TRUE(scored.ok()) << scored.status();
    ExpectSeparatedBallNamed(scored->score, number, 8.0);
    // Without the cap of the edge pass's distance (edge_interior_level), which keeps these
    // two within 9 mm as well.
    PoolAnalyzerOptions by_body_only;
    by_body_only.balls.edge_interior_level = 1;
    by_body_only.balls.near_half_dark_share = 0;
    by_body_only.balls.cloth_hue_ball_dark_share = 0;  // round 62 mends seed 23's 6 as well
    auto slid = AnalyzeAndScore(scene, view, by_body_only);
    ASSERT_TRUE(slid.ok()) << slid.status();
    EXPECT_GT(ErrorOf(slid->score, number), 10.0);
  }
}

// An 8 with its white number disc facing up: by the median of all its pixels (98 against
// the cloth's 104, half of them the disc and the highlight) it was taken for a ball not
// darker than the cloth, and its edge pass slid it 2.5 px into its shadow, 20 mm towards
// the camera (seed 7's frame 26 rendered sRGB). Its body without the disc's white (median
// 29) is darker than the cloth.
TEST(PoolDarkBalls, EightWithItsNumberUpIsToldByItsBlackBody) {
  const auto [scene, view] = SrgbBenchFrame(26);
  auto scored = AnalyzeAndScore(scene, view);
  ASSERT_TRUE(scored.ok()) << scored.status();
  ExpectSeparatedBallNamed(scored->score, 8, 8.0);
}

// An 8 whose white number disc faces the camera, on green cloth in an sRGB picture: JPEG's
// colour smear gives its dark pixels the cloth's colour at a fifth to a third of its
// strength, and they voted for the green 6, which these views do not hold (seed 13's
// frame 12 and seed 43's frame 16: 4 and 5 votes for the 6 against 4 and 8 for the 8).
// Told by how little colour they carry (PoolBallOptions::dark_reflection_chroma_srgb), it
// is named the 8.
TEST(PoolDarkBalls, EightTintedByTheClothIsNotTheSix) {
  // Without the black votes' rule (max_black_share_srgb), which names these 8s as well.
  PoolAnalyzerOptions votes_alone;
  votes_alone.balls.max_black_share_srgb = 0;
  PoolAnalyzerOptions by_hue = votes_alone;
  by_hue.balls.dark_reflection_chroma_srgb = 0;
  // On its rim alone, as the 8 was placed when this rule came (round 50): placed between
  // its rim and silhouette fits (straight_rim_silhouette_share), it takes in fewer tinted
  // pixels and is read as the 8 without the rule too.
  by_hue.balls.straight_rim_silhouette_share = 0;
  ExpectSrgbBallNamedAndReadAsWithout({{13, 12}, {43, 16}}, 8, 8.0, by_hue, 6, votes_alone);
  PoolBallOptions options;
  options.dark_reflection_chroma_srgb = 1.5;
  EXPECT_FALSE(options.Validate().ok());
  options.dark_reflection_chroma_srgb = -0.1;
  EXPECT_FALSE(options.Validate().ok());
}

// An 8 whose white number disc faces the camera, in an sRGB picture: two thirds of its
// votes white, and it was read as the cue ball (seed 31's frame 12, no cue ball in view:
// 25 white votes, 17 black; seed 61's frame 59: 25 and 11), or on green cloth, its few dark
// pixels tinted by the cloth, as the 6 (seed 71's frame 16: 7 votes for the 6, 7 black).
// An sRGB picture lifts a cue ball's and a 6's shaded sides to grey and dark green, so
// black votes rule both out (PoolBallOptions::max_black_share_srgb): named the 8.
TEST(PoolDarkBalls, EightWithItsDiscUpIsNeitherTheCueBallNorTheSix) {
  PoolAnalyzerOptions black_allowed;
  black_allowed.balls.max_black_share_srgb = 0;
  // On their rims alone, as when this rule came (round 52): seed 71's 8, placed between
  // its rim and silhouette fits (straight_rim_silhouette_share), is read as the 8 without
  // the rule too.
  black_allowed.balls.straight_rim_silhouette_share = 0;
  // And with the silhouette fit as it was then: since it counts coloured pixels under a ball
  // (colour_below_ballness), seed 31's cue ball, in a cluster of four, is found, and the 8
  // is no longer left the cue ball's number without the rule.
  black_allowed.balls.colour_below_ballness = 0;
  ExpectSrgbBallNamedAndReadAsWithout({{31, 12}, {61, 59}}, 8, 10.0, black_allowed, 0);
  ExpectSrgbBallNamedAndReadAsWithout({{71, 16}}, 8, 10.0, black_allowed, 6);
  PoolBallOptions options;
  options.max_black_share_srgb = 1.5;
  EXPECT_FALSE(options.Validate().ok());
}

// A green 6 on green cloth whose white number disc faces the camera: the disc's edge is a
// stronger fall of the colour distance than the ball's own outline, and the edge pass
// drew the fit 2.8 px down to it, 21.7 mm towards the camera (held-out seed 61's frame 12
// rendered sRGB). From its silhouette fit straight to its far rim
// (PoolBallOptions::darker_edge_pass_srgb) it is within 5 mm, and so is every ball of the
// view.
TEST(PoolDarkBalls, SixWithItsDiscToTheCameraIsFittedOnItsRim) {
  const auto [scene, view] = SrgbBenchFrame(12, 61);
  auto scored = AnalyzeAndScore(scene, view);
  ASSERT_TRUE(scored.ok()) << scored.status();
  ExpectSeparatedBallNamed(scored->score, 6, 6.0);
  ExpectEveryBallLocatedWithin(scored->score, view, 10.0);
  // The edge pass on the distance as it was before its cap (edge_interior_level), with
  // which the edge pass leaves this 6 within 7 mm as well.
  PoolAnalyzerOptions with_edge_pass;
  with_edge_pass.balls.darker_edge_pass_srgb = true;
  with_edge_pass.balls.edge_interior_level = 1;
  with_edge_pass.balls.cloth_hue_ball_dark_share = 0;  // which keeps the 6 within 5 mm too
  auto drawn = AnalyzeAndScore(scene, view, with_edge_pass);
  ASSERT_TRUE(drawn.ok()) << drawn.status();
  EXPECT_GT(ErrorOf(drawn->score, 6), 15.0);
}

// A green 6 on green cloth, not darker than the cloth by its body, whose white number disc
// faces the camera: the lower edge of the disc is a stronger fall of the colour distance
// than the 6's own outline against the cloth, and the edge pass drew the fit 2-3 px down
// to it (held-out seed 47's frame 54: 21.5 mm off; seed 59's frames 21 and 24: 21.9 and
// 15.5 mm). Read with the distance capped at the ball's interior level
// (PoolBallOptions::edge_interior_level), the edge pass sees only the step from the cloth
// to the ball, and every ball of these views is within 10 mm.
TEST(PoolDarkBalls, EdgePassIsNotDrawnToTheNumberDisc) {
  PoolAnalyzerOptions uncapped;
  uncapped.balls.edge_interior_level = 1;
  uncapped.balls.cloth_hue_ball_dark_share = 0;  // which mends seed 59's two 6s as well
  ExpectSrgbBallPlacedAndOffWithout({{47, 54, 6}, {59, 21, 6}, {59, 24, 6}}, 8.0, uncapped, 15.0);
  ExpectRejected(&PoolBallOptions::edge_interior_level, {0, 1.2});
}

// A dark ball of the cloth's hue or of none in an sRGB picture goes from its silhouette fit
// straight to its far rim (darker_edge_pass_srgb); the two fits measure it apart, with
// errors that do not go together, and it is placed between them
// (PoolBallOptions::straight_rim_silhouette_share): seed 7's frame 6 and seed 53's frame 22
// (separated 6s 12.1 and 12.3 mm off on the rim alone) and seed 67's frame 56 (a separated
// 8, 12.8 mm). (Seed 79's frame 0, a 6 13.1 mm off on the rim alone, was one more until
// round 62 took its darker pixels around its highlight as ball: 23.5 mm off since.)
TEST(PoolDarkBalls, DarkBallFittedStraightToItsRimIsPlacedByBothFits) {
  PoolAnalyzerOptions rim_alone;
  rim_alone.balls.straight_rim_silhouette_share = 0;
  rim_alone.balls.cloth_hue_ball_dark_share = 0;  // which leaves seed 53's 6 at 11.9 mm
  ExpectSrgbBallPlacedAndOffWithout({{7, 6, 6}, {53, 22, 6}, {67, 56, 8}}, 9.0, rim_alone, 12.0);
  ExpectRejected(&PoolBallOptions::straight_rim_silhouette_share, {1, -0.1});
}

// A green 6 on green cloth in an sRGB picture whose lit cap reads as cloth: fitted within a
// few millimetres, it was a third of its silhouette ball (0.34-0.40) and thrown away, and the
// separated 6 of held-out seed 83's frames 32 and 54 was not found at all. Ball by colour
// alone as much (PoolBallOptions::min_fit_ballness_by_colour), it is kept, and the view
// has no false ball.
TEST(PoolDarkBalls, SixWhoseLitCapReadsAsClothIsKeptByItsColour) {
  PoolAnalyzerOptions overall_only;
  overall_only.balls.min_fit_ballness_by_colour = 0;
  overall_only.balls.cloth_hue_ball_dark_share = 0;  // which finds both 6s as well
  ExpectSrgbBallPlaced(
      {{83, 32, 6}, {83, 54, 6}}, 8.0, overall_only,
      [](const testdata::PoolScore& score, const testdata::PoolScore& lost, int number) {
        EXPECT_EQ(score.false_balls, 0);
        EXPECT_LT(ErrorOf(lost, number), 0) << "found without the rule";
      });
  ExpectRejected(&PoolBallOptions::min_fit_ballness_by_colour, {0.45});  // > min_fit_ballness
}

// A ball near the far cushion with the cushion's shaded face behind it: the dark face
// reads as ball and lengthens the blob upwards, and the hidden-ball split took the ball's
// lit top with the face for a ball behind its lower half, which was then pushed 2-3 px down
// the picture and the "hidden" fit stood as a false ball. Held-out seed 47's frame 46 and
// seed 43's frame 23 (a separated 5, 19 mm off), seed 59's frame 9 (a separated 1, 22 mm).
TEST(PoolHardBalls, CushionFaceBehindABallIsNotAHiddenBall) {
  const std::tuple<uint64_t, int, int> cases[] = {{47, 46, 5}, {43, 23, 5}, {59, 9, 1}};
  for (const auto& [seed, frame, number] : cases) {
    SCOPED_TRACE("seed " + std::to_string(seed) + " frame " + std::to_string(frame));
    const auto [scene, view] = RenderBenchFrame(frame, seed);
    auto scored = AnalyzeAndScore(scene, view);
    ASSERT_TRUE(scored.ok()) << scored.status();
    ExpectSeparatedBallNamed(scored->score, number, 10.0);
    EXPECT_EQ(scored->score.false_balls, 0);
  }
}

// Touching pairs seen one behind the other (benchmark seed 23's frame 1: the 9 in front of
// the cue ball; seed 41's frame 48: the 1 in front of the 8; seed 19's frame 34: the 9 in
// front of the cue ball). The nearer ball's fit slid 2-3 px into the far one, and the
// overlap rule moved the far ball out of it: both stood 12-18 mm away from the camera.
// With the nearer ball moved out instead (PoolBallOptions::line_of_sight_pair_deg), every
// ball of those frames is within 10 mm.
TEST(PoolHardBalls, TouchingPairAlongTheLineOfSightKeepsTheFarBallOnItsOutline) {
  const std::pair<uint64_t, int> frames[] = {{23, 1}, {41, 48}, {19, 34}};
  for (const auto& [seed, frame] : frames) {
    SCOPED_TRACE("seed " + std::to_string(seed) + " frame " + std::to_string(frame));
    const auto [scene, view] = RenderBenchFrame(frame, seed);
    auto scored = AnalyzeAndScore(scene, view);
    ASSERT_TRUE(scored.ok()) << scored.status();
    ExpectEveryBallLocatedWithin(scored->score, view, 10.0);
    PoolAnalyzerOptions off;
    off.balls.line_of_sight_pair_deg = 0;
    auto unaware = AnalyzeAndScore(scene, view, off);
    ASSERT_TRUE(unaware.ok()) << unaware.status();
    double worst = 0;
    for (double e : unaware->score.position_errors_mm) worst = std::max(worst, e);
    EXPECT_GT(worst, 10.0) << "no trouble without the rule";
  }
  PoolBallOptions bad;
  bad.line_of_sight_pair_deg = 90;
  EXPECT_FALSE(bad.Validate().ok());
}

// Benchmark seed 23's frame 23: the 8 touching the 1 in front of it. Fitted 1.4-1.5 radii
// apart, the two were merged as one ball that took the separated 9's number, and the 9
// was read as the 1. Merged only closer than PoolBallOptions::seed_merge_distance (1.4),
// every ball of the frame is within 10 mm and named.
TEST(PoolHardBalls, TouchingPairSeenOneBehindTheOtherIsTwoBalls) {
  const auto [scene, view] = RenderBenchFrame(23, 23);
  ExpectEveryBallWithin10Mm(scene, view);
  PoolAnalyzerOptions wider;
  wider.balls.seed_merge_distance = 1.5;
  // With the silhouette fit as it was when this rule came: since its second pass counts
  // coloured pixels under a ball (colour_below_ballness), the fit merged at 1.5 settles on
  // the 8 and is named the 8, and the 9 keeps its number (the 1 stays lost).
  wider.balls.colour_below_ballness = 0;
  wider.balls.colour_below_front_ballness = 0;  // the same in the first pass
  auto scored = AnalyzeAndScore(scene, view, wider);
  ASSERT_TRUE(scored.ok()) << scored.status();
  EXPECT_LT(scored->score.separated_identified, scored->score.separated);
  PoolBallOptions bad;
  bad.seed_merge_distance = 2.5;
  EXPECT_FALSE(bad.Validate().ok());
}

// A dark ball in front of another (benchmark seed 23's frame 12: the 6 in front of the 8)
// has little rim against the cloth: its far side is against the other ball. Its rim fit
// moved it from 3.2 px towards the camera (16 mm) to within a pixel, but from there found
// only 9 rim points and was thrown away; a rim fit is now kept on 8 (seed 37's frame 22:
// its 6 from 21.5 to 11.3 mm).
TEST(PoolHardBalls, DarkBallInFrontOfAnotherKeepsItsRimFit) { ExpectEveryBallWithin10Mm(12, 23); }

// A camera of higher resolution: benchmark frame 31 (seed 7) at 1920x1440, blur scaled
// alike. Analysed at that size its black 8 was fitted 21 mm off (frame 30's, 19): the ball
// fits sample the rim and the cloth beside it a pixel or two apart, which the wider blur
// spans. Reduced to max_working_pixels, every ball is within 10 mm, and the corners and
// the balls' pixels are those of the image as passed.
TEST(PoolResolution, LargeImagesAreAnalysedAtTheWorkingSize) {
  const auto [scene, view] = RenderBenchFrame(31, 7, 3);
  ASSERT_EQ(view.image.cols, 1920);
  auto scored = AnalyzeAndScore(scene, view);
  ASSERT_TRUE(scored.ok()) << scored.status();
  const testdata::PoolScore& score = scored->score;
  EXPECT_LT(score.max_corner_error_px, 1.0);
  EXPECT_EQ(score.false_balls, 0);
  for (const auto& m : score.matches) {
    EXPECT_GE(m.error_mm, 0) << "ball " << m.truth_number;
    EXPECT_LT(m.error_mm, 10.0) << "ball " << m.truth_number;
  }
  EXPECT_EQ(score.separated_identified, score.separated);
  for (const PoolBall& b : scored->analysis.balls)
    for (const auto& t : view.balls)
      if (t.number == b.number) {
        EXPECT_GT(b.radius_px, 12) << "ball " << b.number << ": radius in passed pixels";
        EXPECT_LT(cv::norm(b.pixel - t.pixel), 0.5 * b.radius_px) << "ball " << b.number;
      }
  // The frame shows the failure: analysed at full size with the edge pass's distance
  // uncapped (edge_interior_level, with which full size is within 10 mm too), a ball is
  // fitted over 10 mm off.
  PoolAnalyzerOptions full_size;
  full_size.max_working_pixels = 0;
  full_size.balls.edge_interior_level = 1;
  auto full = AnalyzeAndScore(scene, view, full_size);
  ASSERT_TRUE(full.ok()) << full.status();
  double worst_full_size = 0;
  for (const auto& m : full->score.matches) worst_full_size = std::max(worst_full_size, m.error_mm);
  EXPECT_GT(worst_full_size, 10.0);
  PoolAnalyzerOptions bad;
  bad.max_working_pixels = 1000;
  EXPECT_FALSE(bad.Validate().ok());
}

// Two fits closer than 1.6 radii cannot both be balls as they are (balls are 2 radii
// apart at least). Benchmark frames (seed 7): in frame 13 the yellow 1's shaded lower half
// and its shadow were fitted as a false ball of their own, which, nearer to the camera,
// took the 1's lower half from its votes: the 1, left with its highlight, was read as the
// 9. In frame 58 the purple 4, in front of the 1 on the line of sight, was fitted 21 mm
// into it; in frame 1 the 2 and the 4 touching were fitted into each other. Dropping the
// worse fit only when it has the other's colour (or none), and otherwise moving it out to
// touch the other, removes the false ball and keeps every real one.
TEST(PoolTouchingBalls, OverlappingFitsAreAShadowOrAPairPushedApart) {
  for (int frame : {1, 13, 58}) ExpectEveryBallWithin10Mm(frame, 7);
}

// A ball seen behind another one along the line of sight shows only a crescent above it:
// their blob has about two balls' area but one distance maximum, and its one seed's
// silhouette settled on the farther ball or between the two. Benchmark frames (seed 11):
// in frame 17 the 8 behind the 9 was lost and the 9 found 24 mm off; in frame 14 the 8
// behind the 2 was found 21 mm off and the 2 lost. Fitted as two balls, each is found
// within 10 mm, and a blob lengthened by a ball's own shadow is not split (no false ball).
TEST(PoolTouchingBalls, BallHiddenBehindAnotherIsSplitOffItsBlob) {
  for (int frame : {14, 17}) ExpectEveryBallWithin10Mm(frame, 11);
  PoolBallOptions options;
  options.split_hidden_min_visible = 0;  // off
  EXPECT_TRUE(options.Validate().ok());
  options.split_hidden_min_ballness = 0.4;  // would take a fit half on cloth for a ball
  EXPECT_FALSE(options.Validate().ok());
}

// A benchmark view (texfree-bench-pool --seed --only [--srgb] [--cloth R,G,B]).
struct BenchViewCase {
  uint64_t seed;
  int frame;
  bool srgb;
  std::optional<cv::Vec3d> cloth_rgb = std::nullopt;  // the renderer's green when unset
  // The balls on the table (texfree-bench-pool --ball-set); the profile keeps the common
  // set's colours.
  testdata::PoolBallSet ball_set = testdata::PoolBallSet::kCommon;
};

// The view as the benchmark renders it, and the profile it tells the analysis (the cloth's
// colour, as its --cloth does).
BenchFrame RenderBenchView(const BenchViewCase& c, PoolTableProfile* profile) {
  BenchFrame out;
  out.scene = BenchScene(c.frame, c.seed);
  if (c.cloth_rgb) out.scene.table.cloth_rgb = *c.cloth_rgb;
  out.scene.srgb_tone = c.srgb;
  out.scene.ball_set = c.ball_set;
  out.view = RenderAsBench(out.scene, c.frame, c.seed);
  *profile = ProfileFor(out.scene.table);
  if (c.cloth_rgb)
    profile->cloth_bgr = cv::Vec3b(cv::saturate_cast<uchar>((*c.cloth_rgb)[2]),
                                   cv::saturate_cast<uchar>((*c.cloth_rgb)[1]),
                                   cv::saturate_cast<uchar>((*c.cloth_rgb)[0]));
  return out;
}

std::string CaseName(const BenchViewCase& c) {
  return "seed " + std::to_string(c.seed) + " frame " + std::to_string(c.frame) +
         (c.srgb ? " sRGB" : " linear") + (c.cloth_rgb ? " other cloth" : "") +
         (c.ball_set == testdata::PoolBallSet::kSecond ? " second ball set" : "");
}

// A benchmark view analysed with `with` (the default options unless given) and with
// `without` (the change under test turned off).
struct WithAndWithout {
  PoolView view;
  testdata::PoolScore with, without;
};
void AnalyzeWithAndWithout(const BenchViewCase& c, const PoolAnalyzerOptions& without,
                           WithAndWithout* out, const PoolAnalyzerOptions& with = {}) {
  PoolTableProfile profile;
  const auto [scene, view] = RenderBenchView(c, &profile);
  out->view = view;
  auto scored = AnalyzeAndScore(scene, view, with, &profile);
  ASSERT_TRUE(scored.ok()) << scored.status();
  out->with = scored->score;
  auto before = AnalyzeAndScore(scene, view, without, &profile);
  ASSERT_TRUE(before.ok()) << before.status();
  out->without = before->score;
}

// For each view: every ball named within 10 mm with no false ball, and with `without` (the
// change under test turned off) some ball 12 mm or more off, lost or misnamed.
void ExpectEveryBallNamedButNotWithout(const std::vector<BenchViewCase>& cases,
                                       const PoolAnalyzerOptions& without) {
  for (const BenchViewCase& c : cases) {
    SCOPED_TRACE(CaseName(c));
    WithAndWithout scored;
    ASSERT_NO_FATAL_FAILURE(AnalyzeWithAndWithout(c, without, &scored));
    EXPECT_EQ(scored.with.false_balls, 0);
    ExpectEveryBallLocatedWithin(scored.with, scored.view, 10.0);
    for (const auto& m : scored.with.matches)
      EXPECT_EQ(m.estimated_number, m.truth_number) << "ball " << m.truth_number;
    double worst = 0;  // a ball lost or misnamed counts as off without bound
    for (const auto& m : scored.without.matches)
      worst = std::max(worst, m.error_mm < 0 || m.estimated_number != m.truth_number
                                  ? std::numeric_limits<double>::infinity()
                                  : m.error_mm);
    EXPECT_GT(worst, 12.0) << "every ball placed without the change";
  }
}

// A red 3 on burgundy cloth has the cloth's chromaticity over its lit body, which is
// lighter than the cloth: only its highlight and shaded rim were ball, and the ball was
// lost. Pixels of an sRGB picture over PoolBallOptions::bright_fraction_srgb of the cloth's
// brightness are ball. Seed 7's set on the benchmark's red cloth (--cloth red --srgb),
// frames 10, 15, 17, 23 and 37: the separated 3 is named within 10 mm; without the rule it
// is not found, or found over 20 mm off, in frames 15, 17 and 23 (frames 10 and 37 find it
// without the rule too since the cloth's colour is measured in the colours nearest its
// own, round 63).
TEST(PoolClothColour, LightBallOfTheClothsHueIsFoundByItsBrightness) {
  PoolAnalyzerOptions without;
  without.balls.bright_fraction_srgb = 0;
  for (int frame : {10, 15, 17, 23, 37}) {
    const BenchViewCase red{7, frame, true, cv::Vec3d(125, 30, 40)};
    SCOPED_TRACE(CaseName(red));
    WithAndWithout scored;
    ASSERT_NO_FATAL_FAILURE(AnalyzeWithAndWithout(red, without, &scored));
    ExpectSeparatedBallNamed(scored.with, 3, 10.0);
    if (frame != 10 && frame != 37) {
      const double without_mm = ErrorOf(scored.without, 3);
      EXPECT_TRUE(without_mm < 0 || without_mm > 20) << "the 3 placed without the rule";
    }
  }
  ExpectRejected(&PoolBallOptions::bright_fraction_srgb, {1.0, 5, -1});
}

// Another maker's balls (texfree-bench-pool --ball-set second) hold a dark teal-green 6:
// on green cloth its body is 0.45-0.85 of the cloth's brightness and within the noise of
// the cloth's chromaticity, so only its highlight was ball and the ball was lost. Around a
// highlight whose ball is not seen otherwise, the pixels darker than
// PoolBallOptions::cloth_hue_ball_dark_share of the cloth are ball. Seeds 11, 13 and 17
// rendered sRGB, the profile left at the common set's colours: the separated 6 is named
// within 10 mm; without the rule it is not found.
TEST(PoolClothColour, DarkBallOfTheClothsHueIsFoundAroundItsHighlight) {
  PoolAnalyzerOptions without;
  without.balls.cloth_hue_ball_dark_share = 0;
  for (const auto& [seed, frame] :
       std::vector<std::pair<uint64_t, int>>{{11, 3}, {13, 5}, {13, 33}, {17, 21}}) {
    const BenchViewCase second{seed, frame, true, std::nullopt, testdata::PoolBallSet::kSecond};
    SCOPED_TRACE(CaseName(second));
    WithAndWithout scored;
    ASSERT_NO_FATAL_FAILURE(AnalyzeWithAndWithout(second, without, &scored));
    ExpectSeparatedBallNamed(scored.with, 6, 10.0);
    EXPECT_EQ(scored.with.false_balls, 0);
    EXPECT_LT(ErrorOf(scored.without, 6), 0) << "the 6 found without the rule";
  }
  // At or under dark_fraction + 0.1 it would take the shadows the dark test leaves.
  ExpectRejected(&PoolBallOptions::cloth_hue_ball_dark_share, {0.4, 1.0, -0.1});
}

// The nearer of two touching balls seen one behind the other slid onto the farther one in
// its silhouette fit: its own pixels were then in the dark zone under the fit, which the
// fit leaves out. In the fit's second pass, pixels there that are ball by colour count as
// ball it leaves out (PoolBallOptions::colour_below_ballness). Rendered sRGB: seed 11's
// frame 15 (the red 3 in front of the blue 2, both 20 mm off) and frame 23 (a 4 19 mm off),
// seed 37's frame 58 (a 5 and a 6 12 mm off) and seed 7's frame 58 (the 1 read as the 4,
// 19 mm off, and the 4 lost); in proportion to the light: seed 19's frame 32 (a 2 19 mm
// off) and seed 67's frame 16 (a 9 22 mm off, the 6 behind it lost). Now every ball of
// these views is named within 10 mm, with no false ball.
TEST(PoolTouchingBalls, NearerBallOfAPairIsNotFittedOntoTheFartherOne) {
  PoolAnalyzerOptions without;
  without.balls.colour_below_ballness = 0;
  // The first pass's count for a blob's front ball mends seed 11's frame 15 and both linear
  // views as well.
  without.balls.colour_below_front_ballness = 0;
  ExpectEveryBallNamedButNotWithout({{11, 15, true},
                                     {11, 23, true},
                                     {37, 58, true},
                                     {7, 58, true},
                                     {19, 32, false},
                                     {67, 16, false}},
                                    without);
  ExpectRejected(&PoolBallOptions::colour_below_ballness, {1.5, -0.1});
}

// The same count in the first pass, for the nearest ball of a blob of several
// (PoolBallOptions::colour_below_front_ballness): fitted first, with nothing of the blob
// claimed yet, it slid onto the ball behind it. Rendered sRGB: seed 73's frame 33 (the 5
// 11.2 mm up onto the 7, the 7 lost), held-out seed 43's frame 18 (the 9 lost) and seed
// 71's frame 1 (the 6 lost behind the 7); in proportion to the light: seed 17's frame 56
// (the 9 16 mm off, the cue ball lost) and seed 83's frame 43 (the 2 lost, the 4 10.3 mm
// off).
TEST(PoolTouchingBalls, FrontBallOfABlobIsNotFittedOntoTheBallBehind) {
  PoolAnalyzerOptions without;
  without.balls.colour_below_front_ballness = 0;
  ExpectEveryBallNamedButNotWithout(
      {{73, 33, true}, {43, 18, true}, {71, 1, true}, {17, 56, false}, {83, 43, false}}, without);
  ExpectRejected(&PoolBallOptions::colour_below_front_ballness, {1.5, -0.1});
}

// Two fits closer than a radius are fits of one ball; the one kept was the one more ball,
// and a ball's dark underside and shadow are ball by darkness, so a fit slid into its
// shadow could win. The one more ball by colour alone is kept now
// (PoolBallOptions::same_ball_colour_ballness). Rendered sRGB: seed 7's frame 8 on the
// benchmark's red cloth (the maroon 7, of the cloth's hue, 23.4 mm towards the camera) and
// held-out seed 59's frame 2 on green (the green 6 frozen on the far cushion, 17.9 mm).
TEST(PoolDarkBalls, OfTwoFitsOfOneBallTheOneMoreBallByColourIsKept) {
  PoolAnalyzerOptions without;
  without.balls.same_ball_colour_ballness = 0;
  without.balls.cloth_hue_ball_dark_share = 0;  // which mends seed 59's 6 as well
  ExpectEveryBallNamedButNotWithout({{59, 2, true}}, without);
  // On red cloth the 3 of that view, touching the 8 in front of it, is lost either way.
  // Round 62 (cloth_hue_ball_dark_share) leaves the 7 10.7 mm off with or without the
  // rule, and with the cloth's colour measured without the greys (round 63) the 7 is
  // within 4.2 mm without the rule: the rule is judged without either.
  const BenchViewCase red{7, 8, true, cv::Vec3d(125, 30, 40)};
  SCOPED_TRACE(CaseName(red));
  PoolAnalyzerOptions with_rule, red_without = without;
  with_rule.balls.cloth_hue_ball_dark_share = 0;
  with_rule.table.nearest_colour_cloth_search = red_without.table.nearest_colour_cloth_search =
      false;
  WithAndWithout scored;
  ASSERT_NO_FATAL_FAILURE(AnalyzeWithAndWithout(red, red_without, &scored, with_rule));
  ExpectSeparatedBallNamed(scored.with, 7, 10.0);
  EXPECT_GT(ErrorOf(scored.without, 7), 12.0);
  ExpectRejected(&PoolBallOptions::same_ball_colour_ballness, {1.5, -0.1});
}

// A ball not darker than the cloth is refined on its edge points, not on the mean fall of
// its colour distance over the outline. Benchmark frames (seed 7): in frame 55 the maroon
// 7, touching the 2 and the 9 in a row, has a lit lower half and a dim upper one; the
// outline points at its sides sampled the stronger contrast lower down and the edge pass
// left it 11.9 mm towards the camera. In frame 26 the 1, in a cluster with the 9 and the
// 6, was 10.1 mm off. The edge points' guards are tested by frames 46 (a separated 9 seen
// against the face of the far cushion: the outermost edge above it is the cushion's, with
// no cloth beyond it) and 30 (a 1 in front of another ball, with edge points on two
// sides only: the edge pass's position holds it across them).
TEST(PoolTouchingBalls, BallsNotDarkerThanTheClothAreFittedOnTheirEdgePoints) {
  for (int frame : {26, 30, 46, 55}) {
    const auto [scene, view] = RenderBenchFrame(frame);
    auto scored = AnalyzeAndScore(scene, view);
    ASSERT_TRUE(scored.ok()) << scored.status();
    const testdata::PoolScore& score = scored->score;
    for (const auto& m : score.matches) {
      if (m.error_mm < 0) continue;  // frame 26 has a touching ball not found
      // Frame 30's 8, all but a crescent hidden behind the 1, was not found before the cap
      // of the edge pass's distance (edge_interior_level); found now, 14.6 mm off, it is a
      // hidden ball's case and not this test's.
      if (frame == 30 && m.truth_number == 8) continue;
      EXPECT_LT(m.error_mm, 10.0) << "frame " << frame << ", ball " << m.truth_number;
    }
    if (frame == 46 || frame == 55) {
      EXPECT_EQ(score.position_errors_mm.size(), view.balls.size()) << "frame " << frame;
    }
    EXPECT_EQ(score.separated_identified, score.separated) << "frame " << frame;
  }
}

// The outline fits of a ball not darker than the cloth are not kept when they put a good
// part of its silhouette on the cloth. Benchmark frame 21 (seed 11): the separated green
// 6, seen against the shaded face of the far cushion, was 4 mm off after the silhouette
// fit and 17 mm off (2 px up, drawn by the face's edge) after the edge pass.
TEST(PoolTouchingBalls, OutlineFitsThatLeaveTheBallForTheClothAreNotKept) {
  const auto [scene, view] = RenderBenchFrame(21, 11);
  auto scored = AnalyzeAndScore(scene, view);
  ASSERT_TRUE(scored.ok()) << scored.status();
  const testdata::PoolScore& score = scored->score;
  for (const auto& m : score.matches) {
    if (!m.separated) continue;
    EXPECT_GE(m.error_mm, 0) << "ball " << m.truth_number;
    EXPECT_LT(m.error_mm, 10.0) << "ball " << m.truth_number;
  }
  EXPECT_EQ(score.separated_identified, score.separated);
}

// The edge points of a ball not darker than the cloth that lie against a dark background
// on the outline's far side are taken on the luma's fall: the colour distance is mostly
// chromaticity, and JPEG's halved colour resolution spreads the ball's colour into the
// dark pixels beyond it, whose chromaticity it then dominates. Benchmark frames, each a
// lit ball in front of the far cushion with its shadow and the cushion's shaded face
// above it: seed 13's frame 3 5 (its top edge points 1.3-1.8 px outside it, 12.7 mm away
// from the camera before) and seed 11's frame 32 1 (10.0 mm before).
TEST(PoolTouchingBalls, EdgePointsAgainstADarkBackgroundAreTakenOnTheLuma) {
  ExpectEveryBallWithin10Mm(3, 13);
  ExpectEveryBallWithin10Mm(32, 11);
  PoolBallOptions options;
  options.edge_shade_brightness = 0;  // off
  EXPECT_TRUE(options.Validate().ok());
  options.edge_shade_brightness = 1.5;
  EXPECT_FALSE(options.Validate().ok());
}

// Balls brighter than the cloth in luma (the cue, the 1, the 9 and the 5) were placed
// about 0.3 px up the picture, away from the camera: their outline was taken on the
// colour distance, mostly chromaticity, which JPEG keeps at half resolution, so a blurred
// rim's fall lay outwards, and the lower outline is left out. Their edge points are now
// moved onto the luma's edge within a pixel (PoolBallOptions::edge_luma_snap_px). Over
// the separated bright balls of seed 7's frames 0-11 (28 balls), found with the analysed
// pose: mean 1.88 mm away from the camera and 2.28 mm off before, 0.83 and 1.81 mm after.
TEST(PoolEdgeFit, BrightBallsAreNotPlacedAwayFromTheCamera) {
  int count = 0;
  double away_sum = 0, error_sum = 0;
  for (uint64_t seed : {7}) {
    for (int frame = 0; frame < 12; ++frame) {
      const auto [scene, view] = RenderBenchFrame(frame, seed);
      auto scored = AnalyzeAndScore(scene, view);
      ASSERT_TRUE(scored.ok()) << "seed " << seed << " frame " << frame << ": " << scored.status();
      const cv::Vec3d camera = -(view.rotation.t() * view.translation);
      for (const auto& m : scored->score.matches) {
        const int n = m.truth_number;
        if (!m.separated || m.error_mm < 0 || (n != 0 && n != 1 && n != 9 && n != 5)) continue;
        for (const auto& b : view.balls) {
          if (b.number != n) continue;
          cv::Point2d sight(b.x_mm - camera[0], b.y_mm - camera[1]);
          sight /= cv::norm(sight);
          away_sum += sight.x * m.dx_mm + sight.y * m.dy_mm;
          error_sum += m.error_mm;
          ++count;
        }
      }
    }
  }
  ASSERT_GE(count, 25);
  EXPECT_LT(away_sum / count, 1.3) << count << " balls";
  EXPECT_LT(error_sum / count, 2.05) << count << " balls";
  PoolBallOptions options;
  options.edge_luma_snap_px = 0;  // off
  EXPECT_TRUE(options.Validate().ok());
  options.edge_luma_snap_px = -1;
  EXPECT_FALSE(options.Validate().ok());
}

// A phone's picture is sRGB-encoded: a blurred outline, a mix of ball and cloth in light,
// has its steepest fall elsewhere in the encoded values (outside a bright ball, inside a
// dark one). The edge fit reads such a picture decoded to light
// (PoolBallOptions::pixel_encoding). Seed 7's frames 0-11 rendered sRGB, every ball
// found: mean error 2.96 mm read in light, 3.34 mm read as encoded.
TEST(PoolEdgeFit, AnSrgbPictureIsFittedInLight) {
  int count = 0;
  double error_sum = 0;
  for (int frame = 0; frame < 12; ++frame) {
    const auto [scene, view] = SrgbBenchFrame(frame);
    auto scored = AnalyzeAndScore(scene, view);
    ASSERT_TRUE(scored.ok()) << "frame " << frame << ": " << scored.status();
    for (const auto& m : scored->score.matches) {
      if (m.error_mm < 0) continue;
      error_sum += m.error_mm;
      ++count;
    }
  }
  ASSERT_GE(count, 80);
  EXPECT_LT(error_sum / count, 3.15) << count << " balls";
  // One picture has one encoding: the table's and the balls' must agree.
  PoolAnalyzerOptions mixed;
  mixed.table.pixel_encoding = PixelEncoding::kLinear;
  const absl::Status status = mixed.Validate();
  EXPECT_FALSE(status.ok());
  EXPECT_NE(status.message().find("pixel_encoding"), std::string::npos) << status;
}

// Two fits closer than 1.6 radii, a coloured one and a dark one with no colour of its own:
// the dark one is moved out, not the coloured ball. Benchmark seed 13's frame 46: a dark
// fit in the shadows between the touching 3 and 4 pushed the 4 13.8 mm out and stood as a
// false ball beside the 3 (15.6 mm off).
TEST(PoolTouchingBalls, DarkFitIsMovedOutOfAColouredBall) { ExpectEveryBallWithin10Mm(46, 13); }

// The match of true ball `number` in benchmark frame `frame` of `seed` (a failure, and a
// match that was not found, when the frame has no such ball or is not analysed).
testdata::PoolBallMatch MatchOfBall(int number, int frame, uint64_t seed) {
  const auto [scene, view] = RenderBenchFrame(frame, seed);
  auto scored = AnalyzeAndScore(scene, view);
  EXPECT_TRUE(scored.ok()) << "frame " << frame << ": " << scored.status();
  if (scored.ok())
    if (const testdata::PoolBallMatch* m = FindMatch(scored->score, number)) return *m;
  ADD_FAILURE() << "frame " << frame << " of seed " << seed << ": no ball " << number;
  return {};
}

// PoolNumbers.NineShowingItsStripeIsToldFromTheOneByWhereItsWhiteLies on the rendered
// frames: each 1 and 9 of those frames gets its own number.
TEST(PoolNumbers, OneAndNineOfRenderedFramesAreNotSwapped) {
  EXPECT_EQ(MatchOfBall(9, 42, 37).estimated_number, 9);
  EXPECT_EQ(MatchOfBall(1, 42, 37).estimated_number, 1);
  EXPECT_EQ(MatchOfBall(1, 54, 41).estimated_number, 1);
}

// Two red balls of one picture are the 3 and the 7, told apart by their differences: blur
// and the cloth mixed in lower both balls' saturation alike. Benchmark seed 31's frame 32
// measured its far, separated 3 at 1.11 saturation and 1.62 brightness and its 7 at 1.14 and
// 1.10: each alone is nearer the calibrated 7 in saturation, and the brightness (capped at
// half the gap) could not tip either, so the two were swapped.
TEST(PoolNumbers, TwoRedBallsOfOnePictureAreToldApartByTheirDifferences) {
  const PoolTableProfile profile = BenchPoolProfile();
  constexpr PixelEncoding kLinear = PixelEncoding::kLinear;           // as read on a linear render
  EXPECT_LT(PoolRedShareOfThree(1.11, 1.62, profile, kLinear), 0.5);  // alone: read as the 7
  EXPECT_GT(PoolRedPairShareOfThree(1.11, 1.62, 1.14, 1.10, profile, kLinear), 0.8);
  EXPECT_LT(PoolRedPairShareOfThree(1.14, 1.10, 1.11, 1.62, profile, kLinear), 0.2);  // symmetric
  // Clear pairs stay clear, and a clearly more saturated ball in the shade is still the 3.
  EXPECT_GT(PoolRedPairShareOfThree(1.89, 1.13, 1.34, 0.77, profile, kLinear), 0.99);
  EXPECT_GT(PoolRedPairShareOfThree(1.80, 0.70, 1.35, 1.20, profile, kLinear), 0.8);
  // Without brightness, saturation alone decides.
  EXPECT_GT(PoolRedPairShareOfThree(1.70, 0, 1.40, 0, profile, kLinear), 0.9);
  for (const auto& [number, seen_as] : {std::pair<int, int>{3, 3}, {7, 7}})
    EXPECT_EQ(MatchOfBall(number, 32, 31).estimated_number, seen_as) << "ball " << number;
}

// The black 8 mirrors the green cloth on its lower half and JPEG tints its dark pixels
// the cloth's way, so its darkest pixels read as the dark green 6: benchmark seed 19's
// frames 24, 26 and 37 numbered their 8 as the 6 (31, 17 and 48 votes for the 6 against
// 23, 17 and 37 for the 8). Pixels darker than a fifth of the lit cloth and of the
// cloth's hue vote for the 8; a 6's own pixels are brighter.
TEST(PoolDarkBalls, BlackBallMirroringTheClothIsNotTheGreenSix) {
  for (int frame : {24, 26, 37})
    EXPECT_EQ(MatchOfBall(8, frame, 19).estimated_number, 8) << "frame " << frame;
  PoolBallOptions options;
  options.dark_reflection_brightness = 0;  // off
  EXPECT_TRUE(options.Validate().ok());
  options.dark_reflection_brightness = 1.2;
  EXPECT_FALSE(options.Validate().ok());
  options.dark_reflection_brightness = 0.2;
  options.dark_reflection_hue_deg = -5;
  EXPECT_FALSE(options.Validate().ok());
}

// The black 8's top seen from afar is a thin dark band under a highlight: blurred, the
// band stays under the ball's half-way level, and the rim was met under the highlight,
// 3-4 px inside the ball. Benchmark seed 23's frames 30 and 56 (a seed no round was tuned
// on) had their separated 8 15.7 mm towards the camera. The rim's level is now half-way
// from the cloth to the first band's peak when that band is under the ball's level.
TEST(PoolDarkBalls, BlackBallsThinTopRimBeforeItsHighlightIsItsRim) {
  for (int frame : {30, 56}) {
    const testdata::PoolBallMatch m = MatchOfBall(8, frame, 23);
    EXPECT_GE(m.error_mm, 0) << "frame " << frame;
    EXPECT_LT(m.error_mm, 8.0) << "frame " << frame;
    EXPECT_EQ(m.estimated_number, 8) << "frame " << frame;
  }
}

// A small, soft green 6 on green cloth is a dark ring around a lit cap of nearly the
// cloth's colour: its fitted silhouette is only 0.40-0.48 ball. Benchmark seed 23's frames
// 18 and 55 and seed 29's frame 32 lost their separated 6 when a fit had to be half ball;
// now it is kept from 0.4 (PoolBallOptions::min_fit_ballness) and found within 8 mm.
TEST(PoolDarkBalls, SmallGreenSixWithALitCapIsKept) {
  for (const auto& [frame, seed] :
       std::vector<std::pair<int, uint64_t>>{{18, 23}, {55, 23}, {32, 29}}) {
    const testdata::PoolBallMatch m = MatchOfBall(6, frame, seed);
    EXPECT_GE(m.error_mm, 0) << "frame " << frame << " of seed " << seed;
    EXPECT_LT(m.error_mm, 8.0) << "frame " << frame << " of seed " << seed;
    EXPECT_EQ(m.estimated_number, 6) << "frame " << frame << " of seed " << seed;
  }
  PoolBallOptions options;
  options.min_fit_ballness = 0;
  EXPECT_FALSE(options.Validate().ok());
  options.min_fit_ballness = 1;
  EXPECT_FALSE(options.Validate().ok());
}

// On a 9-ft table at 640x480 a far green 6 is 3-4 px across: its lit top has the cloth's
// colour, and only its lower half, dark and far from the cloth's chromaticity, is ball.
// The benchmark's 9-ft set (texfree-bench-pool --nine-foot, seed 7) lost it in frame 2,
// whose fit slid up onto the cloth (0.11 ball; refitted on colour alone over the zone under
// the ball, which a shadow never passes), and in frame 3, where it broke into two blobs of
// 7 px, each under min_area_fraction of a ball (fragments within a ball's diameter are now
// taken together).
TEST(PoolDarkBalls, FarGreenSixOnANineFootTableIsFoundAndNumbered) {
  // Located (within one ball radius, 28.6 mm) and numbered; at this size a pixel along the
  // line of sight is 11-13 mm.
  for (int frame : {2, 3})
    EXPECT_EQ(ExpectSeparatedBallFound(6, frame, 7, 20.0, /*nine_foot=*/true), 0)
        << "frame " << frame << ": false balls";
}

// A grey or black ball darker than the cloth is fitted on its rim in the full colour
// distance: its far rim is its top, lit to nearly the cloth's brightness and with no
// chromaticity, so in the mostly chromatic distance its rim was met inside the ball.
// Benchmark frames: seed 7's frame 5 8 (touching the cue ball, 12.1 mm towards the camera
// before) and seed 11's frame 56 8 (11.9 mm before).
TEST(PoolDarkBalls, GreyOrBlackBallsAreFittedOnTheirRimInFullColour) {
  for (const auto& [frame, seed] : {std::pair<int, uint64_t>{5, 7}, {56, 11}}) {
    const auto [scene, view] = RenderBenchFrame(frame, seed);
    auto scored = AnalyzeAndScore(scene, view);
    ASSERT_TRUE(scored.ok()) << scored.status();
    const testdata::PoolScore& score = scored->score;
    bool seen = false;
    for (const auto& m : score.matches) {
      EXPECT_GE(m.error_mm, 0) << "frame " << frame << ", ball " << m.truth_number;
      EXPECT_LT(m.error_mm, 10.0) << "frame " << frame << ", ball " << m.truth_number;
      if (m.truth_number != 8) continue;
      seen = true;
      EXPECT_LT(m.error_mm, 7.0) << "frame " << frame;
    }
    EXPECT_TRUE(seen) << "frame " << frame << " has no 8";
    EXPECT_EQ(score.separated_identified, score.separated) << "frame " << frame;
  }
}

// Bar lamps are warm, and a camera's white balance corrects only part of it: the
// benchmark's --light warm (RGB gains 1, 0.9, 0.72). Without a white balance the cue reads
// as the 9 or the 4, the 9 as the 1 and the maroon 7 as the red 3 (seed 7: 304 of 317
// separated balls named). The white of the cue and the cloth both show the cast, and the
// balls are read again balanced: on these three frames every separated ball is named,
// against 5 misnamed without.
TEST(PoolLight, WarmLampsLeaveEveryBallItsNumber) {
  const cv::Vec3d& warm = testdata::kWarmBarLamps;
  int misnamed_unbalanced = 0;
  for (int frame : {16, 28, 41}) {
    SCOPED_TRACE("frame " + std::to_string(frame));
    const auto [scene, view] = RenderBenchFrame(frame, 7, 1, false, false, warm);
    auto scored = AnalyzeAndScore(scene, view);
    ASSERT_TRUE(scored.ok()) << scored.status();
    EXPECT_EQ(scored->score.separated_identified, scored->score.separated);
    // The gains undo the cast up to a common factor: blue raised most, red lowered.
    const cv::Vec3f gains = scored->analysis.light_gains;
    EXPECT_GT(gains[0] / gains[2], 1.2f) << gains;
    EXPECT_LT(gains[0] / gains[2], 1.6f) << gains;
    EXPECT_GT(gains[1] / gains[2], 1.0f) << gains;
    PoolAnalyzerOptions unbalanced;
    unbalanced.balls.white_balance_min_cast = 0;
    auto plain = AnalyzeAndScore(scene, view, unbalanced);
    ASSERT_TRUE(plain.ok()) << plain.status();
    EXPECT_EQ(plain->analysis.light_gains, cv::Vec3f(1, 1, 1));
    misnamed_unbalanced += plain->score.separated - plain->score.separated_identified;
  }
  EXPECT_GE(misnamed_unbalanced, 3);
}

// A room's lamps 500 mm beyond the far cushion (not over the table's middle): that
// cushion's face, and the cloth along it, lie in its shadow, as dark as the 8. Measured
// against the cloth as lit beside the cushions they are not ball: the spread layout's
// balls are all found, from both long sides. Against the cloth's colour alone the face
// was a row of false black balls.
TEST(PoolLight, LampsOffTheTablesMiddleLeaveNoRowOfFalseBallsAlongACushion) {
  for (const auto& [side, shift_y] :
       {std::pair{PoolViewSide::kLongNear, 500.0}, std::pair{PoolViewSide::kLongFar, -500.0}}) {
    SCOPED_TRACE(shift_y);
    PoolScene scene = Scene(side, 35, 6);
    scene.lamp_shift_mm = {0, shift_y, 0};
    const PoolView view = testdata::RenderPoolView(scene, 77);
    auto scored = AnalyzeAndScore(scene, view);
    ASSERT_TRUE(scored.ok()) << scored.status();
    const testdata::PoolScore& score = scored->score;
    // The balls' own shadows fall sideways too, which the fits do not expect: a ball may
    // be off by more than usual, or a shadow stand out far enough to be a ball.
    EXPECT_LE(score.false_balls, 1);
    EXPECT_EQ(score.position_errors_mm.size(), view.balls.size());
    PoolAnalyzerOptions plain;
    plain.balls.cushion_shade_dark_share = 0;
    auto against_cloth = AnalyzeAndScore(scene, view, plain);
    ASSERT_TRUE(against_cloth.ok()) << against_cloth.status();
    EXPECT_GE(against_cloth->score.false_balls, 4);
  }
  PoolBallOptions bad;
  bad.cushion_shade_dark_share = 1.5;
  EXPECT_FALSE(bad.Validate().ok());
}

// Benchmark seed 19's frame 13 under lamps 500 mm beyond the far cushion: that cushion's
// face is near black above the blue 2 frozen before it. At that darkness its hue is JPEG's
// and the noise's, and it read as coloured ball: a false ball on the face above the 2. In
// a cell of the face in deep shade such pixels are ball only by their darkness.
TEST(PoolLight, NearBlackCushionFaceIsNotColouredBall) {
  auto [scene, view] = RenderBenchFrame(13, 19);
  scene.lamp_shift_mm = {0, 500, 0};
  view = testdata::RenderPoolView(scene, 19 * 100003 + 13);
  auto scored = AnalyzeAndScore(scene, view);
  ASSERT_TRUE(scored.ok()) << scored.status();
  EXPECT_EQ(scored->score.false_balls, 0);
  EXPECT_EQ(scored->score.separated_identified, scored->score.separated);
  ExpectSeparatedBallNamed(scored->score, 2, 10);
}

// Under the renderer's neutral light nothing is balanced, even when the white of one ball
// alone says otherwise: seed 7's frame 42, whose only white ball reads 10% warm.
TEST(PoolLight, NeutralLightIsNotBalanced) {
  const auto [scene, view] = RenderBenchFrame(42);
  auto scored = AnalyzeAndScore(scene, view);
  ASSERT_TRUE(scored.ok()) << scored.status();
  EXPECT_EQ(scored->analysis.light_gains, cv::Vec3f(1, 1, 1));
  EXPECT_EQ(scored->score.separated_identified, scored->score.separated);
}

// In a live view the analyzer keeps the light's gains: the next picture is read balanced
// at once, and its balls keep their numbers.
TEST(PoolLight, LiveViewKeepsTheWhiteBalance) {
  const cv::Vec3d& warm = testdata::kWarmBarLamps;
  const auto first = RenderBenchFrame(16, 7, 1, false, false, warm);
  auto analyzer =
      PoolAnalyzer::Create(ProfileFor(first.scene.table), CameraOf(first.view), ForLinearRender());
  ASSERT_TRUE(analyzer.ok()) << analyzer.status();
  auto a = analyzer->Analyze(first.view.image);
  ASSERT_TRUE(a.ok()) << a.status();
  auto b = analyzer->Analyze(first.view.image);
  ASSERT_TRUE(b.ok()) << b.status();
  // The second reading finds no cast left to correct: the gains stay within 2%.
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(b->light_gains[c], a->light_gains[c], 0.02);
  ASSERT_EQ(a->balls.size(), b->balls.size());
  for (size_t i = 0; i < a->balls.size(); ++i) EXPECT_EQ(a->balls[i].number, b->balls[i].number);
}

// Benchmark frame 24 (seed 7): the far cushion is seen at a grazing angle, its top only
// 2 px wide beyond a shaded cushion face as dark as the rail. Taken on brightness, the
// far side's edge fell on the face and the corners were 3.9 px off, which moved three
// separated balls 14-20 mm and lost the 3. On the hue (the face is cloth in shade) the
// side is the top's outer edge.
TEST(PoolTablePose, FarCushionSeenAtAGrazingAngleIsTakenAtItsTop) {
  const auto [scene, view] = RenderBenchFrame(24);
  auto scored = AnalyzeAndScore(scene, view);
  ASSERT_TRUE(scored.ok()) << scored.status();
  const testdata::PoolScore& score = scored->score;
  EXPECT_LT(score.max_corner_error_px, 1.0);
  EXPECT_EQ(score.position_errors_mm.size(), view.balls.size());
  for (const auto& m : score.matches) {
    EXPECT_GE(m.error_mm, 0) << "ball " << m.truth_number;
    EXPECT_LT(m.error_mm, 10.0) << "ball " << m.truth_number;
  }
  EXPECT_EQ(score.separated_identified, score.separated);
}

// Benchmark seed 19's frame 8: the whole table in view, but the near long side, broken by
// its side pocket, and the far long side gave all nine Hough lines tried as sides (a
// few degrees and pixels apart), so the short right side was never among them and the
// table was refused as "only part of the table is in view". A line is tried only when
// most of its outline points are not already near a stronger line.
TEST(PoolTablePose, AShortSideIsNotCrowdedOutByNearCopiesOfTheLongSides) {
  ExpectEveryBallWithin10Mm(8, 19);
}

// A cue stick laid over the cloth, its shaft and its shadow a few pixels wide, cut an inlet
// into the cloth region from the cushion it crosses: the outline ran along both of the
// stick's edges and the side search took that line for a side. Benchmark frames with a cue
// stick rendered sRGB (texfree-bench-pool --cue-stick --srgb): seed 19's frame 25 and seed
// 7's frame 41 had no table ("only part of the table is in view"), seed 11's frame 38 none
// either ("does not fit a table"). With the cloth region's gaps closed
// (PoolTableOptions::cloth_close_fraction) the table's corners are within a pixel and
// every separated ball is named. (The search without the greys, round 63, finds the three
// tables without the closing as well; without both they are lost.)
TEST(PoolTablePose, CueStickOverTheClothLeavesTheTableFound) {
  PoolAnalyzerOptions one_pixel_gaps;
  one_pixel_gaps.table.cloth_close_fraction = 0;
  one_pixel_gaps.table.nearest_colour_cloth_search = false;
  for (const auto& [seed, frame] : {std::pair<uint64_t, int>{19, 25}, {7, 41}, {11, 38}}) {
    SCOPED_TRACE("seed " + std::to_string(seed) + " frame " + std::to_string(frame));
    const auto [scene, view] =
        RenderBenchFrame(frame, seed, 1, false, /*cue_stick=*/true, {1, 1, 1}, /*srgb=*/true);
    auto scored = AnalyzeAndScore(scene, view);
    ASSERT_TRUE(scored.ok()) << scored.status();
    EXPECT_LT(scored->score.max_corner_error_px, 1.0);
    EXPECT_EQ(scored->score.separated_identified, scored->score.separated);
    auto before = AnalyzeAndScore(scene, view, one_pixel_gaps);
    EXPECT_FALSE(before.ok()) << "found with 1 px gaps closed only";
  }
  ExpectRejected(&PoolTableOptions::cloth_close_fraction, {0.2, -0.01});
}

// The sides are found on the chromaticity step (which a dark cushion face cannot fake)
// but placed on the colour's own half-way crossing when it is the same edge (blur mixes
// colours, so a chromaticity step is crossed off its middle). Benchmark frames 0-4
// (seed 7) had corner errors of 0.08-1.52 px (mean 0.43) from the colour alone and
// 0.25-0.46 px (mean 0.38) from the chromaticity alone.
TEST(PoolTablePose, CornersWithinAFractionOfAPixel) {
  const testdata::PoolTableSpec spec = testdata::PoolTableSpec::Bench();
  std::mt19937_64 rng(7);
  double sum = 0, worst = 0;
  constexpr int kFrames = 5;
  for (int frame = 0; frame < kFrames; ++frame) {
    const PoolScene scene = testdata::RandomPoolScene(rng, spec);
    const PoolView view = testdata::RenderPoolView(scene, 7 * 100003 + frame);
    auto analyzer =
        PoolAnalyzer::Create(ProfileFor(scene.table), CameraOf(view), ForLinearRender());
    ASSERT_TRUE(analyzer.ok()) << analyzer.status();
    auto analysis = analyzer->Analyze(view.image);
    ASSERT_TRUE(analysis.ok()) << "frame " << frame << ": " << analysis.status();
    const testdata::PoolScore score =
        testdata::ScorePoolAnalysis(scene, view, analysis->cloth_corners, {});
    EXPECT_LT(score.max_corner_error_px, 0.5) << "frame " << frame;
    sum += score.max_corner_error_px;
    worst = std::max(worst, score.max_corner_error_px);
  }
  EXPECT_LT(sum / kFrames, 0.3) << "worst " << worst;
}

// Many tables have black or dark-stained rails, or light ones. JPEG keeps the colour at half
// resolution, so next to the lit cushion top a dark rail's pixels take on the cloth's
// chromaticity (and a light rail's colour spreads onto the top): the colour and
// chromaticity crossings lay off the edge, and the corners of a black-railed table were
// 1.5-3.4 px off (benchmark seed 7's frames 0-4 with --rail black); in three of these
// views 1.0-2.0 px, and one ball 10.7 mm off. A table whose rails are dark or light has its
// sides taken on the luma, which JPEG keeps whole: the dark rails' corners are now within
// 0.07 px here. The maple rails' views guard the light rails' path (0.14 and 0.18 px; 0.12
// and 0.22 on the colour; the benchmark's ten sets show what it gains).
// Black, dark walnut and maple rails from a long and a short side (rendered sRGB or
// linear): corners within 0.3 px, every ball within 10 mm and every separated ball named.
void ExpectRailsFoundOnTheirEdge(bool srgb) {
  const std::pair<cv::Vec3d, const char*> rails[] = {
      {{28, 27, 26}, "black"}, {{48, 26, 14}, "dark walnut"}, {{205, 165, 115}, "maple"}};
  const ViewCase views[] = {{PoolViewSide::kLongNear, 50, "long near, 50 deg"},
                            {PoolViewSide::kShortRight, 40, "short right, 40 deg"}};
  for (const auto& [rgb, rail] : rails)
    for (const ViewCase& c : views) {
      PoolScene scene = Scene(c.side, c.elevation, 8);
      scene.table.rail_rgb = rgb;
      scene.srgb_tone = srgb;
      const PoolView view = testdata::RenderPoolView(scene, 4321);
      auto scored = AnalyzeAndScore(scene, view);
      ASSERT_TRUE(scored.ok()) << rail << ", " << c.name << ": " << scored.status();
      const testdata::PoolScore& score = scored->score;
      EXPECT_LT(score.max_corner_error_px, 0.3) << rail << ", " << c.name;
      ExpectEveryBallLocatedWithin(score, view, 10.0);
      EXPECT_EQ(score.separated_identified, score.separated) << rail << ", " << c.name;
    }
}
TEST(PoolTablePose, DarkAndLightRailsAreFoundOnTheirEdge) { ExpectRailsFoundOnTheirEdge(false); }

// The same views as a phone encodes them (sRGB): a black rail is lighter against the
// cloth than in light, and read as encoded it was taken for wood (its luma over the
// cloth's 0.45-0.61 in 4 of benchmark seed 7's first 20 frames, against 0.26-0.34 linear);
// and blur mixes light, so the half-way crossings of a side lay off its edge. Both are
// read in light (PoolTableOptions::pixel_encoding): seed 7's 30 frames with black rails,
// median corner error 0.52 -> 0.18 px (p95 2.83 -> 0.27), maple 0.44 -> 0.18, wood 0.31 ->
// 0.23. Read as encoded, these six views' corners are 0.32-0.91 px off; read in light
// 0.14-0.21.
TEST(PoolTablePose, DarkAndLightRailsOfAnSrgbPictureAreFoundOnTheirEdge) {
  ExpectRailsFoundOnTheirEdge(true);
}

TEST(PoolProfile, ValidateSaysWhatIsWrong) {
  EXPECT_TRUE(NineFootPoolProfile().Validate().ok());
  EXPECT_TRUE(BenchPoolProfile().Validate().ok());
  PoolTableProfile p = BenchPoolProfile();
  p.width_mm = 2000;
  EXPECT_NE(p.Validate().message().find("length_mm"), std::string::npos);
  p = BenchPoolProfile();
  p.cushion_height_mm = 60;
  EXPECT_NE(p.Validate().message().find("cushion_height_mm"), std::string::npos);
  p = BenchPoolProfile();
  p.corner_pocket_mm = 30;
  EXPECT_NE(p.Validate().message().find("corner_pocket_mm"), std::string::npos);
  // A cloth of nearly no colour cannot be told from the floor by its colour angle.
  for (const cv::Vec3b& grey :
       {cv::Vec3b(50, 45, 45), cv::Vec3b(0, 0, 0), cv::Vec3b(230, 235, 240)}) {
    p = BenchPoolProfile();
    p.cloth_bgr = grey;
    EXPECT_NE(p.Validate().message().find("is nearly grey"), std::string::npos) << grey;
  }
  p = BenchPoolProfile();
  p.cloth_bgr = cv::Vec3b(160, 95, 20);  // tournament blue
  EXPECT_TRUE(p.Validate().ok());
}

TEST(PoolProfile, CalibrationLearnsClothAndBallColours) {
  const PoolScene scene = Scene(PoolViewSide::kLongNear, 60);
  const PoolView view = testdata::RenderPoolView(scene, 3);
  // A region of cloth around the middle of the table and a box around the 2 ball.
  const cv::Point2d centre = testdata::ProjectTablePoint(view, {665, 350, 0});
  const cv::Rect cloth_region(cvRound(centre.x) - 40, cvRound(centre.y) - 20, 80, 40);
  const auto& two = view.balls[2];
  ASSERT_EQ(two.number, 2);
  const cv::Rect ball_region(cvRound(two.pixel.x) - 8, cvRound(two.pixel.y) - 8, 16, 16);
  auto calibrated =
      CalibratePoolColors(view.image, cloth_region, {{2, ball_region}}, BenchPoolProfile());
  ASSERT_TRUE(calibrated.ok()) << calibrated.status();
  // The cloth's hue is the rendered cloth's; the 2 comes out blue.
  const cv::Vec3f cloth_bgr(scene.table.cloth_rgb[2], scene.table.cloth_rgb[1],
                            scene.table.cloth_rgb[0]);
  const cv::Vec3b& c = calibrated->cloth_bgr;
  EXPECT_LT(ColorAngleDeg(cv::Vec3f(c[0], c[1], c[2]), cloth_bgr), 5);
  const cv::Vec3b& b = calibrated->ball_bgr[2];
  EXPECT_GT(b[0], b[1] + 30);
  EXPECT_GT(b[0], b[2] + 30);
  // A region of the beige-grey floor beyond the table is not a cloth.
  const cv::Point2d floor = testdata::ProjectTablePoint(view, {665, 1400, -760});
  const cv::Rect floor_region(cvRound(floor.x) - 20, cvRound(floor.y) - 10, 40, 20);
  ASSERT_EQ(floor_region & cv::Rect(0, 0, view.image.cols, view.image.rows), floor_region);
  auto grey = CalibratePoolColors(view.image, floor_region, {}, BenchPoolProfile());
  EXPECT_EQ(grey.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(grey.status().message().find("is nearly grey"), std::string::npos) << grey.status();
  // Bad regions are clear errors.
  auto outside =
      CalibratePoolColors(view.image, cv::Rect(600, 400, 100, 100), {}, BenchPoolProfile());
  EXPECT_EQ(outside.status().code(), absl::StatusCode::kInvalidArgument);
}

// The ideal image is undistorted only where the analysis looks. What it does remap must be
// exactly the whole undistortion's pixels, and the balls must not read outside it: the
// same balls, to the last bit, whatever the unremapped part of the buffer holds.
TEST(PoolIdealView, RemapsOnlyWhatIsRequiredAndExactly) {
  const BenchFrame frame = RenderBenchFrame(3);
  const CameraModel camera = CameraOf(frame.view);
  ASSERT_TRUE(camera.has_distortion());
  const PoolUndistorter undistorter(camera);
  const cv::Mat whole = undistorter.Undistort(frame.view.image);
  cv::Mat storage(whole.size(), whole.type(), cv::Scalar(0, 0, 0));
  IdealView view(undistorter, frame.view.image, &storage);
  EXPECT_EQ(view.full().data, storage.data);  // the buffer passed in is the one written
  EXPECT_EQ(view.valid().area(), 0);
  // A middle part, one that overlaps it to the left and below, and one apart from both.
  const cv::Rect parts[3] = {{200, 150, 120, 90}, {150, 200, 100, 100}, {500, 20, 30, 30}};
  cv::Rect expected;
  for (const cv::Rect& part : parts) {
    view.Require(part);
    expected = expected.area() > 0 ? (expected | part) : part;
    ASSERT_EQ(view.valid(), expected);
    EXPECT_EQ(cv::norm(view.full()(expected), whole(expected), cv::NORM_INF), 0);
  }
  // Nothing beyond the bounding box was remapped.
  cv::Mat outside = cv::Mat::ones(whole.size(), CV_8UC1);
  outside(expected).setTo(0);
  cv::Mat untouched;
  cv::cvtColor(view.full(), untouched, cv::COLOR_BGR2GRAY);
  EXPECT_EQ(cv::countNonZero(untouched & outside), 0);
  // Off the picture is clipped.
  view.Require({600, 400, 200, 200});
  EXPECT_EQ(view.valid() & cv::Rect(0, 0, whole.cols, whole.rows), view.valid());
  // The half-resolution picture (pyrDown, then undistorted with the half-size camera)
  // agrees with the whole undistortion's pyrDown to well under a grey level on average.
  cv::Mat half_of_whole;
  cv::pyrDown(whole, half_of_whole);
  ASSERT_EQ(view.half().size(), half_of_whole.size());
  const double mean_abs = cv::norm(view.half(), half_of_whole, cv::NORM_L1) /
                          static_cast<double>(half_of_whole.total() * 3);
  EXPECT_LT(mean_abs, 0.6);
}

TEST(PoolIdealView, TableAndBallsFromTheRequiredPartsAreThoseOfTheWholePicture) {
  for (int index : {3, 8}) {
    SCOPED_TRACE(index);
    const BenchFrame frame = RenderBenchFrame(index);
    const CameraModel camera = CameraOf(frame.view);
    const PoolTableProfile profile = ProfileFor(frame.scene.table);
    const PoolUndistorter undistorter(camera);
    const cv::Mat whole = undistorter.Undistort(frame.view.image);
    const PoolAnalyzerOptions linear = ForLinearRender();
    auto table = DetectPoolTable(whole, camera.K, profile, linear.table);
    ASSERT_TRUE(table.ok()) << table.status();
    const std::vector<PoolDetectedBall> reference =
        DetectPoolBalls(whole, camera.K, table->pose, profile, table->cloth_bgr, linear.balls);
    ASSERT_GE(reference.size(), 5u);
    for (uchar fill : {0, 255}) {
      cv::Mat storage(whole.size(), whole.type(), cv::Scalar::all(fill));
      IdealView view(undistorter, frame.view.image, &storage);
      auto lazy_table = DetectPoolTable(&view, camera.K, profile, linear.table);
      ASSERT_TRUE(lazy_table.ok()) << lazy_table.status();
      // Only the half-resolution search differs: the corners agree to a tenth of a pixel.
      for (int i = 0; i < 4; ++i)
        EXPECT_LT(cv::norm(lazy_table->cushion_corners[i] - table->cushion_corners[i]), 0.1);
      const std::vector<PoolDetectedBall> balls =
          DetectPoolBalls(&view, camera.K, table->pose, profile, table->cloth_bgr, linear.balls);
      ASSERT_EQ(balls.size(), reference.size());
      for (size_t i = 0; i < balls.size(); ++i) {
        EXPECT_EQ(balls[i].number, reference[i].number);
        EXPECT_EQ(balls[i].x_mm, reference[i].x_mm);
        EXPECT_EQ(balls[i].y_mm, reference[i].y_mm);
      }
      // And it did leave most of the picture alone.
      EXPECT_LT(view.valid().area(), 0.8 * whole.total());
    }
  }
}

}  // namespace
}  // namespace texfree
