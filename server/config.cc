// ServerConfig validation and resolution from flags, environment variables and
// a TOML-subset config file (see server/config.h for the rules).
#include "server/config.h"

#include <cerrno>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <set>
#include <sstream>
#include <utility>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/string_view.h"
#include "absl/strings/strip.h"

extern char** environ;

namespace texfree::server {
namespace {

constexpr int kMaxMessageMbLimit = 2047;  // gRPC sizes are ints (< 2 GiB).

const std::vector<std::string>& LogLevels() {
  static const auto* levels = new std::vector<std::string>{
      "trace", "debug", "info", "warn", "error", "critical", "off"};
  return *levels;
}

enum class Kind { kString, kInt };

// One setting: its config-file key, environment variable, flag and type.
struct Setting {
  const char* key;
  const char* env;
  const char* flag;
  Kind kind;
};

const std::vector<Setting>& Settings() {
  static const auto* settings = new std::vector<Setting>{
      {"listen", "TEXFREE_LISTEN", "--listen", Kind::kString},
      {"data_dir", "TEXFREE_DATA_DIR", "--data-dir", Kind::kString},
      {"max_message_mb", "TEXFREE_MAX_MESSAGE_MB", "--max-message-mb", Kind::kInt},
      {"max_image_pixels", "TEXFREE_MAX_IMAGE_PIXELS", "--max-image-pixels", Kind::kInt},
      {"max_query_pixels", "TEXFREE_MAX_QUERY_PIXELS", "--max-query-pixels", Kind::kInt},
      {"live_pool_pixels", "TEXFREE_LIVE_POOL_PIXELS", "--live-pool-pixels", Kind::kInt},
      {"log_level", "TEXFREE_LOG_LEVEL", "--log-level", Kind::kString},
      {"idle_stream_timeout_s", "TEXFREE_IDLE_STREAM_TIMEOUT_S", "--idle-stream-timeout-s",
       Kind::kInt},
  };
  return *settings;
}

const Setting* FindSetting(absl::string_view key) {
  for (const Setting& s : Settings()) {
    if (key == s.key) return &s;
  }
  return nullptr;
}

std::string KnownKeys() {
  std::vector<std::string> keys;
  for (const Setting& s : Settings()) keys.push_back(s.key);
  return absl::StrJoin(keys, ", ");
}

// Parses a decimal integer, allowing TOML-style '_' digit separators.
bool ParseInt(absl::string_view text, int64_t* out) {
  text = absl::StripAsciiWhitespace(text);
  std::string digits;
  for (size_t i = 0; i < text.size(); ++i) {
    char c = text[i];
    if (c == '_') {
      // Underscores only between digits.
      if (i == 0 || i + 1 == text.size() ||
          !absl::ascii_isdigit(static_cast<unsigned char>(text[i - 1])) ||
          !absl::ascii_isdigit(static_cast<unsigned char>(text[i + 1]))) {
        return false;
      }
      continue;
    }
    digits.push_back(c);
  }
  return !digits.empty() && absl::SimpleAtoi(digits, out);
}

// Stores `value` (already unquoted) into the field named by `setting`.
// `source` names where the value came from, for error messages.
absl::Status Assign(const Setting& setting, const std::string& value,
                    const std::string& source, ServerConfig* config) {
  if (setting.kind == Kind::kInt) {
    int64_t n = 0;
    if (!ParseInt(value, &n)) {
      return absl::InvalidArgumentError(
          absl::StrCat(source, ": ", setting.key, " must be an integer, got \"",
                       value, "\""));
    }
    const std::string key = setting.key;
    if (key == "max_image_pixels") {
      config->max_image_pixels = n;
      return absl::OkStatus();
    }
    if (key == "max_query_pixels") {
      config->max_query_pixels = n;
      return absl::OkStatus();
    }
    if (key == "live_pool_pixels") {
      config->live_pool_pixels = n;
      return absl::OkStatus();
    }
    if (n < INT32_MIN || n > INT32_MAX) {
      return absl::InvalidArgumentError(absl::StrCat(
          source, ": ", setting.key, " = ", n, " is out of range"));
    }
    if (key == "max_message_mb") {
      config->max_message_mb = static_cast<int>(n);
    } else if (key == "idle_stream_timeout_s") {
      config->idle_stream_timeout_s = static_cast<int>(n);
    }
    return absl::OkStatus();
  }
  const std::string key = setting.key;
  if (key == "listen") {
    config->listen = value;
  } else if (key == "data_dir") {
    config->data_dir = value;
  } else if (key == "log_level") {
    config->log_level = absl::AsciiStrToLower(value);
  }
  return absl::OkStatus();
}

// Parses a double-quoted TOML basic string starting at text[0] == '"'. On
// success stores the unescaped string and the rest of the line after the
// closing quote.
bool ParseQuoted(absl::string_view text, std::string* out,
                 absl::string_view* rest) {
  out->clear();
  for (size_t i = 1; i < text.size(); ++i) {
    char c = text[i];
    if (c == '"') {
      *rest = text.substr(i + 1);
      return true;
    }
    if (c == '\\') {
      if (++i >= text.size()) return false;
      switch (text[i]) {
        case '"':
          out->push_back('"');
          break;
        case '\\':
          out->push_back('\\');
          break;
        case 'n':
          out->push_back('\n');
          break;
        case 't':
          out->push_back('\t');
          break;
        default:
          return false;
      }
      continue;
    }
    out->push_back(c);
  }
  return false;  // No closing quote.
}

// Host part of HOST:PORT: a name or IPv4 address, or a bracketed IPv6 one.
bool ValidHost(absl::string_view host) {
  if (host.empty()) return false;
  if (host.front() == '[') {
    if (host.size() < 3 || host.back() != ']') return false;
    for (char c : host.substr(1, host.size() - 2)) {
      if (!absl::ascii_isxdigit(static_cast<unsigned char>(c)) && c != ':' &&
          c != '.' && c != '%') {
        return false;
      }
    }
    return true;
  }
  for (char c : host) {
    if (!absl::ascii_isalnum(static_cast<unsigned char>(c)) && c != '.' &&
        c != '-' && c != '_') {
      return false;
    }
  }
  return true;
}

absl::Status ValidateListen(const std::string& listen) {
  const std::string hint =
      " (expected HOST:PORT such as 0.0.0.0:50051, localhost:0 or "
      "[::]:50051)";
  if (absl::StartsWith(listen, "unix:")) {
    if (listen.size() > 5) return absl::OkStatus();
    return absl::InvalidArgumentError(
        "listen address \"unix:\" names no socket path");
  }
  const size_t colon = listen.rfind(':');
  if (colon == std::string::npos) {
    return absl::InvalidArgumentError(
        absl::StrCat("listen address \"", listen, "\" has no port", hint));
  }
  absl::string_view host = absl::string_view(listen).substr(0, colon);
  absl::string_view port = absl::string_view(listen).substr(colon + 1);
  if (host.find(':') != absl::string_view::npos && host.front() != '[') {
    return absl::InvalidArgumentError(
        absl::StrCat("listen address \"", listen,
                     "\": put an IPv6 host in brackets, e.g. [::1]:50051"));
  }
  if (!ValidHost(host)) {
    return absl::InvalidArgumentError(absl::StrCat("listen address \"", listen,
                                                   "\" has an invalid host \"",
                                                   host, "\"", hint));
  }
  int port_number = -1;
  bool digits_only = !port.empty() && port.size() <= 5;
  for (char c : port) {
    digits_only =
        digits_only && absl::ascii_isdigit(static_cast<unsigned char>(c));
  }
  if (!digits_only || !absl::SimpleAtoi(port, &port_number) ||
      port_number > 65535) {
    return absl::InvalidArgumentError(
        absl::StrCat("listen address \"", listen, "\" has an invalid port \"",
                     port, "\" (0..65535, 0 = any free port)"));
  }
  return absl::OkStatus();
}

}  // namespace

absl::Status ServerConfig::Validate() const {
  if (absl::Status s = ValidateListen(listen); !s.ok()) return s;
  if (data_dir.empty()) {
    return absl::InvalidArgumentError(
        "data_dir is empty: give the directory for the database, e.g. "
        "--data-dir ./data");
  }
  if (max_message_mb <= 0 || max_message_mb > kMaxMessageMbLimit) {
    return absl::InvalidArgumentError(
        absl::StrCat("max_message_mb = ", max_message_mb, " must be in 1..",
                     kMaxMessageMbLimit, " (MiB)"));
  }
  if (max_image_pixels <= 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("max_image_pixels = ", max_image_pixels,
                     " must be positive (default 50000000)"));
  }
  if (!DocumentRegistryOptions::ValidMaxQueryPixels(max_query_pixels)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "max_query_pixels = ", max_query_pixels,
        " must be 0 (never reduce) or at least ",
        DocumentRegistryOptions::kMinMaxQueryPixels, " (default ",
        DocumentRegistryOptions::kDefaultMaxQueryPixels, ")"));
  }
  if (live_pool_pixels != 0 && live_pool_pixels < kMinLivePoolPixels) {
    return absl::InvalidArgumentError(absl::StrCat(
        "live_pool_pixels = ", live_pool_pixels,
        " must be 0 (live frames as large as AnalyzeTable's) or at least ", kMinLivePoolPixels,
        " (320x240; default ", kDefaultLivePoolPixels, ", 640x480)"));
  }
  if (idle_stream_timeout_s <= 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("idle_stream_timeout_s = ", idle_stream_timeout_s,
                     " must be positive (seconds)"));
  }
  bool known_level = false;
  for (const std::string& level : LogLevels()) {
    known_level = known_level || level == log_level;
  }
  if (!known_level) {
    return absl::InvalidArgumentError(
        absl::StrCat("unknown log_level \"", log_level, "\"; use one of ",
                     absl::StrJoin(LogLevels(), ", ")));
  }
  return absl::OkStatus();
}

