// Point caches: the full deformed mesh every frame, for renderers that play back vertex
// animation (Blender's Mesh Cache modifier reads PC2).
//
// PC2 layout (little endian):
//   char[12]  "POINTCACHE2\0"
//   int32     file version, 1
//   int32     number of points V
//   float32   start frame
//   float32   sample rate (frames per sample; 1)
//   int32     number of samples T
//   then T samples, each V points of 3 float32 (x, y, z)
// The points are the character's vertices across its meshes in order (the rest OBJ's order), in
// the toolkit's world frame (Z up, metres): in Blender, import the OBJ with Z up and Y forward and
// give the Mesh Cache modifier the same axes.
//
// Pc2Writer streams: samples go to disk as they arrive, memory does not grow with T. The file is
// written under a temporary name beside `path` and renamed onto it by close(); destroyed without
// close(), nothing appears at `path`.
#pragma once

#include <cstddef>
#include <memory>
#include <span>
#include <string>

#include "skeleton/character.h"

namespace odyssey::io {

class Pc2Writer {
 public:
  // Throws std::invalid_argument when points or frames is 0; InputError naming `path` when the
  // temporary file cannot be created.
  Pc2Writer(std::string path, std::size_t points, std::size_t frames, double start_frame = 0);
  ~Pc2Writer();
  Pc2Writer(const Pc2Writer&) = delete;
  Pc2Writer& operator=(const Pc2Writer&) = delete;

  // `count` samples, count * points * 3 floats. Throws std::invalid_argument naming both sizes on a
  // wrong size, too many frames, or a non-finite value; InputError when a write fails.
  void append_frames(std::size_t count, std::span<const float> positions);
  std::size_t frames_written() const;
  // Throws std::invalid_argument when fewer than `frames` samples arrived.
  void close();

 private:
  struct State;
  std::unique_ptr<State> state_;
};

// Writes the character's meshes at the rest pose (skinned with the rest skeleton, world frame) as
// one Wavefront OBJ: an `o` per mesh, its vertices, its triangles (1-based indices into the
// file's running vertex list). Written to a temporary name and renamed; throws InputError naming
// `path` on failure.
void write_rest_obj(const std::string& path, const Character& character);

}  // namespace odyssey::io
