// .npz archives (the zip reader and NpzReader): the directory, then every member's header, data
// and conversions, each member on its own so that one bad member does not hide the next.
#include "fuzz/fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static odyssey::fuzz::ScratchFile file("archive.npz");
  const std::string& path = file.write(data, size);
  odyssey::fuzz::expect_input_errors([&] {
    const odyssey::io::NpzReader reader(path);
    for (const std::string& key : reader.keys()) {
      (void)reader.contains(key);
      odyssey::fuzz::expect_input_errors([&] { (void)reader.header(key); });
      odyssey::fuzz::expect_input_errors([&] { odyssey::fuzz::convert(reader.load(key)); });
    }
    (void)reader.contains("not a member");
  });
  return 0;
}
