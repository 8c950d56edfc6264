#include "mocap_io/png_file.h"

#include <png.h>

#include <csetjmp>
#include <stdexcept>

#include "mocap_io/input_error.h"
#include "mocap_io/output_file.h"

namespace odyssey::io {
namespace {

// libpng reports errors by longjmp back to the setjmp in write_png_rgb; the message is kept here.
struct ErrorState {
  std::string message;
};

void on_error(png_structp png, png_const_charp message) {
  static_cast<ErrorState*>(png_get_error_ptr(png))->message = message;
  png_longjmp(png, 1);
}

void on_warning(png_structp, png_const_charp) {}

}  // namespace

void write_png_rgb(const std::string& path, int width, int height, std::span<const std::uint8_t> rgb) {
  if (width < 1 || height < 1 || rgb.size() != std::size_t(width) * std::size_t(height) * 3) {
    throw std::invalid_argument("png: " + std::to_string(rgb.size()) + " bytes for a " + std::to_string(width) + "x" +
                                std::to_string(height) + " RGB image");
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
  png_set_IHDR(png, info, static_cast<png_uint_32>(width), static_cast<png_uint_32>(height), 8, PNG_COLOR_TYPE_RGB,
               PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  for (int y = 0; y < height; ++y) png_write_row(png, rgb.data() + std::size_t(y) * width * 3);
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  file.commit();
}

}  // namespace odyssey::io
