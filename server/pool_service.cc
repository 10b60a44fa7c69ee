// PoolService handlers: validate, convert, run the analyzer and the shot search, convert
// back with overlays.
#include "server/pool_service.h"

#include <algorithm>
#include <cmath>
#include <optional>

#include <opencv2/core.hpp>
#include <spdlog/spdlog.h>

#include "absl/strings/str_cat.h"
#include "common/pool_analyzer.h"
#include "common/pool_shots.h"
#include "common/status_macros.h"
#include "common/timing.h"
#include "server/proto_convert.h"

namespace texfree::server {
namespace {

grpc::Status Fail(const char* method, const absl::Status& status) {
  return LoggedFailure(method, status);
}

absl::StatusOr<cv::Vec3b> ColourFromProto(const v1::Color& c, const char* what) {
  if (c.r() > 255 || c.g() > 255 || c.b() > 255)
    return absl::InvalidArgumentError(absl::StrCat(what, " components must be in 0..255"));
  return cv::Vec3b(static_cast<uint8_t>(c.b()), static_cast<uint8_t>(c.g()),
                   static_cast<uint8_t>(c.r()));
}

void ColourToProto(const cv::Vec3b& bgr, v1::Color* out) {
  out->set_r(bgr[2]);
  out->set_g(bgr[1]);
  out->set_b(bgr[0]);
  out->set_a(255);
}

absl::Status CheckName(const std::string& name) {
  if (name.empty()) return absl::InvalidArgumentError("profile name is empty");
  if (name.size() > 64) return absl::InvalidArgumentError("profile name is over 64 characters");
  for (char c : name)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == '.'))
      return absl::InvalidArgumentError(
          absl::StrCat("profile name '", name, "' may only hold letters, digits, '-', '_', '.'"));
  return absl::OkStatus();
}

// A profile from its message: zero sizes take the 9-ft defaults, a cushion width of 0
// becomes 1.75 ball radii, unset colours keep the defaults.
absl::StatusOr<PoolTableProfile> ProfileFromProto(const v1::TableProfile& in) {
  PoolTableProfile p;
  p.name = in.name();
  auto size = [](double v, double fallback) { return v == 0 ? fallback : v; };
  p.length_mm = size(in.length_mm(), p.length_mm);
  p.width_mm = size(in.width_mm(), p.width_mm);
  const bool radius_given = in.ball_radius_mm() != 0;
  p.ball_radius_mm = size(in.ball_radius_mm(), p.ball_radius_mm);
  p.cushion_height_mm = size(in.cushion_height_mm(), radius_given ? 1.277 * p.ball_radius_mm
                                                                  : p.cushion_height_mm);
  p.cushion_width_mm = in.cushion_width_mm() == 0 ? 1.75 * p.ball_radius_mm : in.cushion_width_mm();
  p.corner_pocket_mm = size(in.corner_pocket_mm(),
                            radius_given ? 4.0 * p.ball_radius_mm : p.corner_pocket_mm);
  p.side_pocket_mm = size(in.side_pocket_mm(),
                          radius_given ? 4.5 * p.ball_radius_mm : p.side_pocket_mm);
  if (in.has_cloth_color()) {
    ASSIGN_OR_RETURN(p.cloth_bgr, ColourFromProto(in.cloth_color(), "cloth_color"));
  }
  for (const auto& bc : in.ball_colors()) {
    if (bc.number() >= static_cast<uint32_t>(kPoolBallCount))
      return absl::InvalidArgumentError(
          absl::StrCat("ball_colors: number ", bc.number(), " is not 0 (cue) .. 9"));
    ASSIGN_OR_RETURN(p.ball_bgr[bc.number()], ColourFromProto(bc.color(), "ball colour"));
  }
  if (absl::Status s = p.Validate(); !s.ok())
    return absl::InvalidArgumentError(absl::StrCat("table profile: ", s.message()));
  return p;
}

void ProfileToProto(const PoolTableProfile& p, v1::TableProfile* out) {
  out->set_name(p.name);
  out->set_length_mm(p.length_mm);
  out->set_width_mm(p.width_mm);
  out->set_ball_radius_mm(p.ball_radius_mm);
  out->set_cushion_height_mm(p.cushion_height_mm);
  out->set_cushion_width_mm(p.cushion_width_mm);
  out->set_corner_pocket_mm(p.corner_pocket_mm);
  out->set_side_pocket_mm(p.side_pocket_mm);
  ColourToProto(p.cloth_bgr, out->mutable_cloth_color());
  for (int i = 0; i < kPoolBallCount; ++i) {
    auto* bc = out->add_ball_colors();
    bc->set_number(i);
    ColourToProto(p.ball_bgr[i], bc->mutable_color());
  }
}

