// AMASS motion sequences (load_amass_file): poses or split keys, trans, betas, gender, frame rate.
#include "fuzz/fuzz_input.h"
#include "mocap_io/amass.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static odyssey::fuzz::ScratchFile file("motion.npz");
  const std::string& path = file.write(data, size);
  odyssey::fuzz::expect_input_errors([&] { (void)odyssey::io::load_amass_file(path); });
  return 0;
}
