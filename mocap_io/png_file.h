// PNG images through libpng: 8-bit RGB, 8- and 16-bit grey, rows top to bottom.
#pragma once

#include <cstdint>
#include <span>
#include <string>

namespace odyssey::io {

// Writes `rgb` (width x height x 3 bytes, row-major from the top) to `path` under a temporary name
// renamed into place when complete. Throws std::invalid_argument for a wrong size, InputError
// naming the path when libpng or the file fails.
void write_png_rgb(const std::string& path, int width, int height, std::span<const std::uint8_t> rgb);
// One channel, 8 or 16 bits a pixel (width x height samples), at zlib's fastest level (these are
// written every frame of a sequence); the same errors.
void write_png_gray8(const std::string& path, int width, int height, std::span<const std::uint8_t> gray);
void write_png_gray16(const std::string& path, int width, int height, std::span<const std::uint16_t> gray);

}  // namespace odyssey::io
