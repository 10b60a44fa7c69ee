// Seeded synthetic document pages: a small typesetting engine over the DejaVu
// fonts, or a held-out font set (cv::freetype), that varies the layout per
// seed the way real typeset pages vary (columns, fonts, sizes, spacing,
// headings, figures, tables).
//
// Determinism: every random choice comes from a portable generator (raw
// std::mt19937_64 bits, no std distributions), all pixel operations are
// integer or bit-exact OpenCV 8U routines, so a seed gives the same bytes on
// every machine with the same FreeType build.
#include "tests/data/page_renderer.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <memory>
#include <opencv2/freetype.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <utility>

namespace texfree::testdata {
namespace {

// ---------------------------------------------------------------------------
// Portable random numbers.
class Rng {
 public:
  explicit Rng(uint64_t seed) : engine_(seed ^ 0x7465786672656531ULL) {}
  uint64_t Bits() { return engine_(); }
  // Uniform in [0, 1).
  double Unit() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }
  double Uniform(double lo, double hi) { return lo + (hi - lo) * Unit(); }
  // Uniform integer in [lo, hi].
  int Int(int lo, int hi) {
    if (hi <= lo) return lo;
    return lo +
           static_cast<int>(engine_() % static_cast<uint64_t>(hi - lo + 1));
  }
  bool Chance(double p) { return Unit() < p; }
  template <typename T>
  const T& Pick(const std::vector<T>& v) {
    return v[static_cast<size_t>(Int(0, static_cast<int>(v.size()) - 1))];
  }

 private:
  std::mt19937_64 engine_;
};

// ---------------------------------------------------------------------------
// Fonts.
enum Family { kSerif, kSans, kSansCondensed, kSerifCondensed, kMono };
enum Style { kRegular = 0, kBold = 1, kItalic = 2, kBoldItalic = 3 };
// Font ids within a set (family * 4 + style); a set's fonts follow each other
// in the cache (concrete set * kFontsPerSet + id).
constexpr int kFontsPerSet = 5 * 4;
constexpr int kConcreteSets = 4;  // DejaVu, Liberation, FreeFont, Latin Modern
// FontSet::kAll picks among the first three (as when its figures were measured).
constexpr int kAllSets = 3;
constexpr int kNumFonts = kConcreteSets * kFontsPerSet;

struct FontSetFiles {
  const char* directory;
  const char* package;
  const char* files[kFontsPerSet];
};

const FontSetFiles& SetFiles(int concrete_set) {
  static const FontSetFiles kSets[kConcreteSets] = {
      {"/usr/share/fonts/truetype/dejavu/",
       "fonts-dejavu-core fonts-dejavu-extra",
       {
           "DejaVuSerif.ttf",
           "DejaVuSerif-Bold.ttf",
           "DejaVuSerif-Italic.ttf",
           "DejaVuSerif-BoldItalic.ttf",
           "DejaVuSans.ttf",
           "DejaVuSans-Bold.ttf",
           "DejaVuSans-Oblique.ttf",
           "DejaVuSans-BoldOblique.ttf",
           "DejaVuSansCondensed.ttf",
           "DejaVuSansCondensed-Bold.ttf",
           "DejaVuSansCondensed-Oblique.ttf",
           "DejaVuSansCondensed-BoldOblique.ttf",
           "DejaVuSerifCondensed.ttf",
           "DejaVuSerifCondensed-Bold.ttf",
           "DejaVuSerifCondensed-Italic.ttf",
           "DejaVuSerifCondensed-BoldItalic.ttf",
           "DejaVuSansMono.ttf",
           "DejaVuSansMono-Bold.ttf",
           "DejaVuSansMono-Oblique.ttf",
           "DejaVuSansMono-BoldOblique.ttf",
       }},
      // Liberation 2 has no narrow cut: condensed families use the regular.
      {"/usr/share/fonts/truetype/liberation2/",
       "fonts-liberation2",
       {
           "LiberationSerif-Regular.ttf", "LiberationSerif-Bold.ttf",
           "LiberationSerif-Italic.ttf",  "LiberationSerif-BoldItalic.ttf",
           "LiberationSans-Regular.ttf",  "LiberationSans-Bold.ttf",
           "LiberationSans-Italic.ttf",   "LiberationSans-BoldItalic.ttf",
           "LiberationSans-Regular.ttf",  "LiberationSans-Bold.ttf",
           "LiberationSans-Italic.ttf",   "LiberationSans-BoldItalic.ttf",
           "LiberationSerif-Regular.ttf", "LiberationSerif-Bold.ttf",
           "LiberationSerif-Italic.ttf",  "LiberationSerif-BoldItalic.ttf",
           "LiberationMono-Regular.ttf",  "LiberationMono-Bold.ttf",
           "LiberationMono-Italic.ttf",   "LiberationMono-BoldItalic.ttf",
       }},
      // FreeFont has no condensed cut either.
      {"/usr/share/fonts/truetype/freefont/",
       "fonts-freefont-ttf",
       {
           "FreeSerif.ttf", "FreeSerifBold.ttf", "FreeSerifItalic.ttf", "FreeSerifBoldItalic.ttf",
           "FreeSans.ttf",  "FreeSansBold.ttf",  "FreeSansOblique.ttf", "FreeSansBoldOblique.ttf",
           "FreeSans.ttf",  "FreeSansBold.ttf",  "FreeSansOblique.ttf", "FreeSansBoldOblique.ttf",
           "FreeSerif.ttf", "FreeSerifBold.ttf", "FreeSerifItalic.ttf", "FreeSerifBoldItalic.ttf",
           "FreeMono.ttf",  "FreeMonoBold.ttf",  "FreeMonoOblique.ttf", "FreeMonoBoldOblique.ttf",
       }},
      // Latin Modern's text cuts at 10 pt design size; its narrow sans (demi-condensed)
      // has no bold, and no serif is condensed.
      {"/usr/share/texmf/fonts/opentype/public/lm/",
       "fonts-lmodern",
       {
           "lmroman10-regular.otf",        "lmroman10-bold.otf",
           "lmroman10-italic.otf",         "lmroman10-bolditalic.otf",
           "lmsans10-regular.otf",         "lmsans10-bold.otf",
           "lmsans10-oblique.otf",         "lmsans10-boldoblique.otf",
           "lmsansdemicond10-regular.otf", "lmsans10-bold.otf",
           "lmsansdemicond10-oblique.otf", "lmsans10-boldoblique.otf",
           "lmroman10-regular.otf",        "lmroman10-bold.otf",
           "lmroman10-italic.otf",         "lmroman10-bolditalic.otf",
           "lmmono10-regular.otf",         "lmmonolt10-bold.otf",
           "lmmono10-italic.otf",          "lmmonolt10-boldoblique.otf",
       }},
  };
  return kSets[concrete_set];
}

std::string FontPath(int font) {
  const FontSetFiles& set = SetFiles(font / kFontsPerSet);
  return std::string(set.directory) + set.files[font % kFontsPerSet];
}

absl::Status CheckConcreteSet(int concrete_set) {
  const FontSetFiles& set = SetFiles(concrete_set);
  for (const char* file : set.files) {
    const std::string path = std::string(set.directory) + file;
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path, ec)) {
      return absl::NotFoundError("font file " + path + " is missing: install " + set.package +
                                 " (deploy/install-deps.sh)");
    }
  }
  return absl::OkStatus();
}

