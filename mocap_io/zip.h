// Minimal zip archive support for .npz: members stored or deflated, zip64 in both directions.
// Reading trusts nothing in the archive: every offset and size is bounds-checked against the
// file, inflated output is checked against the declared size and CRC-32. Writing streams: a
// member's bytes go through deflate chunk by chunk, and the local header is patched with the
// sizes and CRC afterwards, so memory stays bounded whatever the member size.
#pragma once

#include <cstdint>
#include <cstdio>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace odyssey::io::zip {

enum class Method : std::uint16_t { Stored = 0, Deflated = 8 };

// One central directory record, with zip64 extra fields already applied.
struct Entry {
  std::string name;
  std::uint16_t method = 0;
  std::uint16_t flags = 0;
  std::uint32_t crc32 = 0;
  std::uint64_t compressed_size = 0;
  std::uint64_t uncompressed_size = 0;
  std::uint64_t local_header_offset = 0;
};

// The central directory of the archive at `path`, in archive order. Throws InputError(path, ...)
// when the file is not a zip archive, is truncated, or its directory is inconsistent.
std::vector<Entry> read_directory(const std::string& path);

// Reads one member's uncompressed bytes in sequence. `label` names the member in error
// messages (for example "member 'poses'"); every error is an InputError naming `path`.
class MemberReader {
 public:
  MemberReader(const std::string& path, const Entry& entry, std::string label);
  ~MemberReader();
  MemberReader(const MemberReader&) = delete;
  MemberReader& operator=(const MemberReader&) = delete;

  // Uncompressed bytes not yet read, as the directory declares them.
  std::uint64_t remaining() const;
  // Fills `out` completely; throws if the member ends or breaks before that.
  void read_exact(std::span<std::byte> out);
  // Call after the last byte: checks that the data ends exactly at the declared size and that
  // the CRC-32 of everything read matches the directory.
  void finish();

 private:
  struct State;
  std::unique_ptr<State> state_;
};

// Writes a zip archive into an open, seekable file that the caller owns and closes.
// I/O failures throw InputError naming `path`.
class Writer {
 public:
  struct Options {
    // Zip64 records even for small archives; lets tests check that readers handle them.
    bool force_zip64 = false;
    int deflate_level = 6;
  };

  Writer(std::FILE* file, std::string path);
  Writer(std::FILE* file, std::string path, Options options);
  ~Writer();
  Writer(const Writer&) = delete;
  Writer& operator=(const Writer&) = delete;

  // `size` is the exact number of uncompressed bytes that write() will deliver; it decides
  // whether the local header needs room for zip64 sizes before the data is seen.
  void begin_member(const std::string& name, Method method, std::uint64_t size);
  void write(std::span<const std::byte> bytes);
  void end_member();
  // Writes the central directory and end records and flushes; the file stays open.
  void finish();

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace odyssey::io::zip
