// Tests of image decoding and raw buffer wrapping: errors for empty, garbage, truncated
// and oversized input (refused from the header alone), correct sizes and pixels otherwise.
#include "common/image_io.h"

#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <string>
#include <vector>

namespace texfree {
namespace {

std::string Encode(const cv::Mat& image, const std::string& ext) {
  std::vector<uchar> buf;
  EXPECT_TRUE(cv::imencode(ext, image, buf));
  return std::string(buf.begin(), buf.end());
}

cv::Mat TestImage(int width, int height) {
  cv::Mat image(height, width, CV_8UC3);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x)
      image.at<cv::Vec3b>(y, x) = cv::Vec3b(x * 3, y * 5, (x + y) * 2);
  return image;
}

void PutBigEndian32(std::string& s, size_t at, uint32_t v) {
  s[at] = static_cast<char>(v >> 24);
  s[at + 1] = static_cast<char>(v >> 16);
  s[at + 2] = static_cast<char>(v >> 8);
  s[at + 3] = static_cast<char>(v);
}

// PNG signature and an IHDR chunk claiming width x height (8-bit RGB), no pixel data.
std::string PngHeader(uint32_t width, uint32_t height) {
  std::string s("\x89PNG\r\n\x1a\n", 8);
  s += std::string("\0\0\0\x0dIHDR", 8);
  s += std::string(8, '\0');
  PutBigEndian32(s, 16, width);
  PutBigEndian32(s, 20, height);
  s += std::string("\x08\x02\0\0\0",
                   5);        // bit depth 8, colour type 2, compression, filter, interlace
  s += std::string(4, '\0');  // CRC (not checked before the size test)
  return s;
}

TEST(DecodeImageTest, EmptyBytes) {
  auto r = DecodeImage("", ImageLimits());
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(r.status().message().find("empty"), std::string::npos) << r.status();
}

TEST(DecodeImageTest, GarbageBytes) {
  std::mt19937 rng(3);
  std::string garbage(4096, '\0');
  for (char& c : garbage) c = static_cast<char>(rng());
  auto r = DecodeImage(garbage, ImageLimits());
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(r.status().message().find("could not be decoded"), std::string::npos) << r.status();
  EXPECT_NE(r.status().message().find("PNG"), std::string::npos)
      << "the message should say which formats are accepted: " << r.status();
}

TEST(DecodeImageTest, TruncatedPng) {
  const std::string png = Encode(TestImage(64, 48), ".png");
  for (size_t keep : {png.size() / 2, size_t{40}, size_t{30}, size_t{10}}) {
    auto r = DecodeImage(png.substr(0, keep), ImageLimits());
    ASSERT_FALSE(r.ok()) << "kept " << keep;
    EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_FALSE(r.status().message().empty());
  }
}

TEST(DecodeImageTest, OversizedPngHeaderIsRefusedWithoutDecoding) {
  ImageLimits limits;
  limits.max_pixels = 50'000'000;
  const std::string header = PngHeader(10000, 6000);
  auto r = DecodeImage(header, limits);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument);
  const std::string message(r.status().message());
  EXPECT_NE(message.find("10000x6000"), std::string::npos) << message;
  EXPECT_NE(message.find("50000000"), std::string::npos) << "should state the limit: " << message;
  EXPECT_NE(message.find("limit"), std::string::npos) << message;
  // Under the limit, the same (pixel-less) header is simply undecodable.
  auto small = DecodeImage(PngHeader(100, 100), limits);
  ASSERT_FALSE(small.ok());
  EXPECT_EQ(small.status().message().find("limit"), std::string::npos) << small.status();
}

TEST(DecodeImageTest, OversizedJpegIsRefused) {
  ImageLimits limits;
  limits.max_pixels = 100 * 100;
  const std::string jpg = Encode(TestImage(200, 120), ".jpg");
  auto r = DecodeImage(jpg, limits);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("200x120"), std::string::npos) << r.status();
}

TEST(DecodeImageTest, ValidPngAndJpegDecodeToTheRightSize) {
  const cv::Mat image = TestImage(64, 48);
  for (const char* ext : {".png", ".jpg", ".bmp"}) {
    const std::string bytes = Encode(image, ext);
    auto gray = DecodeImage(bytes, ImageLimits());
    ASSERT_TRUE(gray.ok()) << ext << ": " << gray.status();
    EXPECT_EQ(gray->cols, 64) << ext;
    EXPECT_EQ(gray->rows, 48) << ext;
    EXPECT_EQ(gray->type(), CV_8UC1) << ext;
    auto color = DecodeImage(bytes, ImageLimits(), /*grayscale=*/false);
    ASSERT_TRUE(color.ok()) << ext << ": " << color.status();
    EXPECT_EQ(color->size(), image.size()) << ext;
    EXPECT_EQ(color->type(), CV_8UC3) << ext;
    if (std::string(ext) != ".jpg") {
      EXPECT_EQ(cv::norm(*color, image, cv::NORM_INF), 0) << "lossless " << ext;
    } else {
      EXPECT_LT(cv::norm(*color, image, cv::NORM_L1) / image.total() / 3, 6) << "JPEG";
    }
  }
}

