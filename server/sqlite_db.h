// Thin checked wrapper over the SQLite C API: every call's result becomes an absl::Status.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include "absl/strings/string_view.h"
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

struct sqlite3;
struct sqlite3_stmt;

namespace texfree::server {

class SqliteStatement;

// One connection. Not thread-safe: owners serialise access (DocumentStore holds a mutex).
class SqliteDb {
 public:
  // Opens (creating) the file, enables WAL, foreign keys and a busy timeout.
  static absl::StatusOr<std::unique_ptr<SqliteDb>> Open(const std::string& path);
  ~SqliteDb();

  absl::Status Exec(absl::string_view sql);
  absl::StatusOr<SqliteStatement> Prepare(absl::string_view sql);
  int64_t LastInsertRowId() const;
  int Changes() const;
  sqlite3* handle() const { return db_; }
  absl::Status Error(absl::string_view what) const;

 private:
  explicit SqliteDb(sqlite3* db) : db_(db) {}
  sqlite3* db_;
};

// A prepared statement; Bind* are 1-based like SQLite.
class SqliteStatement {
 public:
  SqliteStatement(SqliteDb* db, sqlite3_stmt* stmt) : db_(db), stmt_(stmt) {}
  SqliteStatement(SqliteStatement&& o) noexcept : db_(o.db_), stmt_(o.stmt_) { o.stmt_ = nullptr; }
  SqliteStatement(const SqliteStatement&) = delete;
  ~SqliteStatement();

  absl::Status BindInt(int i, int64_t v);
  absl::Status BindDouble(int i, double v);
  absl::Status BindText(int i, absl::string_view v);
  absl::Status BindBlob(int i, const void* data, size_t bytes);
  absl::Status BindNull(int i);

  // Steps once: true when a row is available, false when done.
  absl::StatusOr<bool> Step();
  // Steps until done (for statements without rows).
  absl::Status Run();

  int64_t ColumnInt(int i) const;
  double ColumnDouble(int i) const;
  std::string ColumnText(int i) const;
  std::string ColumnBlob(int i) const;
  bool ColumnIsNull(int i) const;

 private:
  SqliteDb* db_;
  sqlite3_stmt* stmt_;
};

// RAII transaction: rolls back unless Commit() succeeded.
class SqliteTransaction {
 public:
  explicit SqliteTransaction(SqliteDb* db) : db_(db) {}
  ~SqliteTransaction();
  absl::Status Begin();
  absl::Status Commit();

 private:
  SqliteDb* db_;
  bool open_ = false;
};

// Brings a database from its PRAGMA user_version up to `count` by running migrations[v]
// (schema v -> v + 1) each in its own transaction; refuses a file newer than `count`.
// `what` names the database in the error ("database", "pool database").
absl::Status MigrateSchema(SqliteDb* db, const char* const* migrations, int count,
                           absl::string_view what);

}  // namespace texfree::server
