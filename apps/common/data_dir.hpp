#pragma once
// Where an app finds its reference data. Installed, <prefix>/share/sparsemps/<name>, found from the executable's own
// path (SPARSEMPS_BIN_TO_DATA: bin to share/sparsemps), so an installed copy never depends on the source tree; run
// from the build tree, the source tree's data/<name> it was configured with.
#include <filesystem>
#include <string>
#include <system_error>

inline std::string default_data_dir(const std::string& name, const std::string& source_dir) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const fs::path installed = (exe.parent_path() / SPARSEMPS_BIN_TO_DATA / name).lexically_normal();
    if (fs::is_directory(installed, ec)) return installed.string();
  }
  return source_dir;
}
