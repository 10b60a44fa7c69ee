// Runs the texfree command line in-process (RunCli) and captures its exit code, stdout and
// stderr: the one way client tests drive commands.
#pragma once

#include <sstream>
#include <string>
#include <vector>

#include "client/cli.h"

namespace texfree::client {

struct CliResult {
  int code = 0;
  std::string out;
  std::string err;
};

// args without the program name, e.g. {"--json", "doc", "list"}.
inline CliResult RunTexfree(std::vector<std::string> args) {
  args.insert(args.begin(), "texfree");
  std::vector<char*> argv;
  for (auto& arg : args) argv.push_back(arg.data());
  std::ostringstream out, err;
  CliResult result;
  result.code = RunCli(static_cast<int>(argv.size()), argv.data(), out, err);
  result.out = out.str();
  result.err = err.str();
  return result;
}

}  // namespace texfree::client
