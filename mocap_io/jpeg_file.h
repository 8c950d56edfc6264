// JPEG images through libjpeg: 8-bit RGB, rows top to bottom, baseline, 4:4:4 (no chroma
// subsampling, so a normal map's channels keep their full resolution).
#pragma once

#include <cstdint>
#include <span>
#include <string>

namespace odyssey::io {

// Writes `rgb` (width x height x 3 bytes, row-major from the top) at `quality` (1 to 100) to
// `path` under a temporary name renamed into place when complete. Throws std::invalid_argument
// for a wrong size or quality, InputError naming the path when libjpeg or the file fails.
void write_jpeg_rgb(const std::string& path, int width, int height, std::span<const std::uint8_t> rgb, int quality = 95);

}  // namespace odyssey::io
