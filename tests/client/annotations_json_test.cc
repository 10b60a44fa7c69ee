// Tests of the annotations JSON parser: a good file and every malformed case.
#include "client/annotations_json.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

namespace texfree::client {
namespace {

constexpr char kGood[] = R"([
  {"type": "text", "text": "Remember this", "x": 120, "y": 300, "font_size": 24,
   "color": "#ff0000"},
  {"type": "highlight", "x": 100, "y": 400, "width": 500, "height": 40,
   "color": "#ffff0080", "opacity": 0.4},
  {"type": "link", "x": 100, "y": 500, "width": 200, "height": 30,
   "url": "https://example.org"},
  {"type": "media", "x": 600, "y": 100, "width": 300, "height": 200,
   "uri": "https://example.org/a.mp4"}
])";

// Parses and returns the error message ("" when parsing succeeds).
std::string ErrorOf(const std::string& text) {
  try {
    ParseAnnotationsJson(text);
  } catch (const AnnotationsError& e) {
    return e.what();
  }
  return "";
}

TEST(AnnotationsJsonTest, ParsesEveryType) {
  auto annotations = ParseAnnotationsJson(kGood);
  ASSERT_EQ(annotations.size(), 4u);
  EXPECT_EQ(annotations[0].kind, AnnotationKind::kText);
  EXPECT_EQ(annotations[0].text, "Remember this");
  EXPECT_DOUBLE_EQ(annotations[0].position.x, 120);
  EXPECT_DOUBLE_EQ(annotations[0].position.y, 300);
  EXPECT_DOUBLE_EQ(annotations[0].font_size_px, 24);
  EXPECT_EQ(annotations[0].color, (Rgba{255, 0, 0, 255}));

  EXPECT_EQ(annotations[1].kind, AnnotationKind::kHighlight);
  EXPECT_EQ(annotations[1].rect, cv::Rect2d(100, 400, 500, 40));
  EXPECT_EQ(annotations[1].color, (Rgba{255, 255, 0, 128}));
  EXPECT_DOUBLE_EQ(annotations[1].opacity, 0.4);

  EXPECT_EQ(annotations[2].kind, AnnotationKind::kLink);
  EXPECT_EQ(annotations[2].url, "https://example.org");

  EXPECT_EQ(annotations[3].kind, AnnotationKind::kMedia);
  EXPECT_EQ(annotations[3].uri, "https://example.org/a.mp4");
  EXPECT_EQ(annotations[3].mime_type,
            "video/mp4");  // guessed from the extension
}

TEST(AnnotationsJsonTest, AcceptsObjectFormAndRgbArrays) {
  auto annotations = ParseAnnotationsJson(
      R"({"annotations": [{"type": "text", "text": "a", "x": 1, "y": 2,
                           "color": [10, 20, 30]}]})");
  ASSERT_EQ(annotations.size(), 1u);
  EXPECT_EQ(annotations[0].color, (Rgba{10, 20, 30, 255}));
  EXPECT_DOUBLE_EQ(annotations[0].font_size_px, 24);  // default
  EXPECT_TRUE(ParseAnnotationsJson("[]").empty());
}

TEST(AnnotationsJsonTest, MediaFileIsReadInline) {
  auto dir =
      std::filesystem::temp_directory_path() / "texfree_annotations_test";
  std::filesystem::create_directories(dir);
  {
    std::ofstream(dir / "clip.png", std::ios::binary) << "PNGDATA";
    std::ofstream(dir / "a.json")
        << R"([{"type": "media", "x": 0, "y": 0, "width": 10, "height": 10,
                "file": "clip.png"}])";
  }
  auto annotations = LoadAnnotationsFile(dir / "a.json");
  ASSERT_EQ(annotations.size(), 1u);
  EXPECT_EQ(annotations[0].data, "PNGDATA");
  EXPECT_EQ(annotations[0].mime_type, "image/png");
  EXPECT_TRUE(annotations[0].uri.empty());
  std::filesystem::remove_all(dir);
}

TEST(AnnotationsJsonTest, UnknownTypeNamesIndexAndField) {
  std::string error = ErrorOf(R"([{"type": "text", "text": "a", "x": 1, "y": 2},
                                  {"type": "sticker", "x": 1, "y": 2}])");
  EXPECT_NE(error.find("annotations[1].type"), std::string::npos) << error;
  EXPECT_NE(error.find("sticker"), std::string::npos) << error;
}

