// RunCli: global options, command groups, error reporting and exit codes.
#include "client/cli.h"

#include <CLI/CLI.hpp>
#include <exception>
#include <string>

#include "client/command_context.h"
#include "client/doc_commands.h"
#include "client/track_commands.h"
#include "client/survey_commands.h"
#include "client/pool_commands.h"

namespace texfree::client {

int RunCli(int argc, char** argv, std::ostream& out, std::ostream& err) {
  CommandContext ctx(out, err);
  CLI::App app{
      "texfree: command-line client of texfree-server (texture-free keypoint "
      "matching).",
      "texfree"};
  app.set_version_flag("--version", "texfree 0.1.0");
  app.fallthrough(true);  // global options may also follow the subcommand
  app.require_subcommand(1);
  app.add_option("--server", ctx.server, "Server address HOST:PORT")
      ->envname("TEXFREE_SERVER")
      ->capture_default_str();
  app.add_flag("--json", ctx.json,
               "Print exactly one JSON object on stdout (errors go to stderr)");
  app.add_option("--connect-timeout", ctx.connect_timeout_s,
                 "Seconds to wait for a connection to the server")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--timeout", ctx.rpc_timeout_s,
                 "Deadline of each call, in seconds")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();

  AddDocCommands(app, ctx);
  AddTrackCommands(app, ctx);
  AddSurveyCommands(app, ctx);
  AddPoolCommands(app, ctx);
  // Later groups (track, survey, map, pool, lights) register here the same way.

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    int code = app.exit(e, out, err);
    return code == 0 ? kExitOk : kExitUsage;
  }
  if (!ctx.action) {
    err << app.help();
    return kExitUsage;
  }
  try {
    return ctx.action();
  } catch (const CliError& e) {
    err << "error: " << e.what() << std::endl;
    return e.exit_code();
  } catch (const std::exception& e) {
    err << "error: " << e.what() << std::endl;
    return kExitFailure;
  }
}

}  // namespace texfree::client
