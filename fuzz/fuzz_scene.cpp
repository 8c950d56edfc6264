// Scene files (odyssey::scene::parse_scene), from memory: parsed only, never run, so the paths a
// scene names are resolved but no file is opened.
#include "fuzz/fuzz_input.h"
#include "scene_layouts/scene_file.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::string path = odyssey::fuzz::scratch_folder() + "/odyssey-fuzz-scene.json";
  const std::string text(reinterpret_cast<const char*>(data), size);
  odyssey::fuzz::expect_input_errors([&] { (void)odyssey::scene::parse_scene(text, path); });
  return 0;
}
