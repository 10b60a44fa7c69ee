// ServiceRegistry: owns the storage and every gRPC service of texfree-server.
#pragma once

#include <memory>

#include <grpcpp/server_builder.h>

#include "absl/status/statusor.h"
#include "server/config.h"

namespace texfree::server {

class DocumentStore;

// Opens the database under config.data_dir, rebuilds in-memory indices and creates
// the services. Not thread-safe itself; the services it owns are.
class ServiceRegistry {
 public:
  static absl::StatusOr<std::unique_ptr<ServiceRegistry>> Create(const ServerConfig& config);
  ~ServiceRegistry();

  // Adds every service to the builder. The registry must outlive the server.
  void RegisterAll(grpc::ServerBuilder& builder);

  // Called after the gRPC server has shut down: flushes and closes storage.
  void Close();

 private:
  ServiceRegistry() = default;
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace texfree::server
