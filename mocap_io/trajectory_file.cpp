#include "mocap_io/trajectory_file.h"

#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <stdexcept>

#include "mocap_io/input_error.h"
#include "mocap_io/npy.h"
#include "mocap_io/output_file.h"

namespace odyssey::io {
namespace {

// Spools are copied into the archive in blocks of this size, so close() needs bounded memory
// whatever T is; 1 MiB is large enough that the per-call overhead of fread and the zip writer
// does not show.
constexpr std::size_t kCopyBlockBytes = std::size_t{1} << 20;

// "frame 12, value 7 of 30": where a flat index of a chunk lands, for messages.
std::string position_text(std::size_t first_frame, std::size_t index, std::size_t per_frame) {
  return "frame " + std::to_string(first_frame + index / per_frame) + ", value " + std::to_string(index % per_frame) + " of " +
         std::to_string(per_frame);
}

void check_size(const char* what, std::size_t found, std::size_t expected, const std::string& layout) {
  if (found != expected)
    throw std::invalid_argument(std::string("trajectory file: ") + what + " holds " + std::to_string(found) + " values, " +
                                layout + " need " + std::to_string(expected));
}

void check_finite(const char* what, std::span<const float> values, std::size_t first_frame, std::size_t per_frame) {
  const std::size_t bad = first_non_finite(values);
  if (bad != values.size())
    throw std::invalid_argument(std::string("trajectory file: ") + what + " value " + std::to_string(values[bad]) + " at " +
                                position_text(first_frame, bad, per_frame) + " is not finite");
}

// numpy reads any non-zero byte of a bool array as True but prints and compares the raw byte, so
// only 0 and 1 are accepted (the same max-reduction trick as for floats).
void check_bools(const char* what, std::span<const std::uint8_t> values, std::size_t first_frame, std::size_t per_frame) {
  std::uint8_t largest = 0;
  for (const std::uint8_t v : values) largest = std::max(largest, v);
  if (largest <= 1) return;
  const std::size_t bad = static_cast<std::size_t>(
      std::find_if(values.begin(), values.end(), [](std::uint8_t v) { return v > 1; }) - values.begin());
  throw std::invalid_argument(std::string("trajectory file: ") + what + " value " + std::to_string(values[bad]) + " at " +
                              position_text(first_frame, bad, per_frame) + " is not 0 or 1");
}

// A temporary file beside the output that one per-frame array accumulates in until close()
// copies it into the archive. Removed when destroyed, whatever happened.
class Spool {
 public:
  Spool(const std::string& target, std::string key, DType dtype, std::vector<std::size_t> frame_shape)
      : target_(target),
        key_(std::move(key)),
        temp_(target + ".partial-" + std::to_string(::getpid()) + "-" + key_),
        dtype_(dtype),
        frame_shape_(std::move(frame_shape)),
        file_(create_temporary_file(temp_, "w+b")) {
    if (!file_) throw InputError(target_, "cannot create temporary file " + temp_ + ": " + std::strerror(errno));
  }
  ~Spool() {
    std::fclose(file_);
    std::remove(temp_.c_str());
    forget_temporary(temp_);
  }
  Spool(const Spool&) = delete;
  Spool& operator=(const Spool&) = delete;

  void write(std::span<const std::byte> bytes) {
    if (std::fwrite(bytes.data(), 1, bytes.size(), file_) != bytes.size())
      throw InputError(target_, "write failed on temporary file " + temp_ + ": " + std::strerror(errno));
    bytes_ += bytes.size();
  }

  // Streams the spool into the archive as the array `key` of shape [frames, frame_shape...].
  void copy_into(NpzWriter& npz, std::size_t frames, std::vector<std::byte>& buffer) {
    if (std::fflush(file_) != 0 || std::ferror(file_) || fseeko(file_, 0, SEEK_SET) != 0)
      throw InputError(target_, "cannot rewind temporary file " + temp_ + ": " + std::strerror(errno));
    std::vector<std::size_t> shape{frames};
    shape.insert(shape.end(), frame_shape_.begin(), frame_shape_.end());
    npz.begin_array(key_, dtype_, std::move(shape));
    for (std::size_t left = bytes_; left > 0;) {
      const std::size_t block = std::min(left, buffer.size());
      errno = 0;
      if (std::fread(buffer.data(), 1, block, file_) != block)
        throw InputError(target_, "cannot read back temporary file " + temp_ +
                                      (errno ? std::string(": ") + std::strerror(errno) : std::string(" (it shrank)")));
      npz.append(std::span<const std::byte>(buffer.data(), block));
      left -= block;
    }
    npz.end_array();
  }

