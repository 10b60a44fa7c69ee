// Pool table profiles in SQLite.
#include "server/pool_profile_store.h"

#include <chrono>
#include <cstdio>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "common/status_macros.h"

namespace texfree::server {
namespace {

// Migration i takes the schema from version i to i + 1.
constexpr const char* kMigrations[] = {
    R"sql(
CREATE TABLE pool_profiles (
  name TEXT PRIMARY KEY,
  length_mm REAL NOT NULL,
  width_mm REAL NOT NULL,
  ball_radius_mm REAL NOT NULL,
  cushion_height_mm REAL NOT NULL,
  cushion_width_mm REAL NOT NULL,
  corner_pocket_mm REAL NOT NULL,
  side_pocket_mm REAL NOT NULL,
  cloth_bgr TEXT NOT NULL,   -- "b,g,r"
  ball_bgr TEXT NOT NULL,    -- ten "b,g,r" separated by ';', cue first
  updated_unix_ms INTEGER NOT NULL
);
)sql",
};

std::string ColourText(const cv::Vec3b& c) { return absl::StrCat(c[0], ",", c[1], ",", c[2]); }

bool ParseColour(absl::string_view text, cv::Vec3b* out) {
  int b, g, r;
  if (std::sscanf(std::string(text).c_str(), "%d,%d,%d", &b, &g, &r) != 3) return false;
  if (b < 0 || g < 0 || r < 0 || b > 255 || g > 255 || r > 255) return false;
  *out = cv::Vec3b(static_cast<uint8_t>(b), static_cast<uint8_t>(g), static_cast<uint8_t>(r));
  return true;
}

}  // namespace

absl::StatusOr<std::unique_ptr<PoolProfileStore>> PoolProfileStore::Open(const std::string& path) {
  ASSIGN_OR_RETURN(auto db, SqliteDb::Open(path));
  std::unique_ptr<PoolProfileStore> store(new PoolProfileStore(std::move(db)));
  RETURN_IF_ERROR(store->Migrate());
  return store;
}

absl::Status PoolProfileStore::Migrate() {
  std::lock_guard lock(mutex_);
  constexpr int kKnown = sizeof(kMigrations) / sizeof(kMigrations[0]);
  static_assert(kKnown == kSchemaVersion);
  return MigrateSchema(db_.get(), kMigrations, kKnown, "pool database");
}

absl::Status PoolProfileStore::Put(const PoolTableProfile& p) {
  RETURN_IF_ERROR(p.Validate());
  std::string balls;
  for (int i = 0; i < kPoolBallCount; ++i)
    absl::StrAppend(&balls, i ? ";" : "", ColourText(p.ball_bgr[i]));
  const int64_t now = std::chrono::duration_cast<std::chrono::milliseconds>(
                          std::chrono::system_clock::now().time_since_epoch())
                          .count();
  std::lock_guard lock(mutex_);
  ASSIGN_OR_RETURN(auto s, db_->Prepare(
                               "INSERT OR REPLACE INTO pool_profiles (name, length_mm, width_mm, "
                               "ball_radius_mm, cushion_height_mm, cushion_width_mm, "
                               "corner_pocket_mm, side_pocket_mm, cloth_bgr, ball_bgr, "
                               "updated_unix_ms) VALUES (?,?,?,?,?,?,?,?,?,?,?)"));
  RETURN_IF_ERROR(s.BindText(1, p.name));
  RETURN_IF_ERROR(s.BindDouble(2, p.length_mm));
  RETURN_IF_ERROR(s.BindDouble(3, p.width_mm));
  RETURN_IF_ERROR(s.BindDouble(4, p.ball_radius_mm));
  RETURN_IF_ERROR(s.BindDouble(5, p.cushion_height_mm));
  RETURN_IF_ERROR(s.BindDouble(6, p.cushion_width_mm));
  RETURN_IF_ERROR(s.BindDouble(7, p.corner_pocket_mm));
  RETURN_IF_ERROR(s.BindDouble(8, p.side_pocket_mm));
  RETURN_IF_ERROR(s.BindText(9, ColourText(p.cloth_bgr)));
  RETURN_IF_ERROR(s.BindText(10, balls));
  RETURN_IF_ERROR(s.BindInt(11, now));
  return s.Run();
}

absl::StatusOr<std::optional<PoolTableProfile>> PoolProfileStore::Get(const std::string& name) {
  std::lock_guard lock(mutex_);
  ASSIGN_OR_RETURN(auto s, db_->Prepare(
                               "SELECT length_mm, width_mm, ball_radius_mm, cushion_height_mm, "
                               "cushion_width_mm, corner_pocket_mm, side_pocket_mm, cloth_bgr, "
                               "ball_bgr FROM pool_profiles WHERE name = ?"));
  RETURN_IF_ERROR(s.BindText(1, name));
  ASSIGN_OR_RETURN(bool row, s.Step());
  if (!row) return std::optional<PoolTableProfile>();
  PoolTableProfile p;
  p.name = name;
  p.length_mm = s.ColumnDouble(0);
  p.width_mm = s.ColumnDouble(1);
  p.ball_radius_mm = s.ColumnDouble(2);
  p.cushion_height_mm = s.ColumnDouble(3);
  p.cushion_width_mm = s.ColumnDouble(4);
  p.corner_pocket_mm = s.ColumnDouble(5);
  p.side_pocket_mm = s.ColumnDouble(6);
  if (!ParseColour(s.ColumnText(7), &p.cloth_bgr))
    return absl::DataLossError(absl::StrCat("pool profile '", name, "': bad cloth colour"));
  const std::vector<std::string> balls = absl::StrSplit(s.ColumnText(8), ';');
  if (balls.size() != kPoolBallCount)
    return absl::DataLossError(absl::StrCat("pool profile '", name, "': bad ball colours"));
  for (int i = 0; i < kPoolBallCount; ++i)
    if (!ParseColour(balls[i], &p.ball_bgr[i]))
      return absl::DataLossError(absl::StrCat("pool profile '", name, "': bad ball colour ", i));
  return std::optional<PoolTableProfile>(p);
}

absl::StatusOr<std::vector<std::string>> PoolProfileStore::Names() {
  std::lock_guard lock(mutex_);
  ASSIGN_OR_RETURN(auto s, db_->Prepare("SELECT name FROM pool_profiles ORDER BY name"));
  std::vector<std::string> names;
  while (true) {
    ASSIGN_OR_RETURN(bool row, s.Step());
    if (!row) break;
    names.push_back(s.ColumnText(0));
  }
  return names;
}

}  // namespace texfree::server
