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
namespace {

// For a command line that names no known command where one is required (`texfree maps
// list`, `texfree doc frobnicate`): a message naming the word and the commands there are,
// instead of CLI11's "A subcommand is required". Empty when that is not the error.
std::string UnknownCommandMessage(CLI::App& app, int argc, char** argv) {
  const CLI::App* level = &app;
  std::string path = "texfree";
  for (int i = 1; i < argc; ++i) {
    const std::string word = argv[i];
    if (word.empty() || word[0] == '-') {
      // An option taking a value has it next (--server HOST:PORT), unless given with '='.
      const CLI::Option* option = level->get_option_no_throw(word);
      if (option == nullptr) option = app.get_option_no_throw(word);  // global, after a group
      if (option != nullptr && option->get_items_expected_min() > 0 &&
          word.find('=') == std::string::npos)
        ++i;
      continue;
    }
    const CLI::App* next = nullptr;
    for (const CLI::App* sub : level->get_subcommands({}))
      if (sub->get_name() == word) next = sub;
    if (next != nullptr) {
      level = next;
      path += " " + word;
      continue;
    }
    if (level->get_require_subcommand_min() == 0) return "";
    std::string names;
    for (const CLI::App* sub : level->get_subcommands({}))
      names += (names.empty() ? "" : ", ") + sub->get_name();
    return "unknown command '" + word + "' after '" + path + "'; the commands there are: " + names;
  }
  return "";
}

}  // namespace

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
  // Each group registers its commands here the same way (survey also adds `lights`).

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (const std::string unknown = UnknownCommandMessage(app, argc, argv); !unknown.empty()) {
      err << "error: " << unknown << "\nRun with --help for more information." << std::endl;
      return kExitUsage;
    }
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