// The concrete set a page is typeset in. kAll hashes the seed (SplitMix64
// finaliser) instead of drawing from the page's generator, so that the
// layout choices stay those of the seed in every set.
int ConcreteSet(FontSet set, uint64_t seed) {
  switch (set) {
    case FontSet::kDejaVu:
      return 0;
    case FontSet::kLiberation:
      return 1;
    case FontSet::kFreeFont:
      return 2;
    case FontSet::kLatinModern:
      return 3;
    case FontSet::kAll:
      break;
  }
  uint64_t z = seed + 0x9e3779b97f4a7c15ULL;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  z ^= z >> 31;
  return static_cast<int>(z % kAllSets);
}

int FontId(Family family, int style) {
  return static_cast<int>(family) * 4 + style;
}

// A word rendered once: its coverage mask cropped to the ink, and where the
// ink sits relative to the pen position on the baseline.
struct WordGlyphs {
  cv::Mat alpha;  // CV_8UC1, tight around the ink (empty for blank text)
  int dx = 0;     // ink left - pen x
  int dy = 0;     // ink top - baseline y
};

// Per-thread cache of FreeType2 objects (slow to create, not thread-safe)
// and of rendered words (the same word at the same size repeats a lot).
class FontCache {
 public:
  cv::freetype::FreeType2& Font(int font_id) {
    auto& font = fonts_[font_id];
    if (font.empty()) {
      // cv::freetype only asserts on a missing file; say which package.
      const absl::Status available = CheckConcreteSet(font_id / kFontsPerSet);
      if (!available.ok()) throw std::runtime_error(available.ToString());
      font = cv::freetype::createFreeType2();
      font->loadFontData(FontPath(font_id), 0);
    }
    return *font;
  }

  // Shared ownership: a line being typeset holds its words while the cache may be cleared.
  std::shared_ptr<const WordGlyphs> Word(int font_id, int size, const std::string& text) {
    std::string key;
    key.reserve(text.size() + 3);
    key.push_back(static_cast<char>(font_id));
    key.push_back(static_cast<char>(size & 0xff));
    key.push_back(static_cast<char>(size >> 8));
    key += text;
    auto it = words_.find(key);
    if (it != words_.end()) return it->second;
    if (words_.size() > 40000) words_.clear();  // bound the memory
    auto glyphs = std::make_shared<WordGlyphs>();
    const int w = static_cast<int>(text.size()) * size + 2 * size;
    const int h = 2 * size + 8;
    const cv::Point org(size / 2, size * 13 / 10 + 2);
    scratch_.create(h, w, CV_8UC3);
    scratch_.setTo(cv::Scalar::all(0));
    Font(font_id).putText(scratch_, text, org, size, cv::Scalar::all(255), -1,
                          cv::LINE_AA, true);
    cv::extractChannel(scratch_, channel_, 0);
    const cv::Rect ink = cv::boundingRect(channel_);
    if (ink.area() > 0) {
      glyphs->alpha = channel_(ink).clone();
      glyphs->dx = ink.x - org.x;
      glyphs->dy = ink.y - org.y;
    }
    return words_.emplace(std::move(key), std::move(glyphs)).first->second;
  }

  int SpaceWidth(int font_id, int size) {
    const int key = font_id * 4096 + size;
    auto it = spaces_.find(key);
    if (it != spaces_.end()) return it->second;
    int baseline = 0;
    const int width =
        std::max(2, Font(font_id).getTextSize(" ", size, -1, &baseline).width);
    spaces_[key] = width;
    return width;
  }

 private:
  std::array<cv::Ptr<cv::freetype::FreeType2>, kNumFonts> fonts_;
  std::unordered_map<std::string, std::shared_ptr<const WordGlyphs>> words_;
  std::unordered_map<int, int> spaces_;
  cv::Mat scratch_, channel_;
};

FontCache& Cache() {
  thread_local FontCache cache;
  return cache;
}

// ---------------------------------------------------------------------------
// Vocabulary: frequent function words and a few hundred content words.
const std::vector<std::string>& FunctionWords() {
  static const std::vector<std::string> kWords = {
      "the",   "of",   "and",  "to",   "a",    "in",    "is",   "that",
      "for",   "it",   "as",   "was",  "with", "be",    "by",   "on",
      "not",   "he",   "this", "are",  "or",   "his",   "from", "at",
      "which", "but",  "have", "an",   "had",  "they",  "you",  "were",
      "their", "one",  "all",  "we",   "can",  "her",   "has",  "there",
      "been",  "if",   "more", "when", "will", "would", "who",  "so",
      "no",    "its",  "into", "than", "then", "these", "two",  "may",
      "our",   "also", "each", "such", "only", "over",  "most", "both"};
  return kWords;
}

