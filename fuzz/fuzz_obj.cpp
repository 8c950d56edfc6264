// Wavefront OBJ props (load_obj).
#include "fuzz/fuzz_input.h"
#include "mocap_io/obj_mesh.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static odyssey::fuzz::ScratchFile file("prop.obj");
  const std::string& path = file.write(data, size);
  odyssey::fuzz::expect_input_errors([&] { (void)odyssey::io::load_obj(path); });
  return 0;
}
