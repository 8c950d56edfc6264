#include "mocap_io/point_cache.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <utility>
#include <vector>

#include "mocap_io/input_error.h"
#include "mocap_io/output_file.h"
#include "skeleton/fk.h"

namespace odyssey::io {
namespace {

static_assert(std::endian::native == std::endian::little, "PC2 is little endian and is written without conversion");

constexpr std::size_t kPc2HeaderBytes = 32;
// The OBJ text is built in memory and written out whenever it passes this size.
constexpr std::size_t kObjFlushBytes = std::size_t{1} << 20;

template <class T>
void put(std::array<std::byte, kPc2HeaderBytes>& header, std::size_t offset, T value) {
  std::memcpy(header.data() + offset, &value, sizeof value);
}

// Shortest text that reads back as exactly this float (std::to_chars round-trip guarantee).
void append_float(std::string& out, float value) {
  char text[32];
  const auto result = std::to_chars(text, text + sizeof text, value);
  out.append(text, result.ptr);
}

// OBJ object names run to the end of the line: control characters would break the file.
std::string object_name(const std::string& name, std::size_t index) {
  if (name.empty()) return "mesh_" + std::to_string(index);
  std::string out = name;
  for (char& c : out)
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = '_';
  return out;
}

}  // namespace

struct Pc2Writer::State {
  std::string path;
  std::size_t points;
  std::size_t frames;
  std::unique_ptr<TempFile> file;  // null once closed, or after a failed write
  std::size_t written = 0;
  bool closed = false;

  TempFile& live() {
    if (closed) throw std::logic_error("Pc2Writer used after close()");
    if (!file) throw std::logic_error("Pc2Writer used after a failed write; the file cannot be completed");
    return *file;
  }
};

Pc2Writer::Pc2Writer(std::string path, std::size_t points, std::size_t frames, double start_frame)
    : state_(std::make_unique<State>()) {
  // The header stores both counts as int32; a sample of V points is 12 V bytes.
  constexpr std::size_t kInt32Max = static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max());
  if (points == 0 || frames == 0 || points > kInt32Max || frames > kInt32Max)
    throw std::invalid_argument("PC2: point and frame counts must be 1.." + std::to_string(kInt32Max) + ", got " +
                                std::to_string(points) + " points and " + std::to_string(frames) + " frames");
  if (!std::isfinite(static_cast<float>(start_frame)))
    throw std::invalid_argument("PC2: start frame " + std::to_string(start_frame) + " is not a finite float32");
  State& s = *state_;
  s.path = std::move(path);
  s.points = points;
  s.frames = frames;
  s.file = std::make_unique<TempFile>(s.path);

  // char[12] "POINTCACHE2\0" | int32 version 1 | int32 V | float32 start | float32 rate 1 | int32 T
  std::array<std::byte, kPc2HeaderBytes> header{};
  std::memcpy(header.data(), "POINTCACHE2", 12);  // 11 characters and the NUL
  put<std::int32_t>(header, 12, 1);
  put(header, 16, static_cast<std::int32_t>(points));
  put(header, 20, static_cast<float>(start_frame));
  put(header, 24, 1.0f);
  put(header, 28, static_cast<std::int32_t>(frames));
  s.file->write(header);
}

Pc2Writer::~Pc2Writer() = default;

void Pc2Writer::append_frames(std::size_t count, std::span<const float> positions) {
  State& s = *state_;
  TempFile& file = s.live();
  if (count > s.frames - s.written)
    throw std::invalid_argument("PC2: " + std::to_string(count) + " more frames after " + std::to_string(s.written) +
                                " would make " + std::to_string(s.written + count) + ", the file holds " +
                                std::to_string(s.frames));
  // count <= frames < 2^31 and points < 2^31, so the product fits in 64-bit size_t.
  const std::size_t expected = count * s.points * 3;
  if (positions.size() != expected)
    throw std::invalid_argument("PC2: " + std::to_string(positions.size()) + " values, " + std::to_string(count) + " frames x " +
                                std::to_string(s.points) + " points x 3 need " + std::to_string(expected));
  const std::size_t bad = first_non_finite(positions);
  if (bad != positions.size()) {
    const std::size_t per_frame = s.points * 3;
    throw std::invalid_argument("PC2: value " + std::to_string(positions[bad]) + " at frame " +
                                std::to_string(s.written + bad / per_frame) + ", point " + std::to_string(bad % per_frame / 3) +
                                " is not finite");
  }
  try {
    file.write(std::as_bytes(positions));
  } catch (...) {
    s.file.reset();  // a partial sample is on disk: the file cannot be completed
    throw;
  }
  s.written += count;
}

std::size_t Pc2Writer::frames_written() const { return state_->written; }

void Pc2Writer::close() {
  State& s = *state_;
  s.live();
  // Whatever happens below, the writer is finished and an uncommitted temporary file goes.
  s.closed = true;
  const std::unique_ptr<TempFile> file = std::move(s.file);
  if (s.written < s.frames)
    throw std::invalid_argument("PC2 " + s.path + ": closed after " + std::to_string(s.written) + " of " +
                                std::to_string(s.frames) + " frames");
  file->commit();
}

void write_rest_obj(const std::string& path, const Character& character) {
  const std::vector<RigidTransform<double>> rest = character.skeleton.rest_world();
  TempFile file(path);
  std::string text = "# " + object_name(character.name, 0) + " at the rest pose: world frame, Z up, metres\n";
  auto flush = [&] {
    file.write(std::as_bytes(std::span(text)));
    text.clear();
  };
  std::size_t first_vertex = 1;  // OBJ indices are 1-based over the whole file
  for (std::size_t m = 0; m < character.meshes.size(); ++m) {
    const CharacterMesh& mesh = character.meshes[m];
    const std::vector<Eigen::Vector3d> positions = skin_mesh_reference(mesh, rest);
    if (mesh.triangles.size() % 3 != 0)
      throw std::invalid_argument("mesh '" + mesh.name + "' has " + std::to_string(mesh.triangles.size()) +
                                  " triangle indices, not a multiple of 3");
    text += "o " + object_name(mesh.name, m) + "\n";
    for (std::size_t v = 0; v < positions.size(); ++v) {
      const Eigen::Vector3f p = positions[v].cast<float>();
      if (!p.allFinite())
        throw std::invalid_argument("mesh '" + mesh.name + "' vertex " + std::to_string(v) + " is not finite at the rest pose");
      text += "v ";
      append_float(text, p.x());
      text += ' ';
      append_float(text, p.y());
      text += ' ';
      append_float(text, p.z());
      text += '\n';
      if (text.size() >= kObjFlushBytes) flush();
    }
    for (std::size_t t = 0; t < mesh.triangles.size(); t += 3) {
      text += 'f';
      for (std::size_t k = 0; k < 3; ++k) {
        const std::uint32_t index = mesh.triangles[t + k];
        if (index >= positions.size())
          throw std::invalid_argument("mesh '" + mesh.name + "' triangle " + std::to_string(t / 3) + " names vertex " +
                                      std::to_string(index) + " of " + std::to_string(positions.size()));
        text += ' ';
        text += std::to_string(first_vertex + index);
      }
      text += '\n';
      if (text.size() >= kObjFlushBytes) flush();
    }
    first_vertex += positions.size();
  }
  flush();
  file.commit();
}

}  // namespace odyssey::io