const std::vector<std::string>& ContentWords() {
  static const std::vector<std::string> kWords = {
      "document",    "camera",        "image",       "paper",
      "method",      "system",        "results",     "feature",
      "point",       "points",        "matching",    "retrieval",
      "page",        "pages",         "word",        "words",
      "text",        "printed",       "surface",     "light",
      "table",       "model",         "number",      "value",
      "values",      "different",     "between",     "several",
      "approach",    "problem",       "solution",    "process",
      "information", "experiment",    "experiments", "accuracy",
      "performance", "database",      "index",       "hash",
      "descriptor",  "invariant",     "geometric",   "projection",
      "perspective", "affine",        "rotation",    "scale",
      "distance",    "neighbour",     "neighbours",  "triangle",
      "area",        "ratio",         "threshold",   "quantized",
      "level",       "levels",        "memory",      "time",
      "frame",       "frames",        "video",       "tracking",
      "pose",        "estimation",    "homography",  "robust",
      "error",       "errors",        "measurement", "position",
      "structure",   "building",      "night",       "marker",
      "markers",     "signal",        "pattern",     "sequence",
      "sample",      "samples",       "header",      "identifier",
      "pixel",       "pixels",        "region",      "regions",
      "contour",     "line",          "lines",       "corner",
      "corners",     "ball",          "balls",       "cloth",
      "colour",      "color",         "shot",        "pocket",
      "player",      "game",          "map",         "maps",
      "street",      "intersection",  "city",        "building",
      "annotation",  "annotations",   "augmented",   "reality",
      "virtual",     "content",       "user",        "users",
      "device",      "mobile",        "phone",       "screen",
      "display",     "application",   "interface",   "server",
      "network",     "computation",   "algorithm",   "algorithms",
      "efficient",   "fast",          "slow",        "large",
      "small",       "simple",        "complex",     "general",
      "specific",    "important",     "possible",    "necessary",
      "previous",    "following",     "first",       "second",
      "third",       "last",          "new",         "old",
      "high",        "low",           "good",        "better",
      "best",        "poor",          "strong",      "weak",
      "main",        "major",         "minor",       "common",
      "single",      "multiple",      "several",     "many",
      "few",         "other",         "same",        "similar",
      "known",       "unknown",       "given",       "found",
      "shown",       "used",          "using",       "based",
      "obtained",    "computed",      "detected",    "extracted",
      "proposed",    "presented",     "described",   "compared",
      "evaluated",   "tested",        "selected",    "required",
      "defined",     "considered",    "observed",    "expected",
      "increase",    "decrease",      "change",      "changes",
      "result",      "effect",        "effects",     "case",
      "cases",       "example",       "examples",    "figure",
      "section",     "chapter",       "part",        "parts",
      "way",         "ways",          "order",       "step",
      "steps",       "stage",         "phase",       "work",
      "research",    "study",         "analysis",    "theory",
      "practice",    "history",       "world",       "country",
      "people",      "person",        "group",       "family",
      "children",    "school",        "house",       "water",
      "river",       "mountain",      "morning",     "evening",
      "summer",      "winter",        "year",        "years",
      "day",         "days",          "hour",        "minutes",
      "government",  "market",        "company",     "business",
      "money",       "price",         "economy",     "policy",
      "health",      "hospital",      "doctor",      "patient",
      "music",       "art",           "book",        "story",
      "letter",      "question",      "answer",      "reason",
      "idea",        "knowledge",     "language",    "meaning",
      "context",     "society",       "culture",     "nature",
      "environment", "energy",        "power",       "force",
      "motion",      "speed",         "weight",      "length",
      "width",       "height",        "depth",       "angle",
      "direction",   "centre",        "edge",        "border",
      "shape",       "size",          "form",        "material",
      "object",      "objects",       "scene",       "view",
      "views",       "viewpoint",     "distortion",  "noise",
      "blur",        "focus",         "lens",        "sensor",
      "resolution",  "quality",       "standard",    "typical",
      "usually",     "often",         "always",      "never",
      "however",     "therefore",     "although",    "because",
      "while",       "where",         "whether",     "without",
      "within",      "through",       "during",      "before",
      "after",       "above",         "below",       "under",
      "against",     "among",         "around",      "towards",
      "describe",    "explain",       "consider",    "improve",
      "reduce",      "detect",        "compute",     "estimate",
      "measure",     "project",       "register",    "retrieve",
      "store",       "update",        "learn",       "learning",
      "training",    "test",          "testing",     "evaluation",
      "robustness",  "stability",     "precision",   "recall",
      "probability", "distribution",  "variance",    "average",
      "mean",        "median",        "maximum",     "minimum",
      "total",       "percent",       "fraction",    "half",
      "quarter",     "hundred",       "thousand",    "million",
      "local",       "global",        "visual",      "spatial",
      "temporal",    "digital",       "physical",    "natural",
      "human",       "social",        "political",   "economic",
      "national",    "international", "public",      "private",
      "Japan",       "Osaka",         "Europe",      "France",
      "Nantes",      "London",        "university",  "laboratory",
      "professor",   "student",       "students",    "thesis"};
  return kWords;
}

std::string Capitalize(std::string word) {
  if (!word.empty() && word[0] >= 'a' && word[0] <= 'z') word[0] -= 32;
  return word;
}

std::string RandomNumber(Rng& rng) {
  switch (rng.Int(0, 6)) {
    case 0:
      return std::to_string(rng.Int(1, 99));
    case 1:
      return std::to_string(rng.Int(1950, 2024));
    case 2: {
      const int whole = rng.Int(0, 99);
      return std::to_string(whole) + "." + std::to_string(rng.Int(0, 99));
    }
    case 3:
      return std::to_string(rng.Int(1, 99)) + "%";
    case 4:
      return "(" + std::to_string(rng.Int(1, 40)) + ")";
    case 5:
      return "[" + std::to_string(rng.Int(1, 60)) + "]";
    default:
      return std::to_string(rng.Int(100, 99999));
  }
}

std::string RandomWord(Rng& rng) {
  const double u = rng.Unit();
  if (u < 0.40) return rng.Pick(FunctionWords());
  if (u < 0.95) return rng.Pick(ContentWords());
  return RandomNumber(rng);
}

struct Token {
  std::string text;
  int style = kRegular;
};

// A paragraph: sentences of 5..24 words, capitals, commas, full stops,
// occasional bold or italic words.
std::vector<Token> RandomParagraph(Rng& rng, int num_words,
                                   double emphasis_rate) {
  std::vector<Token> tokens;
  tokens.reserve(static_cast<size_t>(num_words) + 24);
  while (static_cast<int>(tokens.size()) < num_words) {
    const int sentence = rng.Int(5, 24);
    for (int i = 0; i < sentence; ++i) {
      Token token;
      token.text = RandomWord(rng);
      if (i == 0 || rng.Chance(0.03)) token.text = Capitalize(token.text);
      if (i == sentence - 1) {
        const double u = rng.Unit();
        token.text += u < 0.9 ? "." : (u < 0.95 ? "?" : ":");
      } else if (i > 1 && rng.Chance(0.08)) {
        token.text += rng.Chance(0.85) ? "," : ";";
      }
      if (rng.Chance(emphasis_rate)) {
        token.style = rng.Chance(0.5) ? kItalic : kBold;
      }
      tokens.push_back(std::move(token));
    }
  }
  return tokens;
}

