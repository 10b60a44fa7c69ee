// Small file helpers of the texfree client.
#pragma once

#include <filesystem>
#include <string>

namespace texfree::client {

// Reads a whole file. Throws a usage CliError naming `what` and the path when
// the file is missing, unreadable or empty.
std::string ReadInputFile(const std::filesystem::path& path,
                          const std::string& what);

}  // namespace texfree::client
