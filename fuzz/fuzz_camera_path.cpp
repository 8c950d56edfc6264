// Camera path JSON (read_camera_path_json).
#include "fuzz/fuzz_input.h"
#include "mocap_io/camera_path_file.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static odyssey::fuzz::ScratchFile file("camera.json");
  const std::string& path = file.write(data, size);
  odyssey::fuzz::expect_input_errors([&] { (void)odyssey::io::read_camera_path_json(path); });
  return 0;
}