std::vector<Token> RandomPhrase(Rng& rng, int lo, int hi, int style) {
  std::vector<Token> tokens;
  const int n = rng.Int(lo, hi);
  for (int i = 0; i < n; ++i) {
    std::string w =
        rng.Chance(0.2) ? rng.Pick(FunctionWords()) : rng.Pick(ContentWords());
    if (i == 0 || (w.size() > 3 && rng.Chance(0.5))) w = Capitalize(w);
    tokens.push_back({w, style});
  }
  return tokens;
}

// ---------------------------------------------------------------------------
// Paper.

// Fine paper grain: one 256x256 tile of zero-mean noise per thread, sampled
// at a seeded offset (cheaper than drawing a full page of noise per page).
const cv::Mat& GrainTile() {
  thread_local cv::Mat tile;
  if (tile.empty()) {
    cv::RNG rng(0x9a7e5eedULL);
    tile.create(256, 256, CV_8UC1);
    rng.fill(tile, cv::RNG::NORMAL, 128, 1.3);
  }
  return tile;
}

// Paper colour with a faint low-frequency shading and grain.
cv::Mat MakePaper(Rng& rng, const PageOptions& options, cv::Scalar* ink) {
  const int w = std::max(1, options.width);
  const int h = std::max(1, options.height);
  const int base = rng.Int(236, 252);
  cv::Vec3i tint(0, 0, 0);
  if (options.color) {
    tint[0] = -rng.Int(0, 8);  // warm white
    tint[1] = -rng.Int(0, 3);
  }
  // Low-frequency shading: a coarse random grid, linearly upsampled.
  cv::Mat coarse(std::max(2, h / 90), std::max(2, w / 90), CV_8UC1);
  for (int y = 0; y < coarse.rows; ++y) {
    for (int x = 0; x < coarse.cols; ++x) {
      coarse.at<uint8_t>(y, x) = static_cast<uint8_t>(128 + rng.Int(-2, 2));
    }
  }
  cv::Mat shading;
  cv::resize(coarse, shading, cv::Size(w, h), 0, 0, cv::INTER_LINEAR);
  const cv::Mat& grain = GrainTile();
  const int ox = rng.Int(0, 255), oy = rng.Int(0, 255);
  std::vector<cv::Mat> planes(3);
  for (int c = 0; c < 3; ++c) {
    if (c > 0 && tint[c] == tint[c - 1]) {
      planes[static_cast<size_t>(c)] = planes[static_cast<size_t>(c - 1)];
      continue;
    }
    cv::Mat plane(h, w, CV_8UC1);
    const int offset = base + tint[c] - 256;
    for (int y = 0; y < h; ++y) {
      const uint8_t* s = shading.ptr<uint8_t>(y);
      const uint8_t* g = grain.ptr<uint8_t>((y + oy) & 255);
      uint8_t* p = plane.ptr<uint8_t>(y);
      for (int x = 0; x < w; ++x) {
        const int v = offset + s[x] + g[(x + ox) & 255];
        p[x] = static_cast<uint8_t>(v < 0 ? 0 : (v > 255 ? 255 : v));
      }
    }
    planes[static_cast<size_t>(c)] = plane;
  }
  cv::Mat paper;
  cv::merge(planes, paper);
  if (ink != nullptr) {
    const int level = rng.Int(8, 55);
    *ink = cv::Scalar::all(level);
    if (options.color && rng.Chance(0.1)) *ink = cv::Scalar(60, 25, 15);
  }
  return paper;
}

// ---------------------------------------------------------------------------
// Typesetting.
class Typesetter {
 public:
  // Font ids passed in are within a set (FontId()); the typesetter maps them
  // into the page's concrete set.
  Typesetter(cv::Mat* page, std::vector<cv::Rect>* boxes, int concrete_set)
      : page_(page), boxes_(boxes), cache_(Cache()), font_base_(concrete_set * kFontsPerSet) {}

  struct Measured {
    std::shared_ptr<const WordGlyphs> glyphs;
    int width;
  };

  Measured Measure(int font_id, int size, const std::string& text) {
    std::shared_ptr<const WordGlyphs> g = cache_.Word(font_base_ + font_id, size, text);
    const int width = g->alpha.cols;
    return {std::move(g), width};
  }

  int Space(int font_id, int size) { return cache_.SpaceWidth(font_base_ + font_id, size); }

  // Composites a measured word with its ink's left edge at x, on baseline y.
  void Draw(const Measured& word, int x, int baseline, const cv::Scalar& ink) {
    const WordGlyphs& g = *word.glyphs;
    if (g.alpha.empty()) return;
    cv::Rect box(x, baseline + g.dy, g.alpha.cols, g.alpha.rows);
    const cv::Rect clipped = box & cv::Rect(0, 0, page_->cols, page_->rows);
    if (clipped.area() <= 0) return;
    const int ink_c[3] = {static_cast<int>(ink[0]), static_cast<int>(ink[1]),
                          static_cast<int>(ink[2])};
    for (int y = clipped.y; y < clipped.br().y; ++y) {
      const uint8_t* a = g.alpha.ptr<uint8_t>(y - box.y) + (clipped.x - box.x);
      cv::Vec3b* p = page_->ptr<cv::Vec3b>(y) + clipped.x;
      for (int i = 0; i < clipped.width; ++i) {
        const int alpha = a[i];
        if (alpha == 0) continue;
        for (int c = 0; c < 3; ++c) {
          p[i][c] = static_cast<uint8_t>(
              (p[i][c] * (255 - alpha) + ink_c[c] * alpha + 127) / 255);
        }
      }
    }
    boxes_->push_back(clipped);
  }

