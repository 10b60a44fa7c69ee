// ServiceRegistry: opens storage under the data directory and creates every service.
#include "server/service_registry.h"

#include <filesystem>

#include <spdlog/spdlog.h>

#include "absl/strings/str_cat.h"
#include "common/status_macros.h"
#include "server/document_registry.h"
#include "server/document_service.h"
#include "server/document_store.h"
#include "server/tracking_service.h"
#include "server/survey_service.h"
#include "server/survey_store.h"
#include "server/pool_profile_store.h"
#include "server/pool_service.h"
#include "server/unimplemented_services.h"

namespace texfree::server {

struct ServiceRegistry::Impl {
  std::unique_ptr<DocumentRegistry> documents;
  std::unique_ptr<DocumentServiceImpl> document_service;
  std::unique_ptr<TrackingServiceImpl> tracking_service;
  std::unique_ptr<SurveyStore> surveys;
  std::unique_ptr<SurveyServiceImpl> survey_service;
  std::unique_ptr<PoolProfileStore> pool_profiles;
  std::unique_ptr<PoolServiceImpl> pool_service;
  std::vector<std::unique_ptr<grpc::Service>> pending;
};

ServiceRegistry::~ServiceRegistry() = default;

absl::StatusOr<std::unique_ptr<ServiceRegistry>> ServiceRegistry::Create(
    const ServerConfig& config) {
  std::error_code ec;
  std::filesystem::create_directories(config.data_dir, ec);
  if (ec) {
    return absl::UnavailableError(
        absl::StrCat("cannot create data directory '", config.data_dir, "': ", ec.message()));
  }
  const std::string db_path = (std::filesystem::path(config.data_dir) / "texfree.db").string();
  ASSIGN_OR_RETURN(auto store, DocumentStore::Open(db_path));
  spdlog::info("database {}", db_path);
  DocumentRegistryOptions document_options;
  document_options.max_query_pixels = config.max_query_pixels;
  ASSIGN_OR_RETURN(auto documents, DocumentRegistry::Open(std::move(store), document_options));

  std::unique_ptr<ServiceRegistry> registry(new ServiceRegistry());
  registry->impl_ = std::make_unique<Impl>();
  ImageLimits limits;
  limits.max_pixels = config.max_image_pixels;
  RETURN_IF_ERROR(limits.Validate());
  registry->impl_->document_service =
      std::make_unique<DocumentServiceImpl>(documents.get(), limits);
  TrackingServiceOptions tracking;
  tracking.idle_timeout = std::chrono::seconds(config.idle_stream_timeout_s);
  tracking.limits = limits;
  RETURN_IF_ERROR(tracking.Validate());
  registry->impl_->tracking_service =
      std::make_unique<TrackingServiceImpl>(documents.get(), std::move(tracking));
  registry->impl_->documents = std::move(documents);
  // Light surveys live in their own database file.
  const std::string survey_db_path =
      (std::filesystem::path(config.data_dir) / "surveys.db").string();
  ASSIGN_OR_RETURN(registry->impl_->surveys, SurveyStore::Open(survey_db_path));
  spdlog::info("survey database {}", survey_db_path);
  SurveyServiceOptions survey_options;
  survey_options.limits = limits;
  RETURN_IF_ERROR(survey_options.Validate());
  registry->impl_->survey_service =
      std::make_unique<SurveyServiceImpl>(registry->impl_->surveys.get(), survey_options);
  const std::string pool_db_path = (std::filesystem::path(config.data_dir) / "pool.db").string();
  ASSIGN_OR_RETURN(registry->impl_->pool_profiles, PoolProfileStore::Open(pool_db_path));
  spdlog::info("pool table profiles {}", pool_db_path);
  registry->impl_->pool_service = std::make_unique<PoolServiceImpl>(
      registry->impl_->pool_profiles.get(), limits, config.live_pool_pixels);
  registry->impl_->pending = MakeNotYetImplementedServices();
  return registry;
}

void ServiceRegistry::RegisterAll(grpc::ServerBuilder& builder) {
  builder.RegisterService(impl_->document_service.get());
  builder.RegisterService(impl_->tracking_service.get());
  builder.RegisterService(impl_->survey_service.get());
  builder.RegisterService(impl_->pool_service.get());
  for (auto& service : impl_->pending) builder.RegisterService(service.get());
}

void ServiceRegistry::Close() {
  if (!impl_) return;
  impl_->document_service.reset();
  impl_->tracking_service.reset();
  impl_->pool_service.reset();
  impl_->pool_profiles.reset();
  impl_->documents.reset();  // closes the database
  impl_->survey_service.reset();
  impl_->surveys.reset();
  spdlog::info("storage closed");
}

}  // namespace texfree::server
