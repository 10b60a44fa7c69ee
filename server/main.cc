// texfree-server: parses flags (CLI11), resolves the configuration, opens the
// storage through ServiceRegistry, serves texfree.v1 plus gRPC health checking
// and reflection, and shuts down cleanly on SIGINT/SIGTERM.
#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/grpcpp.h>
#include <grpcpp/health_check_service_interface.h>
#include <pthread.h>
#include <signal.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <system_error>
#include <thread>
#include <utility>

#include "server/config.h"
#include "server/service_registry.h"

namespace {

using texfree::server::ServerConfig;

// HOST part of HOST:PORT (brackets of an IPv6 host kept).
std::string HostOf(const std::string& listen) {
  const size_t colon = listen.rfind(':');
  return colon == std::string::npos ? listen : listen.substr(0, colon);
}

void SetUpLogging(const std::string& level) {
  auto logger = spdlog::stderr_color_mt("texfree-server");
  logger->set_pattern("[%Y-%m-%d %H:%M:%S.%e] [%^%l%$] %v");
  spdlog::set_default_logger(logger);
  spdlog::set_level(spdlog::level::from_str(level));
  spdlog::flush_on(spdlog::level::info);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "texfree-server: gRPC server for texture-free keypoint matching "
      "(documents, maps, light photogrammetry, pool).\n"
      "Settings: flags > TEXFREE_* environment variables > --config file > "
      "defaults.",
      "texfree-server"};
  // Only flags given on the command line go into `flags`, so that the
  // environment and the config file can fill the others.
  std::map<std::string, std::string> flags;
  std::string listen, data_dir, config_path, max_message_mb, max_image_pixels, max_query_pixels,
      live_pool_pixels, log_level, idle_timeout;
  const ServerConfig defaults;
  auto* listen_opt =
      app.add_option("--listen", listen,
                     "HOST:PORT to serve on (env TEXFREE_LISTEN, default " +
                         defaults.listen + "; port 0 = any free port)");
  auto* data_dir_opt = app.add_option(
      "--data-dir", data_dir,
      "directory of the SQLite database, created if missing (env "
      "TEXFREE_DATA_DIR, default " +
          defaults.data_dir + ")");
  auto* config_opt =
      app.add_option("--config", config_path,
                     "config file, `key = value` lines (env TEXFREE_CONFIG)");
  auto* mb_opt = app.add_option(
      "--max-message-mb", max_message_mb,
      "largest gRPC message in MiB (env TEXFREE_MAX_MESSAGE_MB, default " +
          std::to_string(defaults.max_message_mb) + ")");
  auto* pixels_opt = app.add_option(
      "--max-image-pixels", max_image_pixels,
      "largest image, width*height (env TEXFREE_MAX_IMAGE_PIXELS, default " +
          std::to_string(defaults.max_image_pixels) + ")");
  auto* query_pixels_opt = app.add_option(
      "--max-query-pixels", max_query_pixels,
      "document retrieval reduces larger pictures to this many pixels, 0 = "
      "never (env TEXFREE_MAX_QUERY_PIXELS, default " +
          std::to_string(defaults.max_query_pixels) + ")");
  auto* live_pixels_opt =
      app.add_option("--live-pool-pixels", live_pool_pixels,
                     "TrackTable analyses live frames reduced to this many pixels, 0 = as "
                     "AnalyzeTable (env TEXFREE_LIVE_POOL_PIXELS, default " +
                         std::to_string(defaults.live_pool_pixels) + ")");
  auto* level_opt = app.add_option(
      "--log-level", log_level,
      "trace|debug|info|warn|error|critical|off (env TEXFREE_LOG_LEVEL, "
      "default " +
          defaults.log_level + ")");
  auto* idle_opt =
      app.add_option("--idle-stream-timeout-s", idle_timeout,
                     "end a stream idle for this many seconds (env "
                     "TEXFREE_IDLE_STREAM_TIMEOUT_S, default " +
                         std::to_string(defaults.idle_stream_timeout_s) + ")");
  listen_opt->type_name("HOST:PORT");
  data_dir_opt->type_name("DIR");
  config_opt->type_name("FILE");
  mb_opt->type_name("N");
  pixels_opt->type_name("N");
  query_pixels_opt->type_name("N");
  live_pixels_opt->type_name("N");
  level_opt->type_name("LEVEL");
  idle_opt->type_name("SECONDS");
  CLI11_PARSE(app, argc, argv);

