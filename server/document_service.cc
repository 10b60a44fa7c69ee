// DocumentService handlers: validate, convert, call the registry, convert back.
#include "server/document_service.h"

#include <spdlog/spdlog.h>

#include <chrono>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "common/timing.h"
#include "server/proto_convert.h"

namespace texfree::server {
namespace {

using Clock = SteadyClock;

grpc::Status Fail(const char* method, const absl::Status& status) {
  return LoggedFailure(method, status);
}

absl::Status CheckId(const std::string& id, const char* what) {
  if (id.empty()) return absl::InvalidArgumentError(absl::StrCat(what, " is empty"));
  if (id.size() > 128) return absl::InvalidArgumentError(absl::StrCat(what, " is too long"));
  return absl::OkStatus();
}

}  // namespace

grpc::Status DocumentServiceImpl::RegisterDocument(grpc::ServerContext*,
                                                   const v1::RegisterDocumentRequest* request,
                                                   v1::RegisterDocumentResponse* response) {
  const auto t0 = Clock::now();
  auto image = ImageFromProto(request->image(), limits_);
  if (!image.ok()) return Fail("RegisterDocument", image.status());
  std::vector<AnnotationRecord> annotations;
  for (int i = 0; i < request->annotations_size(); ++i) {
    auto a = AnnotationFromProto(request->annotations(i));
    if (!a.ok())
      return Fail("RegisterDocument",
                  absl::InvalidArgumentError(absl::StrCat("annotation ", i, ": ", a.status().message())));
    annotations.push_back(std::move(*a));
  }
  auto record = registry_->Register(*image, request->title(), std::move(annotations));
  if (!record.ok()) return Fail("RegisterDocument", record.status());
  DocumentToProto(*record, response->mutable_document());
  response->set_server_ms(MillisecondsSince(t0));
  return grpc::Status::OK;
}

grpc::Status DocumentServiceImpl::DeleteDocument(grpc::ServerContext*,
                                                 const v1::DeleteDocumentRequest* request,
                                                 v1::DeleteDocumentResponse* response) {
  const auto t0 = Clock::now();
  if (auto s = CheckId(request->document_id(), "document_id"); !s.ok())
    return Fail("DeleteDocument", s);
  if (auto s = registry_->Delete(request->document_id()); !s.ok())
    return Fail("DeleteDocument", s);
  response->set_document_id(request->document_id());
  response->set_server_ms(MillisecondsSince(t0));
  return grpc::Status::OK;
}

grpc::Status DocumentServiceImpl::GetDocument(grpc::ServerContext*,
                                              const v1::GetDocumentRequest* request,
                                              v1::Document* response) {
  if (auto s = CheckId(request->document_id(), "document_id"); !s.ok())
    return Fail("GetDocument", s);
  auto record = registry_->Get(request->document_id());
  if (!record.ok()) return Fail("GetDocument", record.status());
  DocumentToProto(*record, response);
  return grpc::Status::OK;
}

grpc::Status DocumentServiceImpl::ListDocuments(grpc::ServerContext*,
                                                const v1::ListDocumentsRequest* request,
                                                v1::ListDocumentsResponse* response) {
  int page_size = request->page_size() == 0 ? 100 : static_cast<int>(request->page_size());
  if (page_size > 1000) {
    return Fail("ListDocuments", absl::InvalidArgumentError(absl::StrCat(
                                     "page_size ", page_size, " is over the maximum of 1000")));
  }
  uint32_t after = 0;
  if (!request->page_token().empty() && !absl::SimpleAtoi(request->page_token(), &after)) {
    return Fail("ListDocuments",
                absl::InvalidArgumentError("page_token is not one this server handed out"));
  }
  auto page = registry_->List(after, page_size + 1);
  if (!page.ok()) return Fail("ListDocuments", page.status());
  const bool more = static_cast<int>(page->size()) > page_size;
  if (more) page->resize(page_size);
  for (const auto& d : *page) SummaryToProto(d, response->add_documents());
  if (more) response->set_next_page_token(absl::StrCat(page->back().index_id));
  auto total = registry_->Count();
  if (!total.ok()) return Fail("ListDocuments", total.status());
  response->set_total(static_cast<uint32_t>(*total));
  return grpc::Status::OK;
}

grpc::Status DocumentServiceImpl::AddAnnotation(grpc::ServerContext*,
                                                const v1::AddAnnotationRequest* request,
                                                v1::Annotation* response) {
  if (auto s = CheckId(request->document_id(), "document_id"); !s.ok())
    return Fail("AddAnnotation", s);
  auto a = AnnotationFromProto(request->annotation());
  if (!a.ok()) return Fail("AddAnnotation", a.status());
  auto stored = registry_->AddAnnotation(request->document_id(), std::move(*a));
  if (!stored.ok()) return Fail("AddAnnotation", stored.status());
  AnnotationToProto(*stored, response);
  return grpc::Status::OK;
}

grpc::Status DocumentServiceImpl::DeleteAnnotation(grpc::ServerContext*,
                                                   const v1::DeleteAnnotationRequest* request,
                                                   v1::DeleteAnnotationResponse* response) {
  if (auto s = CheckId(request->document_id(), "document_id"); !s.ok())
    return Fail("DeleteAnnotation", s);
  if (auto s = CheckId(request->annotation_id(), "annotation_id"); !s.ok())
    return Fail("DeleteAnnotation", s);
  if (auto s = registry_->DeleteAnnotation(request->document_id(), request->annotation_id());
      !s.ok())
    return Fail("DeleteAnnotation", s);
  response->set_annotation_id(request->annotation_id());
  return grpc::Status::OK;
}

grpc::Status DocumentServiceImpl::RetrieveDocuments(grpc::ServerContext*,
                                                    const v1::RetrieveDocumentsRequest* request,
                                                    v1::RetrieveDocumentsResponse* response) {
  const auto t0 = Clock::now();
  auto image = ImageFromProto(request->image(), limits_);
  if (!image.ok()) return Fail("RetrieveDocuments", image.status());
  const double decode_ms = MillisecondsSince(t0);
  auto camera = CameraFromProto(request->intrinsics());
  if (!camera.ok()) return Fail("RetrieveDocuments", camera.status());
  if (request->max_results() > 1000)
    return Fail("RetrieveDocuments", absl::InvalidArgumentError("max_results is over 1000"));
  auto result = registry_->Retrieve(*image, *camera, static_cast<int>(request->max_results()));
  if (!result.ok()) return Fail("RetrieveDocuments", result.status());
  std::string found;  // for the log line
  for (const auto& doc : result->documents) {
    MatchToProto(doc, response->add_matches());
    absl::StrAppend(&found, found.empty() ? "" : ", ", doc.document.id, " (", doc.inliers,
                    " inliers)");
  }
  auto* decode = response->add_timings();
  decode->set_stage("decode");
  decode->set_ms(decode_ms);
  std::string stages = absl::StrFormat("decode %.1f", decode_ms);  // for the log line
  for (const auto& [stage, ms] : result->timings.stages) {
    auto* t = response->add_timings();
    t->set_stage(stage);
    t->set_ms(ms);
    absl::StrAppend(&stages, absl::StrFormat(", %s %.1f", stage, ms));
  }
  response->set_query_keypoints(result->query_keypoints);
  response->set_server_ms(MillisecondsSince(t0));
  // One line per query, at info level: what was found and where the time went.
  spdlog::info("RetrieveDocuments: {}x{}, {} keypoints: {}; {:.1f} ms ({} ms)", image->cols,
               image->rows, result->query_keypoints, found.empty() ? "no document" : found,
               response->server_ms(), stages);
  return grpc::Status::OK;
}

}  // namespace texfree::server
