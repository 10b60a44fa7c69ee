// `texfree doc ...`: register, retrieve, delete, list, show and annotate
// documents.
#pragma once

namespace CLI {
class App;
}

namespace texfree::client {

class CommandContext;

// Adds the `doc` subcommand group to `app`; the chosen command sets ctx.action.
void AddDocCommands(CLI::App& app, CommandContext& ctx);

}  // namespace texfree::client
