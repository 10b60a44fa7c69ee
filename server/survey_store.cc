// SurveyStore implementation: schema, migrations and queries.
#include "server/survey_store.h"

#include <chrono>
#include <cstring>

#include "absl/strings/str_cat.h"
#include "common/status_macros.h"
#include "server/document_store.h"  // NewPublicId

namespace texfree::server {
namespace {

// Migrations, in order: entry i brings the schema from version i to i + 1.
const char* const kMigrations[] = {
    R"sql(
CREATE TABLE surveys (
  survey_row INTEGER PRIMARY KEY,
  public_id TEXT NOT NULL UNIQUE,
  name TEXT NOT NULL,
  fx REAL NOT NULL, fy REAL NOT NULL, cx REAL NOT NULL, cy REAL NOT NULL,
  distortion BLOB,
  width INTEGER NOT NULL, height INTEGER NOT NULL,
  created_unix_ms INTEGER NOT NULL,
  solved INTEGER NOT NULL DEFAULT 0,
  bundle_adjusted INTEGER NOT NULL DEFAULT 0
);
CREATE TABLE reference_lights (
  survey INTEGER NOT NULL REFERENCES surveys(survey_row) ON DELETE CASCADE,
  light_id INTEGER NOT NULL,
  x REAL NOT NULL, y REAL NOT NULL, z REAL NOT NULL,
  PRIMARY KEY (survey, light_id)
);
CREATE TABLE views (
  view_row INTEGER PRIMARY KEY,
  survey INTEGER NOT NULL REFERENCES surveys(survey_row) ON DELETE CASCADE,
  name TEXT NOT NULL,
  frames INTEGER NOT NULL,
  width INTEGER NOT NULL, height INTEGER NOT NULL,
  posed INTEGER NOT NULL,
  pose_error TEXT NOT NULL DEFAULT '',
  pose BLOB,
  references_used INTEGER NOT NULL DEFAULT 0,
  reprojection_rms_px REAL NOT NULL DEFAULT 0,
  created_unix_ms INTEGER NOT NULL,
  UNIQUE (survey, name)
);
CREATE TABLE view_lights (
  view INTEGER NOT NULL REFERENCES views(view_row) ON DELETE CASCADE,
  light_id INTEGER NOT NULL,
  u REAL NOT NULL, v REAL NOT NULL,
  pixels INTEGER NOT NULL,
  quality REAL NOT NULL,
  conflict INTEGER NOT NULL
);
CREATE INDEX view_lights_by_view ON view_lights(view);
CREATE TABLE points (
  survey INTEGER NOT NULL REFERENCES surveys(survey_row) ON DELETE CASCADE,
  light_id INTEGER NOT NULL,
  x REAL NOT NULL, y REAL NOT NULL, z REAL NOT NULL,
  views INTEGER NOT NULL,
  rms_px REAL NOT NULL,
  sigma_x REAL NOT NULL, sigma_y REAL NOT NULL, sigma_z REAL NOT NULL,
  PRIMARY KEY (survey, light_id)
);
)sql",
};

int64_t NowUnixMs() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

std::string PackDoubles(const double* values, size_t n) {
  std::string out(n * sizeof(double), '\0');
  if (n) std::memcpy(out.data(), values, out.size());
  return out;
}

std::vector<double> UnpackDoubles(const std::string& blob) {
  std::vector<double> v(blob.size() / sizeof(double));
  if (!v.empty()) std::memcpy(v.data(), blob.data(), v.size() * sizeof(double));
  return v;
}

std::string PackPose(const survey::CameraPose& pose) {
  double values[12];
  for (int i = 0; i < 9; ++i) values[i] = pose.R.val[i];
  for (int i = 0; i < 3; ++i) values[9 + i] = pose.t[i];
  return PackDoubles(values, 12);
}

survey::CameraPose UnpackPose(const std::string& blob) {
  survey::CameraPose pose;
  const std::vector<double> v = UnpackDoubles(blob);
  if (v.size() != 12) return pose;
  for (int i = 0; i < 9; ++i) pose.R.val[i] = v[i];
  for (int i = 0; i < 3; ++i) pose.t[i] = v[9 + i];
  return pose;
}

}  // namespace

absl::StatusOr<std::unique_ptr<SurveyStore>> SurveyStore::Open(const std::string& path) {
  ASSIGN_OR_RETURN(auto db, SqliteDb::Open(path));
  std::unique_ptr<SurveyStore> store(new SurveyStore(std::move(db)));
  RETURN_IF_ERROR(store->Migrate());
  return store;
}