TEST(DecodeImageTest, TooSmallImageIsRefused) {
  auto r = DecodeImage(Encode(TestImage(10, 40), ".png"), ImageLimits());
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("minimum side"), std::string::npos) << r.status();
}

TEST(ImageFromRawTest, TightAndPaddedStrides) {
  const int w = 20, h = 17;
  // Gray, tightly packed.
  std::string gray(w * h, '\0');
  for (int i = 0; i < w * h; ++i) gray[i] = static_cast<char>(i * 7);
  auto g = ImageFromRaw(gray, RawPixelFormat::kGray8, w, h, 0, ImageLimits());
  ASSERT_TRUE(g.ok()) << g.status();
  ASSERT_EQ(g->size(), cv::Size(w, h));
  ASSERT_EQ(g->type(), CV_8UC1);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      ASSERT_EQ(g->at<uchar>(y, x), static_cast<uchar>((y * w + x) * 7)) << x << "," << y;

  // BGR with a padded stride; the last row need not be padded.
  const int stride = w * 3 + 13;
  std::string bgr(stride * (h - 1) + w * 3, '\x55');
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c)
        bgr[y * stride + x * 3 + c] = static_cast<char>(x + 2 * y + 50 * c);
  auto b = ImageFromRaw(bgr, RawPixelFormat::kBgr8, w, h, stride, ImageLimits());
  ASSERT_TRUE(b.ok()) << b.status();
  ASSERT_EQ(b->size(), cv::Size(w, h));
  ASSERT_EQ(b->type(), CV_8UC3);
  EXPECT_TRUE(b->isContinuous()) << "a copy, not a view of the caller's buffer";
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c)
        ASSERT_EQ(b->at<cv::Vec3b>(y, x)[c], static_cast<uchar>(x + 2 * y + 50 * c));
  // The result owns its pixels.
  bgr.assign(bgr.size(), '\0');
  EXPECT_EQ(b->at<cv::Vec3b>(3, 4)[1], static_cast<uchar>(4 + 6 + 50));
}

TEST(ImageFromRawTest, StrideTooSmallOrBufferTooShort) {
  const int w = 20, h = 17;
  const std::string bytes(w * 3 * h, '\0');
  auto r = ImageFromRaw(bytes, RawPixelFormat::kBgr8, w, h, w * 3 - 1, ImageLimits());
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(r.status().message().find("stride"), std::string::npos) << r.status();

  r = ImageFromRaw(bytes.substr(0, bytes.size() - 1), RawPixelFormat::kBgr8, w, h, 0,
                   ImageLimits());
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(r.status().message().find(std::to_string(w * 3 * h)), std::string::npos)
      << "should say how many bytes are needed: " << r.status();

  r = ImageFromRaw(bytes, RawPixelFormat::kBgr8, w, h, w * 3 + 1, ImageLimits());
  EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument) << "padded stride needs more";

  ImageLimits tiny;
  tiny.max_pixels = 100;
  r = ImageFromRaw(bytes, RawPixelFormat::kBgr8, w, h, 0, tiny);
  EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument);
  r = ImageFromRaw(bytes, RawPixelFormat::kGray8, 0, h, 0, ImageLimits());
  EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument);
}

TEST(ImageLimitsTest, Validate) {
  EXPECT_TRUE(ImageLimits().Validate().ok());
  ImageLimits l;
  l.max_pixels = 0;
  EXPECT_FALSE(l.Validate().ok());
  l = ImageLimits();
  l.min_side = 0;
  EXPECT_FALSE(l.Validate().ok());
}

TEST(ToGrayTest, ChannelsAndNoCopy) {
  const cv::Mat bgr = TestImage(32, 16);
  const cv::Mat gray = ToGray(bgr);
  EXPECT_EQ(gray.type(), CV_8UC1);
  EXPECT_EQ(gray.size(), bgr.size());
  EXPECT_EQ(ToGray(gray).data, gray.data) << "gray input is returned as is";
  cv::Mat bgra;
  cv::cvtColor(bgr, bgra, cv::COLOR_BGR2BGRA);
  EXPECT_EQ(cv::norm(ToGray(bgra), gray, cv::NORM_INF), 0);
}

}  // namespace
}  // namespace texfree
