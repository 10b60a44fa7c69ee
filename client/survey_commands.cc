// `texfree survey ...` commands on SurveyService and `texfree lights encode`.
#include "client/survey_commands.h"

#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iomanip>
#include <memory>
#include <set>
#include <sstream>

#include "client/camera_file.h"
#include "client/command_context.h"
#include "client/file_util.h"
#include "client/json_output.h"
#include "common/light_codec.h"
#include "texfree/v1/survey.grpc.pb.h"

namespace texfree::client {
namespace {

using nlohmann::json;

struct CreateOptions {
  std::string intrinsics;
  std::string references;
  std::string name;
};

struct UploadOptions {
  std::string survey_id;
  std::string view;
  std::string folder;
};

struct SolveOptions {
  std::string survey_id;
  std::string out;
  bool bundle_adjustment = false;
};

struct ExportOptions {
  std::string survey_id;
  std::string format = "csv";
  std::string out;
};

struct EncodeOptions {
  unsigned id = 0;
  unsigned idle = 0;
};

std::unique_ptr<v1::SurveyService::Stub> SurveyStub(CommandContext& ctx) {
  return v1::SurveyService::NewStub(ctx.Channel());
}

std::string Trim(const std::string& s) {
  const auto begin = s.find_first_not_of(" \t\r\n");
  if (begin == std::string::npos) return "";
  return s.substr(begin, s.find_last_not_of(" \t\r\n") - begin + 1);
}

std::vector<std::string> SplitCsv(const std::string& line) {
  std::vector<std::string> fields;
  std::stringstream in(line);
  std::string field;
  while (std::getline(in, field, ',')) fields.push_back(Trim(field));
  if (!line.empty() && line.back() == ',') fields.push_back("");
  return fields;
}

bool ParseDouble(const std::string& text, double* value) {
  if (text.empty()) return false;
  char* end = nullptr;
  *value = std::strtod(text.c_str(), &end);
  return end == text.c_str() + text.size() && std::isfinite(*value);
}

json LightsToJson(const v1::View& view) {
  json lights = json::array();
  for (const auto& l : view.lights()) {
    lights.push_back(json{{"id", l.id()},
                          {"u", l.u()},
                          {"v", l.v()},
                          {"pixels", l.pixels()},
                          {"quality", l.quality()},
                          {"conflict", l.conflict()}});
  }
  return lights;
}

json ViewToJson(const v1::View& view) {
  json out{{"view", view.name()},
           {"frames", view.frames()},
           {"width", view.width()},
           {"height", view.height()},
           {"lights", LightsToJson(view)},
           {"posed", view.posed()},
           {"reprojection_rms_px", view.reprojection_rms_px()},
           {"references_used", view.references_used()}};
  if (view.posed()) out["pose"] = PoseToJson(view.pose());
  if (!view.pose_error().empty()) out["pose_error"] = view.pose_error();
  return out;
}

json PointToJson(const v1::SolvedPoint& p) {
  return json{{"id", p.id()},
              {"x", p.position_m().x()},
              {"y", p.position_m().y()},
              {"z", p.position_m().z()},
              {"views", p.views()},
              {"rms_px", p.rms_px()},
              {"sigma_m", json::array({p.sigma_m().x(), p.sigma_m().y(), p.sigma_m().z()})}};
}

std::string Fixed(double v, int digits) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(digits) << v;
  return s.str();
}

int RunCreate(CommandContext& ctx, const CreateOptions& options) {
  const CameraFile camera = LoadCameraOrUsage(options.intrinsics);
  const auto references =
      ParseReferencesCsv(ReadInputFile(options.references, "references file"), options.references);
  v1::CreateSurveyRequest request;
  request.set_name(options.name.empty() ? std::filesystem::path(options.references).stem().string()
                                        : options.name);
  auto* in = request.mutable_intrinsics();
  in->set_fx(camera.fx());
  in->set_fy(camera.fy());
  in->set_cx(camera.cx());
  in->set_cy(camera.cy());
  for (double d : camera.distortion) in->add_distortion(d);
  in->set_width(static_cast<uint32_t>(camera.image_width));
  in->set_height(static_cast<uint32_t>(camera.image_height));
  for (const auto& [id, X] : references) {
    auto* ref = request.add_references();
    ref->set_id(id);
    ref->mutable_position_m()->set_x(X.x);
    ref->mutable_position_m()->set_y(X.y);
    ref->mutable_position_m()->set_z(X.z);
  }
  grpc::ClientContext context;
  ctx.Prepare(&context);
  v1::Survey response;
  ctx.Check(SurveyStub(ctx)->CreateSurvey(&context, request, &response));
  if (ctx.json) {
    ctx.PrintJson(json{{"survey_id", response.survey_id()},
                       {"name", response.name()},
                       {"references", response.references_size()}});
  } else {
    ctx.out() << "created survey " << response.survey_id() << " '" << response.name() << "' with "
              << response.references_size() << " reference lights\n";
  }
  return kExitOk;
}

// Progress bar on stderr, only when stderr is a terminal.
class Progress {
 public:
  Progress(std::ostream& err, int total) : err_(err), total_(total), enabled_(isatty(2) != 0) {}
  void Update(int sent) {
    if (!enabled_) return;
    const int width = 30;
    const int filled = total_ ? width * sent / total_ : width;
    err_ << "\r[" << std::string(filled, '#') << std::string(width - filled, '.') << "] " << sent
         << "/" << total_ << " frames sent" << std::flush;
  }
  void Done(const std::string& text) {
    if (enabled_) err_ << "\r" << std::string(72, ' ') << "\r" << text << "\n";
  }

