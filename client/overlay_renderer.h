// Draws registered pages and their annotations onto camera images in
// perspective: page outlines, text glued to the page, highlights, link and
// media boxes. Works on plain OpenCV types so that `doc retrieve --overlay` and
// `track` share it.
#pragma once

#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "client/annotation.h"

namespace cv::freetype {
class FreeType2;
}

namespace texfree::client {

// One matched page to draw.
struct OverlayPage {
  // Registration-image pixels -> image pixels.
  cv::Matx33d homography = cv::Matx33d::eye();
  // Registration image size (the page's outline is its 4 corners).
  cv::Size2d page_size;
  std::string title;  // drawn near the outline's first corner when non-empty
  std::vector<PageAnnotation> annotations;
};

class OverlayRenderer {
 public:
  struct Options {
    // TrueType font for text; when it cannot be loaded, OpenCV's Hershey font
    // is used.
    std::string font_path = "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf";
    int outline_thickness = 3;
    bool draw_outline = true;
    bool draw_title = true;
    bool draw_annotations = true;
  };

  OverlayRenderer();
  explicit OverlayRenderer(Options options);
  ~OverlayRenderer();
  OverlayRenderer(const OverlayRenderer&) = delete;
  OverlayRenderer& operator=(const OverlayRenderer&) = delete;

  // Draws one page onto `image` (8-bit BGR, modified in place). `page_index`
  // picks the outline colour from a fixed palette.
  void DrawPage(cv::Mat& image, const OverlayPage& page,
                int page_index = 0) const;

  // Draws every page.
  void DrawPages(cv::Mat& image, const std::vector<OverlayPage>& pages) const;

  // The page outline alone (closed polygon through the 4 mapped page corners).
  void DrawOutline(cv::Mat& image, const cv::Matx33d& homography,
                   const cv::Size2d& page_size, const cv::Scalar& bgr) const;

  // One annotation, mapped by `homography` (registration pixels -> image
  // pixels).
  void DrawAnnotation(cv::Mat& image, const cv::Matx33d& homography,
                      const PageAnnotation& annotation) const;

  // Text rendered in registration coordinates with its baseline starting at
  // `origin` and height `font_size_px`, warped by `homography` and
  // alpha-blended: it looks printed on the page.
  void DrawWarpedText(cv::Mat& image, const cv::Matx33d& homography,
                      const std::string& text, const cv::Point2d& origin,
                      double font_size_px, const Rgba& color) const;

  // Fills the quad `rect` mapped by `homography` with `bgr` at `opacity`
  // (0..1).
  static void FillQuad(cv::Mat& image, const cv::Matx33d& homography,
                       const cv::Rect2d& rect, const cv::Scalar& bgr,
                       double opacity);

  // Maps points by a homography; returns false if a point falls behind the
  // camera (w <= 0) or is not finite.
  static bool MapPoints(const cv::Matx33d& homography,
                        const std::vector<cv::Point2d>& in,
                        std::vector<cv::Point2d>* out);

  // Distinct outline colours (BGR) for pages 0, 1, 2, ...
  static cv::Scalar PaletteColor(int index);

  bool has_truetype_font() const { return font_ != nullptr; }

 private:
  // Renders text into a single-channel coverage mask; returns the mask and sets
  // `baseline_y` (row of the baseline in the mask) and `left_x`.
  cv::Mat RenderTextMask(const std::string& text, int height_px,
                         int* baseline_y, int* left_x) const;

  Options options_;
  cv::Ptr<cv::freetype::FreeType2> font_;
};

}  // namespace texfree::client
