// DeformingThings4D .anime meshes (read_anime_file).
#include "fuzz/fuzz_input.h"
#include "mocap_io/anime_file.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static odyssey::fuzz::ScratchFile file("mesh.anime");
  const std::string& path = file.write(data, size);
  odyssey::fuzz::expect_input_errors([&] { (void)odyssey::io::read_anime_file(path); });
  return 0;
}
