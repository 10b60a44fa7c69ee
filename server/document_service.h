// DocumentService: the gRPC face of DocumentRegistry (texfree.v1.DocumentService).
#pragma once

#include "common/image_io.h"
#include "server/document_registry.h"
#include "texfree/v1/document.grpc.pb.h"

namespace texfree::server {

// Thread-safe (DocumentRegistry is); gRPC calls handlers concurrently.
class DocumentServiceImpl final : public v1::DocumentService::Service {
 public:
  DocumentServiceImpl(DocumentRegistry* registry, ImageLimits limits)
      : registry_(registry), limits_(limits) {}

  grpc::Status RegisterDocument(grpc::ServerContext*, const v1::RegisterDocumentRequest*,
                                v1::RegisterDocumentResponse*) override;
  grpc::Status DeleteDocument(grpc::ServerContext*, const v1::DeleteDocumentRequest*,
                              v1::DeleteDocumentResponse*) override;
  grpc::Status GetDocument(grpc::ServerContext*, const v1::GetDocumentRequest*,
                           v1::Document*) override;
  grpc::Status ListDocuments(grpc::ServerContext*, const v1::ListDocumentsRequest*,
                             v1::ListDocumentsResponse*) override;
  grpc::Status AddAnnotation(grpc::ServerContext*, const v1::AddAnnotationRequest*,
                             v1::Annotation*) override;
  grpc::Status DeleteAnnotation(grpc::ServerContext*, const v1::DeleteAnnotationRequest*,
                                v1::DeleteAnnotationResponse*) override;
  grpc::Status RetrieveDocuments(grpc::ServerContext*, const v1::RetrieveDocumentsRequest*,
                                 v1::RetrieveDocumentsResponse*) override;

 private:
  DocumentRegistry* registry_;
  ImageLimits limits_;
};

}  // namespace texfree::server
