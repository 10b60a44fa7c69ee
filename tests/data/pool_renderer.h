// Seeded synthetic photographs of a pool table with exact ground truth, for the pool
// assistant's tests and benchmark.
//
// The renderer is a small ray caster in the table frame (millimetres; origin at a corner
// of the playing surface, X along the long side, Y along the short side, Z up; the cloth
// is Z = 0): cloth bed, cushions (cloth-covered, top at the cushion height), wooden rails
// with sight diamonds, six pockets, the floor, and balls as true spheres of the ball
// radius resting on the cloth (centre at Z = radius), lit by lamps above the table with
// soft shadows, ambient occlusion and specular highlights. Each pixel is a 3x3
// supersampled pinhole ray (with radial lens distortion), then lens vignetting, blur,
// sensor noise and JPEG as in a real camera. Because spheres are ray-cast, a ball's image
// is the true perspective silhouette (an ellipse), so accuracy measured against this
// ground truth is honest. Independent of the code under test (no texfree_common).
#ifndef TEXFREE_TESTS_DATA_POOL_RENDERER_H_
#define TEXFREE_TESTS_DATA_POOL_RENDERER_H_

#include <array>
#include <cstdint>
#include <opencv2/core.hpp>
#include <optional>
#include <random>
#include <string>
#include <vector>

namespace texfree::testdata {

// Table dimensions (mm) and colours (RGB 0..255) of the rendered table.
struct PoolTableSpec {
  double length_mm = 1330;  // playing surface between the cushion noses
  double width_mm = 700;
  double ball_radius_mm = 24;
  double cushion_height_mm = 37;  // nose/top of the cushion above the cloth
  double cushion_width_mm = 42;   // cloth-covered cushion top, nose to rail
  double rail_width_mm = 110;     // wooden rail outside the cushions
  double corner_pocket_mm = 100;  // mouth width
  double side_pocket_mm = 110;
  cv::Vec3d cloth_rgb{38, 128, 92};
  cv::Vec3d rail_rgb{105, 58, 30};

