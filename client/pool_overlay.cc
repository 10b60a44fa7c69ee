// Pool overlays in perspective and the top view.
#include "client/pool_overlay.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <opencv2/imgproc.hpp>

namespace texfree::client {
namespace {

cv::Scalar Bgr(const v1::Color& c) { return cv::Scalar(c.b(), c.g(), c.r()); }

std::vector<cv::Point> Points(const google::protobuf::RepeatedPtrField<v1::Point2>& in,
                              int shift) {
  std::vector<cv::Point> out;
  for (const auto& p : in)
    out.emplace_back(static_cast<int>(std::lround(p.x() * (1 << shift))),
                     static_cast<int>(std::lround(p.y() * (1 << shift))));
  return out;
}

cv::Scalar BallBgr(int number) {
  static const cv::Scalar kColours[] = {{235, 235, 235}, {20, 200, 250}, {180, 70, 30},
                                        {40, 40, 220},   {130, 40, 100}, {20, 120, 250},
                                        {60, 130, 20},   {40, 40, 130},  {25, 25, 25},
                                        {20, 200, 250}};
  return number >= 0 && number < 10 ? kColours[number] : cv::Scalar(150, 150, 150);
}

}  // namespace

void DrawOverlays(cv::Mat& image,
                  const google::protobuf::RepeatedPtrField<v1::Overlay>& overlays) {
  constexpr int kShift = 4;  // sub-pixel drawing
  for (const auto& o : overlays) {
    const cv::Scalar colour = Bgr(o.color());
    const int thickness = std::max(1, static_cast<int>(std::lround(o.thickness())));
    const std::vector<cv::Point> pts = Points(o.points(), kShift);
    const double opacity = o.opacity() <= 0 ? 1.0 : std::min(1.0, o.opacity());
    cv::Mat layer = opacity < 1 ? image.clone() : image;
    switch (o.kind()) {
      case v1::Overlay::POLYLINE:
      case v1::Overlay::POLYGON:
        if (pts.size() >= 2)
          cv::polylines(layer, pts, o.kind() == v1::Overlay::POLYGON, colour, thickness,
                        cv::LINE_AA, kShift);
        break;
      case v1::Overlay::FILLED_POLYGON:
        if (pts.size() >= 3) cv::fillPoly(layer, std::vector<std::vector<cv::Point>>{pts}, colour,
                                          cv::LINE_AA, kShift);
        break;
      case v1::Overlay::CIRCLE:
        if (!pts.empty())
          cv::circle(layer, pts[0], static_cast<int>(std::lround(o.radius() * (1 << kShift))),
                     colour, thickness, cv::LINE_AA, kShift);
        break;
      case v1::Overlay::TEXT:
        if (!pts.empty()) {
          const double scale = std::max(0.3, o.font_size_px() / 22.0);
          const cv::Point at(pts[0].x >> kShift, pts[0].y >> kShift);
          cv::putText(layer, o.text(), at, cv::FONT_HERSHEY_SIMPLEX, scale, cv::Scalar(0, 0, 0),
                      3, cv::LINE_AA);
          cv::putText(layer, o.text(), at, cv::FONT_HERSHEY_SIMPLEX, scale, colour, 1,
                      cv::LINE_AA);
        }
        break;
      default:
        break;
    }
    if (opacity < 1) cv::addWeighted(layer, opacity, image, 1 - opacity, 0, image);
  }
}

cv::Mat RenderPoolTopView(const v1::AnalyzeTableResponse& response, double length_mm,
                          double width_mm, double ball_radius_mm, double scale) {
  const double rail = 4 * ball_radius_mm;
  const int w = static_cast<int>(std::lround((length_mm + 2 * rail) * scale));
  const int h = static_cast<int>(std::lround((width_mm + 2 * rail) * scale));
  cv::Mat view(h, w, CV_8UC3, cv::Scalar(30, 60, 110));  // wooden rail
  // Table frame -> view pixels: X right, Y up (origin at the bottom-left corner).
  auto px = [&](double x, double y) {
    return cv::Point(static_cast<int>(std::lround((x + rail) * scale * 16)),
                     static_cast<int>(std::lround((width_mm + rail - y) * scale * 16)));
  };
  cv::rectangle(view, px(0, width_mm), px(length_mm, 0), cv::Scalar(90, 128, 40), cv::FILLED,
                cv::LINE_AA, 4);
  const double pocket = 2.1 * ball_radius_mm;
  for (const auto& p : {cv::Point2d(0, 0), cv::Point2d(length_mm, 0), cv::Point2d(length_mm, width_mm),
                        cv::Point2d(0, width_mm), cv::Point2d(length_mm / 2, -ball_radius_mm * 0.5),
                        cv::Point2d(length_mm / 2, width_mm + ball_radius_mm * 0.5)})
    cv::circle(view, px(p.x, p.y), static_cast<int>(pocket * scale * 16), cv::Scalar(15, 15, 15),
               cv::FILLED, cv::LINE_AA, 4);
  const int radius = static_cast<int>(std::lround(ball_radius_mm * scale * 16));
  if (response.shots_size() > 0) {
    const v1::Shot& shot = response.shots(0);
    for (const auto& path : shot.paths()) {
      std::vector<cv::Point> line;
      for (const auto& q : path.path_mm()) line.push_back(px(q.x(), q.y()));
      if (line.size() >= 2)
        cv::polylines(view, line, false, path.number() == 0 ? cv::Scalar(255, 255, 255)
                                                            : BallBgr(path.number()),
                      2, cv::LINE_AA, 4);
      if (!line.empty())
        cv::circle(view, line.back(), radius, cv::Scalar(200, 200, 200), 1, cv::LINE_AA, 4);
    }
  }
  for (const auto& b : response.balls()) {
    const cv::Point c = px(b.x_mm(), b.y_mm());
    cv::circle(view, c, radius, BallBgr(b.number()), cv::FILLED, cv::LINE_AA, 4);
    if (b.number() == 9)
      cv::circle(view, c, radius / 2, cv::Scalar(255, 255, 255), cv::FILLED, cv::LINE_AA, 4);
    cv::circle(view, c, radius, cv::Scalar(0, 0, 0), 1, cv::LINE_AA, 4);
    const std::string label = b.number() < 0 ? "?" : (b.number() == 0 ? "" : std::to_string(b.number()));
    if (!label.empty())
      cv::putText(view, label, cv::Point(c.x / 16 - 4, c.y / 16 + 4), cv::FONT_HERSHEY_SIMPLEX,
                  0.4, b.number() == 8 ? cv::Scalar(255, 255, 255) : cv::Scalar(0, 0, 0), 1,
                  cv::LINE_AA);
  }
  if (response.shots_size() > 0)
    cv::putText(view, response.shots(0).description(), cv::Point(8, h - 8),
                cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
  return view;
}

}  // namespace texfree::client
