// Pool assistant benchmark: renders seeded 640x480 photographs of a table (random side,
// height, lens, light, blur, noise, JPEG; random layouts with touching and frozen balls),
// analyses each with PoolAnalyzer on one core and prints a table: frames where the table
// was found, corner error, ball position error (mean, max) against the ground truth,
// separated balls found and identified, and analysis time per frame (mean, p95).
// Shot search is timed separately on the found arrangements.
//
//   texfree-bench-pool [--frames 60] [--seed 7] [--nine-foot] [--cue-stick] [--save DIR]
//   [--verbose]
//                      [--clean] [--only FRAME] [--cache DIR] [--srgb]
//                      [--ball-set common|second]
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cctype>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "common/pool_analyzer.h"
#include "common/pool_profile.h"
#include "common/pool_shots.h"
#include "common/timing.h"
#include "tests/data/pool_renderer.h"
#include "tests/data/pool_scoring.h"

namespace {

using namespace texfree;
using namespace texfree::testdata;

// A colour named on the command line into `rgb`: one of `names` (each with its RGB, or
// none for the renderer's own, which leaves `rgb` empty) or R,G,B. False for any other name.
struct NamedRgb {
  const char* name;
  std::optional<cv::Vec3d> rgb;
};
bool ParseNamedRgb(const std::string& name, std::initializer_list<NamedRgb> names,
                   std::optional<cv::Vec3d>* rgb) {
  for (const NamedRgb& n : names)
    if (name == n.name) {
      *rgb = n.rgb;
      return true;
    }
  int r = 0, g = 0, b = 0;
  if (std::sscanf(name.c_str(), "%d,%d,%d", &r, &g, &b) != 3) return false;
  *rgb = cv::Vec3d(r, g, b);
  return true;
}

// --cloth: green (the renderer's own), tournament blue and a burgundy as cloth makers sell
// them.
bool ParseCloth(const std::string& name, std::optional<cv::Vec3d>* rgb) {
  return ParseNamedRgb(
      name, {{"green", {}}, {"blue", cv::Vec3d(20, 95, 160)}, {"red", cv::Vec3d(125, 30, 40)}},
      rgb);
}

// --rail: wood (the renderer's own), black (a modern table's painted or laminated rails),
// maple (light wood).
bool ParseRail(const std::string& name, std::optional<cv::Vec3d>* rgb) {
  return ParseNamedRgb(
      name, {{"wood", {}}, {"black", cv::Vec3d(28, 27, 26)}, {"maple", cv::Vec3d(205, 165, 115)}},
      rgb);
}

// The lamps' colour named by --light into `rgb` (gains): neutral, warm (bar lamps of about
// 3000 K under a camera whose white balance corrected half of it), cool (daylight from a
// window through the same balance), or R,G,B gains. False for any other name.
bool ParseLight(const std::string& name, cv::Vec3d* rgb) {
  double r = 0, g = 0, b = 0;
  if (name == "neutral") {
    *rgb = {1, 1, 1};
  } else if (name == "warm") {
    *rgb = texfree::testdata::kWarmBarLamps;
  } else if (name == "cool") {
    *rgb = texfree::testdata::kDaylight;
  } else if (std::sscanf(name.c_str(), "%lf,%lf,%lf", &r, &g, &b) == 3 && r > 0 && g > 0 && b > 0) {
    *rgb = {r, g, b};
  } else {
    return false;
  }
  return true;
}

// --lamp-shift's "X,Y,Z" (mm) into `shift`: false unless three numbers that keep the lamps
// over the cloth (Z > -800, the lamps hanging 900 mm over it).
bool ParseLampShift(const std::string& text, cv::Vec3d* shift) {
  double x = 0, y = 0, z = 0;
  if (std::sscanf(text.c_str(), "%lf,%lf,%lf", &x, &y, &z) != 3 || !(z > -800)) return false;
  *shift = {x, y, z};
  return true;
}

// --elevation's "LO,HI" (degrees) into lo and hi: false unless 10 <= LO <= HI <= 85.
bool ParseElevation(const std::string& text, double* lo, double* hi) {
  char tail = 0;
  if (std::sscanf(text.c_str(), "%lf,%lf%c", lo, hi, &tail) != 2) return false;
  return *lo >= 10 && *lo <= *hi && *hi <= 85;
}

double Percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(q * (v.size() - 1) + 0.5))];
}

// CPU time of this thread, ms: the one-core cost of the analysis, whatever else the
// machine is running (wall-clock time is reported beside it).
double ThreadCpuMs() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec / 1e6;
}

double Mean(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x;
  return v.empty() ? 0 : s / v.size();
}