absl::Status SurveyStore::Migrate() {
  std::lock_guard lock(mutex_);
  ASSIGN_OR_RETURN(auto version_stmt, db_->Prepare("PRAGMA user_version"));
  ASSIGN_OR_RETURN(auto has_row, version_stmt.Step());
  const int version = has_row ? static_cast<int>(version_stmt.ColumnInt(0)) : 0;
  constexpr int kKnown = sizeof(kMigrations) / sizeof(kMigrations[0]);
  static_assert(kKnown == kSchemaVersion);
  if (version > kKnown) {
    return absl::FailedPreconditionError(absl::StrCat(
        "survey database schema version ", version, " is newer than this server understands (",
        kKnown, "); upgrade texfree-server"));
  }
  for (int v = version; v < kKnown; ++v) {
    SqliteTransaction tx(db_.get());
    RETURN_IF_ERROR(tx.Begin());
    RETURN_IF_ERROR(db_->Exec(kMigrations[v]));
    RETURN_IF_ERROR(db_->Exec(absl::StrCat("PRAGMA user_version = ", v + 1)));
    RETURN_IF_ERROR(tx.Commit());
  }
  return absl::OkStatus();
}

absl::StatusOr<int64_t> SurveyStore::RowLocked(const std::string& id) {
  ASSIGN_OR_RETURN(auto s, db_->Prepare("SELECT survey_row FROM surveys WHERE public_id = ?"));
  RETURN_IF_ERROR(s.BindText(1, id));
  ASSIGN_OR_RETURN(bool row, s.Step());
  if (!row) return absl::NotFoundError(absl::StrCat("survey '", id, "' does not exist"));
  return s.ColumnInt(0);
}

absl::StatusOr<SurveyRecord> SurveyStore::Create(SurveyRecord record) {
  std::lock_guard lock(mutex_);
  record.id = NewPublicId();
  record.created_unix_ms = NowUnixMs();
  SqliteTransaction tx(db_.get());
  RETURN_IF_ERROR(tx.Begin());
  {
    ASSIGN_OR_RETURN(auto s, db_->Prepare(
                                 "INSERT INTO surveys (public_id, name, fx, fy, cx, cy, distortion, "
                                 "width, height, created_unix_ms) VALUES (?,?,?,?,?,?,?,?,?,?)"));
    const CameraModel& c = record.camera;
    const std::string distortion = PackDoubles(c.distortion.data(), c.distortion.size());
    RETURN_IF_ERROR(s.BindText(1, record.id));
    RETURN_IF_ERROR(s.BindText(2, record.name));
    RETURN_IF_ERROR(s.BindDouble(3, c.K(0, 0)));
    RETURN_IF_ERROR(s.BindDouble(4, c.K(1, 1)));
    RETURN_IF_ERROR(s.BindDouble(5, c.K(0, 2)));
    RETURN_IF_ERROR(s.BindDouble(6, c.K(1, 2)));
    RETURN_IF_ERROR(s.BindBlob(7, distortion.data(), distortion.size()));
    RETURN_IF_ERROR(s.BindInt(8, c.size.width));
    RETURN_IF_ERROR(s.BindInt(9, c.size.height));
    RETURN_IF_ERROR(s.BindInt(10, record.created_unix_ms));
    RETURN_IF_ERROR(s.Run());
  }
  const int64_t row = db_->LastInsertRowId();
  for (const auto& [light_id, X] : record.references) {
    ASSIGN_OR_RETURN(auto s, db_->Prepare("INSERT INTO reference_lights (survey, light_id, x, y, z) "
                                          "VALUES (?,?,?,?,?)"));
    RETURN_IF_ERROR(s.BindInt(1, row));
    RETURN_IF_ERROR(s.BindInt(2, light_id));
    RETURN_IF_ERROR(s.BindDouble(3, X.x));
    RETURN_IF_ERROR(s.BindDouble(4, X.y));
    RETURN_IF_ERROR(s.BindDouble(5, X.z));
    RETURN_IF_ERROR(s.Run());
  }
  RETURN_IF_ERROR(tx.Commit());
  return record;
}

