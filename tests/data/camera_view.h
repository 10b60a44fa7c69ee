// Synthetic camera photographs of a page: pinhole projection with an exact
// ground-truth homography and pose, then lens blur, uneven light, sensor noise
// and JPEG compression. Optionally the page curls off the desk and the lens
// distorts radially; the homography is then the flat page's nominal one and
// ProjectPagePoint gives where a page point truly lands.
//
// Camera model: world = page plane Z = 0 in page pixel units (x right, y
// down); the camera z axis points into the page. An untilted, unrolled camera
// shows the page upright. H = K [r1 r2 t] maps page pixels to image pixels,
// pixel centres at integer coordinates in both.
#ifndef TEXFREE_TESTS_DATA_CAMERA_VIEW_H_
#define TEXFREE_TESTS_DATA_CAMERA_VIEW_H_

#include <cstdint>
#include <opencv2/core.hpp>
#include <random>
#include <string>

namespace texfree::testdata {

struct CameraViewOptions {
  cv::Size image_size{640, 480};
  double horizontal_fov_deg = 60;     // sets fx = fy
  double tilt_deg = 0;                // angle between optical axis and normal
  double tilt_azimuth_deg = 0;        // direction of the tilt in the page plane
  double roll_deg = 0;                // in-plane rotation around the axis
  double scale = 1.0;                 // image px per page px at image centre
  cv::Point2d look_at{-1, -1};        // page point at the image centre;
                                      // (-1,-1) = page centre
  double blur_sigma = 0;              // lens defocus (Gaussian or disk), px
  double noise_sigma = 0;             // additive Gaussian noise, gray levels
  double illumination_gradient = 0;   // 0..0.7: uneven light strength (linear
                                      // ramp + vignette + soft shadow)
  int jpeg_quality = 0;               // 0 = no JPEG round trip, else 1..100
  cv::Scalar background{60, 70, 80};  // desk colour around the page
  // Real pages do not lie flat: the sheet lifts off the desk towards the
  // camera by up to `page_curl` page widths, quadratically along the page
  // direction `curl_azimuth_deg` (0 = page x), from the middle line towards
  // both edges (a sheet that has been folded) or, with `curl_one_sided`, from
  // one edge to the other (a page lying in an open book). A height field: the
  // sheet's stretch (under 1% at a lift of 0.1) is not modelled.
  double page_curl = 0;
  double curl_azimuth_deg = 0;
  bool curl_one_sided = false;
  // Radial lens distortion (OpenCV's k1 on normalised coordinates; < 0 barrel,
  // as a phone's wide lens). 0 = ideal pinhole.
  double radial_k1 = 0;
  // Motion blur of a handheld camera during the exposure: a smear of this
  // length (pixels) along `motion_blur_angle_deg` (0 = image x), after the
  // lens blur. 0 = none.
  double motion_blur_px = 0;
  double motion_blur_angle_deg = 0;
  // Glare: a lamp reflected by glossy paper, a veil of light added over a soft
  // (Gaussian) spot of `glare_radius` image diagonals centred at `glare_centre`
  // (fractions of the image width and height). `glare` is the veil's peak as a
  // share of white: from about 0.3 on, the page's white clips at the centre and
  // the text there fades out. 0 = none.
  double glare = 0;
  double glare_radius = 0.12;
  cv::Point2d glare_centre{0.5, 0.5};
};

struct CameraView {
  cv::Mat image;              // CV_8UC3, image_size
  cv::Matx33d homography;     // page pixels -> image pixels (exact)
  cv::Matx33d camera_matrix;  // K
  cv::Matx33d rotation;       // world->camera, world = page plane Z=0
  cv::Vec3d translation;      // world->camera, page pixel units
};

// The pinhole geometry alone (K, R, t, H) for the options and a page size.
CameraView ComputeCameraGeometry(const cv::Size& page_size,
                                 const CameraViewOptions& options);

// Renders the page as seen by a pinhole camera with the given pose, then
// applies blur, uneven light, noise and JPEG in that order. Deterministic for
// (page, options, seed).
CameraView RenderCameraView(const cv::Mat& page,
                            const CameraViewOptions& options, uint64_t seed);

// Random view in the ranges the benchmark uses: tilt uniform in
// [0, max_tilt_deg], random azimuth, roll uniform in [-180, 180], scale uniform
// in [min_scale, max_scale], look_at inside the page's middle region, blur
// 0..1.5, noise 0..6, gradient 0..0.5, JPEG quality 60..95, random desk colour
// and field of view 50..70 degrees. Portable: uses no std distributions.
CameraViewOptions RandomViewOptions(std::mt19937_64& rng,
                                    const cv::Size& page_size,
                                    double max_tilt_deg = 40,
                                    double min_scale = 0.6,
                                    double max_scale = 1.3);

// Real-world bends of one view, drawn from their own stream `stream_seed` (so that the view
// is otherwise what it was without them): a sheet lifted by up to max_curl page widths
// (half bowed, half curled from one edge, any azimuth), a radial k1 in
// [-max_k1, max_k1 / 2] (mostly barrel) and camera shake of up to max_motion_px pixels in
// any direction. Portable: uses no std distributions.
void DrawBends(uint64_t stream_seed, double max_curl, double max_k1, double max_motion_px,
               CameraViewOptions* options);

// A camera's shake during the exposure: a straight smear of `length` pixels along
// `angle_deg` (0 = image x), anti-aliased at its ends, normalised to sum 1.
cv::Mat MotionBlurKernel(double length, double angle_deg);

// Glare of one view, from its own stream: a veil of up to max_glare (CameraViewOptions::glare)
// over a spot of 0.06-0.18 image diagonals centred anywhere in the middle 70% of the image.
void DrawGlare(uint64_t stream_seed, double max_glare, CameraViewOptions* options);

// Mean distance in image pixels between where `estimated` and `truth` (both page ->
// image) put an 11 x 11 grid of page points, over the points `truth` places inside the
// image. Returns 1e9 when no grid point is visible.
double MeanHomographyError(const cv::Matx33d& estimated, const cv::Matx33d& truth,
                           const cv::Size& page_size, const cv::Size& image_size);

// Where page point `page_point` (page pixels) lands in the image of `view`,
// rendered with `options`: on the curled sheet, through the distorting lens.
// Equals the homography's mapping when the page is flat and the lens ideal.
// NaN for a point behind the camera or past the field over which the lens
// model is monotonic.
cv::Point2d ProjectPagePoint(const CameraView& view, const CameraViewOptions& options,
                             const cv::Size& page_size, const cv::Point2d& page_point);

// `image` (a render of `view` with `options`, or a copy of it) as an ideal pinhole with the
// same camera matrix sees it: the lens's radial_k1 undone. `options` then describes the
// undistorted image (radial_k1 = 0), for ProjectPagePoint and MeanProjectionError.
cv::Mat UndistortView(const cv::Mat& image, const CameraView& view, CameraViewOptions* options);

// As MeanHomographyError, against the view's true projection (ProjectPagePoint):
// for a curled page or a distorting lens no homography is exact, and this is
// the error a user sees.
double MeanProjectionError(const cv::Matx33d& estimated, const CameraView& view,
                           const CameraViewOptions& options, const cv::Size& page_size);

// Ground truth as JSON text (homography, K, R, t, options) for writing beside
// an image.
std::string CameraViewGroundTruthJson(const CameraView& view,
                                      const CameraViewOptions& options);

}  // namespace texfree::testdata

#endif  // TEXFREE_TESTS_DATA_CAMERA_VIEW_H_