// The options that change what is rendered (analysis options left out), as parsed.
struct RenderConditions {
  bool nine_foot = false;
  bool clean = false;
  std::string cloth = "green";
  std::string rail = "wood";
  std::string light = "neutral";
  std::string ball_set = "common";
  double scale = 1;
  bool cue_stick = false;
  double motion_blur = 0;
  std::string lamp_shift;
  double exposure = 1;
  bool srgb = false;
  double lamp_radius = PoolScene().lamp_radius_mm;
  double sharpen = 0;
  std::string elevation;
  static constexpr double kRendererMaxRoll = 6;  // RandomPoolScene's default
  double max_roll = kRendererMaxRoll;
  std::string floor;

  // As a file name stem; the renderer's defaults leave their part out, so that the views
  // cached before a condition existed keep their names.
  std::string CacheKey(uint64_t seed, int frame) const {
    std::string key =
        "seed" + std::to_string(seed) + (nine_foot ? "_ninefoot" : "") + (clean ? "_clean" : "") +
        "_cloth_" + cloth + (rail == "wood" ? "" : "_rail_" + rail) +
        (light == "neutral" ? "" : "_light_" + light) + "_scale" + std::to_string(scale) +
        (cue_stick ? "_cuestick" : "") +
        (motion_blur > 0 ? "_motion" + std::to_string(motion_blur) : "") +
        (lamp_shift.empty() ? "" : "_lamps_" + lamp_shift) +
        (exposure == 1 ? "" : "_exposure" + std::to_string(exposure)) + (srgb ? "_srgb" : "") +
        (ball_set == "second" ? "_balls_second" : "") +
        (lamp_radius == PoolScene().lamp_radius_mm ? ""
                                                   : "_lampradius" + std::to_string(lamp_radius)) +
        (sharpen > 0 ? "_sharpen" + std::to_string(sharpen) : "") +
        (elevation.empty() ? "" : "_elevation_" + elevation) +
        (max_roll == kRendererMaxRoll ? "" : "_roll" + std::to_string(max_roll)) +
        (floor.empty() ? "" : "_floor_" + floor) + "_f" + std::to_string(frame);
    for (char& c : key)
      if (!std::isalnum(static_cast<unsigned char>(c)) && c != '.' && c != '-') c = '_';
    return key;
  }

  // Frame `frame` of the set `seed` (drawn from `rng`, the set's generator) under these
  // conditions; every option was checked by its validator.
  PoolScene Scene(std::mt19937_64& rng, const PoolTableSpec& spec, uint64_t seed, int frame) const {
    double min_elevation = 30, max_elevation = 65;
    if (!elevation.empty()) ParseElevation(elevation, &min_elevation, &max_elevation);
    PoolScene scene = RandomPoolScene(rng, spec, true, min_elevation, max_elevation, max_roll);
    if (clean) {
      scene.blur_sigma = scene.noise_sigma = 0;
      scene.jpeg_quality = 0;
      scene.camera.k1 = scene.camera.k2 = 0;
    }
    ScalePoolCamera(&scene, scale);
    ParseLight(light, &scene.light_rgb);
    scene.light_gain *= exposure;
    scene.srgb_tone = srgb;
    scene.ball_set = ball_set == "second" ? PoolBallSet::kSecond : PoolBallSet::kCommon;
    scene.lamp_radius_mm = lamp_radius;
    scene.sharpen_amount = sharpen;
    if (!floor.empty()) {
      std::optional<cv::Vec3d> rgb;
      ParseNamedRgb(floor, {}, &rgb);
      scene.floor_rgb = *rgb;
    }
    if (!lamp_shift.empty()) ParseLampShift(lamp_shift, &scene.lamp_shift_mm);
    if (motion_blur > 0)
      DrawPoolShake(seed * 7907 + static_cast<uint64_t>(frame) + 0x5ba4e, motion_blur, &scene);
    if (cue_stick) {
      // Its own generator: the scenes stay those of the set without a stick.
      std::mt19937_64 stick_rng(seed * 7919 + static_cast<uint64_t>(frame));
      scene.cue_stick = AimedCueStick(stick_rng, spec, scene.balls);
    }
    return scene;
  }
};