absl::Status SurveyStore::LoadViewsLocked(int64_t row, bool with_lights, SurveyRecord* record) {
  ASSIGN_OR_RETURN(auto s, db_->Prepare(
                               "SELECT view_row, name, frames, width, height, posed, pose_error, "
                               "pose, references_used, reprojection_rms_px, created_unix_ms "
                               "FROM views WHERE survey = ? ORDER BY view_row"));
  RETURN_IF_ERROR(s.BindInt(1, row));
  std::vector<int64_t> view_rows;
  while (true) {
    ASSIGN_OR_RETURN(bool has, s.Step());
    if (!has) break;
    StoredView v;
    view_rows.push_back(s.ColumnInt(0));
    v.name = s.ColumnText(1);
    v.frames = static_cast<int>(s.ColumnInt(2));
    v.size = cv::Size(static_cast<int>(s.ColumnInt(3)), static_cast<int>(s.ColumnInt(4)));
    v.posed = s.ColumnInt(5) != 0;
    v.pose_error = s.ColumnText(6);
    v.pose = UnpackPose(s.ColumnBlob(7));
    v.references_used = static_cast<int>(s.ColumnInt(8));
    v.reprojection_rms_px = s.ColumnDouble(9);
    v.created_unix_ms = s.ColumnInt(10);
    record->views.push_back(std::move(v));
  }
  if (!with_lights) return absl::OkStatus();
  for (size_t i = 0; i < view_rows.size(); ++i) {
    ASSIGN_OR_RETURN(auto l, db_->Prepare("SELECT light_id, u, v, pixels, quality, conflict FROM "
                                          "view_lights WHERE view = ? ORDER BY light_id, u"));
    RETURN_IF_ERROR(l.BindInt(1, view_rows[i]));
    while (true) {
      ASSIGN_OR_RETURN(bool has, l.Step());
      if (!has) break;
      StoredLight light;
      light.id = static_cast<uint32_t>(l.ColumnInt(0));
      light.pixel = {l.ColumnDouble(1), l.ColumnDouble(2)};
      light.pixels = static_cast<int>(l.ColumnInt(3));
      light.quality = l.ColumnDouble(4);
      light.conflict = l.ColumnInt(5) != 0;
      record->views[i].lights.push_back(light);
    }
  }
  return absl::OkStatus();
}

absl::StatusOr<SurveyRecord> SurveyStore::Get(const std::string& id) {
  std::lock_guard lock(mutex_);
  ASSIGN_OR_RETURN(auto s, db_->Prepare(
                               "SELECT survey_row, name, fx, fy, cx, cy, distortion, width, height, "
                               "created_unix_ms, solved, bundle_adjusted FROM surveys "
                               "WHERE public_id = ?"));
  RETURN_IF_ERROR(s.BindText(1, id));
  ASSIGN_OR_RETURN(bool has, s.Step());
  if (!has) return absl::NotFoundError(absl::StrCat("survey '", id, "' does not exist"));
  SurveyRecord record;
  const int64_t row = s.ColumnInt(0);
  record.id = id;
  record.name = s.ColumnText(1);
  record.camera.K = cv::Matx33d(s.ColumnDouble(2), 0, s.ColumnDouble(4), 0, s.ColumnDouble(3),
                                s.ColumnDouble(5), 0, 0, 1);
  record.camera.distortion = UnpackDoubles(s.ColumnBlob(6));
  record.camera.size = cv::Size(static_cast<int>(s.ColumnInt(7)), static_cast<int>(s.ColumnInt(8)));
  record.created_unix_ms = s.ColumnInt(9);
  record.solved = s.ColumnInt(10) != 0;
  record.bundle_adjusted = s.ColumnInt(11) != 0;
  {
    ASSIGN_OR_RETURN(auto r, db_->Prepare("SELECT light_id, x, y, z FROM reference_lights WHERE "
                                          "survey = ? ORDER BY light_id"));
    RETURN_IF_ERROR(r.BindInt(1, row));
    while (true) {
      ASSIGN_OR_RETURN(bool more, r.Step());
      if (!more) break;
      record.references[static_cast<uint32_t>(r.ColumnInt(0))] =
          cv::Point3d(r.ColumnDouble(1), r.ColumnDouble(2), r.ColumnDouble(3));
    }
  }
  RETURN_IF_ERROR(LoadViewsLocked(row, true, &record));
  {
    ASSIGN_OR_RETURN(auto p, db_->Prepare("SELECT light_id, x, y, z, views, rms_px, sigma_x, "
                                          "sigma_y, sigma_z FROM points WHERE survey = ? "
                                          "ORDER BY light_id"));
    RETURN_IF_ERROR(p.BindInt(1, row));
    while (true) {
      ASSIGN_OR_RETURN(bool more, p.Step());
      if (!more) break;
      survey::SolvedPoint point;
      point.id = static_cast<uint32_t>(p.ColumnInt(0));
      point.position = {p.ColumnDouble(1), p.ColumnDouble(2), p.ColumnDouble(3)};
      point.views = static_cast<int>(p.ColumnInt(4));
      point.rms_px = p.ColumnDouble(5);
      point.sigma = {p.ColumnDouble(6), p.ColumnDouble(7), p.ColumnDouble(8)};
      record.points.push_back(point);
    }
  }
  return record;
}

