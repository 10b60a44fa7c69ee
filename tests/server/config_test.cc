// Tests of ServerConfig: defaults, Validate() messages, config file parsing
// and the precedence flags > environment > config file > defaults.
#include "server/config.h"

#include <cstdlib>
#include <fstream>
#include <map>
#include <string>

#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace texfree::server {
namespace {

using ::testing::HasSubstr;

using StringMap = std::map<std::string, std::string>;

TEST(ServerConfigTest, DefaultsAreValid) {
  ServerConfig config;
  EXPECT_EQ(config.listen, "0.0.0.0:50051");
  EXPECT_EQ(config.data_dir, "./data");
  EXPECT_EQ(config.max_message_mb, 64);
  EXPECT_EQ(config.max_image_pixels, 50'000'000);
  EXPECT_EQ(config.max_query_pixels, 1920 * 1440);
  EXPECT_EQ(config.live_pool_pixels, 640 * 480);
  EXPECT_EQ(config.log_level, "info");
  EXPECT_EQ(config.idle_stream_timeout_s, 60);
  EXPECT_TRUE(config.Validate().ok()) << config.Validate();
}

TEST(ServerConfigTest, ResolveWithNothingGivesDefaults) {
  absl::StatusOr<ServerConfig> config = ResolveServerConfig({}, {}, "");
  ASSERT_TRUE(config.ok()) << config.status();
  EXPECT_EQ(config->listen, "0.0.0.0:50051");
  EXPECT_EQ(config->data_dir, "./data");
}

TEST(ServerConfigTest, ValidListenAddresses) {
  for (const char* listen :
       {"0.0.0.0:50051", "127.0.0.1:0", "localhost:50051", "[::]:50051",
        "[::1]:0", "my-host.example.org:65535", "unix:/tmp/texfree.sock"}) {
    ServerConfig config;
    config.listen = listen;
    EXPECT_TRUE(config.Validate().ok()) << listen << ": " << config.Validate();
  }
}

TEST(ServerConfigTest, BadListenAddressesAreExplained) {
  const std::map<std::string, std::string> cases = {
      {"localhost", "has no port"},        {"localhost:", "invalid port"},
      {"localhost:65536", "invalid port"}, {"localhost:http", "invalid port"},
      {":50051", "invalid host"},          {"bad host:50051", "invalid host"},
      {"::1:50051", "brackets"},           {"[::1:50051", "invalid host"},
  };
  for (const auto& [listen, message] : cases) {
    ServerConfig config;
    config.listen = listen;
    absl::Status status = config.Validate();
    EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument) << listen;
    EXPECT_THAT(std::string(status.message()), HasSubstr(message)) << listen;
    EXPECT_THAT(std::string(status.message()), HasSubstr(listen));
  }
}

TEST(ServerConfigTest, ValidateExplainsEachBadField) {
  ServerConfig config;
  config.data_dir = "";
  EXPECT_THAT(std::string(config.Validate().message()),
              HasSubstr("data_dir is empty"));

  config = ServerConfig();
  config.max_message_mb = 0;
  EXPECT_THAT(std::string(config.Validate().message()),
              HasSubstr("max_message_mb = 0"));
  config.max_message_mb = 4096;
  EXPECT_THAT(std::string(config.Validate().message()),
              HasSubstr("max_message_mb = 4096"));

  config = ServerConfig();
  config.max_image_pixels = -5;
  EXPECT_THAT(std::string(config.Validate().message()),
              HasSubstr("max_image_pixels = -5 must be positive"));

  config = ServerConfig();
  config.max_query_pixels = 1000;
  EXPECT_THAT(std::string(config.Validate().message()),
              HasSubstr("max_query_pixels = 1000 must be 0 (never reduce)"));
  config.max_query_pixels = 0;
  EXPECT_TRUE(config.Validate().ok()) << "0: never reduce";

  config = ServerConfig();
  config.live_pool_pixels = 1000;
  EXPECT_THAT(std::string(config.Validate().message()),
              HasSubstr("live_pool_pixels = 1000 must be 0"));
  config.live_pool_pixels = 0;
  EXPECT_TRUE(config.Validate().ok()) << "0: live frames as AnalyzeTable's";

  config = ServerConfig();
  config.idle_stream_timeout_s = 0;
  EXPECT_THAT(std::string(config.Validate().message()),
              HasSubstr("idle_stream_timeout_s"));

  config = ServerConfig();
  config.log_level = "verbose";
  absl::Status status = config.Validate();
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(status.message()),
              HasSubstr("unknown log_level \"verbose\""));
  EXPECT_THAT(std::string(status.message()), HasSubstr("debug"));
}