// Renders the view, or reads it back from `dir` (PNG + YAML) when an earlier run wrote it.
PoolView CachedPoolView(const std::string& dir, const std::string& key, const PoolScene& scene,
                        uint64_t seed) {
  if (dir.empty()) return RenderPoolView(scene, seed);
  std::filesystem::create_directories(dir);
  const std::string stem = dir + "/" + key;
  PoolView v;
  cv::FileStorage in;
  if (std::filesystem::exists(stem + ".yml") && in.open(stem + ".yml", cv::FileStorage::READ)) {
    v.image = cv::imread(stem + ".png", cv::IMREAD_COLOR);
    if (!v.image.empty()) {
      cv::Mat K, R, t, corners, cushion, balls;
      in["K"] >> K;
      in["R"] >> R;
      in["t"] >> t;
      in["distortion"] >> v.distortion;
      in["corners"] >> corners;
      in["cushion"] >> cushion;
      in["balls"] >> balls;
      v.camera_matrix = cv::Matx33d(K);
      v.rotation = cv::Matx33d(R);
      v.translation = cv::Vec3d(t);
      for (int k = 0; k < 4; ++k) {
        v.cloth_corners[k] = {corners.at<double>(k, 0), corners.at<double>(k, 1)};
        v.cushion_corners[k] = {cushion.at<double>(k, 0), cushion.at<double>(k, 1)};
      }
      for (int i = 0; i < balls.rows; ++i) {
        PoolBallTruth b;
        b.number = static_cast<int>(balls.at<double>(i, 0));
        b.x_mm = balls.at<double>(i, 1);
        b.y_mm = balls.at<double>(i, 2);
        b.pixel = {balls.at<double>(i, 3), balls.at<double>(i, 4)};
        b.visible_pixels = static_cast<int>(balls.at<double>(i, 5));
        b.separated = balls.at<double>(i, 6) != 0;
        v.balls.push_back(b);
      }
      return v;
    }
  }
  v = RenderPoolView(scene, seed);
  cv::imwrite(stem + ".png", v.image);
  cv::FileStorage out(stem + ".yml", cv::FileStorage::WRITE);
  cv::Mat corners(4, 2, CV_64F), cushion(4, 2, CV_64F);
  for (int k = 0; k < 4; ++k) {
    corners.at<double>(k, 0) = v.cloth_corners[k].x;
    corners.at<double>(k, 1) = v.cloth_corners[k].y;
    cushion.at<double>(k, 0) = v.cushion_corners[k].x;
    cushion.at<double>(k, 1) = v.cushion_corners[k].y;
  }
  cv::Mat balls(static_cast<int>(v.balls.size()), 7, CV_64F);
  for (size_t i = 0; i < v.balls.size(); ++i) {
    const PoolBallTruth& b = v.balls[i];
    const double row[7] = {
        double(b.number),       b.x_mm, b.y_mm, b.pixel.x, b.pixel.y, double(b.visible_pixels),
        b.separated ? 1.0 : 0.0};
    for (int c = 0; c < 7; ++c) balls.at<double>(static_cast<int>(i), c) = row[c];
  }
  out << "K" << cv::Mat(v.camera_matrix) << "R" << cv::Mat(v.rotation) << "t"
      << cv::Mat(v.translation) << "distortion" << v.distortion << "corners" << corners << "cushion"
      << cushion << "balls" << balls;
  return v;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"texfree-bench-pool: pool table analysis accuracy and speed"};
  int frames = 60;
  uint64_t seed = 7;
  RenderConditions render;
  bool verbose = false;
  std::string save;
  app.add_option("--frames", frames, "Rendered photographs")->check(CLI::PositiveNumber);
  app.add_option("--seed", seed, "Seed of the rendered set");
  app.add_flag("--nine-foot", render.nine_foot,
               "A 9-ft table instead of the 1330x700 mm bench table");
  app.add_option("--save", save, "Write each image and its ground truth to this folder");
  std::string cache;
  app.add_option("--cache", cache,
                 "Keep rendered views (lossless) in this folder and reuse them on later runs "
                 "with the same options: the ray caster is most of a run's time");
  app.add_flag("--verbose", verbose, "One line per frame");
  double verbose_over_mm = 8;
  app.add_option("--verbose-over", verbose_over_mm,
                 "With --verbose: print every ball off by more than this (mm; 8)");
  int only = -1;
  app.add_option("--only", only, "Analyse only this frame of the set (to look into one case)");
  app.add_flag("--clean", render.clean,
               "No blur, noise, JPEG or lens distortion (the method's floor)");
  bool true_pose = false;
  app.add_flag("--true-pose", true_pose,
               "Find the balls with the true table pose (separates ball errors from pose errors)");
  // A colour option checked by its parser (ParseCloth, ParseRail).
  const auto colour_option = [&app](const char* name, std::string* value,
                                    bool (*parse)(const std::string&, std::optional<cv::Vec3d>*),
                                    const std::string& help, const std::string& expected) {
    app.add_option(name, *value, help)->check([parse, expected](const std::string& v) {
      std::optional<cv::Vec3d> rgb;
      return parse(v, &rgb) ? std::string() : expected;
    });
  };
  colour_option("--cloth", &render.cloth, ParseCloth,
                "Cloth colour: green (the renderer's), blue, red or R,G,B; the profile is told "
                "the cloth colour, as table.json's cloth_color tells the server",
                "expected green, blue, red or R,G,B");
  colour_option("--rail", &render.rail, ParseRail,
                "Rail colour: wood (the renderer's), black, maple or R,G,B; the profile is not "
                "told (it has no rail colour)",
                "expected wood, black, maple or R,G,B");
  app.add_option("--light", render.light,
                 "Colour of the lamps as the camera records it: neutral, warm (bar lamps, half "
                 "corrected by white balance), cool (daylight) or R,G,B gains")
      ->check([](const std::string& v) {
        cv::Vec3d rgb;
        return ParseLight(v, &rgb) ? std::string() : "expected neutral, warm, cool or R,G,B";
      });
  app.add_option("--ball-set", render.ball_set,
                 "The balls on the table: common (the default profile's colours) or second "
                 "(another maker's set: a dark teal-green 6, a brown 7, a violet 4, a lighter "
                 "blue 2, a red-orange 5; the profile keeps the common set's colours)")
      ->check(CLI::IsMember({"common", "second"}));
  bool cloth_unknown = false;
  app.add_flag("--cloth-unknown", cloth_unknown,
               "Keep the profile's default cloth colour whatever the cloth (a user who did not "
               "set it)");
  // A number option checked against its range.
  const auto ranged_option = [&app](const char* name, double* value, const std::string& help,
                                    double lo, double hi) {
    app.add_option(name, *value, help)->check(CLI::Range(lo, hi));
  };
  ranged_option("--scale", &render.scale,
                "Render at this many times 640x480 (the same views, blur scaled alike): a "
                "camera of higher resolution",
                0.5, 4.0);
  ranged_option("--motion-blur", &render.motion_blur,
                "A handheld camera's shake in every frame (live video): a smear of up to this "
                "many pixels in a random direction, each frame's drawn from a stream of its own",
                0.0, 20.0);
  double profile_table_scale = 1;
  ranged_option("--profile-table-scale", &profile_table_scale,
                "Analyse with the profile of a table this many times as long and wide (the same "
                "balls and cushions): a user's wrong table.json, which the analysis's profile "
                "note should name",
                0.3, 3.0);
  bool nine_foot_profile = false;
  app.add_flag("--nine-foot-profile", nine_foot_profile,
               "Analyse with the default 9-ft profile whatever the table (a user who gave no "
               "table.json)");
  app.add_flag("--cue-stick", render.cue_stick,
               "A cue stick in every frame, aimed through the cue ball at another ball as a "
               "player holds it (the same scenes otherwise)");
  ranged_option("--exposure", &render.exposure,
                "Scale each frame's exposure by this (over 1: the lit balls and cloth clip, "
                "as an overexposed phone picture; under 1: a dim, noisier picture)",
                0.25, 4.0);
  app.add_flag("--srgb", render.srgb,
               "Encode the pictures with the sRGB curve, as a phone does (lighter shading and "
               "shadows), instead of in proportion to the light");
  app.add_option("--lamp-shift", render.lamp_shift,
                 "Move the lamps by X,Y,Z mm from their line over the table's long axis: a "
                 "room's light off the table's middle, its shadows cast sideways")
      ->check([](const std::string& v) {
        cv::Vec3d shift;
        return ParseLampShift(v, &shift)
                   ? std::string()
                   : "expected X,Y,Z in mm, the lamps kept over the cloth (Z > -800)";
      });
  ranged_option(
      "--lamp-radius", &render.lamp_radius,
      "Radius of each lamp in mm (70: a bare bulb's reflector; a billiard lamp's "
      "shade is 300-500 across, a radius of 150-250): softer shadows and wider, dimmer highlights",
      10.0, 400.0);
  ranged_option("--sharpen", &render.sharpen,
                "A phone's sharpening of this amount (unsharp mask of 1 px at 640x480, after "
                "the noise): dark and light rings along every edge (0: none)",
                0.0, 3.0);
  app.add_option("--elevation", render.elevation,
                 "The camera's elevation range LO,HI in degrees (30,65): the same scenes seen "
                 "from lower or higher (a player standing at the table's end looks down at "
                 "20-30 degrees)")
      ->check([](const std::string& v) {
        double lo = 0, hi = 0;
        return ParseElevation(v, &lo, &hi) ? std::string()
                                           : "expected LO,HI in degrees, 10 <= LO <= HI <= 85";
      });
  ranged_option("--max-roll", &render.max_roll,
                "The camera's roll is drawn within this many degrees either way (6): a phone "
                "held crooked",
                0.0, 45.0);
  app.add_option("--floor", render.floor,
                 "The floor's colour R,G,B (the renderer's warm grey tiles by default; a "
                 "wooden floor is about 150,95,55, a red carpet 120,30,35)")
      ->check([](const std::string& v) {
        std::optional<cv::Vec3d> rgb;
        return ParseNamedRgb(v, {}, &rgb) ? std::string() : "expected R,G,B";
      });
  double focal_scale = 1;
  ranged_option("--focal-scale", &focal_scale,
                "Tell the analysis a focal length this many times the camera's (a phone's "
                "intrinsics guessed from its field of view, not calibrated)",
                0.5, 2.0);
  PoolAnalyzerOptions analyzer_options;
  // The ball finder's options, each shown with its default.
  const auto ball_option = [&app](const char* name, double* value, const std::string& help) {
    app.add_option(name, *value, help)->capture_default_str();
  };
  ball_option("--ball-chroma-distance", &analyzer_options.balls.ball_chroma_distance,
              "A pixel whose chromaticity is this far from the cloth's is ball");
  ball_option("--cloth-hue-ball-dark-share", &analyzer_options.balls.cloth_hue_ball_dark_share,
              "Around a highlight whose ball is not seen otherwise (a dark ball of the cloth's "
              "hue), the pixels under this share of the cloth's brightness are ball (0: off)");
  ball_option("--stick-opening-radius", &analyzer_options.balls.stick_opening_radius,
              "Cue-stick strips are what an opening with a disc of this many ball radii "
              "removes (0: nothing is a stick)");
  ball_option("--stick-bridge-length", &analyzer_options.balls.stick_bridge_length,
              "Over the cloth the stick's line is followed this many ball radii past each "
              "strip found");
  ball_option("--seed-merge-distance", &analyzer_options.balls.seed_merge_distance,
              "Seeds closer than this many ball radii after the first fits are one ball");
  ball_option("--white-balance-min-cast", &analyzer_options.balls.white_balance_min_cast,
              "The balls are read again white-balanced when their white and the cloth show a "
              "light cast over this share (0: never)");
  ball_option("--line-of-sight-pair-deg", &analyzer_options.balls.line_of_sight_pair_deg,
              "Of two overlapping fits within this many degrees of the line of sight, the "
              "nearer is moved out, also in the final separation (0: the worse fit is, and the "
              "final separation moves both by halves)");
  ball_option("--edge-point-reach", &analyzer_options.balls.edge_point_reach,
              "Edge points of a ball not darker than the cloth are sought this many apparent "
              "radii either side of its outline (0: no edge fit)");
  ball_option("--min-fit-ballness-by-colour", &analyzer_options.balls.min_fit_ballness_by_colour,
              "A fit under the ball-ness to keep it is kept when it is this much ball as fitted "
              "and by colour alone (0: never)");
  ball_option("--colour-below-ballness", &analyzer_options.balls.colour_below_ballness,
              "In the silhouette fit's second pass, pixels under a ball's silhouette this much "
              "ball by colour count as ball it leaves out (0: never)");
  ball_option("--bright-fraction-srgb", &analyzer_options.balls.bright_fraction_srgb,
              "In an sRGB picture pixels brighter than this multiple of the cloth are ball "
              "(0: never)");
  ball_option("--colour-below-front-ballness", &analyzer_options.balls.colour_below_front_ballness,
              "The same in the first pass for the nearest ball of a blob of several (0: never)");
  ball_option("--same-ball-colour-ballness", &analyzer_options.balls.same_ball_colour_ballness,
              "Of two fits closer than a radius, the one more ball by colour alone is kept when "
              "either is this much (0: by ball-ness)");
  ball_option("--straight-rim-silhouette-share",
              &analyzer_options.balls.straight_rim_silhouette_share,
              "A dark ball fitted straight to its far rim (sRGB) is placed this share of the way "
              "back to its silhouette fit (0: on its rim)");
  ball_option("--edge-interior-level", &analyzer_options.balls.edge_interior_level,
              "The edge pass reads a ball's colour distance capped at this quantile of its "
              "interior's (1: not capped)");
  ball_option("--edge-point-prior", &analyzer_options.balls.edge_point_prior,
              "The edge fit's start counts as this many points on its outline");
  ball_option("--cushion-shade", &analyzer_options.balls.cushion_shade_dark_share,
              "Next to the cushions a pixel is dark only under this share of the cloth as lit "
              "there (0: the cloth's colour everywhere)");
  ball_option("--edge-luma-snap", &analyzer_options.balls.edge_luma_snap_px,
              "Edge points of a ball brighter than the cloth in luma move to the luma's edge "
              "within this many pixels (0: never)");
  ball_option("--near-half-dark-share", &analyzer_options.balls.near_half_dark_share,
              "A ball whose silhouette's near half has under this share of the cloth's light "
              "is fitted as one darker than the cloth (0: only by its body's median brightness)");
  ball_option("--dark-reflection-chroma-srgb", &analyzer_options.balls.dark_reflection_chroma_srgb,
              "In an sRGB picture a ball pixel of the cloth's hue with under this share of the "
              "cloth's colour votes for the 8 (0: never)");
  ball_option("--vote-min-colour-share", &analyzer_options.balls.vote_min_colour_share,
              "A chromatic pixel votes for the colour whose chroma, from this share of it to "
              "all of it, lies nearest (1: the colour's point alone)");
  ball_option("--max-black-share-srgb", &analyzer_options.balls.max_black_share_srgb,
              "In an sRGB picture a ball with this share of black votes is neither the cue ball "
              "nor the 6 (0: black does not count against them)");
  app.add_flag("--darker-edge-pass-srgb", analyzer_options.balls.darker_edge_pass_srgb,
               "Give a ball darker than the cloth in an sRGB picture the edge pass between its "
               "silhouette and rim fits (PoolBallOptions::darker_edge_pass_srgb)");
  app.add_flag("!--no-fit-separation", analyzer_options.balls.separate_overlapping_fits,
               "Leave fits closer than two radii where they are (PoolBallOptions::"
               "separate_overlapping_fits)");
  app.add_flag("!--whole-cloth-cone", analyzer_options.table.nearest_colour_cloth_search,
               "Search the cloth in every colour within the wide angle of its own, also those "
               "nearer to grey or to another dominant colour (PoolTableOptions::"
               "nearest_colour_cloth_search off, as before round 63)");
  app.add_option("--cloth-close-fraction", analyzer_options.table.cloth_close_fraction,
                 "Gaps in the cloth region up to this share of the image's width are closed "
                 "before the table's outline is taken (0: the 3x3 closing alone)")
      ->capture_default_str();
  app.add_option("--max-working-pixels", analyzer_options.max_working_pixels,
                 "Larger images are analysed reduced to this many pixels (0: never)")
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  cv::setNumThreads(1);  // one core
  // The analysis is told how the renderer encodes its pictures, as a user's camera is known.
  analyzer_options.balls.pixel_encoding =
      render.srgb ? PixelEncoding::kSrgb : PixelEncoding::kLinear;
  analyzer_options.table.pixel_encoding = analyzer_options.balls.pixel_encoding;

  PoolTableSpec spec = render.nine_foot ? PoolTableSpec::NineFoot() : PoolTableSpec::Bench();
  std::optional<cv::Vec3d> cloth_rgb;
  ParseCloth(render.cloth, &cloth_rgb);  // checked by --cloth's validator
  if (cloth_rgb) spec.cloth_rgb = *cloth_rgb;
  std::optional<cv::Vec3d> rail_rgb;
  ParseRail(render.rail, &rail_rgb);  // checked by --rail's validator
  if (rail_rgb) spec.rail_rgb = *rail_rgb;
  PoolTableProfile profile = render.nine_foot ? NineFootPoolProfile() : BenchPoolProfile();
  profile.length_mm = spec.length_mm;
  profile.width_mm = spec.width_mm;
  profile.ball_radius_mm = spec.ball_radius_mm;
  profile.cushion_height_mm = spec.cushion_height_mm;
  profile.cushion_width_mm = spec.cushion_width_mm;
  if (cloth_rgb && !cloth_unknown)
    profile.cloth_bgr = cv::Vec3b(cv::saturate_cast<uchar>(spec.cloth_rgb[2]),
                                  cv::saturate_cast<uchar>(spec.cloth_rgb[1]),
                                  cv::saturate_cast<uchar>(spec.cloth_rgb[0]));
  if (!save.empty()) std::filesystem::create_directories(save);
  // A user's mistake: the profile of a larger or smaller table than the one in view, or
  // the default 9-ft profile left in place.
  if (nine_foot_profile) {
    const cv::Vec3b cloth = profile.cloth_bgr;
    profile = PoolTableProfile();
    profile.cloth_bgr = cloth;
  }
  profile.length_mm *= profile_table_scale;
  profile.width_mm *= profile_table_scale;

  std::mt19937_64 rng(seed);
  int found = 0, separated = 0, separated_found = 0, identified = 0, false_balls = 0;
  int noted = 0;  // frames whose analysis says the profile is not the table's
  int balls_total = 0, balls_matched = 0;
  std::vector<double> errors, separated_errors, corner_errors, times, cpu_times, per_frame_max,
      shot_times;
  std::string failures;
  cv::Size image_size;  // of the rendered frames
  for (int f = 0; f < frames; ++f) {
    const PoolScene scene = render.Scene(rng, spec, seed, f);
    if (only >= 0 && f != only) continue;
    const PoolView view = CachedPoolView(cache, render.CacheKey(seed, f), scene, seed * 100003 + f);
    image_size = view.image.size();
    if (!save.empty()) {
      char name[64];
      std::snprintf(name, sizeof(name), "%s/pool_%04d", save.c_str(), f);
      cv::imwrite(std::string(name) + ".png", view.image);
    }
    CameraModel camera;
    camera.K = view.camera_matrix;
    camera.K(0, 0) *= focal_scale;  // a user's focal length, off by this factor
    camera.K(1, 1) *= focal_scale;
    camera.distortion = view.distortion;
    camera.size = view.image.size();
    auto analyzer = PoolAnalyzer::Create(profile, camera, analyzer_options);
    if (!analyzer.ok()) {
      std::fprintf(stderr, "%s\n", analyzer.status().ToString().c_str());
      return 1;
    }
    // Warm the undistortion tables (built once per camera in a live view).
    (void)analyzer->Analyze(view.image);
    const auto t0 = SteadyClock::now();
    const double cpu0 = ThreadCpuMs();
    auto analysis = analyzer->Analyze(view.image);
    cpu_times.push_back(ThreadCpuMs() - cpu0);
    times.push_back(MillisecondsSince(t0));
    balls_total += static_cast<int>(view.balls.size());
    for (const auto& b : view.balls) separated += b.separated;
    if (!analysis.ok()) {
      failures += "  frame " + std::to_string(f) + ": " + analysis.status().ToString() + "\n";
      continue;
    }
    ++found;
    std::vector<PoolDetectedBall> detected = analyzer->last_detected_balls();
    std::array<cv::Point2d, 4> corners = analysis->cloth_corners;
    if (true_pose) {
      // The same ball finder on the same ideal image, given the renderer's pose.
      const PoolUndistorter undistorter(camera);
      const cv::Mat ideal = undistorter.Undistort(view.image);
      PlanarPose pose;
      pose.R = view.rotation;
      pose.t = view.translation;
      detected = DetectPoolBalls(ideal, camera.K, pose, profile, analysis->cloth_bgr,
                                 analyzer_options.balls);
      corners = view.cloth_corners;
    }
    std::vector<EstimatedPoolBall> est;
    for (const auto& b : detected) est.push_back({b.number, b.x_mm, b.y_mm});
    const PoolScore score = ScorePoolAnalysis(scene, view, corners, est);
    corner_errors.push_back(score.max_corner_error_px);
    for (const auto& m : score.matches)
      if (m.separated && m.error_mm >= 0) separated_errors.push_back(m.error_mm);
    std::vector<PoolBallOnTable> on_table;
    for (const auto& b : analysis->balls) on_table.push_back({b.number, b.x_mm, b.y_mm});
    const auto s0 = SteadyClock::now();
    (void)SuggestPoolShots(profile, on_table);
    shot_times.push_back(MillisecondsSince(s0));
    errors.insert(errors.end(), score.position_errors_mm.begin(), score.position_errors_mm.end());
    balls_matched += static_cast<int>(score.position_errors_mm.size());
    separated_found += score.separated_found;
    identified += score.separated_identified;
    false_balls += score.false_balls;
    noted += !analysis->profile_note.empty();
    double frame_max = 0;
    for (double e : score.position_errors_mm) frame_max = std::max(frame_max, e);
    per_frame_max.push_back(frame_max);
    // The frame first, then what went wrong in it.
    if (verbose) {
      const cv::Vec3d c = -(view.rotation.t() * view.translation);
      std::printf(
          "frame %3d  camera (%6.0f %6.0f %5.0f)  corners %.2f px  balls %zu/%zu  "
          "max %.1f mm  separated %d/%d id %d  false %d  %.1f ms\n",
          f, c[0], c[1], c[2], score.max_corner_error_px, score.position_errors_mm.size(),
          view.balls.size(), frame_max, score.separated_found, score.separated,
          score.separated_identified, score.false_balls, times.back());
      for (const auto& [stage, ms] : analysis->timings_ms)
        std::printf("    %s %.1f ms", stage.c_str(), ms);
      std::printf("\n");
    }
    if (verbose && score.max_corner_error_px > 1) {
      for (int i = 0; i < 4; ++i)
        std::printf("    corner %d: (%.2f, %.2f) truth (%.2f, %.2f)\n", i,
                    analysis->cloth_corners[i].x, analysis->cloth_corners[i].y,
                    view.cloth_corners[i].x, view.cloth_corners[i].y);
    }
    if (verbose) {
      for (const auto& m : score.matches)
        if (m.estimated_number != m.truth_number || m.error_mm > verbose_over_mm ||
            m.error_mm < 0) {
          // The error along the camera's line of sight on the table (+ = farther away).
          const cv::Vec3d c = -(view.rotation.t() * view.translation);
          const PoolBallTruth* truth = nullptr;
          for (const auto& b : view.balls)
            if (b.pixel == m.pixel) truth = &b;
          cv::Point2d away(truth->x_mm - c[0], truth->y_mm - c[1]);
          away *= 1.0 / cv::norm(away);
          // What one pixel is worth there: the table distance along the line of sight
          // that moves the ball's image by one pixel.
          const double r = spec.ball_radius_mm;
          const cv::Point2d p0 = ProjectTablePoint(view, {truth->x_mm, truth->y_mm, r});
          const cv::Point2d p1 =
              ProjectTablePoint(view, {truth->x_mm + 10 * away.x, truth->y_mm + 10 * away.y, r});
          const cv::Point2d found =
              ProjectTablePoint(view, {truth->x_mm + m.dx_mm, truth->y_mm + m.dy_mm, r});
          // The nearest other ball: the gap between the two (0: touching).
          int nearest = -1;
          double gap_mm = 1e9;
          cv::Point2d towards(0, 0);  // unit vector to the nearest ball
          for (const auto& b : view.balls) {
            const double gap = std::hypot(b.x_mm - truth->x_mm, b.y_mm - truth->y_mm) - 2 * r;
            if (&b != truth && gap < gap_mm) {
              gap_mm = gap;
              nearest = b.number;
              towards = cv::Point2d(b.x_mm - truth->x_mm, b.y_mm - truth->y_mm);
              towards *= 1.0 / std::max(1e-9, cv::norm(towards));
            }
          }
          std::printf(
              "    ball %d%s at px (%.1f, %.1f) mm (%.1f, %.1f): found as %d at px (%.1f, %.1f), "
              "error %.1f mm (%.1f, %.1f), %.1f mm away from the camera; 1 px = %.1f mm along "
              "it; nearest ball %d, %.1f mm apart (%.1f mm towards it, which lies %+.2f of the "
              "way behind)\n",
              m.truth_number, m.separated ? " (separated)" : "", p0.x, p0.y, truth->x_mm,
              truth->y_mm, m.estimated_number, found.x, found.y, m.error_mm, m.dx_mm, m.dy_mm,
              m.dx_mm * away.x + m.dy_mm * away.y, 10 / std::max(1e-9, cv::norm(p1 - p0)), nearest,
              gap_mm, m.dx_mm * towards.x + m.dy_mm * towards.y, towards.dot(away));
        }
      for (const auto& m : score.matches) {
        if (m.estimated_index < 0) continue;
        const PoolDetectedBall& b = detected[m.estimated_index];
        std::printf("      votes of %d as %d:", m.truth_number, b.number);
        for (int v : b.votes) std::printf(" %d", v);
        std::printf(
            "  white share %.2f (outward %.2f)  red saturation %.2f brightness %.2f  radius %.1f "
            "px\n",
            b.white_share, b.white_outward, b.colour_saturation, b.colour_brightness, b.radius_px);
      }
      // Balls found where no ball is (false balls), with what they were taken for.
      std::vector<bool> matched(detected.size(), false);
      for (const auto& m : score.matches)
        if (m.estimated_index >= 0) matched[static_cast<size_t>(m.estimated_index)] = true;
      for (size_t i = 0; i < detected.size(); ++i) {
        if (matched[i]) continue;
        const PoolDetectedBall& b = detected[i];
        std::printf(
            "    false ball as %d at ideal px (%.0f, %.0f) mm (%.1f, %.1f), radius %.1f px, votes:",
            b.number, b.ideal_pixel.x, b.ideal_pixel.y, b.x_mm, b.y_mm, b.radius_px);
        for (int v : b.votes) std::printf(" %d", v);
        std::printf("\n");
      }
    }
  }
  std::printf(
      "\nPool analysis benchmark: %d frames of %dx%d, %s table (%.0f x %.0f mm, ball "
      "radius %.3f mm), seed %llu, one core\n\n",
      frames, image_size.width, image_size.height, render.nine_foot ? "9-ft" : "bench",
      spec.length_mm, spec.width_mm, spec.ball_radius_mm, static_cast<unsigned long long>(seed));
  std::printf("| measure | value |\n|---|---|\n");
  std::printf("| table found | %d / %d frames |\n", found, frames);
  std::printf("| corner error (max per frame), median / p95 | %.2f / %.2f px |\n",
              Percentile(corner_errors, 0.5), Percentile(corner_errors, 0.95));
  std::printf("| balls located (within one radius) | %d / %d |\n", balls_matched, balls_total);
  std::printf("| position error mean | %.2f mm |\n", Mean(errors));
  std::printf("| position error p95 / max | %.2f / %.2f mm |\n", Percentile(errors, 0.95),
              errors.empty() ? 0.0 : *std::max_element(errors.begin(), errors.end()));
  std::printf("| balls over 10 mm | %d / %zu |\n",
              static_cast<int>(
                  std::count_if(errors.begin(), errors.end(), [](double e) { return e > 10; })),
              errors.size());
  std::printf("| position error, separated balls: mean / max | %.2f / %.2f mm |\n",
              Mean(separated_errors),
              separated_errors.empty()
                  ? 0.0
                  : *std::max_element(separated_errors.begin(), separated_errors.end()));
  std::printf("| separated balls found | %d / %d |\n", separated_found, separated);
  std::printf("| separated balls identified | %d / %d (%.1f%%) |\n", identified, separated,
              separated ? 100.0 * identified / separated : 0.0);
  std::printf("| false balls | %d |\n", false_balls);
  std::printf("| frames with a profile note (a profile of another table) | %d / %d |\n", noted,
              static_cast<int>(per_frame_max.size()));
  std::printf("| analysis time per frame mean / p95 | %.1f / %.1f ms |\n", Mean(times),
              Percentile(times, 0.95));
  std::printf("| analysis CPU time per frame mean / p95 | %.1f / %.1f ms |\n", Mean(cpu_times),
              Percentile(cpu_times, 0.95));
  std::printf("| shot search per arrangement mean / p95 | %.1f / %.1f ms |\n", Mean(shot_times),
              Percentile(shot_times, 0.95));
  if (!failures.empty()) std::printf("\nFailures:\n%s", failures.c_str());
  return 0;
}
