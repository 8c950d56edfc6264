// Bone map JSON (parse_bone_map, which load_bone_map_file uses), from memory.
#include "fuzz/fuzz_input.h"
#include "mocap_io/bone_map_file.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  odyssey::fuzz::expect_input_errors([&] { (void)odyssey::io::parse_bone_map(text, "fuzz.json"); });
  return 0;
}
