// Drawing of the pool assistant's results: the server's overlay primitives (table
// outline, balls, shot paths already placed in the image, i.e. in perspective) onto a
// photograph or video frame, and the seed's 2D style: a top view of the table with the
// balls and the suggested shot.
#pragma once

#include <opencv2/core.hpp>

#include "texfree/v1/common.pb.h"
#include "texfree/v1/pool.pb.h"

namespace texfree::client {

// Draws every overlay (polyline, polygon, filled polygon, circle, text) onto `image`
// (8-bit BGR, in place).
void DrawOverlays(cv::Mat& image,
                  const google::protobuf::RepeatedPtrField<v1::Overlay>& overlays);

// A top view (2D style, seed figure 4.8a) of a `length_mm` x `width_mm` table, `scale`
// pixels per millimetre: cloth, cushions, pockets, the balls with their numbers and the
// paths of the first shot.
cv::Mat RenderPoolTopView(const v1::AnalyzeTableResponse& response, double length_mm,
                          double width_mm, double ball_radius_mm, double scale = 0.4);

}  // namespace texfree::client