 private:
  std::ostream& err_;
  int total_;
  bool enabled_;
};

int RunUpload(CommandContext& ctx, const UploadOptions& options) {
  const auto files = BurstFrameFiles(options.folder);
  if (files.size() < static_cast<size_t>(lights::kPacketSamples)) {
    throw UsageError("'" + options.folder + "' holds " + std::to_string(files.size()) +
                     " frames; a view needs at least " + std::to_string(lights::kPacketSamples) +
                     " (100 recommended)");
  }
  auto stub = SurveyStub(ctx);
  grpc::ClientContext context;
  ctx.Prepare(&context);
  v1::UploadViewResponse response;
  auto writer = stub->UploadView(&context, &response);
  v1::UploadViewRequest header;
  header.mutable_header()->set_survey_id(options.survey_id);
  header.mutable_header()->set_view_name(options.view);
  header.mutable_header()->set_expected_frames(static_cast<uint32_t>(files.size()));
  Progress progress(ctx.err(), static_cast<int>(files.size()));
  bool open = writer->Write(header);
  int sent = 0;
  for (const auto& file : files) {
    if (!open) break;
    v1::UploadViewRequest frame;
    *frame.mutable_frame()->mutable_encoded() = ReadInputFile(file, "frame");
    open = writer->Write(frame);
    if (open) progress.Update(++sent);
  }
  writer->WritesDone();
  const grpc::Status status = writer->Finish();
  progress.Done(status.ok() ? std::to_string(response.view().lights_size()) + " lights found in " +
                                  std::to_string(sent) + " frames"
                            : std::string("upload failed"));
  ctx.Check(status);
  const v1::View& view = response.view();
  if (ctx.json) {
    json out = ViewToJson(view);
    out["server_ms"] = response.server_ms();
    out["candidate_pixels"] = response.candidate_pixels();
    json timings = json::object();
    for (const auto& t : response.timings()) timings[t.stage()] = t.ms();
    out["timings"] = timings;
    ctx.PrintJson(out);
  } else {
    ctx.out() << "view '" << view.name() << "': " << view.lights_size() << " lights in "
              << view.frames() << " frames (" << Fixed(response.server_ms(), 0) << " ms)\n";
    for (const auto& l : view.lights()) {
      ctx.out() << "  light " << std::setw(2) << l.id() << "  (" << Fixed(l.u(), 2) << ", "
                << Fixed(l.v(), 2) << ")  " << l.pixels() << " px  quality "
                << Fixed(l.quality(), 3)
                << (l.conflict() ? "  CONFLICT: decoded in two places" : "") << "\n";
    }
    if (view.posed()) {
      ctx.out() << "posed from " << view.references_used() << " reference lights, rms "
                << Fixed(view.reprojection_rms_px(), 3) << " px\n";
    }
  }
  if (!view.posed()) ctx.err() << "warning: view not posed: " << view.pose_error() << "\n";
  return kExitOk;
}

int RunSolve(CommandContext& ctx, const SolveOptions& options) {
  v1::SolveRequest request;
  request.set_survey_id(options.survey_id);
  request.set_bundle_adjustment(options.bundle_adjustment);
  grpc::ClientContext context;
  ctx.Prepare(&context);
  v1::SolveResponse response;
  ctx.Check(SurveyStub(ctx)->Solve(&context, request, &response));
  if (!options.out.empty()) {
    std::ofstream out(options.out);
    out << "id,x,y,z,views,rms_px,sigma_x,sigma_y,sigma_z\n" << std::fixed << std::setprecision(6);
    for (const auto& p : response.points()) {
      out << p.id() << "," << p.position_m().x() << "," << p.position_m().y() << ","
          << p.position_m().z() << "," << p.views() << "," << p.rms_px() << "," << p.sigma_m().x()
          << "," << p.sigma_m().y() << "," << p.sigma_m().z() << "\n";
    }
    if (!out) throw CliError(kExitFailure, "cannot write '" + options.out + "'");
  }
  if (ctx.json) {
    json points = json::array(), views = json::array();
    for (const auto& p : response.points()) points.push_back(PointToJson(p));
    for (const auto& v : response.views()) {
      json view{{"view", v.view()},
                {"reprojection_rms_px", v.reprojection_rms_px()},
                {"posed", v.posed()}};
      if (!v.pose_error().empty()) view["pose_error"] = v.pose_error();
      views.push_back(view);
    }
    ctx.PrintJson(json{{"points", points},
                       {"views", views},
                       {"bundle_adjusted", response.bundle_adjusted()},
                       {"server_ms", response.server_ms()}});
  } else {
    ctx.out() << response.points_size() << " points"
              << (response.bundle_adjusted() ? " (bundle-adjusted)" : "") << "\n";
    for (const auto& p : response.points()) {
      ctx.out() << "  light " << std::setw(2) << p.id() << "  x " << Fixed(p.position_m().x(), 4)
                << "  y " << Fixed(p.position_m().y(), 4) << "  z " << Fixed(p.position_m().z(), 4)
                << "  +-(" << Fixed(p.sigma_m().x() * 1000, 1) << ", "
                << Fixed(p.sigma_m().y() * 1000, 1) << ", " << Fixed(p.sigma_m().z() * 1000, 1)
                << ") mm  " << p.views() << " views  rms " << Fixed(p.rms_px(), 3) << " px\n";
    }
    for (const auto& v : response.views()) {
      ctx.out() << "  view '" << v.view() << "': "
                << (v.posed() ? "rms " + Fixed(v.reprojection_rms_px(), 3) + " px"
                              : "not posed: " + v.pose_error())
                << "\n";
    }
  }
  return kExitOk;
}

int RunList(CommandContext& ctx) {
  grpc::ClientContext context;
  ctx.Prepare(&context);
  v1::ListSurveysResponse response;
  ctx.Check(SurveyStub(ctx)->ListSurveys(&context, v1::ListSurveysRequest(), &response));
  if (ctx.json) {
    json list = json::array();
    for (const auto& s : response.surveys()) {
      json views = json::array();
      for (const auto& v : s.views()) views.push_back(v.name());
      list.push_back(json{{"survey_id", s.survey_id()},
                          {"name", s.name()},
                          {"views", views},
                          {"solved", s.solved()},
                          {"created_unix_ms", s.created_unix_ms()}});
    }
    ctx.PrintJson(json{{"surveys", list}});
  } else {
    for (const auto& s : response.surveys()) {
      ctx.out() << s.survey_id() << "  '" << s.name() << "'  " << s.views_size() << " views"
                << (s.solved() ? ", solved" : "") << "\n";
    }
  }
  return kExitOk;
}

int RunShow(CommandContext& ctx, const std::string& survey_id) {
  v1::GetSurveyRequest request;
  request.set_survey_id(survey_id);
  grpc::ClientContext context;
  ctx.Prepare(&context);
  v1::Survey s;
  ctx.Check(SurveyStub(ctx)->GetSurvey(&context, request, &s));
  if (ctx.json) {
    json references = json::array(), views = json::array(), points = json::array();
    for (const auto& r : s.references()) {
      references.push_back(json{{"id", r.id()},
                                {"x", r.position_m().x()},
                                {"y", r.position_m().y()},
                                {"z", r.position_m().z()}});
    }
    for (const auto& v : s.views()) views.push_back(ViewToJson(v));
    for (const auto& p : s.points()) points.push_back(PointToJson(p));
    const auto& in = s.intrinsics();
    json distortion = json::array();
    for (double d : in.distortion()) distortion.push_back(d);
    ctx.PrintJson(json{{"survey_id", s.survey_id()},
                       {"name", s.name()},
                       {"intrinsics", json{{"fx", in.fx()},
                                           {"fy", in.fy()},
                                           {"cx", in.cx()},
                                           {"cy", in.cy()},
                                           {"distortion", distortion},
                                           {"width", in.width()},
                                           {"height", in.height()}}},
                       {"references", references},
                       {"views", views},
                       {"points", points},
                       {"solved", s.solved()},
                       {"created_unix_ms", s.created_unix_ms()}});
  } else {
    ctx.out() << s.survey_id() << "  '" << s.name() << "'  " << s.references_size()
              << " reference lights\n";
    for (const auto& v : s.views()) {
      ctx.out() << "  view '" << v.name() << "': " << v.lights_size() << " lights, " << v.frames()
                << " frames, "
                << (v.posed() ? "posed (rms " + Fixed(v.reprojection_rms_px(), 3) + " px)"
                              : "not posed: " + v.pose_error())
                << "\n";
    }
    ctx.out() << "  " << s.points_size() << " solved points" << (s.solved() ? "" : " (not solved)")
              << "\n";
  }
  return kExitOk;
}

int RunDelete(CommandContext& ctx, const std::string& survey_id) {
  v1::DeleteSurveyRequest request;
  request.set_survey_id(survey_id);
  grpc::ClientContext context;
  ctx.Prepare(&context);
  v1::DeleteSurveyResponse response;
  ctx.Check(SurveyStub(ctx)->DeleteSurvey(&context, request, &response));
  if (ctx.json) {
    ctx.PrintJson(json{{"deleted", survey_id}});
  } else {
    ctx.out() << "deleted survey " << survey_id << "\n";
  }
  return kExitOk;
}

int RunExport(CommandContext& ctx, const ExportOptions& options) {
  v1::ExportPointsRequest request;
  request.set_survey_id(options.survey_id);
  if (options.format == "csv") {
    request.set_format(v1::ExportPointsRequest::CSV);
  } else if (options.format == "json") {
    request.set_format(v1::ExportPointsRequest::JSON);
  } else if (options.format == "ply") {
    request.set_format(v1::ExportPointsRequest::PLY);
  } else {
    throw UsageError("--format must be csv, json or ply");
  }
  grpc::ClientContext context;
  ctx.Prepare(&context);
  v1::ExportPointsResponse response;
  ctx.Check(SurveyStub(ctx)->ExportPoints(&context, request, &response));
  if (!options.out.empty()) {
    std::ofstream out(options.out, std::ios::binary);
    out << response.data();
    if (!out) throw CliError(kExitFailure, "cannot write '" + options.out + "'");
  }
  if (ctx.json) {
    json out{{"survey_id", options.survey_id},
             {"format", options.format},
             {"mime_type", response.mime_type()},
             {"bytes", response.data().size()}};
    if (options.out.empty()) {
      out["data"] = response.data();
    } else {
      out["out"] = options.out;
    }
    ctx.PrintJson(out);
  } else if (options.out.empty()) {
    ctx.out() << response.data();
  } else {
    ctx.out() << "wrote " << response.data().size() << " bytes to " << options.out << "\n";
  }
  return kExitOk;
}

int RunEncode(CommandContext& ctx, const EncodeOptions& options) {
  auto packet = lights::EncodeLightPacket(options.id);
  if (!packet.ok()) throw UsageError(std::string(packet.status().message()));
  std::string crc;
  const uint32_t c = lights::LightCrc3(options.id);
  for (int b = lights::kCrcBits - 1; b >= 0; --b) crc.push_back(((c >> b) & 1u) ? '1' : '0');
  std::string samples = lights::SamplesToString(*packet) + std::string(options.idle, '0');
  if (ctx.json) {
    ctx.PrintJson(json{{"id", options.id},
                       {"id_bits", lights::LightIdBits(options.id)},
                       {"crc_bits", crc},
                       {"idle_samples", options.idle},
                       {"samples", samples}});
  } else {
    ctx.out() << "id " << options.id << "  id bits " << lights::LightIdBits(options.id)
              << "  crc bits " << crc << "\n"
              << samples << "\n";
  }
  return kExitOk;
}

}  // namespace

