// CommandContext: channel creation with a connect deadline, status reporting.
#include "client/command_context.h"

#include <grpcpp/create_channel.h>
#include <grpcpp/security/credentials.h>
#include <grpcpp/support/channel_arguments.h>

namespace texfree::client {
namespace {

std::chrono::system_clock::time_point DeadlineAfter(double seconds) {
  return std::chrono::system_clock::now() +
         std::chrono::duration_cast<std::chrono::system_clock::duration>(
             std::chrono::duration<double>(seconds));
}

std::string Unreachable(const std::string& server, double seconds) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%g", seconds);
  return "cannot reach texfree-server at " + server +
         " (no connection within " + buffer +
         " s; is the server running? set --server or TEXFREE_SERVER)";
}

}  // namespace

const char* StatusCodeName(grpc::StatusCode code) {
  switch (code) {
    case grpc::StatusCode::OK:
      return "OK";
    case grpc::StatusCode::CANCELLED:
      return "CANCELLED";
    case grpc::StatusCode::UNKNOWN:
      return "UNKNOWN";
    case grpc::StatusCode::INVALID_ARGUMENT:
      return "INVALID_ARGUMENT";
    case grpc::StatusCode::DEADLINE_EXCEEDED:
      return "DEADLINE_EXCEEDED";
    case grpc::StatusCode::NOT_FOUND:
      return "NOT_FOUND";
    case grpc::StatusCode::ALREADY_EXISTS:
      return "ALREADY_EXISTS";
    case grpc::StatusCode::PERMISSION_DENIED:
      return "PERMISSION_DENIED";
    case grpc::StatusCode::RESOURCE_EXHAUSTED:
      return "RESOURCE_EXHAUSTED";
    case grpc::StatusCode::FAILED_PRECONDITION:
      return "FAILED_PRECONDITION";
    case grpc::StatusCode::ABORTED:
      return "ABORTED";
    case grpc::StatusCode::OUT_OF_RANGE:
      return "OUT_OF_RANGE";
    case grpc::StatusCode::UNIMPLEMENTED:
      return "UNIMPLEMENTED";
    case grpc::StatusCode::INTERNAL:
      return "INTERNAL";
    case grpc::StatusCode::UNAVAILABLE:
      return "UNAVAILABLE";
    case grpc::StatusCode::DATA_LOSS:
      return "DATA_LOSS";
    case grpc::StatusCode::UNAUTHENTICATED:
      return "UNAUTHENTICATED";
    default:
      return "UNKNOWN";
  }
}

std::shared_ptr<grpc::Channel> CommandContext::Channel() {
  if (channel_) return channel_;
  grpc::ChannelArguments args;
  args.SetMaxReceiveMessageSize(-1);  // the server enforces its own limit
  args.SetMaxSendMessageSize(-1);
  // Retry quickly while waiting for a server that is just starting.
  args.SetInt(GRPC_ARG_INITIAL_RECONNECT_BACKOFF_MS, 200);
  args.SetInt(GRPC_ARG_MIN_RECONNECT_BACKOFF_MS, 200);
  args.SetInt(GRPC_ARG_MAX_RECONNECT_BACKOFF_MS, 1000);
  auto channel = grpc::CreateCustomChannel(
      server, grpc::InsecureChannelCredentials(), args);
  if (!channel->WaitForConnected(DeadlineAfter(connect_timeout_s))) {
    throw CliError(kExitFailure, Unreachable(server, connect_timeout_s));
  }
  channel_ = channel;
  return channel_;
}

void CommandContext::Prepare(grpc::ClientContext* context) const {
  context->set_deadline(DeadlineAfter(rpc_timeout_s));
}

void CommandContext::Check(const grpc::Status& status) const {
  if (status.ok()) return;
  std::string message = std::string(StatusCodeName(status.error_code())) +
                        ": " + status.error_message();
  if (status.error_code() == grpc::StatusCode::UNAVAILABLE) {
    message += " (texfree-server at " + server + ")";
  }
  throw CliError(kExitFailure, message);
}

void CommandContext::PrintJson(const nlohmann::json& value) {
  out_ << value.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace)
       << "\n";
  out_.flush();
}

}  // namespace texfree::client