  // The bench table of seed 4.6 (1330 x 700 mm, ball radius 24 mm) and a standard 9-ft
  // table (2540 x 1270 mm, 28.575 mm).
  static PoolTableSpec Bench();
  static PoolTableSpec NineFoot();
};

// Which ball set is on the table. kCommon: the colours the default PoolTableProfile
// holds. kSecond: another maker's set, not tuned on: a dark teal-green 6 (near a green
// cloth's hue, darker than it), a brown 7, a violet 4, a lighter blue 2, a red-orange 5,
// a deeper yellow 1 and 9.
enum class PoolBallSet { kCommon, kSecond };

// Reference albedo (RGB) of ball `number` (0 = cue, 9 = yellow stripe on white).
cv::Vec3d PoolBallRgb(int number, PoolBallSet set = PoolBallSet::kCommon);

struct PoolBallPlacement {
  int number = 0;  // 0 = cue, 1..9
  double x_mm = 0, y_mm = 0;
};

// Which side of the table the camera stands at.
enum class PoolViewSide { kLongNear, kLongFar, kShortLeft, kShortRight };

struct PoolCamera {
  cv::Size image_size{640, 480};
  double horizontal_fov_deg = 62;
  cv::Vec3d position_mm{665, -900, 900};  // camera centre in the table frame
  cv::Vec3d look_at_mm{665, 350, 0};
  double roll_deg = 0;
  double k1 = 0, k2 = 0;  // radial distortion (OpenCV model)
};

// A cue stick held over the table, as a player aiming holds it: a shaft of maple ending
// in a tip behind the cue ball, and a darker butt, rising towards the player. Two
// cylinders (the taper in two steps).
struct PoolCueStick {
  cv::Vec3d tip_mm{0, 0, 0};       // centre of the tip, table frame
  cv::Vec3d toward_butt{1, 0, 0};  // unit, from the tip to the butt
  double shaft_length_mm = 700, butt_length_mm = 750;
  double shaft_radius_mm = 6.5, butt_radius_mm = 13;
};

struct PoolScene {
  PoolTableSpec table;
  std::optional<PoolCueStick> cue_stick;  // none: no stick in the scene
  std::vector<PoolBallPlacement> balls;
  PoolBallSet ball_set = PoolBallSet::kCommon;
  PoolCamera camera;
  int lamps = 2;              // lamps above the long axis, 900 mm over the cloth
  // The lamps moved off that line (X, Y, Z in mm): a room's light not over the table's
  // middle casts its shadows sideways.
  cv::Vec3d lamp_shift_mm{0, 0, 0};
  // Radius of each lamp (a disc facing down): the shadows' penumbra and the highlights'
  // width. A billiard lamp's shade is 300-500 mm across; 70 mm is a bare bulb's reflector.
  double lamp_radius_mm = 70;
  // The floor's tiles (RGB albedo): a warm grey by default; a wooden floor is about
  // (150, 95, 55), a red carpet (120, 30, 35).
  cv::Vec3d floor_rgb{128, 118, 104};
  double light_gain = 1.0;    // overall exposure
  // Colour the camera records the lamps' white as (RGB gains): what the camera's white
  // balance leaves of warm bar lamps or cool daylight (kWarmBarLamps, kDaylight).
  // (1, 1, 1): neutral.
  cv::Vec3d light_rgb{1, 1, 1};
  // How the camera turns light into pixel values. Linear: in proportion, clipped at 255 (the
  // renderer's colours are the albedos as recorded under the lamps). sRGB: the colours are
  // sRGB albedos, the light adds up in linear units and the image is encoded with the sRGB
  // transfer curve, as a phone's processing does: shadows and shading are lighter, the
  // highlights clip the same.
  bool srgb_tone = false;
  double vignetting = 0.25;   // brightness lost in the image corners
  double blur_sigma = 0.5;    // px
  // A handheld camera's shake during the exposure (live video): a smear of this many
  // pixels along motion_blur_angle_deg, after the lens blur. 0 = none.
  double motion_blur_px = 0;
  double motion_blur_angle_deg = 0;
  double noise_sigma = 2.0;   // gray levels
  // A phone's sharpening after its noise: img + amount * (img - Gaussian(img, sigma)),
  // which rings dark and light along every edge. 0 = none.
  double sharpen_amount = 0;
  double sharpen_sigma_px = 1.0;
  int jpeg_quality = 90;      // 0 = no JPEG round trip
};

// PoolScene::light_rgb of bar lamps of about 3000 K under a camera whose white balance
// corrected half of it, and of daylight from a window through the same balance.
inline const cv::Vec3d kWarmBarLamps{1.0, 0.9, 0.72};
inline const cv::Vec3d kDaylight{0.88, 0.96, 1.08};

struct PoolBallTruth {
  int number = 0;
  double x_mm = 0, y_mm = 0;  // centre at Z = ball radius
  cv::Point2d pixel;          // projection of the centre (distorted image pixels)
  int visible_pixels = 0;     // pixels where this ball is the first surface hit
  bool separated = false;     // fully visible and not touching another ball in the image
};

struct PoolView {
  cv::Mat image;  // CV_8UC3 BGR
  cv::Matx33d camera_matrix;
  std::vector<double> distortion;  // k1 k2 p1 p2 k3
  cv::Matx33d rotation;            // table -> camera
  cv::Vec3d translation;
  // Playing-surface corners (Z = 0) in the order (0,0), (L,0), (L,W), (0,W), image pixels.
  std::array<cv::Point2d, 4> cloth_corners;
  // Outer corners of the cloth-covered cushion tops (Z = cushion height), same order.
  std::array<cv::Point2d, 4> cushion_corners;
  std::vector<PoolBallTruth> balls;
};

// Renders the scene; deterministic for (scene, seed).
PoolView RenderPoolView(const PoolScene& scene, uint64_t seed);

// The rotation (table -> camera) of `cam`: its optical axis towards look_at_mm, its image
// x axis horizontal (before the roll).
cv::Matx33d PoolCameraRotation(const PoolCamera& cam);

// Projects a table-frame point with the view's camera (distortion included).
cv::Point2d ProjectTablePoint(const PoolView& view, const cv::Vec3d& point_mm);

// A camera at `side`, with its optical axis `elevation_deg` below the horizontal, moved
// back until the whole table (rails included) fits the image with `margin` (fraction of
// the image) to spare.
PoolCamera FramedPoolCamera(const PoolTableSpec& table, PoolViewSide side,
                            double elevation_deg, double horizontal_fov_deg,
                            double azimuth_offset_deg = 0, double roll_deg = 0,
                            double margin = 0.04, cv::Size image_size = {640, 480});

// Random ball layout: the cue and `count - 1` numbered balls (always including the 9),
// non-overlapping, some frozen against a cushion and some touching another ball when
// `allow_touching`.
std::vector<PoolBallPlacement> RandomPoolLayout(std::mt19937_64& rng, const PoolTableSpec& table,
                                                int count, bool allow_touching);

// A random scene as the benchmark uses: random layout of 6..10 balls, random side,
// elevation min_elevation_deg..max_elevation_deg (30..65), field of view 55..70, roll
// within +-max_roll_deg (6), slight distortion, 1..3 lamps, exposure, blur 0.3..1.0, noise
// 1..4, JPEG 70..95. The ranges change only the elevation and the roll: the same draws
// make the same scenes.
PoolScene RandomPoolScene(std::mt19937_64& rng, const PoolTableSpec& table,
                          bool allow_touching = true, double min_elevation_deg = 30,
                          double max_elevation_deg = 65, double max_roll_deg = 6);

// A handheld camera's shake for one frame, from its own stream `stream_seed` (so the scene
// is otherwise what it was): a smear of up to `max_px` pixels in any direction.
void DrawPoolShake(uint64_t stream_seed, double max_px, PoolScene* scene);

// A cue stick aimed through the cue ball at a random other ball (a random direction when
// the cue is alone), its tip 30-80 mm behind the cue ball, rising 4-10 degrees.
PoolCueStick AimedCueStick(std::mt19937_64& rng, const PoolTableSpec& table,
                           const std::vector<PoolBallPlacement>& balls);

// The same view from a camera with `scale` times the pixels each way (the image size and
// the blur in pixels scaled alike, as a sharper sensor behind the same optics would see).
void ScalePoolCamera(PoolScene* scene, double scale);

// Ground truth as JSON text (camera, pose, corners, balls) for writing beside an image.
std::string PoolViewGroundTruthJson(const PoolScene& scene, const PoolView& view);

}  // namespace texfree::testdata

#endif  // TEXFREE_TESTS_DATA_POOL_RENDERER_H_