// The profile an analysis asks for: inline, stored by name, or the 9-ft default.
absl::StatusOr<PoolTableProfile> ResolveProfile(PoolProfileStore* store,
                                                const v1::AnalyzeTableRequest& request) {
  if (request.has_profile() && request.profile().length_mm() != 0)
    return ProfileFromProto(request.profile());
  if (request.profile_name().empty()) return NineFootPoolProfile();
  RETURN_IF_ERROR(CheckName(request.profile_name()));
  ASSIGN_OR_RETURN(auto stored, store->Get(request.profile_name()));
  if (!stored)
    return absl::NotFoundError(absl::StrCat("no table profile named '", request.profile_name(),
                                            "'; create it with SetTableProfile"));
  return *stored;
}

absl::StatusOr<CameraModel> RequiredCamera(const v1::CameraIntrinsics& intrinsics) {
  ASSIGN_OR_RETURN(auto camera, CameraFromProto(intrinsics));
  if (!camera)
    return absl::InvalidArgumentError(
        "camera intrinsics are required: ball positions in millimetres need the camera's focal "
        "length and principal point (texfree pool analyze --intrinsics CAMERA.yml)");
  return *camera;
}

void PointToProto(const cv::Point2d& p, v1::Point2* out) {
  out->set_x(p.x);
  out->set_y(p.y);
}

// Overlay colours (RGB) per ball number, the cue white.
cv::Vec3b BallOverlayRgb(int number) {
  static const cv::Vec3b kColours[] = {{255, 255, 255}, {255, 210, 0},   {40, 90, 255},
                                       {230, 30, 30},   {150, 60, 200},  {255, 130, 0},
                                       {0, 190, 80},    {150, 40, 40},   {30, 30, 30},
                                       {255, 230, 80}};
  return number >= 0 && number < 10 ? kColours[number] : cv::Vec3b(200, 200, 200);
}

void SetRgb(const cv::Vec3b& rgb, v1::Color* c) {
  c->set_r(rgb[0]);
  c->set_g(rgb[1]);
  c->set_b(rgb[2]);
  c->set_a(255);
}

