// DeformingThings4D meshes (.anime): one triangle mesh whose every vertex moves, frame by frame.
// The layout, little-endian, with no header beyond three counts:
//
//   int32   nf, nv, nt                 frames, vertices, triangles
//   float32 nv x 3                     the vertices of frame 1
//   int32   nt x 3                     triangles: zero-based vertex indices
//   float32 (nf - 1) x nv x 3          frames 2..nf as offsets from frame 1 (vertex = frame 1 + offset)
//
// so a file holds exactly 12 + 12 nv + 12 nt + 12 (nf - 1) nv bytes. The format stores no frame
// rate and no axes (the dataset's files are Y up; scene_layouts/actor_source.h turns them).
//
// Untrusted input: the counts must be positive (nf >= 1, nv >= 3, nt >= 1) and the file's size must
// equal the size they imply, checked before anything is allocated; every index must be below nv;
// every position and offset finite. A problem throws InputError(path, ...) naming the record (the
// header, frame 1's vertex v, triangle t, frame f's offset of vertex v) and, for a length that
// disagrees, both sizes.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "skeleton/mesh_animation.h"

namespace odyssey::io {

struct AnimeFile {
  std::vector<std::uint32_t> triangles;  // 3 a triangle
  MeshAnimation frames;                  // absolute positions of every frame, as the file's axes have them; fps unset
};

AnimeFile read_anime_file(const std::string& path);

// Writes `frames` (absolute positions; frame 0 first) and `triangles` in the layout above, under a
// temporary name renamed when complete. For tests and tools that make .anime files.
void write_anime_file(const std::string& path, const MeshAnimation& frames, const std::vector<std::uint32_t>& triangles);

}  // namespace odyssey::io
