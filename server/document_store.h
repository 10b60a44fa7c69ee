// DocumentStore: SQLite persistence of documents, their keypoints and annotations, and of
// the LLAH settings the index was built with.
#pragma once

#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "server/document_types.h"
#include "server/sqlite_db.h"

namespace texfree::server {

struct DocumentSummary {
  uint32_t index_id = 0;
  std::string id;
  std::string title;
  cv::Size size;
  int keypoints = 0;
  int64_t created_unix_ms = 0;
};

// Thread-safe: one connection guarded by a mutex (SQLite writes are serial anyway).
class DocumentStore {
 public:
  // Current schema version; Open() migrates older files forward, refuses newer ones.
  static constexpr int kSchemaVersion = 5;

  static absl::StatusOr<std::unique_ptr<DocumentStore>> Open(const std::string& path);

  // Inserts the document, its keypoints and annotations in one transaction. Assigns
  // index_id, id (unless set), created time and annotation ids; returns the stored record.
  absl::StatusOr<DocumentRecord> Insert(DocumentRecord record);
  // Deletes a document with its annotations in one transaction; returns its index id.
  absl::StatusOr<uint32_t> Delete(const std::string& id);
  // Document with annotations (keypoints only when asked).
  absl::StatusOr<DocumentRecord> Get(const std::string& id, bool with_keypoints = false);
  absl::StatusOr<std::vector<AnnotationRecord>> Annotations(uint32_t index_id);
  // Documents ordered by index id, after `after_index_id`.
  absl::StatusOr<std::vector<DocumentSummary>> List(uint32_t after_index_id, int limit);
  absl::StatusOr<int64_t> Count();
  absl::StatusOr<AnnotationRecord> AddAnnotation(const std::string& document_id,
                                                 AnnotationRecord annotation);
  absl::Status DeleteAnnotation(const std::string& document_id, const std::string& annotation_id);

  // A document's keypoints as the start-up index rebuild reads them.
  struct StoredKeypoints {
    std::vector<cv::Point2f> keypoints;
    std::vector<cv::Point2f> layer_keypoints;  // DocumentRecord's
    std::vector<uint32_t> layer_sizes;
    std::vector<uint64_t> hashes;  // empty when none are stored
    std::vector<cv::Point2f> figure_keypoints;  // DocumentRecord's
    std::vector<cv::Point2f> letter_keypoints;  // DocumentRecord's
    std::vector<uint64_t> letter_hashes;        // empty when none are stored
  };
  // Streams every document's summary and keypoints for the start-up index rebuild.
  absl::Status ForEachKeypoints(
      const std::function<void(const DocumentSummary&, StoredKeypoints)>& f);

  // Stores descriptor hashes of documents (index_id -> hashes), in one transaction: of their
  // words (DocumentRecord::hashes) or of their letters (DocumentRecord::letter_hashes).
  enum class HashColumn { kWords, kLetters };
  absl::Status PutHashes(const std::vector<std::pair<uint32_t, std::vector<uint64_t>>>& hashes,
                         HashColumn column = HashColumn::kWords);

  absl::StatusOr<std::optional<std::string>> GetSetting(const std::string& key);
  absl::Status PutSetting(const std::string& key, const std::string& value);

 private:
  explicit DocumentStore(std::unique_ptr<SqliteDb> db) : db_(std::move(db)) {}
  absl::Status Migrate();
  absl::Status InsertAnnotationLocked(uint32_t index_id, AnnotationRecord* a);
  absl::StatusOr<uint32_t> IndexIdLocked(const std::string& id);

  std::mutex mutex_;
  std::unique_ptr<SqliteDb> db_;
};

// Random public id: 16 lowercase hex digits.
std::string NewPublicId();

}  // namespace texfree::server