 private:
  const std::string& target_;
  std::string key_;
  std::string temp_;
  DType dtype_;
  std::vector<std::size_t> frame_shape_;
  std::FILE* file_;
  std::size_t bytes_ = 0;
};

// Everything on disk while the file is being written: the archive (under NpzWriter's temporary
// name, trajs_3d open in it) and the spools. Destroying it removes all of them unless the archive
// was closed.
struct Archive {
  Archive(const std::string& path, bool compress, std::size_t points)
      : npz(path, compress),
        trajs_2d(path, "trajs_2d", DType::Float32, {points, 2}),
        visibs(path, "visibs", DType::Bool, {points}),
        valids(path, "valids", DType::Bool, {points}),
        intrinsics(path, "intrinsics", DType::Float32, {3, 3}),
        extrinsics(path, "extrinsics", DType::Float32, {4, 4}) {}

  NpzWriter npz;
  Spool trajs_2d;
  Spool visibs;
  Spool valids;
  Spool intrinsics;
  Spool extrinsics;
  std::unique_ptr<Spool> visibility_codes;  // when the header asks for them
  std::unique_ptr<Spool> visibilities;      // likewise
};

}  // namespace

struct TrajectoryFileWriter::State {
  std::string path;  // outlives `archive`, whose spools refer to it
  TrajectoryFileHeader header;
  std::unique_ptr<Archive> archive;  // null once closed, or after a failed write
  std::size_t written = 0;
  bool closed = false;

