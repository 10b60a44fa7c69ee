// `texfree pool ...` commands on PoolService: analyze, track, profile, calibrate.
#include "client/pool_commands.h"

#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "client/camera_file.h"
#include "client/command_context.h"
#include "client/file_util.h"
#include "client/json_output.h"
#include "client/pool_overlay.h"
#include "client/proto_convert.h"
#include "texfree/v1/pool.grpc.pb.h"

namespace texfree::client {
namespace {

using nlohmann::json;

struct AnalyzeOptions {
  std::string image;
  std::string intrinsics;
  std::string table;
  std::string profile;
  std::string overlay;
  std::string topview;
  unsigned max_shots = 3;
};

struct TrackOptions {
  std::string input;
  std::string intrinsics;
  std::string table;
  std::string profile;
  std::string output;
  double fps = 30;
};

struct ProfileOptions {
  std::string table;
  std::string name;
};

struct CalibrateOptions {
  std::string image;
  std::string profile;
  std::string cloth;
  std::vector<std::string> balls;
};

std::unique_ptr<v1::PoolService::Stub> PoolStub(CommandContext& ctx) {
  return v1::PoolService::NewStub(ctx.Channel());
}

// "#rrggbb" or [r, g, b].
v1::Color ColourFromJson(const json& value, const std::string& what) {
  v1::Color c;
  c.set_a(255);
  if (value.is_string()) {
    const std::string s = value.get<std::string>();
    unsigned rgb = 0;
    if (s.size() != 7 || s[0] != '#' || std::sscanf(s.c_str() + 1, "%6x", &rgb) != 1)
      throw UsageError(what + ": colour must be \"#rrggbb\" or [r, g, b]");
    c.set_r((rgb >> 16) & 255);
    c.set_g((rgb >> 8) & 255);
    c.set_b(rgb & 255);
    return c;
  }
  if (value.is_array() && value.size() == 3) {
    for (const auto& v : value)
      if (!v.is_number_integer() || v.get<int>() < 0 || v.get<int>() > 255)
        throw UsageError(what + ": colour components must be integers 0..255");
    c.set_r(value[0].get<int>());
    c.set_g(value[1].get<int>());
    c.set_b(value[2].get<int>());
    return c;
  }
  throw UsageError(what + ": colour must be \"#rrggbb\" or [r, g, b]");
}

// TABLE.json -> TableProfile. Keys: length_mm, width_mm, ball_radius_mm,
// cushion_height_mm, cushion_width_mm, corner_pocket_mm, side_pocket_mm (numbers, mm),
// name, cloth_color, ball_colors {"0": colour, ... "9": colour}.
v1::TableProfile LoadTableFile(const std::string& path) {
  const std::string text = ReadInputFile(path, "table file");
  json doc;
  try {
    doc = json::parse(text);
  } catch (const json::exception& e) {
    throw UsageError(path + ": not valid JSON: " + e.what());
  }
  if (!doc.is_object()) throw UsageError(path + ": expected a JSON object");
  v1::TableProfile profile;
  auto number = [&](const char* key, void (v1::TableProfile::*set)(double)) {
    if (!doc.contains(key)) return;
    if (!doc[key].is_number() || doc[key].get<double>() <= 0)
      throw UsageError(path + ": \"" + key + "\" must be a positive number (millimetres)");
    (profile.*set)(doc[key].get<double>());
  };
  number("length_mm", &v1::TableProfile::set_length_mm);
  number("width_mm", &v1::TableProfile::set_width_mm);
  number("ball_radius_mm", &v1::TableProfile::set_ball_radius_mm);
  number("cushion_height_mm", &v1::TableProfile::set_cushion_height_mm);
  number("cushion_width_mm", &v1::TableProfile::set_cushion_width_mm);
  number("corner_pocket_mm", &v1::TableProfile::set_corner_pocket_mm);
  number("side_pocket_mm", &v1::TableProfile::set_side_pocket_mm);
  if (profile.length_mm() == 0 || profile.width_mm() == 0)
    throw UsageError(path + ": \"length_mm\" and \"width_mm\" are required");
  if (doc.contains("name")) {
    if (!doc["name"].is_string()) throw UsageError(path + ": \"name\" must be a string");
    profile.set_name(doc["name"].get<std::string>());
  }
  if (doc.contains("cloth_color"))
    *profile.mutable_cloth_color() = ColourFromJson(doc["cloth_color"], path + ": cloth_color");
  if (doc.contains("ball_colors")) {
    if (!doc["ball_colors"].is_object())
      throw UsageError(path + ": \"ball_colors\" must map \"0\"..\"9\" to colours");
    for (const auto& [key, value] : doc["ball_colors"].items()) {
      int n = -1;
      if (std::sscanf(key.c_str(), "%d", &n) != 1 || n < 0 || n > 9)
        throw UsageError(path + ": ball_colors key \"" + key + "\" is not 0..9");
      auto* bc = profile.add_ball_colors();
      bc->set_number(static_cast<uint32_t>(n));
      *bc->mutable_color() = ColourFromJson(value, path + ": ball_colors." + key);
    }
  }
  return profile;
}

json PathToJson(const google::protobuf::RepeatedPtrField<v1::Point2>& points) {
  json out = json::array();
  for (const auto& p : points) out.push_back(PointToJson(p));
  return out;
}

json ResponseToJson(const v1::AnalyzeTableResponse& r) {
  json corners = json::array();
  for (const auto& c : r.corners()) corners.push_back(PointToJson(c));
  json balls = json::array();
  for (const auto& b : r.balls())
    balls.push_back({{"number", b.number()},
                     {"u", b.u()},
                     {"v", b.v()},
                     {"x_mm", b.x_mm()},
                     {"y_mm", b.y_mm()},
                     {"confidence", b.confidence()}});
  json shots = json::array();
  static const char* kKinds[] = {"unspecified", "direct", "bank", "combination", "safety"};
  for (const auto& s : r.shots()) {
    json paths = json::array();
    json cue_path = json::array();
    for (const auto& p : s.paths()) {
      paths.push_back({{"number", p.number()},
                       {"path", PathToJson(p.path_mm())},
                       {"path_px", PathToJson(p.path_px())}});
      if (p.number() == 0) cue_path = PathToJson(p.path_mm());
    }
    shots.push_back({{"type", s.type() == v1::Shot::SAFETY ? "safety" : "pocket"},
                     {"kind", kKinds[std::clamp(static_cast<int>(s.kind()), 0, 4)]},
                     {"target_ball", s.target_ball()},
                     {"pocketed_ball", s.pocketed_ball()},
                     {"pocket", s.pocket()},
                     {"cue_direction_deg", s.cue_direction_deg()},
                     {"speed_mm_s", s.speed_mm_s()},
                     {"cut_angle_deg", s.cut_angle_deg()},
                     {"chance", s.chance()},
                     {"difficulty", s.difficulty()},
                     {"next_chance", s.next_chance()},
                     {"opponent_chance", s.opponent_chance()},
                     {"description", s.description()},
                     {"path", cue_path},
                     {"paths", paths}});
  }
  json timings = json::object();
  for (const auto& t : r.timings()) timings[t.stage()] = t.ms();
  json out = {
      {"corners", corners},          {"balls", balls},     {"shots", shots},
      {"server_ms", r.server_ms()},  {"timings", timings}, {"long_side_view", r.long_side_view()},
      {"pose", PoseToJson(r.pose())}};
  if (!r.shots_note().empty()) out["shots_note"] = r.shots_note();
  if (!r.profile_note().empty()) out["profile_note"] = r.profile_note();
  // How well the table and its balls fit the profile (AnalyzeTableResponse).
  out["rectangle_inconsistency"] = r.rectangle_inconsistency();
  out["ball_size_ratio"] = r.ball_size_ratio();
  return out;
}

void WriteImage(const std::string& path, const cv::Mat& image, const std::string& what) {
  bool written = false;
  try {
    written = cv::imwrite(path, image);
  } catch (const cv::Exception&) {
    written = false;
  }
  if (!written) throw CliError(kExitFailure, "cannot write " + what + " '" + path + "'");
}

void CheckWritableImage(const std::string& path, const std::string& option) {
  if (!path.empty() && !cv::haveImageWriter(path))
    throw UsageError(option + ": cannot write images of this type: '" + path +
                     "' (use .png or .jpg)");
}

// Fills the profile part of a request from --table / --profile.
void SetProfile(const std::string& table, const std::string& profile,
                v1::AnalyzeTableRequest* request) {
  if (!table.empty()) *request->mutable_profile() = LoadTableFile(table);
  request->set_profile_name(profile);
}

int RunAnalyze(CommandContext& ctx, const AnalyzeOptions& options) {
  std::string bytes = ReadInputFile(options.image, "image");
  const CameraFile camera = LoadCameraOrUsage(options.intrinsics);
  CheckWritableImage(options.overlay, "--overlay");
  CheckWritableImage(options.topview, "--topview");
  v1::AnalyzeTableRequest request;
  SetProfile(options.table, options.profile, &request);
  *request.mutable_intrinsics() = IntrinsicsToProto(camera);
  request.set_max_shots(options.max_shots);
  cv::Mat canvas;
  if (!options.overlay.empty()) {
    canvas = cv::imdecode(std::vector<uchar>(bytes.begin(), bytes.end()), cv::IMREAD_COLOR);
    if (canvas.empty())
      throw UsageError("cannot decode image '" + options.image + "' (JPEG, PNG, BMP, TIFF)");
  }
  request.mutable_image()->set_encoded(std::move(bytes));
  auto stub = PoolStub(ctx);
  grpc::ClientContext context;
  ctx.Prepare(&context);
  v1::AnalyzeTableResponse response;
  ctx.Check(stub->AnalyzeTable(&context, request, &response));

  if (!canvas.empty()) {
    DrawOverlays(canvas, response.overlays());
    WriteImage(options.overlay, canvas, "overlay");
  }
  if (!options.topview.empty()) {
    const v1::TableProfile& table = response.profile();
    const double length = table.length_mm() > 0 ? table.length_mm() : 2540;
    const double width = table.width_mm() > 0 ? table.width_mm() : 1270;
    const double radius = table.ball_radius_mm() > 0 ? table.ball_radius_mm() : 28.575;
    WriteImage(options.topview, RenderPoolTopView(response, length, width, radius), "top view");
  }
  if (ctx.json) {
    json out = ResponseToJson(response);
    if (!options.overlay.empty()) out["overlay"] = options.overlay;
    if (!options.topview.empty()) out["topview"] = options.topview;
    ctx.PrintJson(out);
    return kExitOk;
  }
  std::ostream& out = ctx.out();
  out << "table found (" << (response.long_side_view() ? "long" : "short")
      << " side view), corners";
  for (const auto& c : response.corners())
    out << " (" << std::fixed << std::setprecision(1) << c.x() << ", " << c.y() << ")";
  out << "\n";
  if (!response.profile_note().empty()) out << "note: " << response.profile_note() << "\n";
  out << response.balls_size() << " balls:\n";
  for (const auto& b : response.balls())
    out << "  "
        << (b.number() < 0    ? std::string("?")
            : b.number() == 0 ? std::string("cue")
                              : std::to_string(b.number()))
        << "  x " << std::setprecision(0) << b.x_mm() << " mm, y " << b.y_mm() << " mm\n";
  if (response.shots_size() == 0) out << "no shots: " << response.shots_note() << "\n";
  for (const auto& s : response.shots()) out << "  shot: " << s.description() << "\n";
  out << "server " << std::setprecision(1) << response.server_ms() << " ms\n";
  return kExitOk;
}

// Frames from a video file, a folder of images (sorted by name) or cam:N.
class FrameSource {
 public:
  explicit FrameSource(const std::string& input) {
    namespace fs = std::filesystem;
    std::error_code ec;
    if (input.rfind("cam:", 0) == 0) {
      int index = -1;
      if (std::sscanf(input.c_str() + 4, "%d", &index) != 1 || index < 0)
        throw UsageError("camera input must be cam:N with N >= 0");
      if (!capture_.open(index)) throw UsageError("cannot open camera " + input);
    } else if (fs::is_directory(input, ec)) {
      for (const auto& entry : fs::directory_iterator(input)) {
        if (!entry.is_regular_file()) continue;
        std::string ext = entry.path().extension().string();
        std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
        if (ext == ".png" || ext == ".jpg" || ext == ".jpeg" || ext == ".bmp" || ext == ".tif" ||
            ext == ".tiff")
          files_.push_back(entry.path().string());
      }
      std::sort(files_.begin(), files_.end());
      if (files_.empty()) throw UsageError("no images in folder '" + input + "'");
    } else if (fs::is_regular_file(input, ec)) {
      if (!capture_.open(input)) throw UsageError("cannot open video '" + input + "'");
    } else {
      throw UsageError("input '" + input + "' is not a video file, a folder or cam:N");
    }
  }
  bool Next(cv::Mat* frame) {
    if (!files_.empty()) {
      while (next_ < files_.size()) {
        *frame = cv::imread(files_[next_++], cv::IMREAD_COLOR);
        if (!frame->empty()) return true;
      }
      return false;
    }
    return capture_.read(*frame) && !frame->empty();
  }
  size_t count() const { return files_.size(); }

