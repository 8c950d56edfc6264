#include "mocap_io/anime_file.h"

#include <bit>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "mocap_io/input_error.h"
#include "mocap_io/input_file.h"
#include "mocap_io/output_file.h"

namespace odyssey::io {
namespace {

static_assert(std::endian::native == std::endian::little, ".anime files are little-endian and are copied as they are");

constexpr std::uint64_t kHeaderBytes = 12;

}  // namespace

AnimeFile read_anime_file(const std::string& path) {
  return naming_out_of_memory(path, [&] {
    std::error_code error;
    require_input_file(path);
    const std::uint64_t size = std::filesystem::file_size(path, error);
    if (error) throw InputError(path, "cannot be read");
    std::ifstream in(path, std::ios::binary);
    if (!in) throw InputError(path, "cannot be opened");
    if (size < kHeaderBytes) {
      throw InputError(path, "truncated .anime header: " + std::to_string(size) + " bytes, less than the 12 of nf, nv, nt");
    }
    std::int32_t counts[3];
    if (!in.read(reinterpret_cast<char*>(counts), sizeof counts)) throw InputError(path, "the header could not be read");
    const std::int64_t nf = counts[0], nv = counts[1], nt = counts[2];
    if (nf < 1 || nv < 3 || nt < 1) {
      throw InputError(path, "header: " + std::to_string(nf) + " frames, " + std::to_string(nv) + " vertices, " +
                                 std::to_string(nt) + " triangles; expected at least 1 frame, 3 vertices and 1 triangle");
    }
    // 12 + 12 nv + 12 nt + 12 (nf - 1) nv, each count below 2^31: at most about 2^67, so in 128 bits.
    const unsigned __int128 expected = kHeaderBytes + 12 * (unsigned __int128)nv + 12 * (unsigned __int128)nt +
                                       12 * (unsigned __int128)(nf - 1) * (unsigned __int128)nv;
    if (expected != size) {
      const std::string wanted = expected > UINT64_MAX ? "more than 2^64" : std::to_string(static_cast<std::uint64_t>(expected));
      throw InputError(path, "the header (" + std::to_string(nf) + " frames, " + std::to_string(nv) + " vertices, " +
                                 std::to_string(nt) + " triangles) implies " + wanted + " bytes, but the file has " +
                                 std::to_string(size) + (expected > size ? " (truncated)" : " (trailing bytes)"));
    }
    AnimeFile out;
    MeshAnimation& frames = out.frames;
    frames.vertex_count = static_cast<std::size_t>(nv);
    const std::size_t frame_floats = static_cast<std::size_t>(nv) * 3;
    frames.positions.resize(static_cast<std::size_t>(nf) * frame_floats);
    out.triangles.resize(static_cast<std::size_t>(nt) * 3);
    std::vector<std::int32_t> indices(out.triangles.size());
    const auto read = [&](void* to, std::size_t bytes, const char* what) {
      if (!in.read(static_cast<char*>(to), static_cast<std::streamsize>(bytes))) throw InputError(path, std::string("could not read ") + what);
    };
    read(frames.positions.data(), frame_floats * 4, "frame 1's vertices");
    read(indices.data(), indices.size() * 4, "the triangles");
    read(frames.positions.data() + frame_floats, (frames.positions.size() - frame_floats) * 4, "the offsets");
    for (std::size_t i = 0; i < frame_floats; ++i) {
      if (!std::isfinite(frames.positions[i])) {
        throw InputError(path, "frame 1, vertex " + std::to_string(i / 3) + " has a non-finite coordinate");
      }
    }
    for (std::size_t i = 0; i < indices.size(); ++i) {
      if (indices[i] < 0 || indices[i] >= nv) {
        throw InputError(path, "triangle " + std::to_string(i / 3) + " uses vertex " + std::to_string(indices[i]) +
                                   "; the mesh has vertices 0 to " + std::to_string(nv - 1));
      }
      out.triangles[i] = static_cast<std::uint32_t>(indices[i]);
    }
    // Offsets to positions: frame f (1-based f >= 2) = frame 1 + its offset.
    for (std::size_t f = 1; f < static_cast<std::size_t>(nf); ++f) {
      float* p = frames.positions.data() + f * frame_floats;
      for (std::size_t i = 0; i < frame_floats; ++i) {
        if (!std::isfinite(p[i])) {
          throw InputError(path, "frame " + std::to_string(f + 1) + ", vertex " + std::to_string(i / 3) +
                                     " has a non-finite offset");
        }
        p[i] += frames.positions[i];
        if (!std::isfinite(p[i])) {
          throw InputError(path, "frame " + std::to_string(f + 1) + ", vertex " + std::to_string(i / 3) + " overflows");
        }
      }
    }
    return out;
  });
}

void write_anime_file(const std::string& path, const MeshAnimation& frames, const std::vector<std::uint32_t>& triangles) {
  const int nf = frames.frame_count();
  const std::size_t floats = frames.vertex_count * 3;
  std::string bytes;
  const auto put = [&](const void* data, std::size_t size) { bytes.append(static_cast<const char*>(data), size); };
  const std::int32_t counts[3] = {nf, static_cast<std::int32_t>(frames.vertex_count), static_cast<std::int32_t>(triangles.size() / 3)};
  put(counts, sizeof counts);
  put(frames.positions.data(), floats * 4);
  for (const std::uint32_t index : triangles) {
    const std::int32_t value = static_cast<std::int32_t>(index);
    put(&value, 4);
  }
  for (int f = 1; f < nf; ++f) {
    for (std::size_t i = 0; i < floats; ++i) {
      const float offset = frames.positions[f * floats + i] - frames.positions[i];
      put(&offset, 4);
    }
  }
  write_file_atomically(path, bytes);
}

}  // namespace odyssey::io