std::map<uint32_t, cv::Point3d> ParseReferencesCsv(const std::string& text,
                                                   const std::string& path) {
  std::stringstream in(text);
  std::string line;
  int line_number = 0;
  int col_id = -1, col_x = -1, col_y = -1, col_z = -1;
  std::map<uint32_t, cv::Point3d> references;
  while (std::getline(in, line)) {
    ++line_number;
    const std::string trimmed = Trim(line);
    if (trimmed.empty() || trimmed[0] == '#') continue;
    const auto fields = SplitCsv(trimmed);
    const std::string where = path + ":" + std::to_string(line_number) + ": ";
    if (col_id < 0) {
      for (size_t i = 0; i < fields.size(); ++i) {
        std::string name = fields[i];
        std::transform(name.begin(), name.end(), name.begin(), ::tolower);
        if (name == "id") col_id = static_cast<int>(i);
        if (name == "x") col_x = static_cast<int>(i);
        if (name == "y") col_y = static_cast<int>(i);
        if (name == "z") col_z = static_cast<int>(i);
      }
      if (col_id < 0 || col_x < 0 || col_y < 0 || col_z < 0) {
        throw UsageError(where + "the first line must be the header id,x,y,z");
      }
      continue;
    }
    const int needed = std::max({col_id, col_x, col_y, col_z}) + 1;
    if (static_cast<int>(fields.size()) < needed) {
      throw UsageError(where + "expected id,x,y,z but found " + std::to_string(fields.size()) +
                       " fields");
    }
    double id = 0, x = 0, y = 0, z = 0;
    if (!ParseDouble(fields[col_id], &id) || id != std::floor(id) || id < 0 ||
        id > lights::kMaxLightId) {
      throw UsageError(where + "id '" + fields[col_id] + "' is not a light id 0.." +
                       std::to_string(lights::kMaxLightId));
    }
    if (!ParseDouble(fields[col_x], &x) || !ParseDouble(fields[col_y], &y) ||
        !ParseDouble(fields[col_z], &z)) {
      throw UsageError(where + "x, y, z must be numbers in metres");
    }
    if (!references.emplace(static_cast<uint32_t>(id), cv::Point3d(x, y, z)).second) {
      throw UsageError(where + "light " + fields[col_id] + " is listed twice");
    }
  }
  if (col_id < 0) throw UsageError(path + ": no header id,x,y,z");
  if (references.empty()) throw UsageError(path + ": no reference lights");
  return references;
}

