// DocumentStore implementation: schema, migrations and queries.
#include "server/document_store.h"

#include <chrono>
#include <cstring>
#include <random>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "common/status_macros.h"

namespace texfree::server {
namespace {

// Migrations, in order: entry i brings the schema from version i to i + 1.
const char* const kMigrations[] = {
    R"sql(
CREATE TABLE settings (
  key TEXT PRIMARY KEY,
  value BLOB NOT NULL
);
CREATE TABLE documents (
  index_id INTEGER PRIMARY KEY,
  public_id TEXT NOT NULL UNIQUE,
  title TEXT NOT NULL,
  width INTEGER NOT NULL CHECK (width > 0),
  height INTEGER NOT NULL CHECK (height > 0),
  created_unix_ms INTEGER NOT NULL,
  keypoint_count INTEGER NOT NULL,
  keypoints BLOB NOT NULL
);
CREATE TABLE annotations (
  annotation_row INTEGER PRIMARY KEY,
  public_id TEXT NOT NULL UNIQUE,
  document INTEGER NOT NULL REFERENCES documents(index_id) ON DELETE CASCADE,
  kind INTEGER NOT NULL,
  text TEXT NOT NULL DEFAULT '',
  x REAL NOT NULL DEFAULT 0, y REAL NOT NULL DEFAULT 0,
  width REAL NOT NULL DEFAULT 0, height REAL NOT NULL DEFAULT 0,
  font_size REAL NOT NULL DEFAULT 0,
  rgba INTEGER NOT NULL DEFAULT 0,
  opacity REAL NOT NULL DEFAULT 1,
  uri TEXT NOT NULL DEFAULT '',
  mime_type TEXT NOT NULL DEFAULT '',
  data BLOB
);
CREATE INDEX annotations_by_document ON annotations(document);
)sql",
    // v2: the LLAH descriptor hashes of each page, so that start-up reads them instead of
    // recomputing them (NULL: recomputed at start-up and written back).
    R"sql(
ALTER TABLE documents ADD COLUMN hashes BLOB;
)sql",
    // v3: extra keypoint layers (the page cut into words as a camera sees it): the sizes
    // of the layers, as 32-bit counts, then their points (NULL: none).
    R"sql(
ALTER TABLE documents ADD COLUMN layers BLOB;
)sql",
    // v4: the keypoints of the page's figures (FigureKeypointExtractor; NULL: none, or the
    // page was registered before they were).
    R"sql(
ALTER TABLE documents ADD COLUMN figures BLOB;
)sql",
    // v5: the letters of the page's large type (LetterKeypointExtractor; NULL: none, or the
    // page was registered before they were) and their LLAH descriptor hashes (NULL:
    // recomputed at start-up and written back).
    R"sql(
ALTER TABLE documents ADD COLUMN letters BLOB;
ALTER TABLE documents ADD COLUMN letter_hashes BLOB;
)sql",
};

int64_t NowUnixMs() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

std::string PackPoints(const std::vector<cv::Point2f>& points) {
  std::string out(points.size() * 2 * sizeof(float), '\0');
  if (!points.empty()) std::memcpy(out.data(), points.data(), out.size());
  return out;
}

std::vector<cv::Point2f> UnpackPoints(const std::string& blob) {
  std::vector<cv::Point2f> points(blob.size() / (2 * sizeof(float)));
  if (!points.empty()) std::memcpy(points.data(), blob.data(), points.size() * 2 * sizeof(float));
  return points;
}

// Layer sizes (uint32 each) after their count (uint32), then the points.
std::string PackLayers(const std::vector<cv::Point2f>& points, const std::vector<uint32_t>& sizes) {
  const uint32_t count = static_cast<uint32_t>(sizes.size());
  std::string out(sizeof(uint32_t), '\0');
  std::memcpy(out.data(), &count, sizeof(count));
  if (!sizes.empty())
    out.append(reinterpret_cast<const char*>(sizes.data()), sizes.size() * sizeof(uint32_t));
  return out + PackPoints(points);
}