  // Draws tokens left to right from x on baseline y (no wrapping); returns
  // the x after the last word.
  int DrawRun(const std::vector<Token>& tokens, Family family, int size, int x,
              int baseline, const cv::Scalar& ink) {
    for (const Token& t : tokens) {
      const int font = FontId(family, t.style);
      const Measured m = Measure(font, size, t.text);
      Draw(m, x, baseline, ink);
      x += m.width + Space(font, size);
    }
    return x;
  }

  int RunWidth(const std::vector<Token>& tokens, Family family, int size) {
    int width = 0;
    for (size_t i = 0; i < tokens.size(); ++i) {
      const int font = FontId(family, tokens[i].style);
      width += Measure(font, size, tokens[i].text).width;
      if (i + 1 < tokens.size()) width += Space(font, size);
    }
    return width;
  }

 private:
  cv::Mat* page_;
  std::vector<cv::Rect>* boxes_;
  FontCache& cache_;
  int font_base_;
};

struct Column {
  int x0, x1;
};

struct PageStyle {
  Family body_family;
  Family heading_family;
  int body_size;
  double line_spacing;
  bool justified;
  int indent;         // first-line indent in pixels (0 = block paragraphs)
  int paragraph_gap;  // extra vertical space between paragraphs
  double emphasis_rate;
  cv::Scalar ink;
  cv::Scalar heading_ink;
  bool color;
};

class PageBuilder {
 public:
  PageBuilder(Rng* rng, cv::Mat* page, std::vector<cv::Rect>* boxes, const PageStyle& style,
              double unit, int concrete_set)
      : rng_(*rng), page_(*page), ts_(page, boxes, concrete_set), style_(style), unit_(unit) {}

  void SetColumns(std::vector<Column> columns, int top, int bottom) {
    columns_ = std::move(columns);
    column_ = 0;
    top_ = top;
    bottom_ = bottom;
    y_ = top;
  }

  bool Full() const { return column_ >= static_cast<int>(columns_.size()); }
  const Column& Col() const { return columns_[static_cast<size_t>(column_)]; }
  int ColWidth() const { return Col().x1 - Col().x0; }

  int LineHeight(int size) const {
    return static_cast<int>(std::lround(size * style_.line_spacing));
  }

  // Makes room for h pixels in the current column, moving to the next column
  // if needed. Returns false when the page is full.
  bool Reserve(int h) {
    while (!Full()) {
      if (y_ + h <= bottom_) return true;
      if (y_ == top_) {  // taller than a whole column: give up on it
        ++column_;
        y_ = top_;
        return false;
      }
      ++column_;
      y_ = top_;
    }
    return false;
  }

  // True when h pixels fit in the current column or a later column exists.
  // Blocks that would end the page early (a figure near the bottom of the
  // last column) are dropped instead, as a typesetter would float them.
  bool CanPlace(int h) const {
    return !Full() && (y_ + h <= bottom_ ||
                       column_ + 1 < static_cast<int>(columns_.size()));
  }

  void Skip(int h) {
    if (!Full() && y_ != top_) y_ += h;
  }

  // Lays out a paragraph in the flowing columns.
  void Paragraph(const std::vector<Token>& tokens, Family family, int size,
                 int indent, bool justified, const cv::Scalar& ink) {
    size_t next = 0;
    bool first_line = true;
    const int line_height = LineHeight(size);
    const int ascent = static_cast<int>(std::lround(size * 0.78));
    while (next < tokens.size()) {
      if (!Reserve(line_height)) return;
      const int line_indent = first_line ? indent : 0;
      const int avail = ColWidth() - line_indent;
      // Greedy line breaking.
      std::vector<Typesetter::Measured> words;
      std::vector<int> spaces;
      int used = 0;
      size_t end = next;
      while (end < tokens.size()) {
        const int font = FontId(family, tokens[end].style);
        const auto m = ts_.Measure(font, size, tokens[end].text);
        const int space = ts_.Space(font, size);
        const int need =
            words.empty() ? m.width : used + spaces.back() + m.width;
        if (!words.empty() && need > avail) break;
        used = need;
        words.push_back(m);
        spaces.push_back(space);
        ++end;
      }
      const bool last_line = end >= tokens.size();
      int gaps = static_cast<int>(words.size()) - 1;
      int extra = avail - used;
      // Justify unless the gaps would become absurd (a real typesetter would
      // hyphenate there).
      if (!justified || last_line || gaps <= 0 || 2 * extra > 3 * gaps * size) {
        extra = 0;
      }
      int x = Col().x0 + line_indent;
      const int baseline = y_ + ascent;
      for (size_t i = 0; i < words.size(); ++i) {
        ts_.Draw(words[i], x, baseline, ink);
        int add = 0;
        if (gaps > 0 && extra > 0) {
          add = extra * static_cast<int>(i + 1) / gaps -
                extra * static_cast<int>(i) / gaps;
        }
        x += words[i].width + spaces[i] + add;
      }
      y_ += line_height;
      next = end;
      first_line = false;
    }
  }

  void BodyParagraph() {
    const int words = rng_.Int(15, 140);
    auto tokens = RandomParagraph(rng_, words, style_.emphasis_rate);
    Paragraph(tokens, style_.body_family, style_.body_size, style_.indent,
              style_.justified, style_.ink);
    Skip(style_.paragraph_gap);
  }

  void Heading(int* section) {
    const int size = static_cast<int>(
        std::lround(style_.body_size * rng_.Uniform(1.05, 1.45)));
    const int line_height = LineHeight(size);
    Skip(static_cast<int>(style_.body_size * rng_.Uniform(0.6, 1.4)));
    // Keep a heading together with two lines of text.
    const int need = line_height + 2 * LineHeight(style_.body_size);
    if (!CanPlace(need) || !Reserve(need)) return;
    ++*section;
    std::vector<Token> tokens;
    if (rng_.Chance(0.7)) {
      std::string number = std::to_string(*section);
      if (rng_.Chance(0.4)) number += "." + std::to_string(rng_.Int(1, 6));
      tokens.push_back({number, kBold});
    }
    const int style = rng_.Chance(0.85) ? kBold : kBoldItalic;
    for (auto& t : RandomPhrase(rng_, 1, 5, style)) tokens.push_back(t);
    Paragraph(tokens, style_.heading_family, size, 0, false,
              style_.heading_ink);
    Skip(static_cast<int>(style_.body_size * rng_.Uniform(0.2, 0.6)));
  }