 private:
  cv::VideoCapture capture_;
  std::vector<std::string> files_;
  size_t next_ = 0;
};

int RunTrack(CommandContext& ctx, const TrackOptions& options) {
  const CameraFile camera = LoadCameraOrUsage(options.intrinsics);
  FrameSource source(options.input);
  v1::TrackTableRequest config;
  SetProfile(options.table, options.profile, config.mutable_config());
  *config.mutable_config()->mutable_intrinsics() = IntrinsicsToProto(camera);
  auto stub = PoolStub(ctx);
  grpc::ClientContext context;
  auto stream = stub->TrackTable(&context);
  if (!stream->Write(config)) ctx.Check(stream->Finish());
  cv::VideoWriter writer;
  const bool progress = !ctx.json && isatty(STDERR_FILENO);
  cv::Mat frame;
  int index = 0;
  std::vector<uchar> jpeg;
  bool noted = false;  // the profile note was printed
  while (source.Next(&frame)) {
    v1::TrackTableRequest message;
    cv::imencode(".jpg", frame, jpeg, {cv::IMWRITE_JPEG_QUALITY, 90});
    message.mutable_frame()->set_encoded(std::string(jpeg.begin(), jpeg.end()));
    if (!stream->Write(message)) break;
    v1::AnalyzeTableResponse response;
    if (!stream->Read(&response)) break;
    if (!options.output.empty()) {
      if (!writer.isOpened()) {
        writer.open(options.output, cv::VideoWriter::fourcc('m', 'p', '4', 'v'), options.fps,
                    frame.size());
        if (!writer.isOpened())
          throw CliError(kExitFailure, "cannot write video '" + options.output + "'");
      }
      DrawOverlays(frame, response.overlays());
      writer.write(frame);
    }
    if (!ctx.json && !noted && !response.profile_note().empty()) {
      // Once: every frame of the same table would say the same.
      ctx.err() << (progress ? "\n" : "") << "note: " << response.profile_note() << "\n";
      noted = true;
    }
    if (ctx.json) {
      json line = ResponseToJson(response);
      line["frame"] = index;
      line["state"] = response.state();
      if (!response.message().empty()) line["message"] = response.message();
      ctx.out() << line.dump() << "\n" << std::flush;
    } else if (progress) {
      ctx.err() << "\rframe " << index;
      if (source.count() > 0) ctx.err() << " / " << source.count();
      ctx.err() << "  " << response.state() << "  " << response.balls_size() << " balls  "
                << std::fixed << std::setprecision(1) << response.server_ms() << " ms   "
                << std::flush;
    }
    ++index;
  }
  stream->WritesDone();
  ctx.Check(stream->Finish());
  if (progress) ctx.err() << "\n";
  if (!ctx.json)
    ctx.out() << index << " frames"
              << (options.output.empty() ? "" : " written to " + options.output) << "\n";
  return kExitOk;
}

int RunProfileSet(CommandContext& ctx, const ProfileOptions& options) {
  v1::SetTableProfileRequest request;
  *request.mutable_profile() = LoadTableFile(options.table);
  if (!options.name.empty()) request.mutable_profile()->set_name(options.name);
  if (request.profile().name().empty())
    throw UsageError("give the profile a name: --name NAME or \"name\" in " + options.table);
  auto stub = PoolStub(ctx);
  grpc::ClientContext context;
  ctx.Prepare(&context);
  v1::TableProfile response;
  ctx.Check(stub->SetTableProfile(&context, request, &response));
  if (ctx.json) {
    ctx.PrintJson({{"name", response.name()},
                   {"length_mm", response.length_mm()},
                   {"width_mm", response.width_mm()},
                   {"ball_radius_mm", response.ball_radius_mm()},
                   {"cushion_height_mm", response.cushion_height_mm()},
                   {"cushion_width_mm", response.cushion_width_mm()},
                   {"cloth_color", ColorToJson(response.cloth_color())}});
  } else {
    ctx.out() << "profile '" << response.name() << "': " << response.length_mm() << " x "
              << response.width_mm() << " mm, ball radius " << response.ball_radius_mm() << " mm\n";
  }
  return kExitOk;
}

v1::Rect ParseRect(const std::string& text, const std::string& what) {
  double x, y, w, h;
  char extra;
  if (std::sscanf(text.c_str(), "%lf,%lf,%lf,%lf%c", &x, &y, &w, &h, &extra) != 4 || w <= 0 ||
      h <= 0)
    throw UsageError(what + ": expected X,Y,WIDTH,HEIGHT in pixels, got '" + text + "'");
  v1::Rect r;
  r.set_x(x);
  r.set_y(y);
  r.set_width(w);
  r.set_height(h);
  return r;
}

int RunCalibrate(CommandContext& ctx, const CalibrateOptions& options) {
  v1::CalibrateColorsRequest request;
  request.set_profile_name(options.profile);
  request.mutable_image()->set_encoded(ReadInputFile(options.image, "image"));
  *request.mutable_cloth_region() = ParseRect(options.cloth, "--cloth");
  for (const auto& ball : options.balls) {
    const size_t colon = ball.find(':');
    int number = -1;
    if (colon == std::string::npos || std::sscanf(ball.c_str(), "%d", &number) != 1 || number < 0 ||
        number > 9)
      throw UsageError("--ball: expected N:X,Y,WIDTH,HEIGHT with N = 0 (cue) .. 9, got '" + ball +
                       "'");
    auto* region = request.add_balls();
    region->set_number(static_cast<uint32_t>(number));
    *region->mutable_region() = ParseRect(ball.substr(colon + 1), "--ball " + ball);
  }
  auto stub = PoolStub(ctx);
  grpc::ClientContext context;
  ctx.Prepare(&context);
  v1::TableProfile response;
  ctx.Check(stub->CalibrateColors(&context, request, &response));
  json balls = json::object();
  for (const auto& bc : response.ball_colors())
    balls[std::to_string(bc.number())] = ColorToJson(bc.color());
  const json out = {{"name", response.name()},
                    {"cloth_color", ColorToJson(response.cloth_color())},
                    {"ball_colors", balls}};
  if (ctx.json) {
    ctx.PrintJson(out);
  } else {
    ctx.out() << out.dump(2) << "\n";
  }
  return kExitOk;
}

}  // namespace

void AddPoolCommands(CLI::App& app, CommandContext& ctx) {
  CLI::App* pool =
      app.add_subcommand("pool", "Pool assistant: find the table and the balls, suggest shots");
  pool->require_subcommand(1);
  {
    auto options = std::make_shared<AnalyzeOptions>();
    CLI::App* cmd = pool->add_subcommand(
        "analyze", "Table corners, ball numbers and positions (mm) and shot suggestions");
    cmd->add_option("IMAGE", options->image, "Photograph of the whole table")->required();
    cmd->add_option("--intrinsics", options->intrinsics, "CAMERA.yml (OpenCV calibration file)")
        ->required();
    cmd->add_option("--table", options->table,
                    "TABLE.json: {\"length_mm\", \"width_mm\", \"ball_radius_mm\", "
                    "\"cushion_height_mm\", ...} (default: a 9-ft table)");
    cmd->add_option("--profile", options->profile, "A table profile stored on the server");
    cmd->add_option("--overlay", options->overlay,
                    "Write the photograph with the table, balls and best shot drawn on it");
    cmd->add_option("--topview", options->topview, "Write a top view of the table and the shot");
    cmd->add_option("--max-shots", options->max_shots, "Shots to suggest (default 3)")
        ->check(CLI::Range(1, 20));
    cmd->callback(
        [&ctx, options] { ctx.action = [&ctx, options] { return RunAnalyze(ctx, *options); }; });
  }
  {
    auto options = std::make_shared<TrackOptions>();
    CLI::App* cmd =
        pool->add_subcommand("track", "Live view: the suggested shot drawn onto every frame");
    cmd->add_option("INPUT", options->input, "Video file, folder of images or cam:N")->required();
    cmd->add_option("--intrinsics", options->intrinsics, "CAMERA.yml (OpenCV calibration file)")
        ->required();
    cmd->add_option("--table", options->table, "TABLE.json (default: a 9-ft table)");
    cmd->add_option("--profile", options->profile, "A table profile stored on the server");
    cmd->add_option("--output", options->output, "Write the frames with the overlays (MP4)");
    cmd->add_option("--fps", options->fps, "Frame rate of --output")->check(CLI::PositiveNumber);
    cmd->callback(
        [&ctx, options] { ctx.action = [&ctx, options] { return RunTrack(ctx, *options); }; });
  }
  {
    auto options = std::make_shared<ProfileOptions>();
    CLI::App* cmd = pool->add_subcommand("profile", "Store a table profile on the server");
    cmd->add_option("TABLE", options->table, "TABLE.json")->required();
    cmd->add_option("--name", options->name, "Profile name (default: \"name\" in the file)");
    cmd->callback(
        [&ctx, options] { ctx.action = [&ctx, options] { return RunProfileSet(ctx, *options); }; });
  }
  {
    auto options = std::make_shared<CalibrateOptions>();
    CLI::App* cmd = pool->add_subcommand(
        "calibrate", "Learn the cloth and ball colours of a stored profile from a photograph");
    cmd->add_option("IMAGE", options->image, "Photograph of the table")->required();
    cmd->add_option("--profile", options->profile, "Stored profile to update")->required();
    cmd->add_option("--cloth", options->cloth, "X,Y,WIDTH,HEIGHT of a cloth region (pixels)")
        ->required();
    cmd->add_option("--ball", options->balls, "N:X,Y,WIDTH,HEIGHT around ball N (0 = cue)");
    cmd->callback(
        [&ctx, options] { ctx.action = [&ctx, options] { return RunCalibrate(ctx, *options); }; });
  }
}

}  // namespace texfree::client