TEST(ServerConfigTest, ConfigFileSetsEveryKey) {
  const std::string text = R"(# texfree-server configuration
listen = "127.0.0.1:6000"   # loopback only
data_dir = "/var/lib/texfree"

max_message_mb = 128
max_image_pixels = 20_000_000
log_level = "DEBUG"
idle_stream_timeout_s = 30
)";
  absl::StatusOr<ServerConfig> config = ResolveServerConfig({}, {}, text);
  ASSERT_TRUE(config.ok()) << config.status();
  EXPECT_EQ(config->listen, "127.0.0.1:6000");
  EXPECT_EQ(config->data_dir, "/var/lib/texfree");
  EXPECT_EQ(config->max_message_mb, 128);
  EXPECT_EQ(config->max_image_pixels, 20'000'000);
  EXPECT_EQ(config->log_level, "debug");
  EXPECT_EQ(config->idle_stream_timeout_s, 30);
}

TEST(ServerConfigTest, ConfigFileStringsKeepHashesAndEscapes) {
  absl::StatusOr<ServerConfig> config = ResolveServerConfig(
      {}, {}, "data_dir = \"/srv/a#b \\\"q\\\"\"  # comment\n");
  ASSERT_TRUE(config.ok()) << config.status();
  EXPECT_EQ(config->data_dir, "/srv/a#b \"q\"");
}

TEST(ServerConfigTest, UnknownKeyNamesKeyAndLine) {
  absl::StatusOr<ServerConfig> config = ResolveServerConfig(
      {}, {}, "# comment\nlisten = \"0.0.0.0:1\"\nport = 5\n");
  ASSERT_FALSE(config.ok());
  EXPECT_EQ(config.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(config.status().message()), HasSubstr("line 3"));
  EXPECT_THAT(std::string(config.status().message()),
              HasSubstr("unknown key \"port\""));
}

TEST(ServerConfigTest, BadConfigFilesAreRejected) {
  const std::map<std::string, std::string> cases = {
      {"listen 0.0.0.0:1\n", "line 1: expected `key = value`"},
      {"listen = 0.0.0.0:1\n", "line 1: listen must be a double-quoted"},
      {"listen = \"0.0.0.0:1\n", "line 1: listen must be a double-quoted"},
      {"\nmax_message_mb = \"64\"\n",
       "line 2: max_message_mb must be an integer"},
      {"max_message_mb = 6 4\n", "must be an integer"},
      {"max_message_mb = 64_\n", "must be an integer"},
      {"max_message_mb = 99999999999\n", "out of range"},
      {"log_level = \"info\" extra\n", "unexpected text after the value"},
      {"log_level = \"info\"\nlog_level = \"debug\"\n",
       "line 2: key \"log_level\" is set twice"},
      {"max_message_mb = 0\n", "max_message_mb = 0 must be in 1..2047"},
      {"log_level = \"loud\"\n", "unknown log_level \"loud\""},
  };
  for (const auto& [text, message] : cases) {
    absl::StatusOr<ServerConfig> config = ResolveServerConfig({}, {}, text);
    ASSERT_FALSE(config.ok()) << text;
    EXPECT_EQ(config.status().code(), absl::StatusCode::kInvalidArgument)
        << text;
    EXPECT_THAT(std::string(config.status().message()), HasSubstr(message))
        << text;
  }
}