// Fills the response from an analysis and shots: corners, balls, pose, shots with their
// paths in the image, overlays (table outline, balls, the best shot's paths).
void FillResponse(const PoolAnalyzer& analyzer, const PoolAnalysis& analysis,
                  const std::vector<PoolShot>& shots, v1::AnalyzeTableResponse* out) {
  const double r = analyzer.profile().ball_radius_mm;
  for (const auto& c : analysis.cloth_corners) PointToProto(c, out->add_corners());
  for (const auto& b : analysis.balls) {
    auto* ball = out->add_balls();
    ball->set_number(b.number);
    ball->set_u(b.pixel.x);
    ball->set_v(b.pixel.y);
    ball->set_x_mm(b.x_mm);
    ball->set_y_mm(b.y_mm);
    ball->set_confidence(b.confidence);
  }
  PoseToProto(analysis.pose, out->mutable_pose());
  out->set_long_side_view(analysis.long_side_view);
  out->set_profile_note(analysis.profile_note);
  out->set_ball_size_ratio(analysis.ball_size_ratio);
  out->set_rectangle_inconsistency(analysis.rectangle_inconsistency);
  ColourToProto(analysis.cloth_bgr, out->mutable_cloth_color());
  for (const auto& s : shots) {
    auto* shot = out->add_shots();
    shot->set_type(s.type == PoolShot::Type::kPocket ? v1::Shot::POCKET : v1::Shot::SAFETY);
    switch (s.kind) {
      case PoolShot::Kind::kDirect: shot->set_kind(v1::Shot::DIRECT); break;
      case PoolShot::Kind::kBank: shot->set_kind(v1::Shot::BANK); break;
      case PoolShot::Kind::kCombination: shot->set_kind(v1::Shot::COMBINATION); break;
      case PoolShot::Kind::kSafety: shot->set_kind(v1::Shot::SAFETY_PLAY); break;
    }
    shot->set_target_ball(s.target_ball);
    shot->set_pocketed_ball(s.pocketed_ball);
    shot->set_pocket(s.pocket);
    shot->set_cue_direction_deg(s.cue_direction_deg);
    shot->set_speed_mm_s(s.speed_mm_s);
    shot->set_cut_angle_deg(s.cut_angle_deg);
    shot->set_chance(s.chance);
    shot->set_next_chance(s.next_chance);
    shot->set_opponent_chance(s.opponent_chance);
    shot->set_difficulty(s.difficulty);
    shot->set_description(s.Describe());
    for (const auto& path : s.paths) {
      auto* p = shot->add_paths();
      p->set_number(path.number);
      for (const auto& q : path.points_mm) {
        PointToProto(q, p->add_path_mm());
        PointToProto(analyzer.Project(analysis.pose, {q.x, q.y, r}), p->add_path_px());
      }
    }
  }
  // Overlays: the table outline, each ball, the best shot's paths (cue ball first).
  auto* outline = out->add_overlays();
  outline->set_kind(v1::Overlay::POLYGON);
  for (const auto& c : analysis.cloth_corners) PointToProto(c, outline->add_points());
  SetRgb({240, 240, 240}, outline->mutable_color());
  outline->set_opacity(0.8);
  outline->set_thickness(2);
  for (const auto& b : analysis.balls) {
    auto* circle = out->add_overlays();
    circle->set_kind(v1::Overlay::CIRCLE);
    PointToProto(b.pixel, circle->add_points());
    circle->set_radius(b.radius_px + 2);
    SetRgb(BallOverlayRgb(b.number), circle->mutable_color());
    circle->set_opacity(1);
    circle->set_thickness(2);
    auto* label = out->add_overlays();
    label->set_kind(v1::Overlay::TEXT);
    PointToProto(b.pixel + cv::Point2d(b.radius_px + 3, -b.radius_px - 3), label->add_points());
    PointToProto(b.pixel + cv::Point2d(b.radius_px + 13, -b.radius_px - 3), label->add_points());
    label->set_text(b.number < 0 ? "?" : (b.number == 0 ? "cue" : std::to_string(b.number)));
    label->set_font_size_px(std::max(10.0, 1.6 * b.radius_px));
    SetRgb({255, 255, 255}, label->mutable_color());
    label->set_opacity(1);
  }
  if (!shots.empty()) {
    for (const auto& path : shots.front().paths) {
      auto* line = out->add_overlays();
      line->set_kind(v1::Overlay::POLYLINE);
      for (const auto& q : path.points_mm)
        PointToProto(analyzer.Project(analysis.pose, {q.x, q.y, r}), line->add_points());
      SetRgb(path.number == 0 ? cv::Vec3b(255, 255, 255) : BallOverlayRgb(path.number),
             line->mutable_color());
      line->set_opacity(0.9);
      line->set_thickness(path.number == 0 ? 2 : 3);
    }
  }
  for (const auto& [stage, ms] : analysis.timings_ms) {
    auto* t = out->add_timings();
    t->set_stage(stage);
    t->set_ms(ms);
  }
}

std::vector<PoolBallOnTable> OnTable(const std::vector<PoolBall>& balls) {
  std::vector<PoolBallOnTable> out;
  for (const auto& b : balls) out.push_back({b.number, b.x_mm, b.y_mm});
  return out;
}

// Shots for an analysis; an arrangement without a cue ball or object ball gives a note,
// not an error.
std::vector<PoolShot> Shots(const PoolTableProfile& profile, const PoolAnalysis& analysis,
                            int max_shots, std::string* note, double* ms) {
  const auto t0 = SteadyClock::now();
  PoolShotOptions options;
  options.max_shots = max_shots;
  auto shots = SuggestPoolShots(profile, OnTable(analysis.balls), options);
  *ms = MillisecondsSince(t0);
  if (!shots.ok()) {
    *note = std::string(shots.status().message());
    return {};
  }
  if (shots->empty()) *note = "no legal shot found (every path is blocked)";
  return *std::move(shots);
}

// Has the arrangement changed since the reference (a ball moved, appeared or went)?
bool ArrangementChanged(const std::vector<PoolBall>& now, const std::vector<PoolBall>& reference,
                        double radius) {
  // Mean distance to the same ball before: a ball missed in one frame changes little, a
  // ball that moved or a new ball changes much.
  if (now.empty()) return !reference.empty();
  return ArrangementDistance(now, reference, 10 * radius) > 1.5 * radius * now.size();
}

}  // namespace

grpc::Status PoolServiceImpl::SetTableProfile(grpc::ServerContext*,
                                              const v1::SetTableProfileRequest* request,
                                              v1::TableProfile* response) {
  if (auto s = CheckName(request->profile().name()); !s.ok()) return Fail("SetTableProfile", s);
  auto profile = ProfileFromProto(request->profile());
  if (!profile.ok()) return Fail("SetTableProfile", profile.status());
  if (auto s = store_->Put(*profile); !s.ok()) return Fail("SetTableProfile", s);
  spdlog::info("SetTableProfile: '{}' {} x {} mm, ball radius {} mm", profile->name,
               profile->length_mm, profile->width_mm, profile->ball_radius_mm);
  ProfileToProto(*profile, response);
  return grpc::Status::OK;
}

