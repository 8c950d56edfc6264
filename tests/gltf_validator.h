// Where the Khronos glTF validator lives for the tests (tools/gltf-validator, installed by
// scripts/install-deps.sh through npm), and why it cannot run when it cannot.
#pragma once

#include <cstdlib>
#include <filesystem>
#include <string>

namespace odyssey::test_support {

inline std::filesystem::path validator_dir() {
  return std::filesystem::path(__FILE__).parent_path().parent_path() / "tools" / "gltf-validator";
}

// Why the validator cannot run here, or "" when it can.
inline std::string validator_missing() {
  if (std::system("node --version > /dev/null 2>&1") != 0) return "node is not installed";
  if (!std::filesystem::exists(validator_dir() / "node_modules" / "gltf-validator")) {
    return "the glTF validator is not installed: npm install --prefix " + validator_dir().string() + " --package-lock=false";
  }
  return "";
}

}  // namespace odyssey::test_support
