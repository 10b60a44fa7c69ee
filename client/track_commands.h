// `texfree track ...`: live tracking through TrackingService.
#pragma once

namespace CLI {
class App;
}

namespace texfree::client {

class CommandContext;

// Registers `track INPUT [--intrinsics CAMERA.yml] [--output OUT.mp4] [--no-learning]`.
void AddTrackCommands(CLI::App& app, CommandContext& ctx);

}  // namespace texfree::client
