// SMPL / SMPL-H / SMPL-X body model files (load_body_model).
#include "fuzz/fuzz_input.h"
#include "mocap_io/body_model_file.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static odyssey::fuzz::ScratchFile file("model.npz");
  const std::string& path = file.write(data, size);
  odyssey::fuzz::expect_input_errors([&] { (void)odyssey::io::load_body_model(path); });
  return 0;
}