absl::StatusOr<ServerConfig> ParseConfigFile(const std::string& text,
                                             ServerConfig base) {
  ServerConfig config = std::move(base);
  std::set<std::string> seen;
  std::istringstream lines(text);
  std::string raw_line;
  int line_number = 0;
  while (std::getline(lines, raw_line)) {
    ++line_number;
    const std::string where = absl::StrCat("config file line ", line_number);
    absl::string_view line = absl::StripAsciiWhitespace(raw_line);
    if (line.empty() || line.front() == '#') continue;
    const size_t eq = line.find('=');
    if (eq == absl::string_view::npos) {
      return absl::InvalidArgumentError(
          absl::StrCat(where, ": expected `key = value`, got \"", line, "\""));
    }
    const std::string key(absl::StripAsciiWhitespace(line.substr(0, eq)));
    absl::string_view value_text =
        absl::StripAsciiWhitespace(line.substr(eq + 1));
    const Setting* setting = FindSetting(key);
    if (setting == nullptr) {
      return absl::InvalidArgumentError(
          absl::StrCat(where, ": unknown key \"", key,
                       "\" (known keys: ", KnownKeys(), ")"));
    }
    if (!seen.insert(key).second) {
      return absl::InvalidArgumentError(
          absl::StrCat(where, ": key \"", key, "\" is set twice"));
    }
    std::string value;
    absl::string_view rest;
    if (setting->kind == Kind::kString) {
      if (value_text.empty() || value_text.front() != '"' ||
          !ParseQuoted(value_text, &value, &rest)) {
        return absl::InvalidArgumentError(absl::StrCat(
            where, ": ", key, " must be a double-quoted string, e.g. ", key,
            " = \"...\""));
      }
    } else {
      const size_t hash = value_text.find('#');
      value =
          std::string(absl::StripAsciiWhitespace(value_text.substr(0, hash)));
      rest = hash == absl::string_view::npos ? absl::string_view()
                                             : value_text.substr(hash);
    }
    rest = absl::StripAsciiWhitespace(rest);
    if (!rest.empty() && rest.front() != '#') {
      return absl::InvalidArgumentError(absl::StrCat(
          where, ": unexpected text after the value: \"", rest, "\""));
    }
    if (absl::Status s = Assign(*setting, value, where, &config); !s.ok()) {
      return s;
    }
  }
  return config;
}