grpc::Status PoolServiceImpl::CalibrateColors(grpc::ServerContext*,
                                              const v1::CalibrateColorsRequest* request,
                                              v1::TableProfile* response) {
  if (auto s = CheckName(request->profile_name()); !s.ok()) return Fail("CalibrateColors", s);
  auto stored = store_->Get(request->profile_name());
  if (!stored.ok()) return Fail("CalibrateColors", stored.status());
  if (!*stored)
    return Fail("CalibrateColors",
                absl::NotFoundError(absl::StrCat("no table profile named '",
                                                 request->profile_name(),
                                                 "'; create it with SetTableProfile first")));
  auto image = ImageFromProto(request->image(), limits_, /*gray=*/false);
  if (!image.ok()) return Fail("CalibrateColors", image.status());
  auto rect = [](const v1::Rect& r) {
    return cv::Rect(static_cast<int>(std::lround(r.x())), static_cast<int>(std::lround(r.y())),
                    static_cast<int>(std::lround(r.width())),
                    static_cast<int>(std::lround(r.height())));
  };
  std::vector<std::pair<int, cv::Rect>> balls;
  for (const auto& b : request->balls()) balls.emplace_back(b.number(), rect(b.region()));
  auto calibrated = CalibratePoolColors(*image, rect(request->cloth_region()), balls, **stored);
  if (!calibrated.ok()) return Fail("CalibrateColors", calibrated.status());
  if (auto s = store_->Put(*calibrated); !s.ok()) return Fail("CalibrateColors", s);
  spdlog::info("CalibrateColors: '{}' cloth BGR {},{},{}, {} balls", calibrated->name,
               calibrated->cloth_bgr[0], calibrated->cloth_bgr[1], calibrated->cloth_bgr[2],
               balls.size());
  ProfileToProto(*calibrated, response);
  return grpc::Status::OK;
}

grpc::Status PoolServiceImpl::AnalyzeTable(grpc::ServerContext*,
                                           const v1::AnalyzeTableRequest* request,
                                           v1::AnalyzeTableResponse* response) {
  const auto t0 = SteadyClock::now();
  auto image = ImageFromProto(request->image(), limits_, /*gray=*/false);
  if (!image.ok()) return Fail("AnalyzeTable", image.status());
  const double decode_ms = MillisecondsSince(t0);
  auto camera = RequiredCamera(request->intrinsics());
  if (!camera.ok()) return Fail("AnalyzeTable", camera.status());
  auto profile = ResolveProfile(store_, *request);
  if (!profile.ok()) return Fail("AnalyzeTable", profile.status());
  auto analyzer = PoolAnalyzer::Create(*profile, *camera);
  if (!analyzer.ok()) return Fail("AnalyzeTable", analyzer.status());
  absl::StatusOr<PoolAnalysis> analysis;
  try {
    analysis = analyzer->Analyze(*image);
  } catch (const cv::Exception& e) {
    analysis = absl::InternalError(absl::StrCat("image analysis failed: ", e.what()));
  }
  if (!analysis.ok()) return Fail("AnalyzeTable", analysis.status());
  const cv::Vec3b& seen = analysis->cloth_bgr;
  const cv::Vec3b& told = profile->cloth_bgr;
  if (analysis->cloth_not_profile_colour)
    spdlog::info(
        "AnalyzeTable: the table's cloth (BGR {},{},{}) is not the profile's colour (BGR {},{},{}); "
        "it was found among the image's own colours: set the profile's cloth_color to skip "
        "that search",
        seen[0], seen[1], seen[2], told[0], told[1], told[2]);
  const cv::Vec3f& gains = analysis->light_gains;
  if (gains != cv::Vec3f(1, 1, 1))
    spdlog::info(
        "AnalyzeTable: the light is coloured (the cue's white and the cloth agree); the balls "
        "were read white-balanced, BGR gains {:.2f},{:.2f},{:.2f} (CalibrateColors under this "
        "light makes the profile's colours the light's own)",
        gains[0], gains[1], gains[2]);
  if (!analysis->profile_note.empty()) spdlog::warn("AnalyzeTable: {}", analysis->profile_note);
  std::vector<PoolShot> shots;
  std::string note;
  double shots_ms = 0;
  if (!request->skip_shots()) {
    const int max_shots = request->max_shots() == 0 ? 3 : static_cast<int>(std::min(20u, request->max_shots()));
    shots = Shots(*profile, *analysis, max_shots, &note, &shots_ms);
    analysis->timings_ms.emplace_back("shots", shots_ms);
  }
  analysis->timings_ms.insert(analysis->timings_ms.begin(), {"decode", decode_ms});
  FillResponse(*analyzer, *analysis, shots, response);
  ProfileToProto(*profile, response->mutable_profile());
  response->set_shots_note(note);
  response->set_state("analysed");
  response->set_server_ms(MillisecondsSince(t0));
  spdlog::info("AnalyzeTable: {}x{}, {} balls, {} shots, {:.1f} ms (shots {:.1f} ms)",
               image->cols, image->rows, analysis->balls.size(), shots.size(),
               response->server_ms(), shots_ms);
  return grpc::Status::OK;
}