  void Caption(const std::string& label, int number) {
    const int size =
        std::max(10, static_cast<int>(std::lround(style_.body_size * 0.85)));
    std::vector<Token> tokens;
    tokens.push_back({label, kBold});
    tokens.push_back({std::to_string(number) + ":", kBold});
    auto words = RandomParagraph(rng_, rng_.Int(4, 30), 0);
    for (auto& t : words) tokens.push_back(t);
    Paragraph(tokens, style_.body_family, size, 0, style_.justified,
              style_.ink);
  }

  void Figure(int number) {
    const int width = ColWidth();
    const int height = static_cast<int>(width * rng_.Uniform(0.35, 0.75));
    Skip(style_.body_size / 2);
    const int need = height + 2 * LineHeight(style_.body_size);
    if (!CanPlace(need) || !Reserve(need)) return;
    const cv::Rect box(Col().x0, y_, width, height);
    switch (rng_.Int(0, 2)) {
      case 0:
        PhotoFigure(box);
        break;
      case 1:
        PlotFigure(box, false);
        break;
      default:
        PlotFigure(box, true);
        break;
    }
    y_ += height + style_.body_size / 2;
    Caption("Figure", number);
    Skip(style_.body_size / 2);
  }

  void Table(int number) {
    const int rows = rng_.Int(3, 8);
    const int cols = rng_.Int(2, std::max(2, std::min(5, ColWidth() / 110)));
    const int size =
        std::max(10, static_cast<int>(std::lround(style_.body_size * 0.9)));
    const int row_height = LineHeight(size) + size / 3;
    Skip(style_.body_size / 2);
    const int need = (rows + 1) * row_height + 3 * LineHeight(size);
    if (!CanPlace(need) || !Reserve(need)) return;
    Caption("Table", number);
    const int x0 = Col().x0, x1 = Col().x1;
    const int thick = std::max(1, static_cast<int>(std::lround(unit_ * 2)));
    const int thin = std::max(1, static_cast<int>(std::lround(unit_)));
    int y = y_ + size / 3;
    cv::line(page_, {x0, y}, {x1, y}, style_.ink, thick, cv::LINE_AA);
    y += size / 3;
    const int cell = (x1 - x0) / cols;
    const int pad = std::max(2, size / 4);
    const int ascent = static_cast<int>(std::lround(size * 0.78));
    for (int r = 0; r <= rows; ++r) {
      for (int c = 0; c < cols; ++c) {
        std::vector<Token> text;
        if (r == 0) {
          text = RandomPhrase(rng_, 1, cols > 3 ? 1 : 2, kBold);
        } else if (c == 0) {
          text = RandomPhrase(rng_, 1, cols > 3 ? 1 : 2, kRegular);
        } else {
          std::string value = std::to_string(rng_.Int(0, 999));
          if (rng_.Chance(0.5)) {
            value = std::to_string(rng_.Int(0, 99)) + "." + value.substr(0, 1);
          }
          text.push_back({value, kRegular});
        }
        // Drop words that do not fit in the cell.
        while (text.size() > 1 &&
               ts_.RunWidth(text, style_.body_family, size) > cell - 2 * pad) {
          text.pop_back();
        }
        if (ts_.RunWidth(text, style_.body_family, size) > cell - 2 * pad) {
          continue;
        }
        const int w = ts_.RunWidth(text, style_.body_family, size);
        const int x = c == 0 ? x0 + pad : x0 + (c + 1) * cell - pad - w;
        ts_.DrawRun(text, style_.body_family, size, x, y + ascent, style_.ink);
      }
      y += row_height;
      if (r == 0) {
        cv::line(page_, {x0, y - size / 6}, {x1, y - size / 6}, style_.ink,
                 thin, cv::LINE_AA);
      }
    }
    cv::line(page_, {x0, y}, {x1, y}, style_.ink, thick, cv::LINE_AA);
    y_ = y + style_.body_size;
  }

  int y() const { return y_; }
  void set_y(int y) { y_ = y; }
  Typesetter& ts() { return ts_; }

 private:
  cv::Scalar FigureColor(int i) {
    static const cv::Scalar kColors[] = {{180, 90, 30},
                                         {40, 40, 200},
                                         {50, 150, 60},
                                         {20, 140, 220},
                                         {150, 60, 140}};
    if (style_.color) return kColors[i % 5];
    const int g = 40 + 35 * (i % 4);
    return cv::Scalar::all(g);
  }

  // A grey "photograph": smooth shading with a few soft shapes.
  void PhotoFigure(const cv::Rect& box) {
    cv::Mat roi = page_(box);
    const int g0 = rng_.Int(110, 200), g1 = rng_.Int(80, 220);
    cv::Vec3b c0 = cv::Vec3b::all(static_cast<uint8_t>(g0));
    if (style_.color) {
      for (int c = 0; c < 3; ++c)
        c0[c] = static_cast<uint8_t>(rng_.Int(60, 220));
    }
    for (int y = 0; y < roi.rows; ++y) {
      cv::Vec3b* p = roi.ptr<cv::Vec3b>(y);
      const int shade = (g1 - g0) * y / std::max(1, roi.rows);
      for (int x = 0; x < roi.cols; ++x) {
        for (int c = 0; c < 3; ++c) {
          p[x][c] = cv::saturate_cast<uint8_t>(c0[c] + shade / 2);
        }
      }
    }
    const int shapes = rng_.Int(2, 7);
    for (int i = 0; i < shapes; ++i) {
      cv::Point centre;
      centre.x = rng_.Int(0, box.width);
      centre.y = rng_.Int(0, box.height);
      const int r = rng_.Int(box.height / 10, box.height / 3 + 2);
      cv::Scalar colour = cv::Scalar::all(rng_.Int(20, 240));
      if (style_.color) {
        for (int c = 1; c < 3; ++c) colour[c] = rng_.Int(20, 240);
      }
      if (rng_.Chance(0.5)) {
        const int minor = r * rng_.Int(5, 15) / 10;
        const int angle = rng_.Int(0, 179);
        cv::ellipse(roi, centre, {r, minor}, angle, 0, 360, colour, -1,
                    cv::LINE_AA);
      } else {
        cv::rectangle(roi, cv::Rect(centre.x - r, centre.y - r / 2, 2 * r, r),
                      colour, -1, cv::LINE_AA);
      }
    }
    cv::GaussianBlur(roi, roi, cv::Size(0, 0), 1.5 * unit_ + 0.5);
    cv::rectangle(page_, box, style_.ink, 1, cv::LINE_8);
  }

