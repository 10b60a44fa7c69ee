// SurveyStore: SQLite persistence of light surveys (camera, reference lights, uploaded views
// with their decoded lights and poses, solved points) in its own file, surveys.db.
#pragma once

#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "absl/status/statusor.h"
#include "common/light_survey.h"
#include "common/planar_pose.h"
#include "server/sqlite_db.h"

namespace texfree::server {

struct StoredLight {
  uint32_t id = 0;
  cv::Point2d pixel;
  int pixels = 0;
  double quality = 0;
  bool conflict = false;
};

struct StoredView {
  std::string name;
  int frames = 0;
  cv::Size size;
  bool posed = false;
  std::string pose_error;
  survey::CameraPose pose;
  int references_used = 0;
  double reprojection_rms_px = 0;
  std::vector<StoredLight> lights;
  int64_t created_unix_ms = 0;
};

struct SurveyRecord {
  std::string id;
  std::string name;
  CameraModel camera;
  std::map<uint32_t, cv::Point3d> references;
  std::vector<StoredView> views;  // in upload order
  std::vector<survey::SolvedPoint> points;
  bool solved = false;
  bool bundle_adjusted = false;
  int64_t created_unix_ms = 0;
};

// Thread-safe: one connection guarded by a mutex.
class SurveyStore {
 public:
  // Current schema version; Open() migrates older files forward, refuses newer ones.
  static constexpr int kSchemaVersion = 1;

  static absl::StatusOr<std::unique_ptr<SurveyStore>> Open(const std::string& path);

  // Inserts survey and references in one transaction; assigns id and creation time.
  absl::StatusOr<SurveyRecord> Create(SurveyRecord record);
  // Full record (views with lights, points). NOT_FOUND for an unknown id.
  absl::StatusOr<SurveyRecord> Get(const std::string& id);
  // Every survey, oldest first, with views but without their lights.
  absl::StatusOr<std::vector<SurveyRecord>> List();
  absl::Status Delete(const std::string& id);
  // Adds a view, replacing one of the same name; a replaced view invalidates the solution.
  absl::Status PutView(const std::string& survey_id, const StoredView& view);
  // Stores a solution: the points (replacing earlier ones) and the views' poses and residuals.
  absl::Status PutSolution(const std::string& survey_id, const survey::SurveySolution& solution);

 private:
  explicit SurveyStore(std::unique_ptr<SqliteDb> db) : db_(std::move(db)) {}
  absl::Status Migrate();
  absl::StatusOr<int64_t> RowLocked(const std::string& id);
  absl::Status LoadViewsLocked(int64_t row, bool with_lights, SurveyRecord* record);

  std::mutex mutex_;
  std::unique_ptr<SqliteDb> db_;
};

}  // namespace texfree::server
