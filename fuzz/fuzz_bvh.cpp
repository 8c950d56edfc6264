// BVH motion capture (load_bvh), with the default unit.
#include "fuzz/fuzz_input.h"
#include "mocap_io/bvh.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static odyssey::fuzz::ScratchFile file("motion.bvh");
  const std::string& path = file.write(data, size);
  odyssey::fuzz::expect_input_errors([&] { (void)odyssey::io::load_bvh(path); });
  return 0;
}