absl::Status UnpackLayers(const std::string& blob, std::vector<cv::Point2f>* points,
                          std::vector<uint32_t>* sizes) {
  points->clear();
  sizes->clear();
  if (blob.empty()) return absl::OkStatus();
  uint32_t count = 0;
  if (blob.size() >= sizeof(count)) std::memcpy(&count, blob.data(), sizeof(count));
  const size_t header = sizeof(uint32_t) * (1 + static_cast<size_t>(count));
  if (blob.size() < header) return absl::DataLossError("stored keypoint layers are truncated");
  sizes->resize(count);
  if (count > 0)
    std::memcpy(sizes->data(), blob.data() + sizeof(uint32_t), count * sizeof(uint32_t));
  *points = UnpackPoints(blob.substr(header));
  uint64_t total = 0;
  for (uint32_t n : *sizes) total += n;
  if (total != points->size())
    return absl::DataLossError(absl::StrCat("stored keypoint layers hold ", points->size(),
                                            " points, their sizes add up to ", total));
  return absl::OkStatus();
}

std::string PackHashes(const std::vector<uint64_t>& hashes) {
  std::string out(hashes.size() * sizeof(uint64_t), '\0');
  if (!hashes.empty()) std::memcpy(out.data(), hashes.data(), out.size());
  return out;
}

std::vector<uint64_t> UnpackHashes(const std::string& blob) {
  std::vector<uint64_t> hashes(blob.size() / sizeof(uint64_t));
  if (!hashes.empty()) std::memcpy(hashes.data(), blob.data(), hashes.size() * sizeof(uint64_t));
  return hashes;
}

uint32_t PackRgba(const Rgba& c) {
  return (uint32_t{c.r} << 24) | (uint32_t{c.g} << 16) | (uint32_t{c.b} << 8) | c.a;
}

Rgba UnpackRgba(int64_t v) {
  const uint32_t u = static_cast<uint32_t>(v);
  return {static_cast<uint8_t>(u >> 24), static_cast<uint8_t>(u >> 16),
          static_cast<uint8_t>(u >> 8), static_cast<uint8_t>(u)};
}

constexpr const char* kAnnotationColumns =
    "public_id, kind, text, x, y, width, height, font_size, rgba, opacity, uri, mime_type, data";

AnnotationRecord ReadAnnotation(const SqliteStatement& s) {
  AnnotationRecord a;
  a.id = s.ColumnText(0);
  a.kind = static_cast<AnnotationRecord::Kind>(s.ColumnInt(1));
  a.text = s.ColumnText(2);
  a.position = {s.ColumnDouble(3), s.ColumnDouble(4)};
  a.rect = {s.ColumnDouble(3), s.ColumnDouble(4), s.ColumnDouble(5), s.ColumnDouble(6)};
  a.font_size_px = s.ColumnDouble(7);
  a.color = UnpackRgba(s.ColumnInt(8));
  a.opacity = s.ColumnDouble(9);
  a.uri = s.ColumnText(10);
  a.mime_type = s.ColumnText(11);
  a.data = s.ColumnBlob(12);
  return a;
}

}  // namespace

std::string NewPublicId() {
  thread_local std::mt19937_64 rng{std::random_device{}() ^ static_cast<uint64_t>(NowUnixMs())
                                                                << 20};
  return absl::StrFormat("%016x", rng());
}

absl::StatusOr<std::unique_ptr<DocumentStore>> DocumentStore::Open(const std::string& path) {
  ASSIGN_OR_RETURN(auto db, SqliteDb::Open(path));
  std::unique_ptr<DocumentStore> store(new DocumentStore(std::move(db)));
  RETURN_IF_ERROR(store->Migrate());
  return store;
}