absl::StatusOr<std::vector<SurveyRecord>> SurveyStore::List() {
  std::lock_guard lock(mutex_);
  ASSIGN_OR_RETURN(auto s, db_->Prepare("SELECT survey_row, public_id, name, created_unix_ms, "
                                        "solved FROM surveys ORDER BY survey_row"));
  std::vector<std::pair<int64_t, SurveyRecord>> rows;
  while (true) {
    ASSIGN_OR_RETURN(bool has, s.Step());
    if (!has) break;
    SurveyRecord r;
    r.id = s.ColumnText(1);
    r.name = s.ColumnText(2);
    r.created_unix_ms = s.ColumnInt(3);
    r.solved = s.ColumnInt(4) != 0;
    rows.emplace_back(s.ColumnInt(0), std::move(r));
  }
  std::vector<SurveyRecord> out;
  for (auto& [row, record] : rows) {
    RETURN_IF_ERROR(LoadViewsLocked(row, false, &record));
    out.push_back(std::move(record));
  }
  return out;
}

absl::Status SurveyStore::Delete(const std::string& id) {
  std::lock_guard lock(mutex_);
  ASSIGN_OR_RETURN(auto s, db_->Prepare("DELETE FROM surveys WHERE public_id = ?"));
  RETURN_IF_ERROR(s.BindText(1, id));
  RETURN_IF_ERROR(s.Run());
  if (db_->Changes() == 0) return absl::NotFoundError(absl::StrCat("survey '", id, "' does not exist"));
  return absl::OkStatus();
}

absl::Status SurveyStore::PutView(const std::string& survey_id, const StoredView& view) {
  std::lock_guard lock(mutex_);
  SqliteTransaction tx(db_.get());
  RETURN_IF_ERROR(tx.Begin());
  ASSIGN_OR_RETURN(const int64_t row, RowLocked(survey_id));
  {
    ASSIGN_OR_RETURN(auto d, db_->Prepare("DELETE FROM views WHERE survey = ? AND name = ?"));
    RETURN_IF_ERROR(d.BindInt(1, row));
    RETURN_IF_ERROR(d.BindText(2, view.name));
    RETURN_IF_ERROR(d.Run());
    if (db_->Changes() > 0) {
      // A replaced view makes the stored solution stale.
      ASSIGN_OR_RETURN(auto p, db_->Prepare("DELETE FROM points WHERE survey = ?"));
      RETURN_IF_ERROR(p.BindInt(1, row));
      RETURN_IF_ERROR(p.Run());
      ASSIGN_OR_RETURN(auto u, db_->Prepare("UPDATE surveys SET solved = 0 WHERE survey_row = ?"));
      RETURN_IF_ERROR(u.BindInt(1, row));
      RETURN_IF_ERROR(u.Run());
    }
  }
  {
    ASSIGN_OR_RETURN(auto s, db_->Prepare(
                                 "INSERT INTO views (survey, name, frames, width, height, posed, "
                                 "pose_error, pose, references_used, reprojection_rms_px, "
                                 "created_unix_ms) VALUES (?,?,?,?,?,?,?,?,?,?,?)"));
    const std::string pose = PackPose(view.pose);
    RETURN_IF_ERROR(s.BindInt(1, row));
    RETURN_IF_ERROR(s.BindText(2, view.name));
    RETURN_IF_ERROR(s.BindInt(3, view.frames));
    RETURN_IF_ERROR(s.BindInt(4, view.size.width));
    RETURN_IF_ERROR(s.BindInt(5, view.size.height));
    RETURN_IF_ERROR(s.BindInt(6, view.posed ? 1 : 0));
    RETURN_IF_ERROR(s.BindText(7, view.pose_error));
    RETURN_IF_ERROR(s.BindBlob(8, pose.data(), pose.size()));
    RETURN_IF_ERROR(s.BindInt(9, view.references_used));
    RETURN_IF_ERROR(s.BindDouble(10, view.reprojection_rms_px));
    RETURN_IF_ERROR(s.BindInt(11, view.created_unix_ms ? view.created_unix_ms : NowUnixMs()));
    RETURN_IF_ERROR(s.Run());
  }
  const int64_t view_row = db_->LastInsertRowId();
  for (const StoredLight& light : view.lights) {
    ASSIGN_OR_RETURN(auto s, db_->Prepare("INSERT INTO view_lights (view, light_id, u, v, pixels, "
                                          "quality, conflict) VALUES (?,?,?,?,?,?,?)"));
    RETURN_IF_ERROR(s.BindInt(1, view_row));
    RETURN_IF_ERROR(s.BindInt(2, light.id));
    RETURN_IF_ERROR(s.BindDouble(3, light.pixel.x));
    RETURN_IF_ERROR(s.BindDouble(4, light.pixel.y));
    RETURN_IF_ERROR(s.BindInt(5, light.pixels));
    RETURN_IF_ERROR(s.BindDouble(6, light.quality));
    RETURN_IF_ERROR(s.BindInt(7, light.conflict ? 1 : 0));
    RETURN_IF_ERROR(s.Run());
  }
  return tx.Commit();
}

