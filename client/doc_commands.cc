// `texfree doc ...` commands on DocumentService.
#include "client/doc_commands.h"

#include <CLI/CLI.hpp>
#include <filesystem>
#include <iomanip>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "client/annotations_json.h"
#include "client/camera_file.h"
#include "client/command_context.h"
#include "client/file_util.h"
#include "client/json_output.h"
#include "client/overlay_renderer.h"
#include "client/proto_convert.h"
#include "texfree/v1/document.grpc.pb.h"

namespace texfree::client {
namespace {

using nlohmann::json;

struct RegisterOptions {
  std::string image;
  std::string title;
  std::string annotations;
};

struct RetrieveOptions {
  std::string image;
  std::string intrinsics;
  bool undistort = false;
  std::string overlay;
  unsigned max_results = 0;
};

struct IdOptions {
  std::string document_id;
  std::string annotation_id;
  std::string annotations;
};

std::unique_ptr<v1::DocumentService::Stub> DocumentStub(CommandContext& ctx) {
  return v1::DocumentService::NewStub(ctx.Channel());
}

std::vector<PageAnnotation> LoadAnnotationsOrUsage(const std::string& path) {
  try {
    return LoadAnnotationsFile(path);
  } catch (const AnnotationsError& e) {
    throw UsageError(e.what());
  }
}

std::string Ms(double ms) {
  std::ostringstream text;
  text << std::fixed << std::setprecision(1) << ms << " ms";
  return text.str();
}

std::string Quoted(const std::string& text) { return "'" + text + "'"; }

// One line describing an annotation, for readable output.
std::string Describe(const v1::Annotation& annotation) {
  std::ostringstream text;
  text << (annotation.annotation_id().empty() ? "-"
                                              : annotation.annotation_id())
       << "  ";
  auto rect = [&text](const v1::Rect& r) {
    text << r.width() << "x" << r.height() << " at (" << r.x() << ", " << r.y()
         << ")";
  };
  switch (annotation.kind_case()) {
    case v1::Annotation::kText:
      text << "text " << Quoted(annotation.text().text()) << " at ("
           << annotation.text().position().x() << ", "
           << annotation.text().position().y() << "), "
           << annotation.text().font_size_px() << " px";
      break;
    case v1::Annotation::kHighlight:
      text << "highlight ";
      rect(annotation.highlight().rect());
      text << ", opacity " << annotation.highlight().opacity();
      break;
    case v1::Annotation::kLink:
      text << "link ";
      rect(annotation.link().rect());
      text << " -> " << annotation.link().url();
      break;
    case v1::Annotation::kMedia:
      text << "media ";
      rect(annotation.media().rect());
      text << ", " << annotation.media().mime_type();
      if (annotation.media().source_case() == v1::MediaAnnotation::kUri) {
        text << " " << annotation.media().uri();
      } else {
        text << " (" << annotation.media().data().size() << " bytes inline)";
      }
      break;
    case v1::Annotation::KIND_NOT_SET:
      text << "(empty)";
      break;
  }
  return text.str();
}

int RunRegister(CommandContext& ctx, const RegisterOptions& options) {
  // Everything local is checked before the server is contacted.
  std::string bytes = ReadInputFile(options.image, "image");
  std::vector<PageAnnotation> annotations;
  if (!options.annotations.empty())
    annotations = LoadAnnotationsOrUsage(options.annotations);
  std::string title = options.title;
  if (title.empty())
    title = std::filesystem::path(options.image).stem().string();

  v1::RegisterDocumentRequest request;
  request.mutable_image()->set_encoded(std::move(bytes));
  request.set_title(title);
  for (const auto& annotation : annotations) {
    *request.add_annotations() = AnnotationToProto(annotation);
  }
  auto stub = DocumentStub(ctx);
  grpc::ClientContext context;
  ctx.Prepare(&context);
  v1::RegisterDocumentResponse response;
  ctx.Check(stub->RegisterDocument(&context, request, &response));

  const v1::Document& document = response.document();
  if (ctx.json) {
    json out = DocumentToJson(document, false);
    out["annotation_count"] = document.annotations_size();
    out["server_ms"] = response.server_ms();
    ctx.PrintJson(out);
  } else {
    ctx.out() << "registered " << Quoted(document.title()) << " as "
              << document.document_id() << " (" << document.keypoints()
              << " keypoints, " << document.width() << "x" << document.height()
              << ", " << document.annotations_size() << " annotations) in "
              << Ms(response.server_ms()) << "\n";
  }
  return kExitOk;
}

int RunRetrieve(CommandContext& ctx, const RetrieveOptions& options) {
  std::string bytes = ReadInputFile(options.image, "image");
  std::optional<CameraFile> camera = LoadIntrinsicsOption(options.intrinsics, options.undistort);
  cv::Mat canvas;
  if (!options.overlay.empty() && !cv::haveImageWriter(options.overlay)) {
    throw UsageError("--overlay: cannot write images of this type: '" + options.overlay +
                     "' (use .png or .jpg)");
  }
  if (!options.overlay.empty() || options.undistort) {
    std::vector<uchar> buffer(bytes.begin(), bytes.end());
    canvas = cv::imdecode(buffer, cv::IMREAD_COLOR);
    if (canvas.empty()) {
      throw UsageError("cannot decode image '" + options.image +
                       "' (JPEG, PNG, BMP, TIFF)");
    }
  }
  if (options.undistort) {
    // The ideal pinhole's picture is what the server sees and what the overlay is drawn on.
    FrameUndistorter undistorter(*camera);
    try {
      canvas = undistorter.Apply(canvas);
    } catch (const CameraFileError& e) {
      throw UsageError(std::string("--undistort: ") + e.what());
    }
    camera = undistorter.ideal();
    std::vector<uchar> png;
    cv::imencode(".png", canvas, png);
    bytes.assign(png.begin(), png.end());
  }
  if (options.overlay.empty()) canvas.release();

  v1::RetrieveDocumentsRequest request;
  request.mutable_image()->set_encoded(std::move(bytes));
  if (camera) *request.mutable_intrinsics() = IntrinsicsToProto(*camera);
  request.set_max_results(options.max_results);
  auto stub = DocumentStub(ctx);
  grpc::ClientContext context;
  ctx.Prepare(&context);
  v1::RetrieveDocumentsResponse response;
  ctx.Check(stub->RetrieveDocuments(&context, request, &response));

  if (!canvas.empty()) {
    OverlayRenderer renderer;
    for (int i = 0; i < response.matches_size(); ++i) {
      const v1::DocumentMatch& match = response.matches(i);
      OverlayPage page;
      if (!OverlayPageFromMatch(match, &page)) continue;
      if (page.page_size.area() <= 0 && match.outline_size() == 4) {
        // No page size: draw the outline the server computed.
        std::vector<cv::Point> outline;
        for (const auto& p : match.outline())
          outline.emplace_back(cvRound(p.x()), cvRound(p.y()));
        cv::polylines(canvas, outline, true, OverlayRenderer::PaletteColor(i),
                      3, cv::LINE_AA);
      }
      renderer.DrawPage(canvas, page, i);
    }
    bool written = false;
    try {
      written = cv::imwrite(options.overlay, canvas);
    } catch (const cv::Exception& e) {
      written = false;
    }
    if (!written)
      throw CliError(kExitFailure,
                     "cannot write overlay '" + options.overlay + "'");
  }

  if (ctx.json) {
    json out = RetrieveResponseToJson(response);
    if (!options.overlay.empty()) out["overlay"] = options.overlay;
    ctx.PrintJson(out);
    return kExitOk;
  }
  std::ostream& out = ctx.out();
  out << response.matches_size()
      << (response.matches_size() == 1 ? " match" : " matches") << " ("
      << response.query_keypoints() << " query keypoints, server "
      << Ms(response.server_ms()) << ")\n";
  for (const auto& match : response.matches()) {
    out << "  " << match.document_id() << "  " << Quoted(match.title())
        << "  inliers " << match.inliers() << ", votes " << match.votes()
        << "\n";
    out << "    homography:";
    for (double h : match.homography().h())
      out << " " << std::setprecision(6) << h;
    out << "\n";
    if (match.has_pose()) {
      out << "    translation:";
      for (double t : match.pose().translation())
        out << " " << std::setprecision(6) << t;
      out << "\n";
    }
    if (match.annotations_size() > 0) {
      out << "    " << match.annotations_size() << " annotations\n";
    }
  }
  if (!options.overlay.empty())
    out << "overlay written to " << options.overlay << "\n";
  return kExitOk;
}

int RunDelete(CommandContext& ctx, const IdOptions& options) {
  v1::DeleteDocumentRequest request;
  request.set_document_id(options.document_id);
  auto stub = DocumentStub(ctx);
  grpc::ClientContext context;
  ctx.Prepare(&context);
  v1::DeleteDocumentResponse response;
  ctx.Check(stub->DeleteDocument(&context, request, &response));
  std::string deleted = response.document_id().empty() ? options.document_id
                                                       : response.document_id();
  if (ctx.json) {
    ctx.PrintJson(
        json{{"deleted", deleted}, {"server_ms", response.server_ms()}});
  } else {
    ctx.out() << "deleted " << deleted << "\n";
  }
  return kExitOk;
}

int RunList(CommandContext& ctx) {
  auto stub = DocumentStub(ctx);
  std::vector<v1::Document> documents;
  std::set<std::string> seen_tokens;
  std::string token;
  uint32_t total = 0;
  do {
    v1::ListDocumentsRequest request;
    request.set_page_token(token);
    grpc::ClientContext context;
    ctx.Prepare(&context);
    v1::ListDocumentsResponse response;
    ctx.Check(stub->ListDocuments(&context, request, &response));
    for (const auto& document : response.documents())
      documents.push_back(document);
    total = response.total();
    token = response.next_page_token();
    // A token seen before would loop forever: stop.
    if (!token.empty() && !seen_tokens.insert(token).second) break;
  } while (!token.empty());

  if (ctx.json) {
    json list = json::array();
    for (const auto& document : documents)
      list.push_back(DocumentToJson(document, false));
    ctx.PrintJson(json{{"documents", list},
                       {"total", std::max<uint64_t>(total, documents.size())}});
    return kExitOk;
  }
  std::ostream& out = ctx.out();
  if (documents.empty()) {
    out << "no documents\n";
    return kExitOk;
  }
  size_t id_width = 11;
  for (const auto& document : documents) {
    id_width = std::max(id_width, document.document_id().size());
  }
  out << std::left << std::setw(static_cast<int>(id_width) + 2) << "DOCUMENT_ID"
      << std::right << std::setw(9) << "KEYPOINTS"
      << "  " << std::setw(11) << "SIZE"
      << "  TITLE\n";
  for (const auto& document : documents) {
    std::string size = std::to_string(document.width()) + "x" +
                       std::to_string(document.height());
    out << std::left << std::setw(static_cast<int>(id_width) + 2)
        << document.document_id() << std::right << std::setw(9)
        << document.keypoints() << "  " << std::setw(11) << size << "  "
        << document.title() << "\n";
  }
  out << documents.size()
      << (documents.size() == 1 ? " document\n" : " documents\n");
  return kExitOk;
}

int RunShow(CommandContext& ctx, const IdOptions& options) {
  v1::GetDocumentRequest request;
  request.set_document_id(options.document_id);
  auto stub = DocumentStub(ctx);
  grpc::ClientContext context;
  ctx.Prepare(&context);
  v1::Document document;
  ctx.Check(stub->GetDocument(&context, request, &document));
  if (ctx.json) {
    ctx.PrintJson(DocumentToJson(document, true));
    return kExitOk;
  }
  std::ostream& out = ctx.out();
  out << document.document_id() << "  " << Quoted(document.title()) << "\n"
      << "  size " << document.width() << "x" << document.height() << ", "
      << document.keypoints() << " keypoints\n"
      << "  " << document.annotations_size() << " annotations\n";
  for (const auto& annotation : document.annotations()) {
    out << "    " << Describe(annotation) << "\n";
  }
  return kExitOk;
}

int RunAnnotate(CommandContext& ctx, const IdOptions& options) {
  std::vector<PageAnnotation> annotations =
      LoadAnnotationsOrUsage(options.annotations);
  if (annotations.empty())
    throw UsageError(options.annotations + ": no annotations");
  auto stub = DocumentStub(ctx);
  json added = json::array();
  for (size_t i = 0; i < annotations.size(); ++i) {
    v1::AddAnnotationRequest request;
    request.set_document_id(options.document_id);
    PageAnnotation annotation = annotations[i];
    annotation.annotation_id.clear();  // assigned by the server
    *request.mutable_annotation() = AnnotationToProto(annotation);
    grpc::ClientContext context;
    ctx.Prepare(&context);
    v1::Annotation response;
    grpc::Status status = stub->AddAnnotation(&context, request, &response);
    if (!status.ok()) {
      try {
        ctx.Check(status);
      } catch (const CliError& e) {
        throw CliError(e.exit_code(), std::string(e.what()) + " (annotations[" +
                                          std::to_string(i) + "]; " +
                                          std::to_string(i) + " of " +
                                          std::to_string(annotations.size()) +
                                          " were added)");
      }
    }
    added.push_back(AnnotationToJson(response));
    if (!ctx.json) ctx.out() << "added " << Describe(response) << "\n";
  }
  if (ctx.json)
    ctx.PrintJson(json{{"document_id", options.document_id}, {"added", added}});
  return kExitOk;
}

int RunDeleteAnnotation(CommandContext& ctx, const IdOptions& options) {
  v1::DeleteAnnotationRequest request;
  request.set_document_id(options.document_id);
  request.set_annotation_id(options.annotation_id);
  auto stub = DocumentStub(ctx);
  grpc::ClientContext context;
  ctx.Prepare(&context);
  v1::DeleteAnnotationResponse response;
  ctx.Check(stub->DeleteAnnotation(&context, request, &response));
  std::string deleted = response.annotation_id().empty()
                            ? options.annotation_id
                            : response.annotation_id();
  if (ctx.json) {
    ctx.PrintJson(json{{"document_id", options.document_id},
                       {"deleted_annotation", deleted}});
  } else {
    ctx.out() << "deleted annotation " << deleted << " of "
              << options.document_id << "\n";
  }
  return kExitOk;
}

}  // namespace

void AddDocCommands(CLI::App& app, CommandContext& ctx) {
  CLI::App* doc = app.add_subcommand(
      "doc", "Register printed pages with annotations and retrieve them");
  doc->require_subcommand(1);

  {
    auto options = std::make_shared<RegisterOptions>();
    CLI::App* cmd = doc->add_subcommand("register", "Register a page image");
    cmd->add_option("IMAGE", options->image,
                    "Page image (JPEG, PNG, BMP, TIFF)")
        ->required();
    cmd->add_option("--title", options->title,
                    "Title (default: the image file's stem)");
    cmd->add_option("--annotations", options->annotations,
                    "Annotations JSON file (see client/README.md)");
    cmd->callback([&ctx, options] {
      ctx.action = [&ctx, options] { return RunRegister(ctx, *options); };
    });
  }
  {
    auto options = std::make_shared<RetrieveOptions>();
    CLI::App* cmd = doc->add_subcommand(
        "retrieve", "Find every registered page visible in an image");
    cmd->add_option("IMAGE", options->image,
                    "Query image (JPEG, PNG, BMP, TIFF)")
        ->required();
    cmd->add_option(
        "--intrinsics", options->intrinsics,
        "CAMERA.yml (OpenCV calibration file): also return each page's pose");
    cmd->add_flag("--undistort", options->undistort,
                  "Undo the lens distortion of --intrinsics first: homographies and the "
                  "overlay are then in the undistorted image");
    cmd->add_option(
        "--overlay", options->overlay,
        "Write the query image with outlines and annotations to this file");
    cmd->add_option("--max-results", options->max_results,
                    "At most this many matches (0 = every visible page)");
    cmd->callback([&ctx, options] {
      ctx.action = [&ctx, options] { return RunRetrieve(ctx, *options); };
    });
  }
  {
    auto options = std::make_shared<IdOptions>();
    CLI::App* cmd = doc->add_subcommand("delete", "Delete a registered page");
    cmd->add_option("ID", options->document_id, "Document id")->required();
    cmd->callback([&ctx, options] {
      ctx.action = [&ctx, options] { return RunDelete(ctx, *options); };
    });
  }
  {
    CLI::App* cmd = doc->add_subcommand("list", "List registered pages");
    cmd->callback([&ctx] { ctx.action = [&ctx] { return RunList(ctx); }; });
  }
  {
    auto options = std::make_shared<IdOptions>();
    CLI::App* cmd =
        doc->add_subcommand("show", "Show a page and its annotations");
    cmd->add_option("ID", options->document_id, "Document id")->required();
    cmd->callback([&ctx, options] {
      ctx.action = [&ctx, options] { return RunShow(ctx, *options); };
    });
  }
  {
    auto options = std::make_shared<IdOptions>();
    CLI::App* cmd =
        doc->add_subcommand("annotate", "Add annotations to a registered page");
    cmd->add_option("ID", options->document_id, "Document id")->required();
    cmd->add_option("--annotations", options->annotations,
                    "Annotations JSON file")
        ->required();
    cmd->callback([&ctx, options] {
      ctx.action = [&ctx, options] { return RunAnnotate(ctx, *options); };
    });
  }
  {
    auto options = std::make_shared<IdOptions>();
    CLI::App* cmd = doc->add_subcommand("delete-annotation",
                                        "Delete one annotation of a page");
    cmd->add_option("ID", options->document_id, "Document id")->required();
    cmd->add_option("ANNOTATION_ID", options->annotation_id, "Annotation id")
        ->required();
    cmd->callback([&ctx, options] {
      ctx.action = [&ctx, options] {
        return RunDeleteAnnotation(ctx, *options);
      };
    });
  }
}

}  // namespace texfree::client
