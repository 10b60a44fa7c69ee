// ServerProcess: runs the real texfree-server binary on a free port with a data directory,
// for integration tests; stops it with SIGTERM and reports how it exited.
#pragma once

#include <sys/types.h>

#include <memory>
#include <string>

#include <grpcpp/grpcpp.h>

namespace texfree::testing {

class ServerProcess {
 public:
  // Starts `binary --listen 127.0.0.1:0 --data-dir data_dir` and waits (up to 60 s) for the
  // "texfree-server listening on HOST:PORT" line. Empty address() on failure.
  ServerProcess(const std::string& binary, const std::string& data_dir);
  ~ServerProcess();

  const std::string& address() const { return address_; }
  // Process id of the server (for /proc/<pid>/status in benchmarks); -1 when not started.
  pid_t pid() const { return pid_; }
  std::shared_ptr<grpc::Channel> Channel() const;
  bool running() const;
  // SIGTERM and wait; returns the exit code (-1 when killed by a signal or not running).
  int Stop();
  // Everything the server wrote to stderr so far.
  std::string Log() const;

 private:
  mutable pid_t pid_ = -1;
  mutable int exit_code_ = -1;  // set once the child has been reaped
  std::string address_;
  std::string log_path_;
};

}  // namespace texfree::testing
