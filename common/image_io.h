// Image decoding and conversion shared by server and client: encoded bytes or raw
// pixel buffers to cv::Mat, with size limits that protect the server.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include <opencv2/core.hpp>

#include "absl/status/statusor.h"

namespace texfree {

struct ImageLimits {
  // Largest accepted image, in pixels (width * height). Default 50 megapixels.
  int64_t max_pixels = 50'000'000;
  // Smallest accepted side, in pixels.
  int min_side = 16;

  absl::Status Validate() const;
};

// Decodes JPEG/PNG/BMP/TIFF bytes into an 8-bit BGR or gray image (flags as cv::imdecode).
// The header is inspected first so that an oversized image is refused before its pixels
// are allocated. Errors: INVALID_ARGUMENT (empty, undecodable, too large, too small).
absl::StatusOr<cv::Mat> DecodeImage(std::string_view bytes, const ImageLimits& limits,
                                    bool grayscale = true);

// Decodes JPEG/PNG/TIFF bytes to one gray channel keeping the bit depth: CV_8UC1 for 8-bit
// files, CV_16UC1 for 16-bit PNG/TIFF (light bursts keep their full dynamic range). Same
// size checks and errors as DecodeImage.
absl::StatusOr<cv::Mat> DecodeGrayKeepDepth(std::string_view bytes, const ImageLimits& limits);

enum class RawPixelFormat { kGray8, kBgr8 };

// Wraps and copies a raw 8-bit buffer; stride 0 means tightly packed.
absl::StatusOr<cv::Mat> ImageFromRaw(std::string_view pixels, RawPixelFormat format, int width,
                                     int height, int stride, const ImageLimits& limits);

// Any 8-bit 1/3/4-channel image to gray (no copy when already gray).
cv::Mat ToGray(const cv::Mat& image);

}  // namespace texfree