TEST(AnnotationsJsonTest, MissingText) {
  std::string error = ErrorOf(R"([{"type": "text", "x": 1, "y": 2}])");
  EXPECT_NE(error.find("annotations[0].text"), std::string::npos) << error;
  EXPECT_NE(error.find("missing"), std::string::npos) << error;
  error = ErrorOf(R"([{"type": "text", "text": "", "x": 1, "y": 2}])");
  EXPECT_NE(error.find("annotations[0].text"), std::string::npos) << error;
}

TEST(AnnotationsJsonTest, NegativeWidth) {
  std::string error = ErrorOf(
      R"([{"type": "highlight", "x": 1, "y": 2, "width": -5, "height": 3}])");
  EXPECT_NE(error.find("annotations[0].width"), std::string::npos) << error;
  EXPECT_NE(error.find("-5"), std::string::npos) << error;
}

TEST(AnnotationsJsonTest, OpacityOutOfRange) {
  std::string error = ErrorOf(
      R"([{"type": "highlight", "x": 1, "y": 2, "width": 5, "height": 3, "opacity": 1.5}])");
  EXPECT_NE(error.find("annotations[0].opacity"), std::string::npos) << error;
  error = ErrorOf(
      R"([{"type": "highlight", "x": 1, "y": 2, "width": 5, "height": 3, "opacity": -0.1}])");
  EXPECT_NE(error.find("annotations[0].opacity"), std::string::npos) << error;
}

TEST(AnnotationsJsonTest, BadColour) {
  for (const char* colour : {R"("#ff00")", R"("red")", R"("#gg0000")",
                             R"([1, 2])", R"([0, 0, 300])", "12"}) {
    std::string error =
        ErrorOf(std::string(R"([{"type": "text", "text": "a", "x": 1, "y": 2,
                                                 "color": )") +
                colour + "}]");
    EXPECT_NE(error.find("annotations[0].color"), std::string::npos)
        << colour << ": " << error;
  }
}

TEST(AnnotationsJsonTest, OtherMalformedEntries) {
  EXPECT_NE(ErrorOf(R"([{"type": "text", "text": "a", "y": 2}])")
                .find("annotations[0].x"),
            std::string::npos);
  EXPECT_NE(ErrorOf(R"([{"type": "text", "text": "a", "x": "1", "y": 2}])")
                .find("annotations[0].x"),
            std::string::npos);
  EXPECT_NE(
      ErrorOf(R"([{"type": "link", "x": 1, "y": 2, "width": 5, "height": 3}])")
          .find("annotations[0].url"),
      std::string::npos);
  EXPECT_NE(
      ErrorOf(R"([{"type": "media", "x": 1, "y": 2, "width": 5, "height": 3}])")
          .find("annotations[0].uri"),
      std::string::npos);
  EXPECT_NE(
      ErrorOf(R"([{"type": "media", "x": 1, "y": 2, "width": 5, "height": 3,
                         "file": "/nonexistent/x.png"}])")
          .find("annotations[0].file"),
      std::string::npos);
  EXPECT_NE(
      ErrorOf(R"([{"text": "a", "x": 1, "y": 2}])").find("annotations[0].type"),
      std::string::npos);
  EXPECT_NE(
      ErrorOf(R"([{"type": "text", "text": "a", "x": 1, "y": 2, "widht": 3}])")
          .find("annotations[0].widht"),
      std::string::npos);
  EXPECT_NE(
      ErrorOf(
          R"([{"type": "text", "text": "a", "x": 1, "y": 2, "font_size": 0}])")
          .find("annotations[0].font_size"),
      std::string::npos);
  EXPECT_NE(ErrorOf("[1]").find("annotations[0]"), std::string::npos);
  EXPECT_NE(ErrorOf("{oops").find("not valid JSON"), std::string::npos);
  EXPECT_NE(ErrorOf(R"({"notes": []})"), "");
}

TEST(AnnotationsJsonTest, MissingFileNamesThePath) {
  try {
    LoadAnnotationsFile("/nonexistent/annotations.json");
    FAIL() << "expected an error";
  } catch (const AnnotationsError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/annotations.json"),
              std::string::npos);
  }
}

TEST(AnnotationsJsonTest, HexColourRoundTrip) {
  EXPECT_EQ(FormatHexColor(ParseHexColor("#12abEF")), "#12abef");
  EXPECT_EQ(FormatHexColor(ParseHexColor("#12abef80")), "#12abef80");
}

}  // namespace
}  // namespace texfree::client