absl::Status DocumentStore::Migrate() {
  std::lock_guard lock(mutex_);
  constexpr int kKnown = sizeof(kMigrations) / sizeof(kMigrations[0]);
  static_assert(kKnown == kSchemaVersion);
  return MigrateSchema(db_.get(), kMigrations, kKnown, "database");
}

absl::Status DocumentStore::InsertAnnotationLocked(uint32_t index_id, AnnotationRecord* a) {
  if (a->id.empty()) a->id = NewPublicId();
  ASSIGN_OR_RETURN(
      auto s, db_->Prepare(absl::StrCat("INSERT INTO annotations (document, ", kAnnotationColumns,
                                        ") VALUES (?,?,?,?,?,?,?,?,?,?,?,?,?,?)")));
  const bool is_text = a->kind == AnnotationRecord::Kind::kText;
  RETURN_IF_ERROR(s.BindInt(1, index_id));
  RETURN_IF_ERROR(s.BindText(2, a->id));
  RETURN_IF_ERROR(s.BindInt(3, static_cast<int>(a->kind)));
  RETURN_IF_ERROR(s.BindText(4, a->text));
  RETURN_IF_ERROR(s.BindDouble(5, is_text ? a->position.x : a->rect.x));
  RETURN_IF_ERROR(s.BindDouble(6, is_text ? a->position.y : a->rect.y));
  RETURN_IF_ERROR(s.BindDouble(7, is_text ? 0 : a->rect.width));
  RETURN_IF_ERROR(s.BindDouble(8, is_text ? 0 : a->rect.height));
  RETURN_IF_ERROR(s.BindDouble(9, a->font_size_px));
  RETURN_IF_ERROR(s.BindInt(10, PackRgba(a->color)));
  RETURN_IF_ERROR(s.BindDouble(11, a->opacity));
  RETURN_IF_ERROR(s.BindText(12, a->uri));
  RETURN_IF_ERROR(s.BindText(13, a->mime_type));
  if (a->data.empty()) {
    RETURN_IF_ERROR(s.BindNull(14));
  } else {
    RETURN_IF_ERROR(s.BindBlob(14, a->data.data(), a->data.size()));
  }
  return s.Run();
}

absl::StatusOr<DocumentRecord> DocumentStore::Insert(DocumentRecord record) {
  std::lock_guard lock(mutex_);
  if (record.id.empty()) record.id = NewPublicId();
  record.created_unix_ms = NowUnixMs();
  SqliteTransaction tx(db_.get());
  RETURN_IF_ERROR(tx.Begin());
  {
    ASSIGN_OR_RETURN(auto s, db_->Prepare("INSERT INTO documents (public_id, title, width, height, "
                                          "created_unix_ms, keypoint_count, keypoints, hashes, "
                                          "layers, figures, letters, letter_hashes) "
                                          "VALUES (?,?,?,?,?,?,?,?,?,?,?,?)"));
    const std::string blob = PackPoints(record.keypoints);
    const std::string hashes = PackHashes(record.hashes);
    RETURN_IF_ERROR(s.BindText(1, record.id));
    RETURN_IF_ERROR(s.BindText(2, record.title));
    RETURN_IF_ERROR(s.BindInt(3, record.size.width));
    RETURN_IF_ERROR(s.BindInt(4, record.size.height));
    RETURN_IF_ERROR(s.BindInt(5, record.created_unix_ms));
    RETURN_IF_ERROR(s.BindInt(6, static_cast<int64_t>(record.keypoints.size())));
    RETURN_IF_ERROR(s.BindBlob(7, blob.data(), blob.size()));
    if (hashes.empty()) {
      RETURN_IF_ERROR(s.BindNull(8));
    } else {
      RETURN_IF_ERROR(s.BindBlob(8, hashes.data(), hashes.size()));
    }
    if (record.layer_sizes.empty()) {
      RETURN_IF_ERROR(s.BindNull(9));
    } else {
      const std::string layers = PackLayers(record.layer_keypoints, record.layer_sizes);
      RETURN_IF_ERROR(s.BindBlob(9, layers.data(), layers.size()));
    }
    if (record.figure_keypoints.empty()) {
      RETURN_IF_ERROR(s.BindNull(10));
    } else {
      const std::string figures = PackPoints(record.figure_keypoints);
      RETURN_IF_ERROR(s.BindBlob(10, figures.data(), figures.size()));
    }
    if (record.letter_keypoints.empty()) {
      RETURN_IF_ERROR(s.BindNull(11));
    } else {
      const std::string letters = PackPoints(record.letter_keypoints);
      RETURN_IF_ERROR(s.BindBlob(11, letters.data(), letters.size()));
    }
    if (record.letter_hashes.empty()) {
      RETURN_IF_ERROR(s.BindNull(12));
    } else {
      const std::string letter_hashes = PackHashes(record.letter_hashes);
      RETURN_IF_ERROR(s.BindBlob(12, letter_hashes.data(), letter_hashes.size()));
    }
    RETURN_IF_ERROR(s.Run());
  }
  record.index_id = static_cast<uint32_t>(db_->LastInsertRowId());
  record.keypoint_count = static_cast<int>(record.keypoints.size());
  for (AnnotationRecord& a : record.annotations) {
    RETURN_IF_ERROR(InsertAnnotationLocked(record.index_id, &a));
  }
  RETURN_IF_ERROR(tx.Commit());
  return record;
}

