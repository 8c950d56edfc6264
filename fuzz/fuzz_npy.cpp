// .npy arrays from memory (parse_npy, which read_npy uses), then every conversion of the result.
#include <span>

#include "fuzz/fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  odyssey::fuzz::expect_input_errors([&] {
    const auto bytes = std::as_bytes(std::span<const std::uint8_t>(data, size));
    odyssey::fuzz::convert(odyssey::io::parse_npy(bytes, "fuzz.npy"));
  });
  return 0;
}