  Archive& live() {
    if (closed) throw std::logic_error("TrajectoryFileWriter used after close()");
    if (!archive) throw std::logic_error("TrajectoryFileWriter used after a failed write; the file cannot be completed");
    return *archive;
  }
};

TrajectoryFileWriter::TrajectoryFileWriter(std::string path, TrajectoryFileHeader header, bool compress)
    : state_(std::make_unique<State>()) {
  const std::size_t T = header.frames, N = header.points;
  if (T == 0 || N == 0)
    throw std::invalid_argument("trajectory file: needs at least one frame and one point, got " + std::to_string(T) +
                                " frames and " + std::to_string(N) + " points");
  // The largest per-frame array holds max(3N, 16) floats; when T frames of it fit in size_t bytes,
  // every size computed from T and N below does too.
  constexpr std::size_t kMax = std::numeric_limits<std::size_t>::max();
  if (N > kMax / 12 || T > kMax / (std::max<std::size_t>(3 * N, 16) * sizeof(float)))
    throw std::invalid_argument("trajectory file: " + std::to_string(T) + " frames of " + std::to_string(N) +
                                " points are too many to address");
  if (!(header.fps > 0) || !std::isfinite(header.fps))
    throw std::invalid_argument("trajectory file: fps must be positive and finite, got " + std::to_string(header.fps));
  check_size("point_vertex_ids", header.point_vertex_ids.size(), 3 * N, std::to_string(N) + " points x 3 corners");
  check_size("point_barycentric", header.point_barycentric.size(), 3 * N, std::to_string(N) + " points x 3 corners");
  check_size("point_actor_ids", header.point_actor_ids.size(), N, std::to_string(N) + " points");
  const std::size_t bad = first_non_finite(header.point_barycentric);
  if (bad != header.point_barycentric.size())
    throw std::invalid_argument("trajectory file: point_barycentric value " + std::to_string(header.point_barycentric[bad]) +
                                " at index " + std::to_string(bad) + " is not finite");

  State& s = *state_;
  s.path = std::move(path);
  s.header = std::move(header);
  s.archive = std::make_unique<Archive>(s.path, compress, N);
  if (s.header.visibility_codes) {
    s.archive->visibility_codes = std::make_unique<Spool>(s.path, "visibility_codes", DType::UInt8, std::vector<std::size_t>{N});
  }
  if (s.header.visibilities) {
    if (!s.header.visibility_codes) throw std::invalid_argument("trajectory file: visibilities are derived from visibility_codes");
    s.archive->visibilities = std::make_unique<Spool>(s.path, "visibilities", DType::UInt8, std::vector<std::size_t>{N});
  }
  s.archive->npz.begin_array("trajs_3d", DType::Float32, {T, N, 3});
}

TrajectoryFileWriter::~TrajectoryFileWriter() = default;

void TrajectoryFileWriter::append_frames(std::size_t count, std::span<const float> trajs_3d, std::span<const float> trajs_2d,
                                         std::span<const std::uint8_t> valids, std::span<const std::uint8_t> visibs,
                                         std::span<const float> intrinsics, std::span<const float> extrinsics,
                                         std::span<const std::uint8_t> visibility_codes) {
  State& s = *state_;
  Archive& archive = s.live();
  const std::size_t T = s.header.frames, N = s.header.points;
  if (count > T - s.written)
    throw std::invalid_argument("trajectory file: " + std::to_string(count) + " more frames after " + std::to_string(s.written) +
                                " would make " + std::to_string(s.written + count) + ", the file holds " + std::to_string(T));
  // Every check comes before the first write, so a rejected chunk leaves the file as it was and
  // the caller may go on with a corrected one.
  const std::string frames = std::to_string(count) + " frames";
  check_size("trajs_3d", trajs_3d.size(), count * N * 3, frames + " x " + std::to_string(N) + " points x 3");
  check_size("trajs_2d", trajs_2d.size(), count * N * 2, frames + " x " + std::to_string(N) + " points x 2");
  check_size("valids", valids.size(), count * N, frames + " x " + std::to_string(N) + " points");
  check_size("visibs", visibs.size(), count * N, frames + " x " + std::to_string(N) + " points");
  check_size("intrinsics", intrinsics.size(), count * 9, frames + " x 3 x 3");
  check_size("extrinsics", extrinsics.size(), count * 16, frames + " x 4 x 4");
  check_finite("trajs_3d", trajs_3d, s.written, N * 3);
  check_finite("trajs_2d", trajs_2d, s.written, N * 2);
  check_finite("intrinsics", intrinsics, s.written, 9);
  check_finite("extrinsics", extrinsics, s.written, 16);
  check_bools("valids", valids, s.written, N);
  check_bools("visibs", visibs, s.written, N);
  // A point occluded or not is first of all in the image: visibs implies valids, that is (both being
  // 0 or 1) visibs <= valids everywhere; one pass of the same vectorisable kind as above.
  bool violation = false;
  for (std::size_t i = 0; i < visibs.size(); ++i) violation |= visibs[i] > valids[i];
  if (violation) {
    std::size_t bad = 0;
    while (visibs[bad] <= valids[bad]) ++bad;
    throw std::invalid_argument("trajectory file: visibs is 1 but valids 0 at " + position_text(s.written, bad, N) +
                                " (a visible point must be valid)");
  }
  check_size("visibility_codes", visibility_codes.size(), s.header.visibility_codes ? count * N : 0,
             s.header.visibility_codes ? frames + " x " + std::to_string(N) + " points" : "files without codes");
  // Each code agrees with the flags: visible exactly when 0; occluded (1, 2) only when valid;
  // outside the image or behind the camera (3, 4) exactly when not valid.
  for (std::size_t i = 0; i < visibility_codes.size(); ++i) {
    const std::uint8_t code = visibility_codes[i];
    const bool agrees = code == kVisible ? visibs[i] == 1
                        : code <= kOccludedByProp ? valids[i] == 1 && visibs[i] == 0
                        : code <= kBehindCamera ? valids[i] == 0
                                                : false;
    if (!agrees) {
      throw std::invalid_argument("trajectory file: visibility code " + std::to_string(code) + " disagrees with valids " +
                                  std::to_string(valids[i]) + " and visibs " + std::to_string(visibs[i]) + " at " +
                                  position_text(s.written, i, N));
    }
  }

  try {
    archive.npz.append(trajs_3d);
    archive.trajs_2d.write(std::as_bytes(trajs_2d));
    archive.visibs.write(std::as_bytes(visibs));
    archive.valids.write(std::as_bytes(valids));
    archive.intrinsics.write(std::as_bytes(intrinsics));
    archive.extrinsics.write(std::as_bytes(extrinsics));
    if (archive.visibility_codes) archive.visibility_codes->write(std::as_bytes(visibility_codes));
    if (archive.visibilities) {
      std::vector<std::uint8_t> three_state(visibility_codes.size());
      for (std::size_t i = 0; i < three_state.size(); ++i) {
        three_state[i] = visibility_codes[i] == kVisible ? 1 : visibility_codes[i] == kBehindCamera ? 2 : 0;
      }
      archive.visibilities->write(std::as_bytes(std::span<const std::uint8_t>(three_state)));
    }
  } catch (...) {
    s.archive.reset();  // the arrays are out of step now: remove everything
    throw;
  }
  s.written += count;
}

std::size_t TrajectoryFileWriter::frames_written() const { return state_->written; }

void TrajectoryFileWriter::close() {
  State& s = *state_;
  Archive& archive = s.live();
  // Whatever happens below, the writer is finished and its temporary files go.
  s.closed = true;
  const std::unique_ptr<Archive> owned = std::move(s.archive);
  const TrajectoryFileHeader& h = s.header;
  if (s.written < h.frames)
    throw std::invalid_argument("trajectory file " + s.path + ": closed after " + std::to_string(s.written) + " of " +
                                std::to_string(h.frames) + " frames");
  const std::size_t N = h.points;
  archive.npz.end_array();  // trajs_3d
  std::vector<std::byte> buffer(kCopyBlockBytes);
  for (Spool* spool : {&archive.trajs_2d, &archive.visibs, &archive.valids, &archive.intrinsics, &archive.extrinsics})
    spool->copy_into(archive.npz, h.frames, buffer);
  if (archive.visibility_codes) archive.visibility_codes->copy_into(archive.npz, h.frames, buffer);
  if (archive.visibilities) archive.visibilities->copy_into(archive.npz, h.frames, buffer);
  archive.npz.add("point_vertex_ids", NpyArray::from_int32(h.point_vertex_ids, {N, 3}));
  archive.npz.add("point_barycentric", NpyArray::from_float32(h.point_barycentric, {N, 3}));
  archive.npz.add("point_actor_ids", NpyArray::from_int32(h.point_actor_ids, {N}));
  archive.npz.add("fps", NpyArray::scalar_float64(h.fps));
  archive.npz.close();
}

}  // namespace odyssey::io
