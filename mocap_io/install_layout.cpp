#include "mocap_io/install_layout.h"

#include <filesystem>

namespace odyssey::io {

std::string runtime_folder(const std::string& name, const std::string& build_tree_folder) {
  namespace fs = std::filesystem;
  std::error_code error;
  const fs::path executable = fs::read_symlink("/proc/self/exe", error);
  if (!error) {
    const fs::path installed = (executable.parent_path() / ".." / "share" / "odyssey" / name).lexically_normal();
    if (fs::is_directory(installed, error)) return installed.string();
  }
  return build_tree_folder;
}

}  // namespace odyssey::io
