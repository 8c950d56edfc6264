#include "mocap_io/jpeg_file.h"

#include <jpeglib.h>

#include <csetjmp>
#include <cstdio>
#include <stdexcept>

#include "mocap_io/input_error.h"
#include "mocap_io/output_file.h"

namespace odyssey::io {
namespace {

// libjpeg's default error handler exits the process; this one longjmps back with the message.
struct ErrorManager {
  jpeg_error_mgr base;
  std::jmp_buf jump;
  char message[JMSG_LENGTH_MAX];
};

void on_error(j_common_ptr info) {
  ErrorManager* errors = reinterpret_cast<ErrorManager*>(info->err);
  (*info->err->format_message)(info, errors->message);
  std::longjmp(errors->jump, 1);
}

}  // namespace

void write_jpeg_rgb(const std::string& path, int width, int height, std::span<const std::uint8_t> rgb, int quality) {
  if (width < 1 || height < 1 || width > JPEG_MAX_DIMENSION || height > JPEG_MAX_DIMENSION ||
      rgb.size() != std::size_t(width) * std::size_t(height) * 3) {
    throw std::invalid_argument("jpeg: " + std::to_string(rgb.size()) + " bytes for a " + std::to_string(width) + "x" +
                                std::to_string(height) + " RGB image");
  }
  if (quality < 1 || quality > 100) throw std::invalid_argument("jpeg: quality " + std::to_string(quality) + " is not 1 to 100");
  TempFile file(path);
  jpeg_compress_struct info;
  ErrorManager errors;
  info.err = jpeg_std_error(&errors.base);
  errors.base.error_exit = on_error;
  // Nothing with a destructor is created between setjmp and the end of the libjpeg calls.
  if (setjmp(errors.jump)) {
    jpeg_destroy_compress(&info);
    throw InputError(path, std::string("libjpeg: ") + errors.message);
  }
  jpeg_create_compress(&info);
  jpeg_stdio_dest(&info, file.get());
  info.image_width = static_cast<JDIMENSION>(width);
  info.image_height = static_cast<JDIMENSION>(height);
  info.input_components = 3;
  info.in_color_space = JCS_RGB;
  jpeg_set_defaults(&info);
  jpeg_set_quality(&info, quality, TRUE);
  for (int c = 0; c < info.num_components; ++c) {
    info.comp_info[c].h_samp_factor = 1;
    info.comp_info[c].v_samp_factor = 1;
  }
  jpeg_start_compress(&info, TRUE);
  while (info.next_scanline < info.image_height) {
    JSAMPROW row = const_cast<JSAMPROW>(rgb.data() + std::size_t(info.next_scanline) * width * 3);
    jpeg_write_scanlines(&info, &row, 1);
  }
  jpeg_finish_compress(&info);
  jpeg_destroy_compress(&info);
  file.commit();
}

}  // namespace odyssey::io
