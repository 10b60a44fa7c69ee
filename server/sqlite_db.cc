// SqliteDb implementation.
#include "server/sqlite_db.h"

#include <sqlite3.h>

#include "absl/strings/str_cat.h"

namespace texfree::server {

absl::StatusOr<std::unique_ptr<SqliteDb>> SqliteDb::Open(const std::string& path) {
  sqlite3* raw = nullptr;
  const int rc = sqlite3_open_v2(path.c_str(), &raw,
                                 SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_NOMUTEX,
                                 nullptr);
  if (rc != SQLITE_OK) {
    std::string msg = raw ? sqlite3_errmsg(raw) : sqlite3_errstr(rc);
    if (raw) sqlite3_close(raw);
    return absl::UnavailableError(absl::StrCat("cannot open database '", path, "': ", msg));
  }
  std::unique_ptr<SqliteDb> db(new SqliteDb(raw));
  if (sqlite3_busy_timeout(raw, 5000) != SQLITE_OK) return db->Error("set busy timeout");
  // WAL: readers never block the writer, and a crash loses no committed transaction.
  auto mode = db->Prepare("PRAGMA journal_mode=WAL");
  if (!mode.ok()) return mode.status();
  auto row = mode->Step();
  if (!row.ok()) return row.status();
  if (!*row || mode->ColumnText(0) != "wal")
    return absl::UnavailableError(absl::StrCat("database '", path, "' cannot use WAL mode"));
  if (auto s = db->Exec("PRAGMA foreign_keys=ON; PRAGMA synchronous=NORMAL;"); !s.ok()) return s;
  return db;
}

SqliteDb::~SqliteDb() { sqlite3_close_v2(db_); }

absl::Status SqliteDb::Error(absl::string_view what) const {
  return absl::InternalError(absl::StrCat("database error (", what, "): ", sqlite3_errmsg(db_)));
}

absl::Status SqliteDb::Exec(absl::string_view sql) {
  char* err = nullptr;
  const std::string text(sql);
  if (sqlite3_exec(db_, text.c_str(), nullptr, nullptr, &err) != SQLITE_OK) {
    std::string msg = err ? err : "unknown";
    sqlite3_free(err);
    return absl::InternalError(absl::StrCat("database error: ", msg));
  }
  return absl::OkStatus();
}

absl::StatusOr<SqliteStatement> SqliteDb::Prepare(absl::string_view sql) {
  sqlite3_stmt* stmt = nullptr;
  if (sqlite3_prepare_v2(db_, sql.data(), static_cast<int>(sql.size()), &stmt, nullptr) !=
      SQLITE_OK) {
    return Error(absl::StrCat("prepare ", sql.substr(0, 60)));
  }
  return SqliteStatement(this, stmt);
}

int64_t SqliteDb::LastInsertRowId() const { return sqlite3_last_insert_rowid(db_); }
int SqliteDb::Changes() const { return sqlite3_changes(db_); }

SqliteStatement::~SqliteStatement() {
  if (stmt_) sqlite3_finalize(stmt_);
}

#define TEXFREE_SQLITE_BIND(call)                                         \
  do {                                                                    \
    if ((call) != SQLITE_OK) return db_->Error("bind parameter");         \
    return absl::OkStatus();                                              \
  } while (0)

absl::Status SqliteStatement::BindInt(int i, int64_t v) {
  TEXFREE_SQLITE_BIND(sqlite3_bind_int64(stmt_, i, v));
}
absl::Status SqliteStatement::BindDouble(int i, double v) {
  TEXFREE_SQLITE_BIND(sqlite3_bind_double(stmt_, i, v));
}
absl::Status SqliteStatement::BindText(int i, absl::string_view v) {
  TEXFREE_SQLITE_BIND(
      sqlite3_bind_text(stmt_, i, v.data(), static_cast<int>(v.size()), SQLITE_TRANSIENT));
}
absl::Status SqliteStatement::BindBlob(int i, const void* data, size_t bytes) {
  TEXFREE_SQLITE_BIND(sqlite3_bind_blob64(stmt_, i, bytes ? data : "", bytes, SQLITE_TRANSIENT));
}
absl::Status SqliteStatement::BindNull(int i) { TEXFREE_SQLITE_BIND(sqlite3_bind_null(stmt_, i)); }
#undef TEXFREE_SQLITE_BIND

absl::StatusOr<bool> SqliteStatement::Step() {
  const int rc = sqlite3_step(stmt_);
  if (rc == SQLITE_ROW) return true;
  if (rc == SQLITE_DONE) return false;
  if (rc == SQLITE_CONSTRAINT) {
    return absl::AlreadyExistsError(
        absl::StrCat("database constraint: ", sqlite3_errmsg(db_->handle())));
  }
  return db_->Error("step");
}

absl::Status SqliteStatement::Run() {
  while (true) {
    auto row = Step();
    if (!row.ok()) return row.status();
    if (!*row) return absl::OkStatus();
  }
}

int64_t SqliteStatement::ColumnInt(int i) const { return sqlite3_column_int64(stmt_, i); }
double SqliteStatement::ColumnDouble(int i) const { return sqlite3_column_double(stmt_, i); }
std::string SqliteStatement::ColumnText(int i) const {
  const auto* p = sqlite3_column_text(stmt_, i);
  return p ? std::string(reinterpret_cast<const char*>(p),
                         static_cast<size_t>(sqlite3_column_bytes(stmt_, i)))
           : std::string();
}
std::string SqliteStatement::ColumnBlob(int i) const {
  const void* p = sqlite3_column_blob(stmt_, i);
  return p ? std::string(static_cast<const char*>(p),
                         static_cast<size_t>(sqlite3_column_bytes(stmt_, i)))
           : std::string();
}
bool SqliteStatement::ColumnIsNull(int i) const {
  return sqlite3_column_type(stmt_, i) == SQLITE_NULL;
}

SqliteTransaction::~SqliteTransaction() {
  if (open_) db_->Exec("ROLLBACK").IgnoreError();
}

absl::Status SqliteTransaction::Begin() {
  if (auto s = db_->Exec("BEGIN IMMEDIATE"); !s.ok()) return s;
  open_ = true;
  return absl::OkStatus();
}

absl::Status SqliteTransaction::Commit() {
  if (auto s = db_->Exec("COMMIT"); !s.ok()) return s;
  open_ = false;
  return absl::OkStatus();
}

absl::Status MigrateSchema(SqliteDb* db, const char* const* migrations, int count,
                           absl::string_view what) {
  int version = 0;
  {  // finalised before any schema change
    auto version_stmt = db->Prepare("PRAGMA user_version");
    if (!version_stmt.ok()) return version_stmt.status();
    auto has_row = version_stmt->Step();
    if (!has_row.ok()) return has_row.status();
    version = *has_row ? static_cast<int>(version_stmt->ColumnInt(0)) : 0;
  }
  if (version > count) {
    return absl::FailedPreconditionError(absl::StrCat(
        what, " schema version ", version, " is newer than this server understands (", count,
        "); upgrade texfree-server"));
  }
  for (int v = version; v < count; ++v) {
    SqliteTransaction tx(db);
    if (auto s = tx.Begin(); !s.ok()) return s;
    if (auto s = db->Exec(migrations[v]); !s.ok()) return s;
    if (auto s = db->Exec(absl::StrCat("PRAGMA user_version = ", v + 1)); !s.ok()) return s;
    if (auto s = tx.Commit(); !s.ok()) return s;
  }
  return absl::OkStatus();
}

}  // namespace texfree::server
