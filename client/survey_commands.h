// `texfree survey ...` (create, upload, solve, list, show, delete, export) on SurveyService,
// and `texfree lights encode ID` (the sample sequence to program into an LED).
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace CLI {
class App;
}

namespace texfree::client {

class CommandContext;

// Adds the `survey` and `lights` subcommand groups to `app`.
void AddSurveyCommands(CLI::App& app, CommandContext& ctx);

// Parses REFS.csv: a header `id,x,y,z` (any order of those columns, more columns ignored),
// then one light per row, metres. Throws a usage CliError naming the file and line of a bad
// row (missing field, not a number, id out of 0..63, duplicate id).
std::map<uint32_t, cv::Point3d> ParseReferencesCsv(const std::string& text,
                                                   const std::string& path);

// Image files of a burst folder (jpg, jpeg, png, tif, tiff), sorted by name. Throws a usage
// CliError when the folder is missing or holds none.
std::vector<std::filesystem::path> BurstFrameFiles(const std::filesystem::path& folder);

}  // namespace texfree::client