absl::StatusOr<ServerConfig> ResolveServerConfig(
    const std::map<std::string, std::string>& flags,
    const std::map<std::string, std::string>& env,
    const std::string& config_file_text) {
  absl::StatusOr<ServerConfig> config = ParseConfigFile(config_file_text);
  if (!config.ok()) return config.status();
  for (const Setting& setting : Settings()) {
    if (auto it = env.find(setting.env); it != env.end()) {
      if (absl::Status s = Assign(
              setting, it->second,
              absl::StrCat("environment variable ", setting.env), &*config);
          !s.ok()) {
        return s;
      }
    }
  }
  for (const auto& [name, value] : flags) {
    if (name == "config") continue;
    const Setting* setting = FindSetting(name);
    if (setting == nullptr) {
      return absl::InvalidArgumentError(
          absl::StrCat("unknown setting \"", name, "\""));
    }
    if (absl::Status s = Assign(*setting, value,
                                absl::StrCat("flag ", setting->flag), &*config);
        !s.ok()) {
      return s;
    }
  }
  if (absl::Status s = config->Validate(); !s.ok()) return s;
  return config;
}

std::map<std::string, std::string> TexfreeEnvironment() {
  std::map<std::string, std::string> env;
  for (char** e = environ; e != nullptr && *e != nullptr; ++e) {
    absl::string_view entry(*e);
    if (!absl::StartsWith(entry, "TEXFREE_")) continue;
    const size_t eq = entry.find('=');
    if (eq == absl::string_view::npos) continue;
    env.emplace(std::string(entry.substr(0, eq)),
                std::string(entry.substr(eq + 1)));
  }
  return env;
}

absl::StatusOr<ServerConfig> LoadServerConfig(
    const std::map<std::string, std::string>& flags) {
  const std::map<std::string, std::string> env = TexfreeEnvironment();
  std::string path;
  std::string origin;
  if (auto it = flags.find("config"); it != flags.end()) {
    path = it->second;
    origin = "--config";
  } else if (auto it = env.find("TEXFREE_CONFIG"); it != env.end()) {
    path = it->second;
    origin = "TEXFREE_CONFIG";
  }
  std::string text;
  if (!path.empty()) {
    std::ifstream in(path, std::ios::binary);
    if (!in) {
      return absl::NotFoundError(absl::StrCat("cannot read the config file \"",
                                              path, "\" given by ", origin,
                                              ": ", std::strerror(errno)));
    }
    std::ostringstream buffer;
    buffer << in.rdbuf();
    text = buffer.str();
  }
  absl::StatusOr<ServerConfig> config = ResolveServerConfig(flags, env, text);
  if (!config.ok() && !path.empty()) {
    return absl::Status(
        config.status().code(),
        absl::StrCat(config.status().message(), " [config file: ", path, "]"));
  }
  return config;
}

}  // namespace texfree::server
