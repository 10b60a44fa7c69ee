// `texfree pool ...`: analyze a photograph of a pool table (ball numbers, positions in
// mm, shot suggestions, --overlay in perspective and --topview), track a live view with
// the shot drawn onto every frame, store a table profile, calibrate its colours.
#pragma once

namespace CLI {
class App;
}

namespace texfree::client {

class CommandContext;

// Adds the `pool` subcommand group to `app`; the chosen command sets ctx.action.
void AddPoolCommands(CLI::App& app, CommandContext& ctx);

}  // namespace texfree::client