  // A line plot or a bar chart with axes and numeric tick labels.
  void PlotFigure(const cv::Rect& box, bool bars) {
    const int size =
        std::max(10, static_cast<int>(std::lround(style_.body_size * 0.75)));
    const int left = box.x + size * 3, right = box.br().x - size;
    const int top = box.y + size, bottom = box.br().y - size * 2;
    if (right - left < 40 || bottom - top < 30) return;
    const int axis_w = std::max(1, static_cast<int>(std::lround(unit_ * 1.5)));
    cv::line(page_, {left, bottom}, {right, bottom}, style_.ink, axis_w,
             cv::LINE_AA);
    cv::line(page_, {left, bottom}, {left, top}, style_.ink, axis_w,
             cv::LINE_AA);
    const Family family = rng_.Chance(0.5) ? kSans : style_.body_family;
    const int ticks = rng_.Int(3, 6);
    int step = rng_.Int(1, 5);
    if (rng_.Chance(0.5)) step *= 10;
    for (int i = 0; i <= ticks; ++i) {
      const int x = left + (right - left) * i / ticks;
      const int y = bottom - (bottom - top) * i / ticks;
      cv::line(page_, {x, bottom}, {x, bottom + size / 3}, style_.ink, 1);
      cv::line(page_, {left - size / 3, y}, {left, y}, style_.ink, 1);
      const std::vector<Token> xl = {{std::to_string(i * step), kRegular}};
      const int xw = ts_.RunWidth(xl, family, size);
      ts_.DrawRun(xl, family, size, x - xw / 2, bottom + size * 3 / 2,
                  style_.ink);
      const std::vector<Token> yl = {{std::to_string(i * 10), kRegular}};
      const int yw = ts_.RunWidth(yl, family, size);
      ts_.DrawRun(yl, family, size, left - size / 2 - yw, y + size / 3,
                  style_.ink);
    }
    const int series = rng_.Int(1, 3);
    const int n = bars ? rng_.Int(3, 8) : rng_.Int(6, 25);
    for (int s = 0; s < series; ++s) {
      const cv::Scalar colour = FigureColor(s);
      std::vector<cv::Point> pts;
      double v = rng_.Uniform(0.1, 0.9);
      for (int i = 0; i < n; ++i) {
        v = std::clamp(v + rng_.Uniform(-0.2, 0.2), 0.05, 0.95);
        const int x = left + (right - left) * (2 * i + 1) / (2 * n);
        const int y = bottom - static_cast<int>((bottom - top) * v);
        if (bars) {
          const int bw = std::max(2, (right - left) / (n * (series + 1)));
          const int bx = x - series * bw / 2 + s * bw;
          cv::rectangle(page_, cv::Rect(bx, y, bw - 1, bottom - y), colour, -1);
        } else {
          pts.push_back({x, y});
        }
      }
      if (!bars) {
        cv::polylines(page_, pts, false, colour, axis_w, cv::LINE_AA);
        for (const auto& p : pts) {
          cv::circle(page_, p, std::max(2, size / 5), colour, -1, cv::LINE_AA);
        }
      }
    }
  }

  Rng& rng_;
  cv::Mat& page_;
  Typesetter ts_;
  PageStyle style_;
  double unit_;
  std::vector<Column> columns_;
  int column_ = 0;
  int top_ = 0, bottom_ = 0, y_ = 0;
};

Family RandomFamily(Rng& rng) {
  const double u = rng.Unit();
  if (u < 0.35) return kSerif;
  if (u < 0.60) return kSans;
  if (u < 0.75) return kSansCondensed;
  if (u < 0.90) return kSerifCondensed;
  return kMono;
}

}  // namespace

std::string_view FontSetName(FontSet set) {
  switch (set) {
    case FontSet::kDejaVu:
      return "dejavu";
    case FontSet::kLiberation:
      return "liberation";
    case FontSet::kFreeFont:
      return "freefont";
    case FontSet::kLatinModern:
      return "latinmodern";
    case FontSet::kAll:
      return "all";
  }
  return "?";
}

absl::StatusOr<FontSet> ParseFontSet(std::string_view name) {
  for (FontSet set : {FontSet::kDejaVu, FontSet::kLiberation, FontSet::kFreeFont,
                      FontSet::kLatinModern, FontSet::kAll}) {
    if (name == FontSetName(set)) return set;
  }
  return absl::InvalidArgumentError("unknown font set '" + std::string(name) +
                                    "': expected dejavu, liberation, freefont, latinmodern or all");
}

absl::Status CheckFontSet(FontSet set) {
  if (set != FontSet::kAll) return CheckConcreteSet(ConcreteSet(set, 0));
  for (int s = 0; s < kAllSets; ++s) {
    absl::Status status = CheckConcreteSet(s);
    if (!status.ok()) return status;
  }
  return absl::OkStatus();
}

absl::StatusOr<FontSet> AvailableFontSet(std::string_view name) {
  absl::StatusOr<FontSet> set = ParseFontSet(name);
  if (!set.ok()) return set.status();
  if (absl::Status available = CheckFontSet(*set); !available.ok()) return available;
  return set;
}

