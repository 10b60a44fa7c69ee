// Small file helpers of the texfree client: input files and camera files, their
// errors reported as usage errors (exit 2).
#pragma once

#include <filesystem>
#include <optional>
#include <string>

#include "client/camera_file.h"

namespace texfree::client {

// Reads a whole file. Throws a usage CliError naming `what` and the path when
// the file is missing, unreadable or empty.
std::string ReadInputFile(const std::filesystem::path& path,
                          const std::string& what);

// LoadCameraFile, its errors thrown as usage CliErrors.
CameraFile LoadCameraOrUsage(const std::filesystem::path& path);

// The camera of an optional --intrinsics option: none when `path` is empty. With
// `undistort` (--undistort) a camera is required, since undistorting needs its
// distortion coefficients.
std::optional<CameraFile> LoadIntrinsicsOption(const std::string& path, bool undistort);

}  // namespace texfree::client
