// Entry point of the `texfree` command-line client, callable from tests.
#pragma once

#include <ostream>

namespace texfree::client {

// Parses the command line and runs the chosen command. Normal output goes to
// `out` (with --json exactly one JSON object), diagnostics to `err`. Returns
// the exit code: 0 success, 1 server or other runtime error, 2 usage error.
int RunCli(int argc, char** argv, std::ostream& out, std::ostream& err);

}  // namespace texfree::client
