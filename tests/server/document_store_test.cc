// DocumentStore: persistence across reopen, annotations, deletion cascade, schema version,
// and errors for unknown ids.
#include "server/document_store.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <map>

namespace texfree::server {
namespace {

namespace fs = std::filesystem;

class DocumentStoreTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("texfree-store-" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    path_ = (dir_ / "t.db").string();
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
  std::string path_;
};

DocumentRecord MakeRecord(const std::string& title, int points) {
  DocumentRecord r;
  r.title = title;
  r.size = {800, 1100};
  for (int i = 0; i < points; ++i) r.keypoints.emplace_back(i * 1.5f, i * 0.25f);
  AnnotationRecord text;
  text.kind = AnnotationRecord::Kind::kText;
  text.text = "hello";
  text.position = {10, 20};
  text.font_size_px = 18;
  text.color = {255, 0, 0, 255};
  AnnotationRecord hl;
  hl.kind = AnnotationRecord::Kind::kHighlight;
  hl.rect = {5, 6, 70, 8};
  hl.color = {255, 255, 0, 200};
  hl.opacity = 0.35;
  AnnotationRecord media;
  media.kind = AnnotationRecord::Kind::kMedia;
  media.rect = {1, 2, 3, 4};
  media.mime_type = "image/png";
  media.data = std::string("\x00\x01\x02\xff", 4);
  r.annotations = {text, hl, media};
  return r;
}

TEST_F(DocumentStoreTest, InsertGetSurvivesReopen) {
  std::string id;
  {
    auto store = DocumentStore::Open(path_);
    ASSERT_TRUE(store.ok()) << store.status();
    auto rec = (*store)->Insert(MakeRecord("first", 50));
    ASSERT_TRUE(rec.ok()) << rec.status();
    id = rec->id;
    EXPECT_EQ(rec->annotations.size(), 3u);
    EXPECT_FALSE(rec->annotations[0].id.empty());
    ASSERT_TRUE((*store)->Insert(MakeRecord("second", 10)).ok());
  }
  auto store = DocumentStore::Open(path_);
  ASSERT_TRUE(store.ok());
  auto got = (*store)->Get(id, /*with_keypoints=*/true);
  ASSERT_TRUE(got.ok()) << got.status();
  EXPECT_EQ(got->title, "first");
  EXPECT_EQ(got->size, cv::Size(800, 1100));
  EXPECT_EQ(got->keypoint_count, 50);
  ASSERT_EQ(got->keypoints.size(), 50u);
  EXPECT_FLOAT_EQ(got->keypoints[49].x, 49 * 1.5f);
  ASSERT_EQ(got->annotations.size(), 3u);
  EXPECT_EQ(got->annotations[0].text, "hello");
  EXPECT_EQ(got->annotations[0].color.r, 255);
  EXPECT_DOUBLE_EQ(got->annotations[1].opacity, 0.35);
  EXPECT_DOUBLE_EQ(got->annotations[1].rect.width, 70);
  EXPECT_EQ(got->annotations[1].color.a, 200);
  EXPECT_EQ(got->annotations[2].data, std::string("\x00\x01\x02\xff", 4));
  EXPECT_EQ(*(*store)->Count(), 2);

  int seen = 0;
  ASSERT_TRUE(
      (*store)
          ->ForEachKeypoints([&](const DocumentSummary& s, DocumentStore::StoredKeypoints k) {
            EXPECT_EQ(static_cast<int>(k.keypoints.size()), s.keypoints);
            EXPECT_TRUE(k.hashes.empty()) << "none were stored";
            EXPECT_TRUE(k.layer_sizes.empty() && k.layer_keypoints.empty());
            ++seen;
          })
          .ok());
  EXPECT_EQ(seen, 2);
}

// Descriptor hashes are stored with the page or later (start-up writes back what it had to
// compute) and read back bit for bit.
TEST_F(DocumentStoreTest, HashesAreStoredAndUpdated) {
  uint32_t with_hashes = 0, without = 0;
  {
    auto store = DocumentStore::Open(path_);
    ASSERT_TRUE(store.ok());
    DocumentRecord r = MakeRecord("hashed", 4);
    r.hashes = {1, 0xFFFFFFFFFFFFFFFFull, 42, 0x8000000000000000ull};
    auto a = (*store)->Insert(r);
    auto b = (*store)->Insert(MakeRecord("plain", 4));
    ASSERT_TRUE(a.ok() && b.ok());
    with_hashes = a->index_id;
    without = b->index_id;
    ASSERT_TRUE((*store)->PutHashes({{without, {7, 8, 9}}}).ok());
  }
  auto store = DocumentStore::Open(path_);
  ASSERT_TRUE(store.ok());
  std::map<uint32_t, std::vector<uint64_t>> seen;
  ASSERT_TRUE(
      (*store)
          ->ForEachKeypoints([&](const DocumentSummary& s, DocumentStore::StoredKeypoints k) {
            seen[s.index_id] = std::move(k.hashes);
          })
          .ok());
  EXPECT_EQ(seen[with_hashes],
            (std::vector<uint64_t>{1, 0xFFFFFFFFFFFFFFFFull, 42, 0x8000000000000000ull}));
  EXPECT_EQ(seen[without], (std::vector<uint64_t>{7, 8, 9}));
}

// Extra keypoint layers are stored with the page and read back bit for bit, apart from its
// keypoints (which stay the page's own word keypoints).
TEST_F(DocumentStoreTest, KeypointLayersAreStored) {
  uint32_t layered = 0;
  {
    auto store = DocumentStore::Open(path_);
    ASSERT_TRUE(store.ok());
    DocumentRecord r = MakeRecord("layered", 3);
    r.layer_keypoints = {{1.5f, 2.5f}, {3.f, 4.f}, {5.f, 6.f}, {7.25f, 8.f}, {9.f, 10.f}};
    r.layer_sizes = {2, 0, 3};
    auto a = (*store)->Insert(r);
    ASSERT_TRUE(a.ok());
    EXPECT_EQ(a->keypoint_count, 3);
    layered = a->index_id;
  }
  auto store = DocumentStore::Open(path_);
  ASSERT_TRUE(store.ok());
  int seen = 0;
  ASSERT_TRUE(
      (*store)
          ->ForEachKeypoints([&](const DocumentSummary& s, DocumentStore::StoredKeypoints k) {
            ASSERT_EQ(s.index_id, layered);
            EXPECT_EQ(k.keypoints.size(), 3u);
            EXPECT_EQ(k.layer_sizes, (std::vector<uint32_t>{2, 0, 3}));
            ASSERT_EQ(k.layer_keypoints.size(), 5u);
            EXPECT_FLOAT_EQ(k.layer_keypoints[0].x, 1.5f);
            EXPECT_FLOAT_EQ(k.layer_keypoints[3].x, 7.25f);
            EXPECT_FLOAT_EQ(k.layer_keypoints[4].y, 10.f);
            ++seen;
          })
          .ok());
  EXPECT_EQ(seen, 1);
}

// A page's figure keypoints are stored apart from its words and read back bit for bit; a page
// without them (or from before schema version 4) reads back none.
TEST_F(DocumentStoreTest, FigureKeypointsAreStored) {
  {
    auto store = DocumentStore::Open(path_);
    ASSERT_TRUE(store.ok());
    DocumentRecord chart = MakeRecord("chart", 3);
    chart.figure_keypoints = {{10.25f, 20.5f}, {30.f, 40.75f}};
    ASSERT_TRUE((*store)->Insert(chart).ok());
    ASSERT_TRUE((*store)->Insert(MakeRecord("text only", 3)).ok());
  }
  auto store = DocumentStore::Open(path_);
  ASSERT_TRUE(store.ok());
  std::map<std::string, std::vector<cv::Point2f>> figures;
  ASSERT_TRUE(
      (*store)
          ->ForEachKeypoints([&](const DocumentSummary& s, DocumentStore::StoredKeypoints k) {
            EXPECT_EQ(k.keypoints.size(), 3u);
            figures[s.title] = k.figure_keypoints;
          })
          .ok());
  ASSERT_EQ(figures.size(), 2u);
  ASSERT_EQ(figures["chart"].size(), 2u);
  EXPECT_FLOAT_EQ(figures["chart"][0].x, 10.25f);
  EXPECT_FLOAT_EQ(figures["chart"][1].y, 40.75f);
  EXPECT_TRUE(figures["text only"].empty());
}

// A page's large-type letters are stored apart from its words and figures and read back bit
// for bit; a page without them (or from before schema version 5) reads back none.
TEST_F(DocumentStoreTest, LetterKeypointsAreStored) {
  {
    auto store = DocumentStore::Open(path_);
    ASSERT_TRUE(store.ok());
    DocumentRecord poster = MakeRecord("poster", 3);
    poster.letter_keypoints = {{110.5f, 20.25f}, {140.f, 21.75f}, {170.125f, 19.5f}};
    poster.letter_hashes = {7, 0, 0x8000000000000001ull};
    poster.figure_keypoints = {{1.f, 2.f}};
    ASSERT_TRUE((*store)->Insert(poster).ok());
    ASSERT_TRUE((*store)->Insert(MakeRecord("small type", 3)).ok());
  }
  auto store = DocumentStore::Open(path_);
  ASSERT_TRUE(store.ok());
  std::map<std::string, DocumentStore::StoredKeypoints> read;
  ASSERT_TRUE(
      (*store)
          ->ForEachKeypoints([&](const DocumentSummary& s, DocumentStore::StoredKeypoints k) {
            read[s.title] = std::move(k);
          })
          .ok());
  ASSERT_EQ(read.size(), 2u);
  ASSERT_EQ(read["poster"].letter_keypoints.size(), 3u);
  EXPECT_FLOAT_EQ(read["poster"].letter_keypoints[0].x, 110.5f);
  EXPECT_FLOAT_EQ(read["poster"].letter_keypoints[2].x, 170.125f);
  EXPECT_FLOAT_EQ(read["poster"].letter_keypoints[1].y, 21.75f);
  EXPECT_EQ(read["poster"].letter_hashes, (std::vector<uint64_t>{7, 0, 0x8000000000000001ull}));
  ASSERT_EQ(read["poster"].figure_keypoints.size(), 1u);
  EXPECT_TRUE(read["small type"].letter_keypoints.empty());
  EXPECT_TRUE(read["small type"].letter_hashes.empty());
  // Hashes computed at start-up are written back into the letters' column, not the words'.
  std::vector<uint64_t> words_before;
  uint32_t poster_id = 0;
  ASSERT_TRUE(
      (*store)
          ->ForEachKeypoints([&](const DocumentSummary& s, DocumentStore::StoredKeypoints k) {
            if (s.title == "poster") {
              poster_id = s.index_id;
              words_before = k.hashes;
            }
          })
          .ok());
  ASSERT_TRUE(
      (*store)->PutHashes({{poster_id, {1, 2, 3}}}, DocumentStore::HashColumn::kLetters).ok());
  ASSERT_TRUE(
      (*store)
          ->ForEachKeypoints([&](const DocumentSummary& s, DocumentStore::StoredKeypoints k) {
            if (s.index_id != poster_id) return;
            EXPECT_EQ(k.letter_hashes, (std::vector<uint64_t>{1, 2, 3}));
            EXPECT_EQ(k.hashes, words_before);
          })
          .ok());
}

// A database written by schema version 1 (before hashes were stored) is migrated in place
// and keeps its pages.
TEST_F(DocumentStoreTest, MigratesVersionOneDatabase) {
  {
    auto db = SqliteDb::Open(path_);
    ASSERT_TRUE(db.ok());
    ASSERT_TRUE((*db)
                    ->Exec(R"sql(
CREATE TABLE settings (key TEXT PRIMARY KEY, value BLOB NOT NULL);
CREATE TABLE documents (index_id INTEGER PRIMARY KEY, public_id TEXT NOT NULL UNIQUE,
  title TEXT NOT NULL, width INTEGER NOT NULL, height INTEGER NOT NULL,
  created_unix_ms INTEGER NOT NULL, keypoint_count INTEGER NOT NULL, keypoints BLOB NOT NULL);
CREATE TABLE annotations (annotation_row INTEGER PRIMARY KEY, public_id TEXT NOT NULL UNIQUE,
  document INTEGER NOT NULL REFERENCES documents(index_id) ON DELETE CASCADE,
  kind INTEGER NOT NULL, text TEXT NOT NULL DEFAULT '', x REAL NOT NULL DEFAULT 0,
  y REAL NOT NULL DEFAULT 0, width REAL NOT NULL DEFAULT 0, height REAL NOT NULL DEFAULT 0,
  font_size REAL NOT NULL DEFAULT 0, rgba INTEGER NOT NULL DEFAULT 0,
  opacity REAL NOT NULL DEFAULT 1, uri TEXT NOT NULL DEFAULT '',
  mime_type TEXT NOT NULL DEFAULT '', data BLOB);
INSERT INTO documents VALUES (1, 'old-page', 'Old', 100, 200, 0, 1, x'0000803F00000040');
PRAGMA user_version = 1;
)sql")
                    .ok());
  }
  auto store = DocumentStore::Open(path_);
  ASSERT_TRUE(store.ok()) << store.status();
  auto got = (*store)->Get("old-page", /*with_keypoints=*/true);
  ASSERT_TRUE(got.ok()) << got.status();
  ASSERT_EQ(got->keypoints.size(), 1u);
  EXPECT_FLOAT_EQ(got->keypoints[0].x, 1.0f);
  EXPECT_FLOAT_EQ(got->keypoints[0].y, 2.0f);
  ASSERT_TRUE((*store)->PutHashes({{1, {5}}}).ok());
}

TEST_F(DocumentStoreTest, DeleteRemovesAnnotationsAndUnknownIdsAreNotFound) {
  auto store = DocumentStore::Open(path_);
  ASSERT_TRUE(store.ok());
  auto rec = (*store)->Insert(MakeRecord("doomed", 20));
  ASSERT_TRUE(rec.ok());
  auto removed = (*store)->Delete(rec->id);
  ASSERT_TRUE(removed.ok());
  EXPECT_EQ(*removed, rec->index_id);
  EXPECT_EQ((*store)->Get(rec->id).status().code(), absl::StatusCode::kNotFound);
  auto orphans = (*store)->Annotations(rec->index_id);
  ASSERT_TRUE(orphans.ok());
  EXPECT_TRUE(orphans->empty());
  EXPECT_EQ((*store)->Delete(rec->id).status().code(), absl::StatusCode::kNotFound);
  EXPECT_EQ((*store)->AddAnnotation("missing", AnnotationRecord()).status().code(),
            absl::StatusCode::kNotFound);
}

TEST_F(DocumentStoreTest, AnnotationsAddAndDelete) {
  auto store = DocumentStore::Open(path_);
  ASSERT_TRUE(store.ok());
  auto rec = (*store)->Insert(MakeRecord("doc", 5));
  ASSERT_TRUE(rec.ok());
  AnnotationRecord link;
  link.kind = AnnotationRecord::Kind::kLink;
  link.rect = {1, 1, 10, 10};
  link.uri = "https://example.org";
  auto added = (*store)->AddAnnotation(rec->id, link);
  ASSERT_TRUE(added.ok());
  EXPECT_EQ((*store)->Get(rec->id)->annotations.size(), 4u);
  ASSERT_TRUE((*store)->DeleteAnnotation(rec->id, added->id).ok());
  EXPECT_EQ((*store)->Get(rec->id)->annotations.size(), 3u);
  EXPECT_EQ((*store)->DeleteAnnotation(rec->id, added->id).code(), absl::StatusCode::kNotFound);
}

TEST_F(DocumentStoreTest, ListPagesInOrder) {
  auto store = DocumentStore::Open(path_);
  ASSERT_TRUE(store.ok());
  for (int i = 0; i < 5; ++i)
    ASSERT_TRUE((*store)->Insert(MakeRecord("d" + std::to_string(i), 3)).ok());
  auto first = (*store)->List(0, 3);
  ASSERT_TRUE(first.ok());
  ASSERT_EQ(first->size(), 3u);
  auto rest = (*store)->List(first->back().index_id, 3);
  ASSERT_TRUE(rest.ok());
  ASSERT_EQ(rest->size(), 2u);
  EXPECT_EQ(rest->back().title, "d4");
}

TEST_F(DocumentStoreTest, SettingsAndNewerSchemaRefused) {
  {
    auto store = DocumentStore::Open(path_);
    ASSERT_TRUE(store.ok());
    ASSERT_TRUE((*store)->PutSetting("k", "v1").ok());
    ASSERT_TRUE((*store)->PutSetting("k", "v2").ok());
    EXPECT_EQ(**(*store)->GetSetting("k"), "v2");
    EXPECT_FALSE((*store)->GetSetting("absent")->has_value());
  }
  {
    auto db = SqliteDb::Open(path_);
    ASSERT_TRUE(db.ok());
    ASSERT_TRUE((*db)->Exec("PRAGMA user_version = 99").ok());
  }
  auto store = DocumentStore::Open(path_);
  ASSERT_FALSE(store.ok());
  EXPECT_EQ(store.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_NE(store.status().message().find("newer"), std::string::npos);
}

TEST(AnnotationValidation, NamesTheField) {
  const cv::Size page(800, 1000);
  AnnotationRecord a;
  a.kind = AnnotationRecord::Kind::kHighlight;
  a.rect = {0, 0, 10, 10};
  a.opacity = 1.2;
  EXPECT_NE(a.Validate(page).message().find("opacity"), std::string::npos);
  a.opacity = 0.5;
  EXPECT_TRUE(a.Validate(page).ok());
  a.rect.width = 0;
  EXPECT_NE(a.Validate(page).message().find("width"), std::string::npos);
  a.kind = AnnotationRecord::Kind::kLink;
  a.rect.width = 5;
  EXPECT_NE(a.Validate(page).message().find("url"), std::string::npos);
  a.kind = AnnotationRecord::Kind::kText;
  a.text = "x";
  a.font_size_px = -1;
  EXPECT_NE(a.Validate(page).message().find("font_size"), std::string::npos);
}

}  // namespace
}  // namespace texfree::server