grpc::Status PoolServiceImpl::TrackTable(
    grpc::ServerContext* context,
    grpc::ServerReaderWriter<v1::AnalyzeTableResponse, v1::TrackTableRequest>* stream) {
  v1::TrackTableRequest first;
  if (!stream->Read(&first)) return grpc::Status::OK;
  if (first.message_case() != v1::TrackTableRequest::kConfig)
    return Fail("TrackTable", absl::InvalidArgumentError(
                                  "the first TrackTable message must be the config (intrinsics, "
                                  "profile), frames follow"));
  const v1::AnalyzeTableRequest& config = first.config();
  auto camera = RequiredCamera(config.intrinsics());
  if (!camera.ok()) return Fail("TrackTable", camera.status());
  auto profile = ResolveProfile(store_, config);
  if (!profile.ok()) return Fail("TrackTable", profile.status());
  PoolAnalyzerOptions live;
  if (live_pixels_ > 0) live.max_working_pixels = live_pixels_;
  auto analyzer = PoolAnalyzer::Create(*profile, *camera, live);
  if (!analyzer.ok()) return Fail("TrackTable", analyzer.status());
  const int max_shots = config.max_shots() == 0 ? 3 : static_cast<int>(std::min(20u, config.max_shots()));
  spdlog::info("TrackTable: stream started, table {} x {} mm, frames analysed at most {} pixels",
               profile->length_mm, profile->width_mm, live.max_working_pixels);
  // The arrangement found by the last full analysis and the shots computed for it.
  std::vector<PoolBall> reference;
  std::vector<PoolShot> shots;
  std::string note;
  uint32_t frame = 0;
  v1::TrackTableRequest request;
  while (!context->IsCancelled() && stream->Read(&request)) {
    const auto t0 = SteadyClock::now();
    v1::AnalyzeTableResponse response;
    response.set_frame(frame++);
    if (request.message_case() != v1::TrackTableRequest::kFrame) {
      response.set_state("lost");
      response.set_message("expected a frame; the config comes only first");
    } else {
      auto image = ImageFromProto(request.frame(), limits_, /*gray=*/false);
      absl::StatusOr<PoolAnalysis> analysis =
          image.ok() ? absl::StatusOr<PoolAnalysis>(absl::UnknownError("not analysed"))
                     : absl::StatusOr<PoolAnalysis>(image.status());
      if (image.ok()) {
        try {
          analysis = analyzer->Analyze(*image, reference.empty() ? nullptr : &reference);
        } catch (const cv::Exception& e) {
          analysis = absl::InternalError(absl::StrCat("image analysis failed: ", e.what()));
        }
      }
      if (!analysis.ok()) {
        response.set_state("lost");
        response.set_message(std::string(analysis.status().message()));
      } else {
        bool fresh = reference.empty() ||
                     ArrangementChanged(analysis->balls, reference, profile->ball_radius_mm);
        if (fresh) {
          // A new arrangement (first frame, or balls moved): new reference and shots, in
          // this frame's table frame.
          double shots_ms = 0;
          note.clear();
          shots = config.skip_shots() ? std::vector<PoolShot>()
                                      : Shots(*profile, *analysis, max_shots, &note, &shots_ms);
          analysis->timings_ms.emplace_back("shots", shots_ms);
          reference = analysis->balls;
        }
        FillResponse(*analyzer, *analysis, shots, &response);
        ProfileToProto(*profile, response.mutable_profile());
        response.set_shots_note(note);
        response.set_state(fresh ? "analysed" : "tracked");
      }
    }
    response.set_server_ms(MillisecondsSince(t0));
    if (!stream->Write(response)) break;
  }
  spdlog::info("TrackTable: stream ended after {} frames", frame);
  return grpc::Status::OK;
}

}  // namespace texfree::server
