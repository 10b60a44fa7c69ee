// VideoKeypointExtractor implementation: measurement reuse, and rectified extraction of
// pages seen at a slant.
#include "common/video_keypoints.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "absl/strings/str_cat.h"
#include "common/planar_pose.h"

namespace texfree {
namespace {

WordKeypointOptions WithHalfResolution(WordKeypointOptions o, double above) {
  o.half_resolution_above_char_height = above;
  return o;
}

// Video measures text on whole frames of a page seen from afar and on small rectified
// parts of a page, with a few dozen letters: there the area-weighted first size (made for
// large type under noise, on whole pages) lets a heading's few large blobs decide (the
// orbit-far benchmark's rectified crop measured 13 px for 5.3 px text, and the page was
// lost every other frame from 33 deg on). The plain median of the blobs does not.
WordKeypointOptions ForVideo(WordKeypointOptions o) {
  o.area_weighted_text_size = false;
  return o;
}

// Frame grid sampled to find the part of a page in view and how the frame magnifies it.
constexpr int kSamplesX = 17, kSamplesY = 13;

// Projects p by H; false when p is at or behind the horizon (w <= 0).
bool Project(const cv::Matx33d& H, const cv::Point2d& p, cv::Point2d* out) {
  const cv::Vec3d v = H * cv::Vec3d(p.x, p.y, 1);
  if (!(v[2] > 1e-12)) return false;
  *out = cv::Point2d(v[0] / v[2], v[1] / v[2]);
  return std::isfinite(out->x) && std::isfinite(out->y);
}

// Singular values of the homography's Jacobian at page point p (frame pixels per page
// pixel along the most squeezed and the most stretched direction); 0 and 0 behind the
// horizon.
void LocalScales(const cv::Matx33d& H, const cv::Point2d& p, double* smallest, double* largest) {
  const cv::Matx22d J = HomographyJacobian(H, p).value_or(cv::Matx22d::zeros());
  const double a = J(0, 0), b = J(0, 1), c = J(1, 0), d = J(1, 1);
  const double frobenius = a * a + b * b + c * c + d * d;
  const double det = a * d - b * c;
  const double root = std::sqrt(std::max(0.0, frobenius * frobenius - 4 * det * det));
  *largest = std::sqrt((frobenius + root) / 2);
  *smallest = std::sqrt(std::max(0.0, (frobenius - root) / 2));
}

// A word of the rectified image is kept when it lies well inside it and its blob cannot
// reach the frame's border (u: rectified pixels).
bool InnerPart(const RectifiedPage& page, const cv::Point2d& u) {
  const double margin_x = 2 * page.char_height, margin_y = page.char_height;
  if (!(u.x >= margin_x && u.y >= margin_y && u.x < page.size.width - margin_x &&
        u.y < page.size.height - margin_y))
    return false;
  const cv::Point2d probes[] = {
      {u.x - margin_x, u.y}, {u.x + margin_x, u.y}, {u.x, u.y - margin_y}, {u.x, u.y + margin_y}};
  for (const cv::Point2d& probe : probes) {
    cv::Point2d x;
    if (!Project(page.to_frame, probe, &x) || x.x < 1 || x.y < 1 ||
        x.x > page.frame_size.width - 2 || x.y > page.frame_size.height - 2)
      return false;
  }
  return true;
}

}  // namespace

bool TakenByRectified(const RectifiedPage& page, const cv::Point2f& frame_point) {
  cv::Matx33d from_frame;
  if (cv::invert(page.to_frame, from_frame, cv::DECOMP_LU) == 0) return false;
  const cv::Vec3d v = from_frame * cv::Vec3d(frame_point.x, frame_point.y, 1);
  if (std::abs(v[2]) < 1e-12) return false;
  const cv::Point2d u(v[0] / v[2], v[1] / v[2]);
  cv::Point2d back;
  return Project(page.to_frame, u, &back) && InnerPart(page, u);
}

absl::Status VideoKeypointOptions::Validate() const {
  if (measure_every_frames < 1)
    return absl::InvalidArgumentError(
        absl::StrCat("measure_every_frames must be >= 1, got ", measure_every_frames));
  if (measure_phase < 0)
    return absl::InvalidArgumentError(
        absl::StrCat("measure_phase must be >= 0, got ", measure_phase));
  if (!(remeasure_below_ratio >= 0 && remeasure_below_ratio <= 1))
    return absl::InvalidArgumentError(
        absl::StrCat("remeasure_below_ratio must be in [0, 1], got ", remeasure_below_ratio));
  if (!(half_resolution_above_char_height >= 0))
    return absl::InvalidArgumentError(
        absl::StrCat("half_resolution_above_char_height must be >= 0 (0: never), got ",
                     half_resolution_above_char_height));
  if (!(rectify_above_perspective == 0 || rectify_above_perspective >= 1))
    return absl::InvalidArgumentError(absl::StrCat(
        "rectify_above_perspective must be 0 (never) or >= 1, got ", rectify_above_perspective));
  if (!(rectified_min_char_height >= 2.5 && rectified_char_height >= rectified_min_char_height &&
        rectified_char_height <= 64))
    return absl::InvalidArgumentError(absl::StrCat(
        "rectified text height: need 2.5 <= rectified_min_char_height (", rectified_min_char_height,
        ") <= rectified_char_height (", rectified_char_height, ") <= 64"));
  if (!(max_rectify_upsampling >= 1 && max_rectify_upsampling <= 16))
    return absl::InvalidArgumentError(
        absl::StrCat("max_rectify_upsampling must be in [1, 16], got ", max_rectify_upsampling));
  if (!(max_median_upsampling >= 1 && max_median_upsampling <= 16))
    return absl::InvalidArgumentError(
        absl::StrCat("max_median_upsampling must be in [1, 16], got ", max_median_upsampling));
  if (!(max_rectified_area > 0 && max_rectified_area <= 16))
    return absl::InvalidArgumentError(
        absl::StrCat("max_rectified_area must be in (0, 16], got ", max_rectified_area));
  return absl::OkStatus();
}

VideoKeypointExtractor::VideoKeypointExtractor(const WordKeypointOptions& keypoints,
                                               VideoKeypointOptions options)
    : options_(options),
      measuring_(ForVideo(keypoints)),
      reusing_(WithHalfResolution(ForVideo(keypoints), options.half_resolution_above_char_height)),
      rectified_(WithHalfResolution(ForVideo(keypoints), 0)) {}

void VideoKeypointExtractor::Reset() {
  known_.reset();
  pages_.clear();
}

WordKeypoints VideoKeypointExtractor::Measure(const cv::Mat& gray) {
  WordKeypoints result = measuring_.Extract(gray);
  // The first measurement of a stream sets its phase in the cycle.
  frames_since_measure_ = known_ ? 0 : options_.PhaseInCycle();
  measured_keypoints_ = result.points.size();
  if (result.char_height > 0)
    known_ = TextGeometry{result.char_height, result.text_angle_rad};
  else
    known_.reset();
  return result;
}

WordKeypoints VideoKeypointExtractor::Extract(const cv::Mat& gray, bool* measured) {
  if (measured) *measured = true;
  if (!known_ || ++frames_since_measure_ >= options_.measure_every_frames) return Measure(gray);
  WordKeypoints result = reusing_.Extract(gray, *known_);
  if (result.points.size() < options_.remeasure_below_ratio * measured_keypoints_)
    return Measure(gray);
  if (measured) *measured = false;
  return result;
}

WordKeypoints VideoKeypointExtractor::Extract(const cv::Mat& gray,
                                              const std::vector<PageInView>& pages,
                                              VideoFrameInfo* info) {
  VideoFrameInfo local;
  VideoFrameInfo& done = info ? *info : local;
  done = VideoFrameInfo();
  // Forget the text of pages no longer followed.
  for (auto it = pages_.begin(); it != pages_.end();) {
    const bool followed = std::any_of(pages.begin(), pages.end(),
                                      [&](const PageInView& p) { return p.document == it->first; });
    it = followed ? std::next(it) : pages_.erase(it);
  }
  const bool rectify = options_.rectify_above_perspective > 0 && !pages.empty();
  // Pages at a slant, rectified (the frame's text height is needed for a first guess of
  // a page's).
  std::vector<cv::Point2f> rectified;
  auto rectify_pages = [&](double frame_char_height) {
    for (const PageInView& page : pages) {
      RectifiedPage report;
      if (ExtractRectified(gray, page, frame_char_height, &rectified, &report))
        done.rectified.push_back(report);
    }
  };
  auto taken = [&](const cv::Point2f& x) {
    return std::any_of(done.rectified.begin(), done.rectified.end(),
                       [&](const RectifiedPage& r) { return TakenByRectified(r, x); });
  };
  if (rectify && known_) rectify_pages(known_->char_height);
  // Between two measurements of the frame, when every page is rectified, the pages are
  // all that is extracted: their rectified parts, and their far parts, too squeezed to
  // rectify, from the frame itself.
  if (rectify && known_ && frames_since_measure_ + 1 < options_.measure_every_frames &&
      done.rectified.size() == pages.size()) {
    ++frames_since_measure_;
    done.whole_frame = false;
    WordKeypoints pages_only;
    pages_only.char_height = known_->char_height;
    pages_only.text_angle_rad = known_->text_angle_rad;
    for (const RectifiedPage& page : done.rectified) {
      if (page.unresolved.area() <= 0) continue;
      const WordKeypoints band = reusing_.Extract(gray(page.unresolved), *known_);
      for (cv::Point2f x : band.points) {
        x += cv::Point2f(page.unresolved.tl());
        if (!taken(x)) pages_only.points.push_back(x);
      }
    }
    pages_only.points.insert(pages_only.points.end(), rectified.begin(), rectified.end());
    return pages_only;
  }
  const bool first = !known_;
  WordKeypoints result = Extract(gray, &done.measured);
  if (!rectify) return result;
  if (first && result.char_height > 0) rectify_pages(result.char_height);
  if (done.rectified.empty()) return result;
  // The frame's keypoints make way for the rectified ones where those are taken.
  std::vector<cv::Point2f> points;
  points.reserve(result.points.size() + rectified.size());
  for (const cv::Point2f& x : result.points)
    if (!taken(x)) points.push_back(x);
  const int replaced = static_cast<int>(result.points.size() - points.size());
  if (done.rectified.size() == 1) done.rectified[0].replaced = replaced;
  points.insert(points.end(), rectified.begin(), rectified.end());
  result.points = std::move(points);
  return result;
}

bool VideoKeypointExtractor::ExtractRectified(const cv::Mat& gray, const PageInView& page,
                                              double frame_char_height,
                                              std::vector<cv::Point2f>* points,
                                              RectifiedPage* report) {
  const cv::Matx33d& H = page.page_to_frame;
  cv::Matx33d inverse;
  if (cv::invert(H, inverse, cv::DECOMP_LU) == 0 || page.area.area() <= 0) return false;
  // Frame samples on the page's text area: where they are, and how the frame scales the
  // page there.
  struct Sample {
    cv::Point2d page;
    double smallest, largest;
  };
  std::vector<Sample> samples;
  for (int gy = 0; gy < kSamplesY; ++gy) {
    for (int gx = 0; gx < kSamplesX; ++gx) {
      const cv::Point2d x(gx * (gray.cols - 1.0) / (kSamplesX - 1),
                          gy * (gray.rows - 1.0) / (kSamplesY - 1));
      const cv::Vec3d v = inverse * cv::Vec3d(x.x, x.y, 1);
      if (std::abs(v[2]) < 1e-12) continue;
      const cv::Point2d p(v[0] / v[2], v[1] / v[2]);
      cv::Point2d back;
      if (!Project(H, p, &back) || !page.area.contains(cv::Point2f(p))) continue;
      Sample s{p, 0, 0};
      LocalScales(H, p, &s.smallest, &s.largest);
      if (s.smallest > 0) samples.push_back(s);
    }
  }
  if (samples.size() < 6) return false;
  std::vector<double> magnification;
  for (const Sample& s : samples) magnification.push_back(std::sqrt(s.smallest * s.largest));
  std::sort(magnification.begin(), magnification.end());
  if (magnification.back() < options_.rectify_above_perspective * magnification.front())
    return false;

  PageText& text = pages_[page.document];
  // The rectified image at `scale` rectified pixels per page pixel: the region of the page
  // it covers (the scale shrinks to fit the pixel budget), its pixels and its mapping.
  const double budget = options_.max_rectified_area * gray.total();
  cv::Rect2d region;
  cv::Matx33d to_frame;
  cv::Size size;
  cv::Mat image;
  auto rectify = [&](double& scale, double max_upsampling) {
    for (int round = 0; round < 3; ++round) {
      double x0 = 1e300, y0 = 1e300, x1 = -1e300, y1 = -1e300;
      for (const Sample& s : samples) {
        if (scale > max_upsampling * s.smallest) continue;
        x0 = std::min(x0, s.page.x);
        y0 = std::min(y0, s.page.y);
        x1 = std::max(x1, s.page.x);
        y1 = std::max(y1, s.page.y);
      }
      if (!(x1 > x0 && y1 > y0)) return false;
      region = cv::Rect2d(x0, y0, x1 - x0, y1 - y0) & cv::Rect2d(page.area);
      if (region.area() * scale * scale <= budget) break;
      scale = std::sqrt(budget / region.area()) * 0.99;  // smaller text, and a wider region
    }
    if (region.area() <= 0 || region.area() * scale * scale > budget * 1.01) return false;
    // Rectified pixel u -> page origin + u / scale -> frame.
    const cv::Matx33d to_page(1 / scale, 0, region.x, 0, 1 / scale, region.y, 0, 0, 1);
    to_frame = H * to_page;
    size = cv::Size(std::max(1, static_cast<int>(std::ceil(region.width * scale))),
                    std::max(1, static_cast<int>(std::ceil(region.height * scale))));
    // Outside the frame the border is replicated: no step between paper and a fill value
    // for the thresholding to take for ink.
    cv::warpPerspective(gray, image, cv::Mat(to_frame), size,
                        cv::INTER_LINEAR | cv::WARP_INVERSE_MAP, cv::BORDER_REPLICATE);
    return true;
  };
  const double target = options_.rectified_char_height;
  // A measurement of the rectified text is believed when it is within this factor of what
  // was expected: one thresholding pass on a blurred, squeezed view can take the wrong
  // structure (line pitch, letter strokes) for the text height.
  constexpr double kMeasureTolerance = 1.5;
  constexpr size_t kMinFirstWords = 20;
  auto plausible = [&](double measured, double expected) {
    return measured > 0 && measured < kMeasureTolerance * expected &&
           measured * kMeasureTolerance > expected;
  };
  WordKeypoints words;
  double scale = 0;
  if (!text.known) {
    // First sight of the page at a slant: its text is measured where the frame sees it
    // best (the nearer half of the samples, not enlarged), then checked at the scale
    // it asks for over the whole region (titles near the camera can mislead the first
    // measurement), and measured again there when it was off.
    std::vector<double> squeezed;
    for (const Sample& s : samples) squeezed.push_back(s.smallest);
    std::sort(squeezed.begin(), squeezed.end());
    // Too few words there (a steep view, or a heading filling a small crop of a page seen
    // from afar, which would be taken for its text): a wider part, enlarged more.
    for (double enlarge = 1; enlarge <= options_.max_rectify_upsampling; enlarge *= 2) {
      scale = squeezed[squeezed.size() / 2];
      if (!rectify(scale, enlarge)) return false;
      words = rectified_.Extract(image);
      if (words.char_height > 0 && words.points.size() >= kMinFirstWords) break;
    }
    if (!(words.char_height > 0)) return false;
    for (int attempt = 0; attempt < 2 && !text.known; ++attempt) {
      scale *= target / words.char_height;
      const double wanted = scale;
      if (!rectify(scale, options_.max_rectify_upsampling)) return false;
      words = rectified_.Extract(image);
      if (plausible(words.char_height, target * scale / wanted)) {
        text.heights.assign(1, words.char_height / scale);
        text.known = TextGeometry{words.char_height / scale, words.text_angle_rad};
        text.frames_since_measure = options_.PhaseInCycle();
        text.measured_keypoints = static_cast<size_t>(1e4 * words.points.size() / image.total());
      } else if (!(words.char_height > 0)) {
        return false;
      }
    }
    if (!text.known) return false;
    if (scale > options_.max_median_upsampling * magnification[magnification.size() / 2])
      return false;
  } else {
    scale = target / text.known->char_height;
    // Small text seen from afar: the rectified image would mostly enlarge the frame, and
    // the frame's own keypoints do better.
    if (scale > options_.max_median_upsampling * magnification[magnification.size() / 2])
      return false;
    if (!rectify(scale, options_.max_rectify_upsampling)) return false;
    const double expected = text.known->char_height * scale;
    if (expected < options_.rectified_min_char_height) return false;
    const TextGeometry known{expected, text.known->text_angle_rad};
    bool measure = ++text.frames_since_measure >= options_.measure_every_frames;
    if (!measure) {
      words = rectified_.Extract(image, known);
      // Far fewer words per pixel than when last measured: measure again.
      measure = 1e4 * words.points.size() / image.total() <
                options_.remeasure_below_ratio * text.measured_keypoints;
    }
    if (measure) {
      text.frames_since_measure = 0;
      WordKeypoints measured = rectified_.Extract(image);
      if (plausible(measured.char_height, expected)) {
        // The page's text height is one number: the median of its recent measurements
        // (a steep view measures less reliably than the first, moderate one).
        text.heights.push_back(measured.char_height / scale);
        if (text.heights.size() > 7) text.heights.erase(text.heights.begin());
        std::vector<double> sorted = text.heights;
        std::sort(sorted.begin(), sorted.end());
        const double page_height = sorted[sorted.size() / 2];
        text.known = TextGeometry{page_height, measured.text_angle_rad};
        words = page_height == measured.char_height / scale
                    ? std::move(measured)
                    : rectified_.Extract(
                          image, TextGeometry{page_height * scale, measured.text_angle_rad});
      } else {
        words = rectified_.Extract(image, known);  // keep what is known
      }
      text.measured_keypoints = static_cast<size_t>(1e4 * words.points.size() / image.total());
    }
  }
  const double h = words.char_height;
  if (!(h > 0)) return false;

  RectifiedPage done;
  done.document = page.document;
  done.scale = scale;
  done.origin = region.tl();
  done.to_frame = to_frame;
  done.size = size;
  done.char_height = h;
  done.frame_size = gray.size();
  // The part of the page in view left out for being too far: the frame's own keypoints
  // are all there is of it.
  cv::Rect2d far;
  for (const Sample& s : samples) {
    if (scale <= options_.max_rectify_upsampling * s.smallest) continue;
    cv::Point2d x;
    if (!Project(H, s.page, &x)) continue;
    far =
        far.area() > 0 ? (far | cv::Rect2d(x, cv::Size2d(1, 1))) : cv::Rect2d(x, cv::Size2d(1, 1));
  }
  if (far.area() > 0) {
    // One sample spacing around the samples.
    const double dx = gray.cols / (kSamplesX - 1.0), dy = gray.rows / (kSamplesY - 1.0);
    far = cv::Rect2d(far.x - dx, far.y - dy, far.width + 2 * dx, far.height + 2 * dy);
    done.unresolved = cv::Rect(far) & cv::Rect(0, 0, gray.cols, gray.rows);
  }
  for (const cv::Point2f& u : words.points) {
    cv::Point2d x;
    if (!InnerPart(done, u) || !Project(to_frame, u, &x)) continue;
    points->emplace_back(static_cast<float>(x.x), static_cast<float>(x.y));
    ++done.keypoints;
  }
  *report = done;
  return true;
}

}  // namespace texfree
