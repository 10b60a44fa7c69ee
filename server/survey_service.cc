// SurveyService handlers: validate, convert, decode/solve, store, convert back.
#include "server/survey_service.h"

#include <cmath>

#include <spdlog/spdlog.h>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "common/timing.h"
#include "server/proto_convert.h"

namespace texfree::server {
namespace {

absl::Status CheckId(const std::string& id, const char* what) {
  if (id.empty()) return absl::InvalidArgumentError(absl::StrCat(what, " is empty"));
  if (id.size() > 128) return absl::InvalidArgumentError(absl::StrCat(what, " is too long"));
  return absl::OkStatus();
}

void PoseToProto(const survey::CameraPose& pose, v1::Pose* out) {
  for (int i = 0; i < 9; ++i) out->add_rotation(pose.R.val[i]);
  for (int i = 0; i < 3; ++i) out->add_translation(pose.t[i]);
}

void PointToProto(const cv::Point3d& p, v1::Point3* out) {
  out->set_x(p.x);
  out->set_y(p.y);
  out->set_z(p.z);
}

void ViewToProto(const StoredView& v, v1::View* out) {
  out->set_name(v.name);
  for (const auto& l : v.lights) {
    auto* light = out->add_lights();
    light->set_id(l.id);
    light->set_u(l.pixel.x);
    light->set_v(l.pixel.y);
    light->set_pixels(static_cast<uint32_t>(l.pixels));
    light->set_quality(l.quality);
    light->set_conflict(l.conflict);
  }
  if (v.posed) PoseToProto(v.pose, out->mutable_pose());
  out->set_posed(v.posed);
  out->set_pose_error(v.pose_error);
  out->set_reprojection_rms_px(v.reprojection_rms_px);
  out->set_frames(static_cast<uint32_t>(v.frames));
  out->set_width(static_cast<uint32_t>(v.size.width));
  out->set_height(static_cast<uint32_t>(v.size.height));
  out->set_references_used(static_cast<uint32_t>(v.references_used));
}

void SolvedPointToProto(const survey::SolvedPoint& p, v1::SolvedPoint* out) {
  out->set_id(p.id);
  PointToProto(p.position, out->mutable_position_m());
  out->set_views(static_cast<uint32_t>(p.views));
  out->set_rms_px(p.rms_px);
  PointToProto({p.sigma[0], p.sigma[1], p.sigma[2]}, out->mutable_sigma_m());
}

void SurveyToProto(const SurveyRecord& r, v1::Survey* out) {
  out->set_survey_id(r.id);
  out->set_name(r.name);
  auto* in = out->mutable_intrinsics();
  in->set_fx(r.camera.K(0, 0));
  in->set_fy(r.camera.K(1, 1));
  in->set_cx(r.camera.K(0, 2));
  in->set_cy(r.camera.K(1, 2));
  for (double d : r.camera.distortion) in->add_distortion(d);
  in->set_width(static_cast<uint32_t>(r.camera.size.width));
  in->set_height(static_cast<uint32_t>(r.camera.size.height));
  for (const auto& [id, X] : r.references) {
    auto* ref = out->add_references();
    ref->set_id(id);
    PointToProto(X, ref->mutable_position_m());
  }
  for (const auto& v : r.views) ViewToProto(v, out->add_views());
  out->set_created_unix_ms(r.created_unix_ms);
  for (const auto& p : r.points) SolvedPointToProto(p, out->add_points());
  out->set_solved(r.solved);
  out->set_bundle_adjusted(r.bundle_adjusted);
}

std::vector<survey::ViewInput> ViewInputs(const SurveyRecord& record) {
  std::vector<survey::ViewInput> views;
  for (const auto& v : record.views) {
    survey::ViewInput in;
    in.name = v.name;
    for (const auto& l : v.lights) in.lights.push_back({l.id, l.pixel, l.conflict});
    views.push_back(std::move(in));
  }
  return views;
}

// Poses a freshly decoded view from the survey's references (conflicting IDs left out).
void PoseView(const SurveyRecord& record, const survey::PoseOptions& options, StoredView* view) {
  std::vector<cv::Point3d> world;
  std::vector<cv::Point2d> pixels;
  std::vector<uint32_t> ids;
  for (const auto& l : view->lights) {
    auto ref = record.references.find(l.id);
    if (l.conflict || ref == record.references.end()) continue;
    world.push_back(ref->second);
    pixels.push_back(l.pixel);
    ids.push_back(l.id);
  }
  auto pose = survey::EstimateViewPose(world, pixels, record.camera, options);
  if (!pose.ok()) {
    view->posed = false;
    view->pose_error = absl::StrCat(pose.status().message(), " (reference lights decoded: ",
                                    ids.size(), " of ", record.references.size(), ")");
    return;
  }
  view->posed = true;
  view->pose = pose->pose;
  view->references_used = static_cast<int>(pose->inliers.size());
  view->reprojection_rms_px = pose->rms_px;
}

}  // namespace

absl::Status SurveyServiceOptions::Validate() const {
  if (absl::Status s = decoder.Validate(); !s.ok()) return s;
  if (absl::Status s = solve.Validate(); !s.ok()) return s;
  return limits.Validate();
}

std::string PointsToCsv(const std::vector<survey::SolvedPoint>& points) {
  std::string out = "id,x,y,z,views,rms_px,sigma_x,sigma_y,sigma_z\n";
  for (const auto& p : points) {
    absl::StrAppendFormat(&out, "%u,%.6f,%.6f,%.6f,%d,%.4f,%.6f,%.6f,%.6f\n", p.id, p.position.x,
                          p.position.y, p.position.z, p.views, p.rms_px, p.sigma[0], p.sigma[1],
                          p.sigma[2]);
  }
  return out;
}

std::string PointsToJson(const std::string& survey_id,
                         const std::vector<survey::SolvedPoint>& points) {
  std::string out = absl::StrCat("{\"survey_id\": \"", survey_id, "\", \"points\": [");
  for (size_t i = 0; i < points.size(); ++i) {
    const auto& p = points[i];
    absl::StrAppendFormat(&out,
                          "%s{\"id\": %u, \"x\": %.6f, \"y\": %.6f, \"z\": %.6f, \"views\": %d, "
                          "\"rms_px\": %.4f, \"sigma_m\": [%.6f, %.6f, %.6f]}",
                          i ? ", " : "", p.id, p.position.x, p.position.y, p.position.z, p.views,
                          p.rms_px, p.sigma[0], p.sigma[1], p.sigma[2]);
  }
  out += "]}\n";
  return out;
}

std::string PointsToPly(const std::vector<survey::SolvedPoint>& points) {
  std::string out = absl::StrCat(
      "ply\nformat ascii 1.0\ncomment texfree light survey, metres\nelement vertex ",
      points.size(),
      "\nproperty double x\nproperty double y\nproperty double z\nproperty int id\n"
      "end_header\n");
  for (const auto& p : points) {
    absl::StrAppendFormat(&out, "%.6f %.6f %.6f %u\n", p.position.x, p.position.y, p.position.z,
                          p.id);
  }
  return out;
}

grpc::Status SurveyServiceImpl::CreateSurvey(grpc::ServerContext*,
                                             const v1::CreateSurveyRequest* request,
                                             v1::Survey* response) {
  auto camera = CameraFromProto(request->intrinsics());
  if (!camera.ok()) return LoggedFailure("CreateSurvey", camera.status());
  if (!camera->has_value()) {
    return LoggedFailure("CreateSurvey", absl::InvalidArgumentError(
                                             "intrinsics are required (fx, fy, cx, cy, distortion, "
                                             "width, height): pass the camera's calibration"));
  }
  if ((*camera)->size.width <= 0 || (*camera)->size.height <= 0) {
    return LoggedFailure("CreateSurvey",
                         absl::InvalidArgumentError("intrinsics need the image width and height"));
  }
  if (request->name().size() > 256) {
    return LoggedFailure("CreateSurvey", absl::InvalidArgumentError("name is over 256 characters"));
  }
  SurveyRecord record;
  record.name = request->name();
  record.camera = **camera;
  for (int i = 0; i < request->references_size(); ++i) {
    const auto& ref = request->references(i);
    if (ref.id() > static_cast<uint32_t>(lights::kMaxLightId)) {
      return LoggedFailure("CreateSurvey", absl::InvalidArgumentError(absl::StrCat(
                                               "reference ", i, ": light id ", ref.id(),
                                               " is out of range 0..", lights::kMaxLightId)));
    }
    const auto& p = ref.position_m();
    if (!std::isfinite(p.x()) || !std::isfinite(p.y()) || !std::isfinite(p.z())) {
      return LoggedFailure("CreateSurvey",
                           absl::InvalidArgumentError(absl::StrCat("reference light ", ref.id(),
                                                                   " has a non-finite position")));
    }
    if (!record.references.emplace(ref.id(), cv::Point3d(p.x(), p.y(), p.z())).second) {
      return LoggedFailure("CreateSurvey", absl::InvalidArgumentError(absl::StrCat(
                                               "reference light ", ref.id(), " is listed twice")));
    }
  }
  if (static_cast<int>(record.references.size()) < options_.solve.pose.min_references) {
    return LoggedFailure("CreateSurvey",
                         absl::InvalidArgumentError(absl::StrCat(
                             "a survey needs at least ", options_.solve.pose.min_references,
                             " reference lights with surveyed coordinates to pose its views; got ",
                             record.references.size())));
  }
  auto stored = store_->Create(std::move(record));
  if (!stored.ok()) return LoggedFailure("CreateSurvey", stored.status());
  spdlog::info("CreateSurvey: {} '{}' with {} reference lights", stored->id, stored->name,
               stored->references.size());
  SurveyToProto(*stored, response);
  return grpc::Status::OK;
}

grpc::Status SurveyServiceImpl::UploadView(grpc::ServerContext* context,
                                           grpc::ServerReader<v1::UploadViewRequest>* reader,
                                           v1::UploadViewResponse* response) {
  const auto t0 = SteadyClock::now();
  v1::UploadViewRequest message;
  if (!reader->Read(&message) || !message.has_header()) {
    return LoggedFailure(
        "UploadView",
        absl::InvalidArgumentError("the first message of UploadView must be the view header "
                                   "(survey_id, view_name)"));
  }
  const v1::ViewHeader header = message.header();
  if (auto s = CheckId(header.survey_id(), "survey_id"); !s.ok())
    return LoggedFailure("UploadView", s);
  if (header.view_name().empty() || header.view_name().size() > 128) {
    return LoggedFailure("UploadView",
                         absl::InvalidArgumentError("view_name must be 1..128 characters"));
  }
  auto record = store_->Get(header.survey_id());
  if (!record.ok()) return LoggedFailure("UploadView", record.status());

  lights::BurstDecoderOptions decoder_options = options_.decoder;
  auto stream = lights::StreamingBurstDecoder::Create(decoder_options, options_.limits);
  if (!stream.ok()) return LoggedFailure("UploadView", stream.status());
  int frames = 0;
  absl::Status push_status;
  while (reader->Read(&message)) {
    if (context->IsCancelled()) {
      return LoggedFailure("UploadView", absl::CancelledError("client cancelled the upload"));
    }
    if (!message.has_frame()) {
      push_status = absl::InvalidArgumentError(
          absl::StrCat("message ", frames + 1, " is not a frame: send the header once, then frames"));
      break;
    }
    if (message.frame().data_case() != v1::Image::kEncoded) {
      push_status = absl::InvalidArgumentError(absl::StrCat(
          "frame ", frames, " is raw: send JPEG, PNG or TIFF bytes (8- or 16-bit)"));
      break;
    }
    push_status = (*stream)->Push(std::move(*message.mutable_frame()->mutable_encoded()));
    if (!push_status.ok()) break;
    ++frames;
  }
  if (!push_status.ok()) return LoggedFailure("UploadView", push_status);
  const double receive_ms = MillisecondsSince(t0);
  auto result = (*stream)->Finish();
  if (!result.ok()) return LoggedFailure("UploadView", result.status());
  const double image_decode_ms = (*stream)->image_decode_ms();
  const lights::BurstStats& stats = result->stats;

  const CameraModel& camera = record->camera;
  // The view must match the survey's camera (a resized or cropped burst has other intrinsics).
  StoredView view;
  view.name = header.view_name();
  view.frames = frames;
  for (const auto& spot : result->lights) {
    view.lights.push_back({spot.id, spot.center, spot.pixels, spot.quality, spot.conflict});
  }
  const auto t_pose = SteadyClock::now();
  view.size = (*stream)->frame_size();
  if (camera.size.width > 0 && view.size != camera.size) {
    return LoggedFailure("UploadView",
                         absl::InvalidArgumentError(absl::StrCat(
                             "frames are ", view.size.width, "x", view.size.height,
                             " but the survey's camera was calibrated at ", camera.size.width, "x",
                             camera.size.height, ": upload the full-size frames")));
  }
  PoseView(*record, options_.solve.pose, &view);
  const double pose_ms = MillisecondsSince(t_pose);
  if (auto s = store_->PutView(record->id, view); !s.ok()) return LoggedFailure("UploadView", s);

  ViewToProto(view, response->mutable_view());
  response->set_candidate_pixels(static_cast<uint64_t>(stats.candidate_pixels));
  const std::pair<const char*, double> timings[] = {{"receive", receive_ms},
                                                    {"image_decode_cpu", image_decode_ms},
                                                    {"light_decode", stats.decode_ms},
                                                    {"pose", pose_ms}};
  for (const auto& [stage, ms] : timings) {
    auto* t = response->add_timings();
    t->set_stage(stage);
    t->set_ms(ms);
  }
  response->set_server_ms(MillisecondsSince(t0));
  int conflicts = 0;
  for (const auto& l : view.lights) conflicts += l.conflict;
  spdlog::info(
      "UploadView: survey {} view '{}': {} frames {}x{}, {} lights ({} in conflict), {} candidate "
      "pixels, posed={} ({} refs, {:.3f} px){}; {:.0f} ms (image decode cpu {:.0f} ms, light "
      "decode {:.0f} ms)",
      record->id, view.name, frames, view.size.width, view.size.height, view.lights.size(),
      conflicts, stats.candidate_pixels, view.posed, view.references_used,
      view.reprojection_rms_px, view.posed ? "" : absl::StrCat(": ", view.pose_error),
      response->server_ms(), image_decode_ms, stats.decode_ms);
  return grpc::Status::OK;
}

grpc::Status SurveyServiceImpl::Solve(grpc::ServerContext*, const v1::SolveRequest* request,
                                      v1::SolveResponse* response) {
  const auto t0 = SteadyClock::now();
  if (auto s = CheckId(request->survey_id(), "survey_id"); !s.ok())
    return LoggedFailure("Solve", s);
  auto record = store_->Get(request->survey_id());
  if (!record.ok()) return LoggedFailure("Solve", record.status());
  survey::SolveOptions options = options_.solve;
  options.bundle_adjustment = request->bundle_adjustment();
  auto solution = survey::SolveSurvey(record->camera, record->references, ViewInputs(*record), options);
  if (!solution.ok()) return LoggedFailure("Solve", solution.status());
  if (auto s = store_->PutSolution(record->id, *solution); !s.ok())
    return LoggedFailure("Solve", s);
  for (const auto& p : solution->points) SolvedPointToProto(p, response->add_points());
  for (const auto& v : solution->views) {
    auto* r = response->add_views();
    r->set_view(v.name);
    r->set_reprojection_rms_px(v.reprojection_rms_px);
    r->set_posed(v.posed);
    r->set_pose_error(v.pose_error);
  }
  response->set_bundle_adjusted(solution->bundle_adjusted);
  response->set_server_ms(MillisecondsSince(t0));
  spdlog::info("Solve: survey {}: {} points from {} views{}; {:.1f} ms", record->id,
               solution->points.size(), solution->views.size(),
               solution->bundle_adjusted
                   ? absl::StrFormat(", bundle adjustment %.3f -> %.3f px",
                                     solution->bundle_initial_rms_px, solution->bundle_final_rms_px)
                   : std::string(),
               response->server_ms());
  return grpc::Status::OK;
}

grpc::Status SurveyServiceImpl::GetSurvey(grpc::ServerContext*,
                                          const v1::GetSurveyRequest* request,
                                          v1::Survey* response) {
  if (auto s = CheckId(request->survey_id(), "survey_id"); !s.ok())
    return LoggedFailure("GetSurvey", s);
  auto record = store_->Get(request->survey_id());
  if (!record.ok()) return LoggedFailure("GetSurvey", record.status());
  SurveyToProto(*record, response);
  return grpc::Status::OK;
}

grpc::Status SurveyServiceImpl::ListSurveys(grpc::ServerContext*, const v1::ListSurveysRequest*,
                                            v1::ListSurveysResponse* response) {
  auto list = store_->List();
  if (!list.ok()) return LoggedFailure("ListSurveys", list.status());
  for (const auto& r : *list) {
    auto* s = response->add_surveys();
    s->set_survey_id(r.id);
    s->set_name(r.name);
    s->set_created_unix_ms(r.created_unix_ms);
    s->set_solved(r.solved);
    for (const auto& v : r.views) ViewToProto(v, s->add_views());
  }
  return grpc::Status::OK;
}

grpc::Status SurveyServiceImpl::DeleteSurvey(grpc::ServerContext*,
                                             const v1::DeleteSurveyRequest* request,
                                             v1::DeleteSurveyResponse* response) {
  if (auto s = CheckId(request->survey_id(), "survey_id"); !s.ok())
    return LoggedFailure("DeleteSurvey", s);
  if (auto s = store_->Delete(request->survey_id()); !s.ok())
    return LoggedFailure("DeleteSurvey", s);
  spdlog::info("DeleteSurvey: {}", request->survey_id());
  response->set_survey_id(request->survey_id());
  return grpc::Status::OK;
}

grpc::Status SurveyServiceImpl::ExportPoints(grpc::ServerContext*,
                                             const v1::ExportPointsRequest* request,
                                             v1::ExportPointsResponse* response) {
  if (auto s = CheckId(request->survey_id(), "survey_id"); !s.ok())
    return LoggedFailure("ExportPoints", s);
  auto record = store_->Get(request->survey_id());
  if (!record.ok()) return LoggedFailure("ExportPoints", record.status());
  if (!record->solved) {
    return LoggedFailure(
        "ExportPoints",
        absl::FailedPreconditionError(absl::StrCat(
            "survey '", record->id, "' has no solution yet (or a view changed since): run Solve")));
  }
  switch (request->format()) {
    case v1::ExportPointsRequest::FORMAT_UNSPECIFIED:
    case v1::ExportPointsRequest::CSV:
      response->set_data(PointsToCsv(record->points));
      response->set_mime_type("text/csv");
      break;
    case v1::ExportPointsRequest::JSON:
      response->set_data(PointsToJson(record->id, record->points));
      response->set_mime_type("application/json");
      break;
    case v1::ExportPointsRequest::PLY:
      response->set_data(PointsToPly(record->points));
      response->set_mime_type("application/x-ply");
      break;
    default:
      return LoggedFailure("ExportPoints", absl::InvalidArgumentError("unknown export format"));
  }
  return grpc::Status::OK;
}

}  // namespace texfree::server
