// Shared state of one `texfree` invocation: server address, output mode,
// streams and the lazily opened gRPC channel. Each command group (doc, track,
// survey, map, pool, lights) registers its CLI11 subcommands with a
// CommandContext.
#pragma once

#include <grpcpp/grpcpp.h>

#include <chrono>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <ostream>
#include <stdexcept>
#include <string>

namespace texfree::client {

// Exit codes of the texfree client.
inline constexpr int kExitOk = 0;
inline constexpr int kExitFailure =
    1;  // server errors, unreachable server, I/O
inline constexpr int kExitUsage =
    2;  // bad command line or bad local input files

// An error to report as "error: <message>" with an exit code. Commands throw
// it.
class CliError : public std::runtime_error {
 public:
  CliError(int exit_code, const std::string& message)
      : std::runtime_error(message), exit_code_(exit_code) {}
  int exit_code() const { return exit_code_; }

 private:
  int exit_code_;
};

// A usage error (exit 2): bad arguments or malformed local input files.
inline CliError UsageError(const std::string& message) {
  return CliError(kExitUsage, message);
}

// "OK", "CANCELLED", ..., "UNAUTHENTICATED".
const char* StatusCodeName(grpc::StatusCode code);

class CommandContext {
 public:
  CommandContext(std::ostream& out, std::ostream& err) : out_(out), err_(err) {}

  // Global options (filled by CLI11 before a command runs).
  std::string server = "localhost:50051";
  bool json = false;
  double connect_timeout_s = 5.0;
  double rpc_timeout_s = 300.0;

  std::ostream& out() { return out_; }
  std::ostream& err() { return err_; }

  // The channel to the server, connected on first use. Throws CliError(1,
  // "cannot reach texfree-server at HOST:PORT ...") if no connection is made
  // within connect_timeout_s.
  std::shared_ptr<grpc::Channel> Channel();

  // Sets the RPC deadline on a fresh ClientContext.
  void Prepare(grpc::ClientContext* context) const;

  // Throws CliError(1, "CODE: message") for a non-OK status.
  void Check(const grpc::Status& status) const;

  // Prints `value` as the single JSON object of this command (json mode).
  void PrintJson(const nlohmann::json& value);

  // The command chosen on the command line; set by the subcommand callbacks.
  std::function<int()> action;

 private:
  std::ostream& out_;
  std::ostream& err_;
  std::shared_ptr<grpc::Channel> channel_;
};

}  // namespace texfree::client