TEST(ServerConfigTest, EnvironmentOverridesConfigFile) {
  const std::string text =
      "listen = \"127.0.0.1:1000\"\ndata_dir = \"/from/file\"\n"
      "max_message_mb = 10\n";
  const StringMap env = {
      {"TEXFREE_LISTEN", "127.0.0.1:2000"}, {"TEXFREE_MAX_IMAGE_PIXELS", "1234"},
      {"TEXFREE_MAX_QUERY_PIXELS", "0"},    {"TEXFREE_LIVE_POOL_PIXELS", "1228800"},
      {"TEXFREE_LOG_LEVEL", "warn"},        {"HOME", "/root"}};
  absl::StatusOr<ServerConfig> config = ResolveServerConfig({}, env, text);
  ASSERT_TRUE(config.ok()) << config.status();
  EXPECT_EQ(config->listen, "127.0.0.1:2000");
  EXPECT_EQ(config->data_dir, "/from/file");
  EXPECT_EQ(config->max_message_mb, 10);
  EXPECT_EQ(config->max_image_pixels, 1234);
  EXPECT_EQ(config->max_query_pixels, 0);
  EXPECT_EQ(config->live_pool_pixels, 1280 * 960);
  EXPECT_EQ(config->log_level, "warn");
}

TEST(ServerConfigTest, FlagsOverrideEnvironmentAndConfigFile) {
  const std::string text =
      "listen = \"127.0.0.1:1000\"\nmax_message_mb = 10\nlog_level = "
      "\"error\"\n";
  const StringMap env = {{"TEXFREE_LISTEN", "127.0.0.1:2000"},
                         {"TEXFREE_DATA_DIR", "/from/env"},
                         {"TEXFREE_MAX_MESSAGE_MB", "20"}};
  const StringMap flags = {{"listen", "127.0.0.1:3000"},
                           {"max_message_mb", "30"},
                           {"config", "/ignored/by/resolve.toml"}};
  absl::StatusOr<ServerConfig> config = ResolveServerConfig(flags, env, text);
  ASSERT_TRUE(config.ok()) << config.status();
  EXPECT_EQ(config->listen, "127.0.0.1:3000");
  EXPECT_EQ(config->data_dir, "/from/env");
  EXPECT_EQ(config->max_message_mb, 30);
  EXPECT_EQ(config->log_level, "error");
}

TEST(ServerConfigTest, BadEnvironmentAndFlagValuesNameTheirSource) {
  absl::StatusOr<ServerConfig> config =
      ResolveServerConfig({}, {{"TEXFREE_MAX_MESSAGE_MB", "lots"}}, "");
  ASSERT_FALSE(config.ok());
  EXPECT_THAT(std::string(config.status().message()),
              HasSubstr("environment variable TEXFREE_MAX_MESSAGE_MB"));

  config = ResolveServerConfig({{"max_image_pixels", "-"}}, {}, "");
  ASSERT_FALSE(config.ok());
  EXPECT_THAT(std::string(config.status().message()),
              HasSubstr("flag --max-image-pixels"));

  // A valid value given by a flag fixes an invalid one from the environment.
  config = ResolveServerConfig({{"listen", "127.0.0.1:0"}},
                               {{"TEXFREE_LISTEN", "nonsense"}}, "");
  EXPECT_TRUE(config.ok()) << config.status();
}

TEST(ServerConfigTest, LoadReadsConfigFileFromFlag) {
  const std::string path =
      std::string(::testing::TempDir()) + "/texfree_config_test.toml";
  {
    std::ofstream out(path);
    out << "data_dir = \"/from/file\"\nmax_message_mb = 8\n";
  }
  ::unsetenv("TEXFREE_MAX_MESSAGE_MB");
  ::setenv("TEXFREE_DATA_DIR", "/from/env", 1);
  absl::StatusOr<ServerConfig> config = LoadServerConfig({{"config", path}});
  ::unsetenv("TEXFREE_DATA_DIR");
  ASSERT_TRUE(config.ok()) << config.status();
  EXPECT_EQ(config->data_dir, "/from/env");
  EXPECT_EQ(config->max_message_mb, 8);
}

TEST(ServerConfigTest, LoadReportsMissingConfigFile) {
  absl::StatusOr<ServerConfig> config =
      LoadServerConfig({{"config", "/nonexistent/texfree.toml"}});
  ASSERT_FALSE(config.ok());
  EXPECT_EQ(config.status().code(), absl::StatusCode::kNotFound);
  EXPECT_THAT(std::string(config.status().message()),
              HasSubstr("/nonexistent/texfree.toml"));
}

}  // namespace
}  // namespace texfree::server
