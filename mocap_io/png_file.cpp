#include "mocap_io/png_file.h"

#include <png.h>

#include <bit>
#include <csetjmp>
#include <stdexcept>

#include "mocap_io/input_error.h"
#include "mocap_io/output_file.h"

namespace odyssey::io {
namespace {

// libpng reports errors by longjmp back to the setjmp in write_png; the message is kept here.
struct ErrorState {
  std::string message;
};

void on_error(png_structp png, png_const_charp message) {
  static_cast<ErrorState*>(png_get_error_ptr(png))->message = message;
  png_longjmp(png, 1);
}

void on_warning(png_structp, png_const_charp) {}

}  // namespace

namespace {

// One image of `channels` samples of `bit_depth` bits a pixel, rows from the top; 16-bit samples
// in the machine's order (PNG stores them big-endian: libpng swaps).
// `fast`: zlib's fastest level (the per-frame maps of a sequence; about 3 times faster to write
// than the default for 10-20% larger files), else its default.
void write_png(const std::string& path, int width, int height, int channels, int bit_depth, std::span<const std::uint8_t> bytes,
               bool fast = false) {
  const std::size_t row_bytes = std::size_t(width) * channels * (bit_depth / 8);
  if (width < 1 || height < 1 || bytes.size() != row_bytes * std::size_t(height)) {
    throw std::invalid_argument("png: " + std::to_string(bytes.size()) + " bytes for a " + std::to_string(width) + "x" +
                                std::to_string(height) + " image of " + std::to_string(channels) + " channel(s) at " +
                                std::to_string(bit_depth) + " bits");
  }
  TempFile file(path);
  ErrorState state;
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &state, on_error, on_warning);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!png || !info) {
    png_destroy_write_struct(&png, nullptr);
    throw InputError(path, "libpng could not start");
  }
  // Nothing with a destructor is created between setjmp and the end of the libpng calls.
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    throw InputError(path, "libpng: " + state.message);
  }
  png_init_io(png, file.get());
  if (fast) {
    // zlib's fastest level, and one row filter (Up: the difference from the row above, which
    // suits smooth maps) instead of trying all five on every row.
    png_set_compression_level(png, 1);
    png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_UP);
  }
  png_set_IHDR(png, info, static_cast<png_uint_32>(width), static_cast<png_uint_32>(height), bit_depth,
               channels == 3 ? PNG_COLOR_TYPE_RGB : PNG_COLOR_TYPE_GRAY, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
               PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  if (bit_depth == 16 && std::endian::native == std::endian::little) png_set_swap(png);
  for (int y = 0; y < height; ++y) png_write_row(png, bytes.data() + std::size_t(y) * row_bytes);
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  file.commit();
}

}  // namespace

void write_png_rgb(const std::string& path, int width, int height, std::span<const std::uint8_t> rgb) {
  write_png(path, width, height, 3, 8, rgb);
}

void write_png_gray8(const std::string& path, int width, int height, std::span<const std::uint8_t> gray) {
  write_png(path, width, height, 1, 8, gray, true);
}

void write_png_gray16(const std::string& path, int width, int height, std::span<const std::uint16_t> gray) {
  write_png(path, width, height, 1, 16, std::span(reinterpret_cast<const std::uint8_t*>(gray.data()), gray.size() * 2), true);
}

}  // namespace odyssey::io