absl::StatusOr<uint32_t> DocumentStore::IndexIdLocked(const std::string& id) {
  ASSIGN_OR_RETURN(auto s, db_->Prepare("SELECT index_id FROM documents WHERE public_id = ?"));
  RETURN_IF_ERROR(s.BindText(1, id));
  ASSIGN_OR_RETURN(auto row, s.Step());
  if (!row) return absl::NotFoundError(absl::StrCat("document '", id, "' does not exist"));
  return static_cast<uint32_t>(s.ColumnInt(0));
}

absl::StatusOr<uint32_t> DocumentStore::Delete(const std::string& id) {
  std::lock_guard lock(mutex_);
  SqliteTransaction tx(db_.get());
  RETURN_IF_ERROR(tx.Begin());
  ASSIGN_OR_RETURN(auto index_id, IndexIdLocked(id));
  {
    ASSIGN_OR_RETURN(auto a, db_->Prepare("DELETE FROM annotations WHERE document = ?"));
    RETURN_IF_ERROR(a.BindInt(1, index_id));
    RETURN_IF_ERROR(a.Run());
    ASSIGN_OR_RETURN(auto d, db_->Prepare("DELETE FROM documents WHERE index_id = ?"));
    RETURN_IF_ERROR(d.BindInt(1, index_id));
    RETURN_IF_ERROR(d.Run());
  }
  RETURN_IF_ERROR(tx.Commit());
  return index_id;
}

absl::StatusOr<DocumentRecord> DocumentStore::Get(const std::string& id, bool with_keypoints) {
  DocumentRecord r;
  {
    std::lock_guard lock(mutex_);
    ASSIGN_OR_RETURN(
        auto s,
        db_->Prepare(absl::StrCat(
            "SELECT index_id, public_id, title, width, height, created_unix_ms, keypoint_count",
            with_keypoints ? ", keypoints" : "", " FROM documents WHERE public_id = ?")));
    RETURN_IF_ERROR(s.BindText(1, id));
    ASSIGN_OR_RETURN(auto row, s.Step());
    if (!row) return absl::NotFoundError(absl::StrCat("document '", id, "' does not exist"));
    r.index_id = static_cast<uint32_t>(s.ColumnInt(0));
    r.id = s.ColumnText(1);
    r.title = s.ColumnText(2);
    r.size = {static_cast<int>(s.ColumnInt(3)), static_cast<int>(s.ColumnInt(4))};
    r.created_unix_ms = s.ColumnInt(5);
    r.keypoint_count = static_cast<int>(s.ColumnInt(6));
    if (with_keypoints) r.keypoints = UnpackPoints(s.ColumnBlob(7));
  }
  ASSIGN_OR_RETURN(auto annotations, Annotations(r.index_id));
  r.annotations = std::move(annotations);
  return r;
}