absl::Status SurveyStore::PutSolution(const std::string& survey_id,
                                      const survey::SurveySolution& solution) {
  std::lock_guard lock(mutex_);
  SqliteTransaction tx(db_.get());
  RETURN_IF_ERROR(tx.Begin());
  ASSIGN_OR_RETURN(const int64_t row, RowLocked(survey_id));
  {
    ASSIGN_OR_RETURN(auto d, db_->Prepare("DELETE FROM points WHERE survey = ?"));
    RETURN_IF_ERROR(d.BindInt(1, row));
    RETURN_IF_ERROR(d.Run());
  }
  for (const auto& p : solution.points) {
    ASSIGN_OR_RETURN(auto s, db_->Prepare("INSERT INTO points (survey, light_id, x, y, z, views, "
                                          "rms_px, sigma_x, sigma_y, sigma_z) VALUES "
                                          "(?,?,?,?,?,?,?,?,?,?)"));
    RETURN_IF_ERROR(s.BindInt(1, row));
    RETURN_IF_ERROR(s.BindInt(2, p.id));
    RETURN_IF_ERROR(s.BindDouble(3, p.position.x));
    RETURN_IF_ERROR(s.BindDouble(4, p.position.y));
    RETURN_IF_ERROR(s.BindDouble(5, p.position.z));
    RETURN_IF_ERROR(s.BindInt(6, p.views));
    RETURN_IF_ERROR(s.BindDouble(7, p.rms_px));
    RETURN_IF_ERROR(s.BindDouble(8, p.sigma[0]));
    RETURN_IF_ERROR(s.BindDouble(9, p.sigma[1]));
    RETURN_IF_ERROR(s.BindDouble(10, p.sigma[2]));
    RETURN_IF_ERROR(s.Run());
  }
  for (const auto& v : solution.views) {
    if (!v.posed) continue;
    ASSIGN_OR_RETURN(auto s, db_->Prepare("UPDATE views SET pose = ?, reprojection_rms_px = ? "
                                          "WHERE survey = ? AND name = ?"));
    const std::string pose = PackPose(v.pose);
    RETURN_IF_ERROR(s.BindBlob(1, pose.data(), pose.size()));
    RETURN_IF_ERROR(s.BindDouble(2, v.reprojection_rms_px));
    RETURN_IF_ERROR(s.BindInt(3, row));
    RETURN_IF_ERROR(s.BindText(4, v.name));
    RETURN_IF_ERROR(s.Run());
  }
  {
    ASSIGN_OR_RETURN(auto u, db_->Prepare("UPDATE surveys SET solved = 1, bundle_adjusted = ? "
                                          "WHERE survey_row = ?"));
    RETURN_IF_ERROR(u.BindInt(1, solution.bundle_adjusted ? 1 : 0));
    RETURN_IF_ERROR(u.BindInt(2, row));
    RETURN_IF_ERROR(u.Run());
  }
  return tx.Commit();
}

}  // namespace texfree::server
