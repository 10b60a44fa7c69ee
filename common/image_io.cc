// Image decoding with header-first size checks.
#include "common/image_io.h"

#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "absl/strings/str_cat.h"
#include "common/status_macros.h"

namespace texfree {
namespace {

absl::Status CheckSize(int width, int height, const ImageLimits& limits) {
  if (width <= 0 || height <= 0) {
    return absl::InvalidArgumentError("image has no pixels");
  }
  if (static_cast<int64_t>(width) * height > limits.max_pixels) {
    return absl::InvalidArgumentError(
        absl::StrCat("image is ", width, "x", height, " = ", static_cast<int64_t>(width) * height,
                     " pixels, over the limit of ", limits.max_pixels,
                     " pixels; downscale it before sending"));
  }
  if (width < limits.min_side || height < limits.min_side) {
    return absl::InvalidArgumentError(absl::StrCat("image is ", width, "x", height,
                                                   ", smaller than the minimum side of ",
                                                   limits.min_side, " pixels"));
  }
  return absl::OkStatus();
}

uint32_t BigEndian32(const unsigned char* p) {
  return (uint32_t{p[0]} << 24) | (uint32_t{p[1]} << 16) | (uint32_t{p[2]} << 8) | p[3];
}

// Reads width/height from PNG and JPEG headers without decoding. Returns false when the
// format is not recognised (the decoder then decides).
bool PeekSize(std::string_view bytes, int* width, int* height) {
  const auto* p = reinterpret_cast<const unsigned char*>(bytes.data());
  const size_t n = bytes.size();
  if (n >= 24 && p[0] == 0x89 && p[1] == 'P' && p[2] == 'N' && p[3] == 'G') {
    *width = static_cast<int>(BigEndian32(p + 16));
    *height = static_cast<int>(BigEndian32(p + 20));
    return true;
  }
  if (n >= 4 && p[0] == 0xFF && p[1] == 0xD8) {
    size_t i = 2;
    while (i + 9 < n) {
      if (p[i] != 0xFF) return false;
      const unsigned char marker = p[i + 1];
      if (marker == 0xD8 || marker == 0x01 || (marker >= 0xD0 && marker <= 0xD7)) {
        i += 2;
        continue;
      }
      const size_t len = (size_t{p[i + 2]} << 8) | p[i + 3];
      const bool sof = marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 &&
                       marker != 0xCC;
      if (sof) {
        *height = (p[i + 5] << 8) | p[i + 6];
        *width = (p[i + 7] << 8) | p[i + 8];
        return true;
      }
      i += 2 + len;
    }
  }
  return false;
}

absl::StatusOr<cv::Mat> DecodeWithFlags(std::string_view bytes, const ImageLimits& limits,
                                        int flags) {
  if (bytes.empty()) {
    return absl::InvalidArgumentError("image is empty (0 bytes)");
  }
  int width = 0, height = 0;
  if (PeekSize(bytes, &width, &height)) {
    if (absl::Status s = CheckSize(width, height, limits); !s.ok()) return s;
  }
  cv::Mat decoded;
  try {
    const cv::Mat buffer(1, static_cast<int>(bytes.size()), CV_8UC1,
                         const_cast<char*>(bytes.data()));
    decoded = cv::imdecode(buffer, flags);
  } catch (const cv::Exception& e) {
    return absl::InvalidArgumentError(absl::StrCat("image could not be decoded: ", e.what()));
  }
  if (decoded.empty()) {
    return absl::InvalidArgumentError(absl::StrCat(
        "image could not be decoded (", bytes.size(),
        " bytes): send JPEG, PNG, BMP or TIFF bytes, or a raw image with width and height"));
  }
  if (absl::Status s = CheckSize(decoded.cols, decoded.rows, limits); !s.ok()) return s;
  return decoded;
}

}  // namespace

absl::Status ImageLimits::Validate() const {
  if (max_pixels <= 0) return absl::InvalidArgumentError("max_pixels must be positive");
  if (min_side < 1) return absl::InvalidArgumentError("min_side must be at least 1");
  return absl::OkStatus();
}

absl::StatusOr<cv::Mat> DecodeImage(std::string_view bytes, const ImageLimits& limits,
                                    bool grayscale) {
  return DecodeWithFlags(bytes, limits, grayscale ? cv::IMREAD_GRAYSCALE : cv::IMREAD_COLOR);
}

absl::StatusOr<cv::Mat> DecodeGrayKeepDepth(std::string_view bytes, const ImageLimits& limits) {
  ASSIGN_OR_RETURN(cv::Mat decoded,
                   DecodeWithFlags(bytes, limits, cv::IMREAD_GRAYSCALE | cv::IMREAD_ANYDEPTH));
  if (decoded.depth() == CV_8U || decoded.depth() == CV_16U) return decoded;
  cv::Mat converted;  // 32-bit float TIFF and the like: scale to 16 bits
  double lo = 0, hi = 0;
  cv::minMaxLoc(decoded, &lo, &hi);
  decoded.convertTo(converted, CV_16U, hi > 0 ? 65535.0 / hi : 1.0);
  return converted;
}

absl::StatusOr<cv::Mat> ImageFromRaw(std::string_view pixels, RawPixelFormat format, int width,
                                     int height, int stride, const ImageLimits& limits) {
  if (absl::Status s = CheckSize(width, height, limits); !s.ok()) return s;
  const int channels = format == RawPixelFormat::kGray8 ? 1 : 3;
  const int64_t row_bytes = static_cast<int64_t>(width) * channels;
  const int64_t step = stride == 0 ? row_bytes : stride;
  if (step < row_bytes) {
    return absl::InvalidArgumentError(absl::StrCat("raw image stride ", stride,
                                                   " is smaller than width * channels = ",
                                                   row_bytes));
  }
  const int64_t needed = step * (height - 1) + row_bytes;
  if (static_cast<int64_t>(pixels.size()) < needed) {
    return absl::InvalidArgumentError(absl::StrCat("raw image has ", pixels.size(),
                                                   " bytes; ", width, "x", height, " with stride ",
                                                   step, " needs ", needed));
  }
  const cv::Mat view(height, width, channels == 1 ? CV_8UC1 : CV_8UC3,
                     const_cast<char*>(pixels.data()), static_cast<size_t>(step));
  return view.clone();
}

cv::Mat ToGray(const cv::Mat& image) {
  if (image.channels() == 1) return image;
  cv::Mat gray;
  cv::cvtColor(image, gray, image.channels() == 4 ? cv::COLOR_BGRA2GRAY : cv::COLOR_BGR2GRAY);
  return gray;
}

}  // namespace texfree