absl::StatusOr<std::vector<AnnotationRecord>> DocumentStore::Annotations(uint32_t index_id) {
  std::lock_guard lock(mutex_);
  ASSIGN_OR_RETURN(auto s, db_->Prepare(absl::StrCat("SELECT ", kAnnotationColumns,
                                                     " FROM annotations WHERE document = ? "
                                                     "ORDER BY annotation_row")));
  RETURN_IF_ERROR(s.BindInt(1, index_id));
  std::vector<AnnotationRecord> out;
  while (true) {
    ASSIGN_OR_RETURN(auto row, s.Step());
    if (!row) break;
    out.push_back(ReadAnnotation(s));
  }
  return out;
}

absl::StatusOr<std::vector<DocumentSummary>> DocumentStore::List(uint32_t after_index_id,
                                                                 int limit) {
  std::lock_guard lock(mutex_);
  ASSIGN_OR_RETURN(auto s,
                   db_->Prepare("SELECT index_id, public_id, title, width, height, keypoint_count, "
                                "created_unix_ms FROM documents WHERE index_id > ? "
                                "ORDER BY index_id LIMIT ?"));
  RETURN_IF_ERROR(s.BindInt(1, after_index_id));
  RETURN_IF_ERROR(s.BindInt(2, limit));
  std::vector<DocumentSummary> out;
  while (true) {
    ASSIGN_OR_RETURN(auto row, s.Step());
    if (!row) break;
    out.push_back({static_cast<uint32_t>(s.ColumnInt(0)), s.ColumnText(1), s.ColumnText(2),
                   cv::Size(static_cast<int>(s.ColumnInt(3)), static_cast<int>(s.ColumnInt(4))),
                   static_cast<int>(s.ColumnInt(5)), s.ColumnInt(6)});
  }
  return out;
}

absl::StatusOr<int64_t> DocumentStore::Count() {
  std::lock_guard lock(mutex_);
  ASSIGN_OR_RETURN(auto s, db_->Prepare("SELECT COUNT(*) FROM documents"));
  ASSIGN_OR_RETURN(auto row, s.Step());
  return row ? s.ColumnInt(0) : 0;
}

absl::StatusOr<AnnotationRecord> DocumentStore::AddAnnotation(const std::string& document_id,
                                                              AnnotationRecord annotation) {
  std::lock_guard lock(mutex_);
  SqliteTransaction tx(db_.get());
  RETURN_IF_ERROR(tx.Begin());
  ASSIGN_OR_RETURN(auto index_id, IndexIdLocked(document_id));
  annotation.id.clear();
  RETURN_IF_ERROR(InsertAnnotationLocked(index_id, &annotation));
  RETURN_IF_ERROR(tx.Commit());
  return annotation;
}

absl::Status DocumentStore::DeleteAnnotation(const std::string& document_id,
                                             const std::string& annotation_id) {
  std::lock_guard lock(mutex_);
  SqliteTransaction tx(db_.get());
  RETURN_IF_ERROR(tx.Begin());
  ASSIGN_OR_RETURN(auto index_id, IndexIdLocked(document_id));
  ASSIGN_OR_RETURN(auto s,
                   db_->Prepare("DELETE FROM annotations WHERE document = ? AND public_id = ?"));
  RETURN_IF_ERROR(s.BindInt(1, index_id));
  RETURN_IF_ERROR(s.BindText(2, annotation_id));
  RETURN_IF_ERROR(s.Run());
  if (db_->Changes() == 0) {
    return absl::NotFoundError(absl::StrCat("annotation '", annotation_id,
                                            "' does not exist on document '", document_id, "'"));
  }
  return tx.Commit();
}

