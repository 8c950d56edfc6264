// glTF / GLB characters (load_character; GLB is told apart by its magic bytes, so one harness
// covers both). External buffers and images resolve next to the scratch file, where none exist.
#include "fuzz/fuzz_input.h"
#include "mocap_io/gltf_character.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static odyssey::fuzz::ScratchFile file("character.glb");
  const std::string& path = file.write(data, size);
  odyssey::fuzz::expect_input_errors([&] { (void)odyssey::io::load_character(path); });
  return 0;
}
