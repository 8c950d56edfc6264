// The one way a reader opens a file it was given: the path must name a regular file, and the file
// is read whole under a size cap, so that a FIFO never blocks a reader, a device such as /dev/zero
// never grows one without bound, and a huge file fails with its size rather than with whatever
// allocation gives out first.
#pragma once

#include <cstdint>
#include <string>

namespace odyssey::io {

// Caps on the inputs read whole (README, "Errors and outputs"). JSON documents (scenes, JSON
// manifests, camera path files, bone maps) expand several times in memory when parsed; line-based
// text (OBJ meshes, CSV manifests, RealEstate10K and COLMAP camera files) is parsed as it goes.
inline constexpr std::uint64_t kMaxJsonInputBytes = std::uint64_t{256} << 20;
inline constexpr std::uint64_t kMaxTextInputBytes = std::uint64_t{1} << 30;

// The frame cap of every command, the scene's (scene_layouts/placement.cpp): 10 million frames,
// 93 hours at 30 fps, far past any clip or shot, and still small enough that the per-frame arrays
// of one actor fit in memory.
inline constexpr double kMaxFrames = 10'000'000;

// Throws InputError naming `path` and the rates when `frames` frames at `fps`, resampled to
// `target_fps` over the same duration (Clip::resampled's rule), would give more than kMaxFrames
// frames: a two-frame BVH whose frame time is 1e6 s asks for 30 million at 30 fps. Checked before
// anything is allocated.
void require_frames_within_cap(const std::string& path, long long frames, double fps, double target_fps);

// The image-size cap of every camera: 16384 pixels a side and 2^25 pixels in all (8K UHD, 7680 x
// 4320, fits). A frame's maps and buffers take about 30 bytes a pixel, so the cap keeps one
// camera's frame near 1 GiB; checked where an image size is read (scene files, camera path files).
inline constexpr long long kMaxImageSide = 16384;
inline constexpr long long kMaxImagePixels = 1LL << 25;

// Empty when a `width` x `height` image is within the caps, else the problem in words.
std::string image_size_problem(long long width, long long height);

// Throws InputError naming `path`: "no such file" when nothing is there, "is a folder (a FIFO, a
// device, a socket), not a regular file" when something else is. Links are followed.
void require_input_file(const std::string& path);

// The whole of the regular file `path`, at most `max_bytes` long. The file is opened without
// blocking and checked on the open descriptor (fstat), so a path swapped for a FIFO between a
// check and the open cannot hang the reader. Throws InputError naming the file and the cap.
std::string read_input_file(const std::string& path, std::uint64_t max_bytes);

}  // namespace odyssey::io