  const std::pair<CLI::Option*, std::pair<const char*, std::string*>> given[] = {
      {listen_opt, {"listen", &listen}},
      {data_dir_opt, {"data_dir", &data_dir}},
      {config_opt, {"config", &config_path}},
      {mb_opt, {"max_message_mb", &max_message_mb}},
      {pixels_opt, {"max_image_pixels", &max_image_pixels}},
      {query_pixels_opt, {"max_query_pixels", &max_query_pixels}},
      {live_pixels_opt, {"live_pool_pixels", &live_pool_pixels}},
      {level_opt, {"log_level", &log_level}},
      {idle_opt, {"idle_stream_timeout_s", &idle_timeout}}};
  for (const auto& [option, key_value] : given) {
    if (option->count() > 0) flags[key_value.first] = *key_value.second;
  }

  absl::StatusOr<ServerConfig> loaded =
      texfree::server::LoadServerConfig(flags);
  if (!loaded.ok()) {
    std::fprintf(stderr, "texfree-server: configuration error: %s\n",
                 std::string(loaded.status().message()).c_str());
    return 2;
  }
  const ServerConfig config = *std::move(loaded);
  SetUpLogging(config.log_level);

  std::error_code ec;
  std::filesystem::create_directories(config.data_dir, ec);
  if (ec || !std::filesystem::is_directory(config.data_dir)) {
    spdlog::error("cannot create the data directory \"{}\": {}",
                  config.data_dir,
                  ec ? ec.message() : "exists and is not a directory");
    return 1;
  }

  // Block SIGINT/SIGTERM before any thread starts (the registry's and gRPC's
  // threads inherit the mask); a dedicated thread receives them with sigwait.
  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGINT);
  sigaddset(&stop_signals, SIGTERM);
  if (int err = pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr); err != 0) {
    spdlog::error("pthread_sigmask failed: {}", std::strerror(err));
    return 1;
  }

  auto registry = texfree::server::ServiceRegistry::Create(config);
  if (!registry.ok()) {
    spdlog::error("cannot open the storage in \"{}\": {}", config.data_dir,
                  registry.status().ToString());
    return 1;
  }

  grpc::EnableDefaultHealthCheckService(true);
  grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  grpc::ServerBuilder builder;
  int selected_port = 0;
  builder.AddListeningPort(config.listen, grpc::InsecureServerCredentials(),
                           &selected_port);
  // Without this, gRPC sets SO_REUSEPORT and a second server on a busy port
  // would silently share it instead of failing.
  builder.AddChannelArgument(GRPC_ARG_ALLOW_REUSEPORT, 0);
  const int max_bytes = config.max_message_mb * 1024 * 1024;
  builder.SetMaxReceiveMessageSize(max_bytes);
  builder.SetMaxSendMessageSize(max_bytes);
  (*registry)->RegisterAll(builder);
  std::unique_ptr<grpc::Server> server = builder.BuildAndStart();
  const bool is_unix = config.listen.rfind("unix:", 0) == 0;
  if (server == nullptr || (!is_unix && selected_port == 0)) {
    spdlog::error(
        "cannot listen on {} (address in use, or not an address of this "
        "machine?)",
        config.listen);
    if (server != nullptr) server->Shutdown();
    (*registry)->Close();
    return 1;
  }
  const std::string address =
      is_unix ? config.listen
              : HostOf(config.listen) + ":" + std::to_string(selected_port);
  // Machine-readable line (integration tests parse it): keep it exact.
  std::fprintf(stderr, "texfree-server listening on %s\n", address.c_str());
  std::fflush(stderr);
  spdlog::info(
      "data dir {}, max message {} MiB, max image {} pixels, documents "
      "retrieved at most {} pixels, live pool frames at most {} pixels",
      config.data_dir, config.max_message_mb, config.max_image_pixels, config.max_query_pixels,
      config.live_pool_pixels);

  std::thread signal_thread([&server, &stop_signals] {
    int signal_number = 0;
    sigwait(&stop_signals, &signal_number);
    spdlog::info("received {}, shutting down (in-flight calls get 5 s)",
                 signal_number == SIGINT ? "SIGINT" : "SIGTERM");
    server->GetHealthCheckService()->SetServingStatus(false);
    server->Shutdown(std::chrono::system_clock::now() +
                     std::chrono::seconds(5));
  });

  server->Wait();
  signal_thread.join();
  (*registry)->Close();
  spdlog::info("texfree-server stopped");
  spdlog::shutdown();
  return 0;
}
