// PoolProfileStore: SQLite persistence of pool table profiles (sizes and colours) in their
// own database file, pool.db, beside the document database.
#pragma once

#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "common/pool_profile.h"
#include "server/sqlite_db.h"

namespace texfree::server {

// Thread-safe: one connection guarded by a mutex.
class PoolProfileStore {
 public:
  // Current schema version; Open() migrates older files forward, refuses newer ones.
  static constexpr int kSchemaVersion = 1;

  static absl::StatusOr<std::unique_ptr<PoolProfileStore>> Open(const std::string& path);

  // Inserts or replaces the profile of that name (the profile must be valid).
  absl::Status Put(const PoolTableProfile& profile);
  absl::StatusOr<std::optional<PoolTableProfile>> Get(const std::string& name);
  absl::StatusOr<std::vector<std::string>> Names();

 private:
  explicit PoolProfileStore(std::unique_ptr<SqliteDb> db) : db_(std::move(db)) {}
  absl::Status Migrate();

  std::mutex mutex_;
  std::unique_ptr<SqliteDb> db_;
};

}  // namespace texfree::server