absl::Status DocumentStore::ForEachKeypoints(
    const std::function<void(const DocumentSummary&, StoredKeypoints)>& f) {
  std::lock_guard lock(mutex_);
  ASSIGN_OR_RETURN(auto s, db_->Prepare("SELECT index_id, public_id, title, width, height, "
                                        "keypoint_count, created_unix_ms, keypoints, hashes, "
                                        "layers, figures, letters, letter_hashes FROM documents "
                                        "ORDER BY index_id"));
  while (true) {
    ASSIGN_OR_RETURN(auto row, s.Step());
    if (!row) break;
    DocumentSummary d{static_cast<uint32_t>(s.ColumnInt(0)),
                      s.ColumnText(1),
                      s.ColumnText(2),
                      cv::Size(static_cast<int>(s.ColumnInt(3)), static_cast<int>(s.ColumnInt(4))),
                      static_cast<int>(s.ColumnInt(5)),
                      s.ColumnInt(6)};
    StoredKeypoints k;
    k.keypoints = UnpackPoints(s.ColumnBlob(7));
    k.hashes = UnpackHashes(s.ColumnBlob(8));
    if (absl::Status status = UnpackLayers(s.ColumnBlob(9), &k.layer_keypoints, &k.layer_sizes);
        !status.ok())
      return absl::DataLossError(absl::StrCat("document ", d.id, ": ", status.message()));
    k.figure_keypoints = UnpackPoints(s.ColumnBlob(10));
    k.letter_keypoints = UnpackPoints(s.ColumnBlob(11));
    k.letter_hashes = UnpackHashes(s.ColumnBlob(12));
    f(d, std::move(k));
  }
  return absl::OkStatus();
}

absl::Status DocumentStore::PutHashes(
    const std::vector<std::pair<uint32_t, std::vector<uint64_t>>>& hashes, HashColumn column) {
  const char* sql = column == HashColumn::kLetters
                        ? "UPDATE documents SET letter_hashes = ? WHERE index_id = ?"
                        : "UPDATE documents SET hashes = ? WHERE index_id = ?";
  std::lock_guard lock(mutex_);
  SqliteTransaction tx(db_.get());
  RETURN_IF_ERROR(tx.Begin());
  for (const auto& [index_id, h] : hashes) {
    ASSIGN_OR_RETURN(auto s, db_->Prepare(sql));
    const std::string blob = PackHashes(h);
    RETURN_IF_ERROR(s.BindBlob(1, blob.data(), blob.size()));
    RETURN_IF_ERROR(s.BindInt(2, index_id));
    RETURN_IF_ERROR(s.Run());
  }
  return tx.Commit();
}

absl::StatusOr<std::optional<std::string>> DocumentStore::GetSetting(const std::string& key) {
  std::lock_guard lock(mutex_);
  ASSIGN_OR_RETURN(auto s, db_->Prepare("SELECT value FROM settings WHERE key = ?"));
  RETURN_IF_ERROR(s.BindText(1, key));
  ASSIGN_OR_RETURN(auto row, s.Step());
  if (!row) return std::optional<std::string>();
  return std::optional<std::string>(s.ColumnBlob(0));
}

absl::Status DocumentStore::PutSetting(const std::string& key, const std::string& value) {
  std::lock_guard lock(mutex_);
  ASSIGN_OR_RETURN(auto s, db_->Prepare("INSERT INTO settings (key, value) VALUES (?, ?) "
                                        "ON CONFLICT(key) DO UPDATE SET value = excluded.value"));
  RETURN_IF_ERROR(s.BindText(1, key));
  RETURN_IF_ERROR(s.BindBlob(2, value.data(), value.size()));
  return s.Run();
}

}  // namespace texfree::server
