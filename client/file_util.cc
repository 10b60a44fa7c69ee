// File helpers of the texfree client.
#include "client/file_util.h"

#include <fstream>
#include <iterator>

#include "client/command_context.h"

namespace texfree::client {

std::string ReadInputFile(const std::filesystem::path& path,
                          const std::string& what) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) {
    throw UsageError(what + " '" + path.string() + "' does not exist");
  }
  if (!std::filesystem::is_regular_file(path, ec)) {
    throw UsageError(what + " '" + path.string() + "' is not a file");
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) throw UsageError("cannot read " + what + " '" + path.string() + "'");
  std::string bytes((std::istreambuf_iterator<char>(in)),
                    std::istreambuf_iterator<char>());
  if (in.bad())
    throw UsageError("cannot read " + what + " '" + path.string() + "'");
  if (bytes.empty())
    throw UsageError(what + " '" + path.string() + "' is empty");
  return bytes;
}

CameraFile LoadCameraOrUsage(const std::filesystem::path& path) {
  try {
    return LoadCameraFile(path);
  } catch (const CameraFileError& e) {
    throw UsageError(e.what());
  }
}

std::optional<CameraFile> LoadIntrinsicsOption(const std::string& path, bool undistort) {
  std::optional<CameraFile> camera;
  if (!path.empty()) camera = LoadCameraOrUsage(path);
  if (undistort && !camera)
    throw UsageError("--undistort needs --intrinsics (the camera's distortion coefficients)");
  return camera;
}

}  // namespace texfree::client