RenderedPage RenderTextPage(uint64_t seed, const PageOptions& options) {
  Rng rng(seed);
  RenderedPage result;
  result.seed = seed;
  cv::Scalar ink;
  result.image = MakePaper(rng, options, &ink);
  const int width = result.image.cols, height = result.image.rows;
  const double unit = width / 1000.0;
  auto px = [unit](double v) {
    return static_cast<int>(std::lround(v * unit));
  };

  PageStyle style;
  style.color = options.color;
  style.ink = ink;
  style.body_family = RandomFamily(rng);
  style.heading_family =
      rng.Chance(0.5) ? style.body_family : (rng.Chance(0.6) ? kSans : kSerif);
  // Body size 14..30 px at 1000 px width, smaller sizes more common.
  const double size_u = rng.Unit();
  style.body_size = std::max(8, px(14 + 16 * size_u * size_u));
  style.line_spacing = rng.Uniform(1.1, 1.6);
  style.justified = rng.Chance(0.6);
  style.indent = rng.Chance(0.55) ? px(rng.Uniform(15, 45)) : 0;
  style.paragraph_gap =
      style.indent > 0
          ? (rng.Chance(0.7) ? 0 : style.body_size / 3)
          : static_cast<int>(style.body_size * rng.Uniform(0.4, 1.0));
  style.emphasis_rate = rng.Chance(0.5) ? rng.Uniform(0.005, 0.04) : 0;
  style.heading_ink = ink;
  if (options.color && rng.Chance(0.8)) {
    static const cv::Scalar kHeading[] = {{120, 40, 10},
                                          {20, 20, 160},
                                          {30, 110, 30},
                                          {110, 90, 10},
                                          {100, 30, 100}};
    style.heading_ink = kHeading[rng.Int(0, 4)];
  }

  const int margin_left = px(rng.Uniform(50, 120));
  const int margin_right =
      rng.Chance(0.6) ? margin_left : px(rng.Uniform(50, 120));
  const int margin_top = px(rng.Uniform(50, 120));
  const int margin_bottom = px(rng.Uniform(50, 120));
  const int text_width = width - margin_left - margin_right;

  int num_columns = 1;
  const double cu = rng.Unit();
  if (style.body_size <= px(19) && cu < 0.12) {
    num_columns = 3;
  } else if (style.body_size <= px(24) && cu < 0.55) {
    num_columns = 2;
  }

  std::vector<cv::Rect> boxes;
  PageBuilder builder(&rng, &result.image, &boxes, style, unit, ConcreteSet(options.fonts, seed));
  Typesetter& ts = builder.ts();
  const std::vector<Column> full = {{margin_left, width - margin_right}};
  builder.SetColumns(full, margin_top, height - margin_bottom);

  // Running header with a rule line.
  int page_number = rng.Int(1, 480);
  if (rng.Chance(0.4)) {
    const int size = std::max(8, static_cast<int>(style.body_size * 0.75));
    const Family family = rng.Chance(0.5) ? style.body_family : kSans;
    auto title = RandomPhrase(rng, 2, 6, rng.Chance(0.5) ? kItalic : kRegular);
    const int baseline = margin_top + size;
    ts.DrawRun(title, family, size, margin_left, baseline, ink);
    const std::vector<Token> num = {{std::to_string(page_number), kRegular}};
    ts.DrawRun(num, family, size,
               width - margin_right - ts.RunWidth(num, family, size), baseline,
               ink);
    const int rule_y = baseline + size / 2;
    cv::line(result.image, {margin_left, rule_y},
             {width - margin_right, rule_y}, ink, std::max(1, px(1)),
             cv::LINE_AA);
    builder.set_y(rule_y + size);
  }

  // Title block (only on some pages: others start mid-document).
  if (rng.Chance(0.65)) {
    const int size = std::min(
        px(60), static_cast<int>(style.body_size * rng.Uniform(1.5, 2.3)));
    const Family family = rng.Chance(0.6) ? style.heading_family : kSans;
    auto title =
        RandomPhrase(rng, 2, 9, rng.Chance(0.85) ? kBold : kBoldItalic);
    const bool centred = rng.Chance(0.6);
    // Wrap the title by hand so that each line can be centred.
    std::vector<std::vector<Token>> lines(1);
    for (const Token& t : title) {
      lines.back().push_back(t);
      if (lines.back().size() > 1 &&
          ts.RunWidth(lines.back(), family, size) > text_width) {
        lines.back().pop_back();
        lines.push_back({t});
      }
    }
    const int line_height = static_cast<int>(size * 1.25);
    int y = builder.y() + size / 2;
    for (const auto& line : lines) {
      const int w = ts.RunWidth(line, family, size);
      const int x = centred ? margin_left + (text_width - w) / 2 : margin_left;
      ts.DrawRun(line, family, size, x, y + size * 4 / 5, style.heading_ink);
      y += line_height;
    }
    if (rng.Chance(0.6)) {  // authors
      const int asize = std::max(8, static_cast<int>(style.body_size * 0.95));
      auto authors =
          RandomPhrase(rng, 2, 6, rng.Chance(0.5) ? kItalic : kRegular);
      const int w = ts.RunWidth(authors, style.body_family, asize);
      const int x = centred ? margin_left + (text_width - w) / 2 : margin_left;
      y += asize / 3;
      ts.DrawRun(authors, style.body_family, asize, x, y + asize * 4 / 5, ink);
      y += static_cast<int>(asize * 1.4);
    }
    builder.set_y(y + style.body_size);
  }

  // Columns below the title.
  const int gap = px(rng.Uniform(20, 50));
  const int col_width = (text_width - (num_columns - 1) * gap) / num_columns;
  std::vector<Column> columns;
  for (int c = 0; c < num_columns; ++c) {
    const int x0 = margin_left + c * (col_width + gap);
    columns.push_back({x0, x0 + col_width});
  }
  const bool has_page_number = rng.Chance(0.6);
  const int footer = has_page_number ? style.body_size * 2 : 0;
  builder.SetColumns(columns, builder.y(), height - margin_bottom - footer);

  const bool has_figure = rng.Chance(0.3);
  const bool has_table = rng.Chance(0.25);
  const int figure_at = rng.Int(0, 6), table_at = rng.Int(0, 8);
  int section = rng.Int(0, 6);
  for (int block = 0; !builder.Full() && block < 200; ++block) {
    if (has_figure && block == figure_at) builder.Figure(rng.Int(1, 12));
    if (has_table && block == table_at) builder.Table(rng.Int(1, 9));
    if (block > 0 && rng.Chance(0.22)) builder.Heading(&section);
    builder.BodyParagraph();
  }

  if (has_page_number) {
    const int size = std::max(8, static_cast<int>(style.body_size * 0.85));
    const std::vector<Token> num = {{std::to_string(page_number), kRegular}};
    const int w = ts.RunWidth(num, style.body_family, size);
    int x = margin_left + (text_width - w) / 2;
    if (rng.Chance(0.4))
      x = page_number % 2 ? width - margin_right - w : margin_left;
    ts.DrawRun(num, style.body_family, size, x, height - margin_bottom, ink);
  }

  result.word_boxes = std::move(boxes);
  return result;
}

cv::Mat RenderBlankPage(uint64_t seed, const PageOptions& options) {
  Rng rng(seed ^ 0xb1a2c3d4e5f60718ULL);
  return MakePaper(rng, options, nullptr);
}

}  // namespace texfree::testdata