std::vector<std::filesystem::path> BurstFrameFiles(const std::filesystem::path& folder) {
  std::error_code ec;
  if (!std::filesystem::is_directory(folder, ec)) {
    throw UsageError("'" + folder.string() + "' is not a folder of frames");
  }
  static const std::set<std::string> kExtensions = {".jpg", ".jpeg", ".png", ".tif", ".tiff"};
  std::vector<std::filesystem::path> files;
  for (const auto& entry : std::filesystem::directory_iterator(folder, ec)) {
    if (!entry.is_regular_file()) continue;
    std::string ext = entry.path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
    if (kExtensions.count(ext)) files.push_back(entry.path());
  }
  std::sort(files.begin(), files.end());
  if (files.empty()) {
    throw UsageError("'" + folder.string() + "' holds no JPEG, PNG or TIFF frames");
  }
  return files;
}

void AddSurveyCommands(CLI::App& app, CommandContext& ctx) {
  CLI::App* survey = app.add_subcommand(
      "survey", "Light photogrammetry: decode blinking-light bursts, pose views, triangulate");
  survey->require_subcommand(1);
  {
    auto options = std::make_shared<CreateOptions>();
    CLI::App* cmd = survey->add_subcommand("create", "Create a survey");
    cmd->add_option("--intrinsics", options->intrinsics, "CAMERA.yml (OpenCV calibration file)")
        ->required();
    cmd->add_option("--references", options->references,
                    "REFS.csv with header id,x,y,z: reference lights in metres")
        ->required();
    cmd->add_option("--name", options->name, "Name (default: the references file's stem)");
    cmd->callback(
        [&ctx, options] { ctx.action = [&ctx, options] { return RunCreate(ctx, *options); }; });
  }
  {
    auto options = std::make_shared<UploadOptions>();
    CLI::App* cmd = survey->add_subcommand("upload", "Upload one view's burst (100 frames)");
    cmd->add_option("SURVEY_ID", options->survey_id, "Survey id")->required();
    cmd->add_option("--view", options->view, "View name (re-uploading a name replaces it)")
        ->required();
    cmd->add_option("FOLDER", options->folder, "Folder of frames, in capture order by name")
        ->required();
    cmd->callback(
        [&ctx, options] { ctx.action = [&ctx, options] { return RunUpload(ctx, *options); }; });
  }
  {
    auto options = std::make_shared<SolveOptions>();
    CLI::App* cmd = survey->add_subcommand("solve", "Triangulate the lights seen in 2+ views");
    cmd->add_option("SURVEY_ID", options->survey_id, "Survey id")->required();
    cmd->add_option("--out", options->out, "Also write the points to this CSV file");
    cmd->add_flag("--bundle-adjustment", options->bundle_adjustment,
                  "Refine view poses and points together (references held fixed)");
    cmd->callback(
        [&ctx, options] { ctx.action = [&ctx, options] { return RunSolve(ctx, *options); }; });
  }
  {
    CLI::App* cmd = survey->add_subcommand("list", "List surveys");
    cmd->callback([&ctx] { ctx.action = [&ctx] { return RunList(ctx); }; });
  }
  {
    auto id = std::make_shared<std::string>();
    CLI::App* cmd = survey->add_subcommand("show", "Show a survey, its views and points");
    cmd->add_option("SURVEY_ID", *id, "Survey id")->required();
    cmd->callback([&ctx, id] { ctx.action = [&ctx, id] { return RunShow(ctx, *id); }; });
  }
  {
    auto id = std::make_shared<std::string>();
    CLI::App* cmd = survey->add_subcommand("delete", "Delete a survey with its views");
    cmd->add_option("SURVEY_ID", *id, "Survey id")->required();
    cmd->callback([&ctx, id] { ctx.action = [&ctx, id] { return RunDelete(ctx, *id); }; });
  }
  {
    auto options = std::make_shared<ExportOptions>();
    CLI::App* cmd = survey->add_subcommand("export", "Export the solved points");
    cmd->add_option("SURVEY_ID", options->survey_id, "Survey id")->required();
    cmd->add_option("--format", options->format, "csv, json or ply")->capture_default_str();
    cmd->add_option("--out", options->out, "Write to this file (default: stdout)");
    cmd->callback(
        [&ctx, options] { ctx.action = [&ctx, options] { return RunExport(ctx, *options); }; });
  }
  CLI::App* lights_group = app.add_subcommand("lights", "Blinking-light markers");
  lights_group->require_subcommand(1);
  {
    auto options = std::make_shared<EncodeOptions>();
    CLI::App* cmd = lights_group->add_subcommand(
        "encode", "Print the 48-sample packet an LED must blink for an ID");
    cmd->add_option("ID", options->id, "Light id 0..63")->required();
    cmd->add_option("--idle", options->idle, "Idle (off) samples after each packet, 0..4")
        ->check(CLI::Range(0, 4));
    cmd->callback(
        [&ctx, options] { ctx.action = [&ctx, options] { return RunEncode(ctx, *options); }; });
  }
}

}  // namespace texfree::client
