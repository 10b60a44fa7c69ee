// ServerConfig: texfree-server's settings, their defaults, validation, and how
// they are resolved from flags, TEXFREE_* environment variables and a config
// file (precedence: flags > environment > config file > defaults).
#pragma once

#include <cstdint>
#include <map>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "server/document_registry.h"

namespace texfree::server {

struct ServerConfig {
  // gRPC listening address, HOST:PORT ("[::1]:PORT" for IPv6). Port 0 lets the
  // kernel choose a free port (texfree-server prints the one it got).
  std::string listen = "0.0.0.0:50051";
  // Directory holding the embedded SQLite database; created when missing.
  std::string data_dir = "./data";
  // Largest gRPC message accepted or sent, in MiB (1..2047).
  int max_message_mb = 64;
  // Largest decoded image (width * height) a request may carry.
  int64_t max_image_pixels = 50'000'000;
  // Document retrieval reduces larger pictures by a whole factor to at most
  // this many pixels (0: never); results stay in the picture's pixels.
  int64_t max_query_pixels = DocumentRegistryOptions::kDefaultMaxQueryPixels;
  // TrackTable analyses each live frame reduced to at most this many pixels, to
  // keep up with a camera's frame rate (0: as AnalyzeTable, up to 1280x960). At
  // 640x480 an analysis takes 17-19 ms on one core, at 1280x960 about 49 ms.
  int64_t live_pool_pixels = kDefaultLivePoolPixels;
  static constexpr int64_t kDefaultLivePoolPixels = 640 * 480;
  static constexpr int64_t kMinLivePoolPixels = 320 * 240;
  // spdlog level: trace, debug, info, warn, error, critical, off.
  std::string log_level = "info";
  // A streaming call with no message for this many seconds is ended.
  int idle_stream_timeout_s = 60;

  // OK, or INVALID_ARGUMENT explaining what is wrong and how to fix it.
  absl::Status Validate() const;
};

// Names of the settings, as written in the config file and as keys of the
// `flags` map below: listen, data_dir, max_message_mb, max_image_pixels,
// max_query_pixels, live_pool_pixels, log_level, idle_stream_timeout_s. The flags map may also
// hold "config" (the config file path), which ResolveServerConfig ignores.
//
// Environment variables (keys of `env`): TEXFREE_LISTEN, TEXFREE_DATA_DIR,
// TEXFREE_MAX_MESSAGE_MB, TEXFREE_MAX_IMAGE_PIXELS, TEXFREE_MAX_QUERY_PIXELS,
// TEXFREE_LIVE_POOL_PIXELS, TEXFREE_LOG_LEVEL,
// TEXFREE_IDLE_STREAM_TIMEOUT_S (and TEXFREE_CONFIG, the config file path,
// used by LoadServerConfig). Other keys of `env` are ignored.
//
// Config file: a TOML subset, one `key = value` per line; strings in double
// quotes, integers in decimal (underscores allowed: 50_000_000), `#` starts a
// comment, blank lines are skipped. An unknown key, a duplicate key or a
// malformed line is an error naming the line.
//
// Pure function: returns the validated configuration, or INVALID_ARGUMENT
// naming the source (flag, variable or config line) of a bad value.
absl::StatusOr<ServerConfig> ResolveServerConfig(
    const std::map<std::string, std::string>& flags,
    const std::map<std::string, std::string>& env,
    const std::string& config_file_text);

// Parses the config file text alone (on top of the defaults), without
// validating the result. Exposed for tests and tools.
absl::StatusOr<ServerConfig> ParseConfigFile(const std::string& text,
                                             ServerConfig base = {});

// Reads the process environment and the config file named by flags["config"],
// else by $TEXFREE_CONFIG (NOT_FOUND when it cannot be read), then calls
// ResolveServerConfig. `flags` holds only the flags given on the command line
// (texfree-server's main parses them with CLI11).
absl::StatusOr<ServerConfig> LoadServerConfig(
    const std::map<std::string, std::string>& flags);

// The TEXFREE_* variables of the current process environment.
std::map<std::string, std::string> TexfreeEnvironment();

}  // namespace texfree::server
