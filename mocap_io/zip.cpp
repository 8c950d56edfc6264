#include "mocap_io/zip.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstring>
#include <new>
#include <stdexcept>

#include "mocap_io/input_error.h"

namespace odyssey::io::zip {
namespace {

constexpr std::uint32_t kLocalHeaderSignature = 0x04034b50;
constexpr std::uint32_t kCentralHeaderSignature = 0x02014b50;
constexpr std::uint32_t kEndSignature = 0x06054b50;
constexpr std::uint32_t kZip64EndSignature = 0x06064b50;
constexpr std::uint32_t kZip64LocatorSignature = 0x07064b50;
constexpr std::size_t kLocalHeaderSize = 30;
constexpr std::size_t kCentralHeaderSize = 46;
constexpr std::size_t kEndSize = 22;
constexpr std::size_t kZip64EndSize = 56;
constexpr std::size_t kZip64LocatorSize = 20;
constexpr std::uint16_t kZip64ExtraId = 0x0001;
constexpr std::uint32_t kSentinel32 = 0xFFFFFFFF;
constexpr std::uint16_t kSentinel16 = 0xFFFF;
constexpr std::uint16_t kFlagEncrypted = 0x0001;
constexpr std::uint16_t kFlagUtf8Name = 0x0800;
constexpr std::uint16_t kVersionDefault = 20;
constexpr std::uint16_t kVersionZip64 = 45;
// Deflate cannot compress better than about 1032:1; a larger declared ratio is a lie that would
// make us allocate memory the compressed data can never fill.
constexpr std::uint64_t kMaxDeflateRatio = 1032;
// I/O chunk: large enough that zlib and fread run at full speed, small enough to not matter.
constexpr std::size_t kChunk = std::size_t{1} << 18;
// zlib counts in uInt; feed it at most this much per call.
constexpr std::size_t kMaxZlibStep = std::size_t{1} << 30;

std::uint16_t load16(const std::byte* p) {
  return static_cast<std::uint16_t>(std::to_integer<unsigned>(p[0]) | std::to_integer<unsigned>(p[1]) << 8);
}
std::uint32_t load32(const std::byte* p) { return load16(p) | std::uint32_t{load16(p + 2)} << 16; }
std::uint64_t load64(const std::byte* p) { return load32(p) | std::uint64_t{load32(p + 4)} << 32; }

// A read-only file with its size, where every read is positioned and must be complete. Reads
// are single pread calls, no stdio buffer or seeks: an npz of many small members opens the file
// once per member, and each system call counts.
class InputFile {
 public:
  explicit InputFile(const std::string& path) : path_(path), fd_(::open(path.c_str(), O_RDONLY | O_CLOEXEC)) {
    if (fd_ < 0) throw InputError(path_, std::string("cannot open: ") + std::strerror(errno));
    struct stat status {};
    if (::fstat(fd_, &status) != 0) {
      const int error = errno;
      ::close(fd_);
      throw InputError(path_, std::string("cannot tell the file size: ") + std::strerror(error));
    }
    size_ = static_cast<std::uint64_t>(status.st_size);
  }
  ~InputFile() { ::close(fd_); }
  InputFile(const InputFile&) = delete;
  InputFile& operator=(const InputFile&) = delete;

  std::uint64_t size() const { return size_; }

  // `what` says which structure was being read, for the message when the file ends first.
  void read_at(std::uint64_t offset, std::span<std::byte> out, const std::string& what) {
    if (offset > size_ || out.size() > size_ - offset) throw InputError(path_, what + " lies past the end of the file (truncated?)");
    std::size_t done = 0;
    while (done < out.size()) {
      const ssize_t got = ::pread(fd_, out.data() + done, out.size() - done, static_cast<off_t>(offset + done));
      if (got < 0 && errno == EINTR) continue;
      if (got < 0) throw InputError(path_, std::string("read failed: ") + std::strerror(errno));
      if (got == 0) throw InputError(path_, "read failed (file shrank?)");
      done += static_cast<std::size_t>(got);
    }
  }

 private:
  std::string path_;
  int fd_;
  std::uint64_t size_ = 0;
};

struct EndRecord {
  std::uint64_t entry_count = 0;
  std::uint64_t directory_size = 0;
  std::uint64_t directory_offset = 0;
  std::uint64_t directory_limit = 0;  // where the end records begin: the directory must end before
};

EndRecord read_end_record(InputFile& in, const std::string& path) {
  if (in.size() < kEndSize) throw InputError(path, "not a zip archive (file too short)");
  // The end record sits before a comment of at most 65535 bytes: search backwards from the end.
  const std::uint64_t tail_size = std::min<std::uint64_t>(in.size(), kEndSize + 0xFFFF);
  std::vector<std::byte> tail(tail_size);
  in.read_at(in.size() - tail_size, tail, "end of central directory");
  std::size_t found = tail_size;
  for (std::size_t pos = tail_size - kEndSize + 1; pos-- > 0;) {
    if (load32(&tail[pos]) == kEndSignature && pos + kEndSize + load16(&tail[pos + 20]) <= tail_size) {
      found = pos;
      break;
    }
  }
  if (found == tail_size) throw InputError(path, "not a zip archive, or truncated (no end-of-central-directory record)");
  const std::byte* end = &tail[found];
  const std::uint64_t end_offset = in.size() - tail_size + found;
  if (load16(end + 4) != 0 || load16(end + 6) != 0) throw InputError(path, "multi-disk zip archives are not supported");

  EndRecord record;
  record.entry_count = load16(end + 10);
  record.directory_size = load32(end + 12);
  record.directory_offset = load32(end + 16);
  record.directory_limit = end_offset;

  if (end_offset >= kZip64LocatorSize) {
    std::array<std::byte, kZip64LocatorSize> locator;
    in.read_at(end_offset - kZip64LocatorSize, locator, "zip64 end locator");
    if (load32(locator.data()) == kZip64LocatorSignature) {
      const std::uint64_t zip64_offset = load64(locator.data() + 8);
      if (zip64_offset > end_offset - kZip64LocatorSize || end_offset - kZip64LocatorSize - zip64_offset < kZip64EndSize)
        throw InputError(path, "corrupt zip64 end record (offset out of range)");
      std::array<std::byte, kZip64EndSize> zip64_end;
      in.read_at(zip64_offset, zip64_end, "zip64 end record");
      if (load32(zip64_end.data()) != kZip64EndSignature) throw InputError(path, "corrupt zip64 end record (bad signature)");
      record.entry_count = load64(zip64_end.data() + 32);
      record.directory_size = load64(zip64_end.data() + 40);
      record.directory_offset = load64(zip64_end.data() + 48);
      record.directory_limit = zip64_offset;
    }
  }
  if (record.directory_offset > record.directory_limit || record.directory_size > record.directory_limit - record.directory_offset)
    throw InputError(path, "corrupt or truncated zip archive (central directory lies outside the file)");
  if (record.entry_count > record.directory_size / kCentralHeaderSize)
    throw InputError(path, "corrupt zip archive (" + std::to_string(record.entry_count) + " entries cannot fit in a " +
                               std::to_string(record.directory_size) + "-byte central directory)");
  return record;
}

std::string quoted_name(const std::string& name) {
  std::string out = "'";
  for (char c : name) out += (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) ? '?' : c;
  return out + "'";
}

// Zip64 extra field: 64-bit values for exactly those header fields that hold the sentinel.
void apply_zip64_extra(std::span<const std::byte> extra, Entry& entry, const std::string& path) {
  const bool want_size = entry.uncompressed_size == kSentinel32;
  const bool want_compressed = entry.compressed_size == kSentinel32;
  const bool want_offset = entry.local_header_offset == kSentinel32;
  std::size_t pos = 0;
  while (pos + 4 <= extra.size()) {
    const std::uint16_t id = load16(&extra[pos]);
    const std::uint16_t length = load16(&extra[pos + 2]);
    pos += 4;
    // A malformed block ends the scan; sizes left at the sentinel then fail the bounds checks.
    if (length > extra.size() - pos) break;
    if (id == kZip64ExtraId) {
      std::size_t field = pos;
      const std::size_t field_end = pos + length;
      auto take = [&](std::uint64_t& value) {
        if (field + 8 > field_end) throw InputError(path, "corrupt zip64 extra field for member " + quoted_name(entry.name));
        value = load64(&extra[field]);
        field += 8;
      };
      if (want_size) take(entry.uncompressed_size);
      if (want_compressed) take(entry.compressed_size);
      if (want_offset) take(entry.local_header_offset);
      return;
    }
    pos += length;
  }
}

}  // namespace

std::vector<Entry> read_directory(const std::string& path) {
  InputFile in(path);
  const EndRecord end = read_end_record(in, path);
  std::vector<std::byte> directory(end.directory_size);
  in.read_at(end.directory_offset, directory, "central directory");

  std::vector<Entry> entries;
  entries.reserve(end.entry_count);
  std::size_t pos = 0;
  for (std::uint64_t i = 0; i < end.entry_count; ++i) {
    if (directory.size() - pos < kCentralHeaderSize || load32(&directory[pos]) != kCentralHeaderSignature)
      throw InputError(path, "corrupt central directory (record " + std::to_string(i) + " is damaged)");
    const std::byte* h = &directory[pos];
    const std::size_t name_length = load16(h + 28);
    const std::size_t extra_length = load16(h + 30);
    const std::size_t comment_length = load16(h + 32);
    if (directory.size() - pos - kCentralHeaderSize < name_length + extra_length + comment_length)
      throw InputError(path, "corrupt central directory (record " + std::to_string(i) + " runs past its end)");
    Entry entry;
    entry.flags = load16(h + 8);
    entry.method = load16(h + 10);
    entry.crc32 = load32(h + 16);
    entry.compressed_size = load32(h + 20);
    entry.uncompressed_size = load32(h + 24);
    entry.local_header_offset = load32(h + 42);
    const std::byte* name = h + kCentralHeaderSize;
    entry.name.assign(reinterpret_cast<const char*>(name), name_length);
    apply_zip64_extra({name + name_length, extra_length}, entry, path);
    if (entry.local_header_offset > end.directory_offset || end.directory_offset - entry.local_header_offset < kLocalHeaderSize ||
        entry.compressed_size > end.directory_offset - entry.local_header_offset - kLocalHeaderSize)
      throw InputError(path, "corrupt zip archive (member " + quoted_name(entry.name) + " lies outside the data area)");
    entries.push_back(std::move(entry));
    pos += kCentralHeaderSize + name_length + extra_length + comment_length;
  }
  return entries;
}

// ---------------------------------------------------------------------------------------------

struct MemberReader::State {
  InputFile in;
  std::string path;
  std::string label;
  Entry entry;
  std::uint64_t data_position = 0;   // next compressed byte in the file
  std::uint64_t compressed_left = 0;  // compressed bytes not yet read from the file
  std::uint64_t produced = 0;         // uncompressed bytes delivered
  std::uint32_t crc = 0;
  z_stream inflater{};
  bool inflater_ready = false;
  bool stream_ended = false;
  std::vector<std::byte> input;

  State(const std::string& path_, const Entry& entry_, std::string label_)
      : in(path_), path(path_), label(std::move(label_)), entry(entry_) {}
  ~State() {
    if (inflater_ready) inflateEnd(&inflater);
  }

  [[noreturn]] void fail(const std::string& problem) const { throw InputError(path, label + ": " + problem); }

  void refill() {
    const std::size_t n = static_cast<std::size_t>(std::min<std::uint64_t>(input.size(), compressed_left));
    in.read_at(data_position, {input.data(), n}, label + " data");
    data_position += n;
    compressed_left -= n;
    inflater.next_in = reinterpret_cast<Bytef*>(input.data());
    inflater.avail_in = static_cast<uInt>(n);
  }

  // One inflate step into `out`; returns the bytes produced. Throws on corrupt or short data.
  std::size_t inflate_step(std::byte* out, std::size_t capacity) {
    if (inflater.avail_in == 0 && compressed_left > 0) refill();
    inflater.next_out = reinterpret_cast<Bytef*>(out);
    inflater.avail_out = static_cast<uInt>(std::min(capacity, kMaxZlibStep));
    const uInt before = inflater.avail_out;
    const int rc = inflate(&inflater, Z_NO_FLUSH);
    const std::size_t got = before - inflater.avail_out;
    switch (rc) {
      case Z_OK:
        break;
      case Z_STREAM_END:
        stream_ended = true;
        break;
      case Z_BUF_ERROR:
        if (inflater.avail_in == 0 && compressed_left == 0) fail("compressed data is truncated");
        break;
      case Z_MEM_ERROR:
        throw std::bad_alloc();
      default:
        fail(std::string("corrupt deflate data (") + (inflater.msg ? inflater.msg : "zlib error") + ")");
    }
    return got;
  }
};

MemberReader::MemberReader(const std::string& path, const Entry& entry, std::string label)
    : state_(std::make_unique<State>(path, entry, std::move(label))) {
  State& s = *state_;
  if (entry.flags & kFlagEncrypted) s.fail("encrypted members are not supported");
  if (entry.method == static_cast<std::uint16_t>(Method::Stored)) {
    if (entry.compressed_size != entry.uncompressed_size)
      s.fail("stored member sizes disagree (" + std::to_string(entry.compressed_size) + " vs " +
             std::to_string(entry.uncompressed_size) + " bytes)");
  } else if (entry.method == static_cast<std::uint16_t>(Method::Deflated)) {
    if (entry.uncompressed_size / kMaxDeflateRatio > entry.compressed_size + 1)
      s.fail("declared size " + std::to_string(entry.uncompressed_size) + " bytes is impossible for " +
             std::to_string(entry.compressed_size) + " compressed bytes");
  } else {
    s.fail("compression method " + std::to_string(entry.method) + " is not supported (only stored and deflated)");
  }

  std::array<std::byte, kLocalHeaderSize> local;
  s.in.read_at(entry.local_header_offset, local, s.label + " local header");
  if (load32(local.data()) != kLocalHeaderSignature) s.fail("corrupt local header (bad signature)");
  s.data_position = entry.local_header_offset + kLocalHeaderSize + load16(local.data() + 26) + load16(local.data() + 28);
  if (s.data_position > s.in.size() || entry.compressed_size > s.in.size() - s.data_position)
    s.fail("data runs past the end of the file (truncated archive)");
  s.compressed_left = entry.compressed_size;

  if (entry.method == static_cast<std::uint16_t>(Method::Deflated)) {
    if (inflateInit2(&s.inflater, -MAX_WBITS) != Z_OK) throw std::bad_alloc();
    s.inflater_ready = true;
    s.input.resize(static_cast<std::size_t>(std::min<std::uint64_t>(kChunk, std::max<std::uint64_t>(entry.compressed_size, 1))));
  }
}

MemberReader::~MemberReader() = default;

std::uint64_t MemberReader::remaining() const { return state_->entry.uncompressed_size - state_->produced; }

void MemberReader::read_exact(std::span<std::byte> out) {
  State& s = *state_;
  // Also guards crc32_z, which restarts the CRC when handed a null buffer.
  if (out.empty()) return;
  if (out.size() > remaining())
    s.fail("only " + std::to_string(remaining()) + " bytes left, " + std::to_string(out.size()) + " wanted");
  if (!s.inflater_ready) {
    s.in.read_at(s.data_position, out, s.label + " data");
    s.data_position += out.size();
    s.compressed_left -= out.size();
  } else {
    std::size_t filled = 0;
    while (filled < out.size()) {
      if (s.stream_ended)
        s.fail("deflate stream ends after " + std::to_string(s.produced + filled) + " of the declared " +
               std::to_string(s.entry.uncompressed_size) + " bytes: the member is corrupt");
      filled += s.inflate_step(out.data() + filled, out.size() - filled);
    }
  }
  s.crc = static_cast<std::uint32_t>(crc32_z(s.crc, reinterpret_cast<const Bytef*>(out.data()), out.size()));
  s.produced += out.size();
}

void MemberReader::finish() {
  State& s = *state_;
  if (remaining() != 0) throw std::logic_error("MemberReader::finish() before the member was read to its end");
  if (s.inflater_ready) {
    std::byte overflow;
    while (!s.stream_ended) {
      if (s.inflate_step(&overflow, 1) != 0)
        s.fail("inflated data is longer than the declared " + std::to_string(s.entry.uncompressed_size) + " bytes");
    }
  }
  if (s.crc != s.entry.crc32) {
    char message[96];
    std::snprintf(message, sizeof message, "CRC-32 mismatch (archive says %08x, data gives %08x): the file is corrupt",
                  static_cast<unsigned>(s.entry.crc32), static_cast<unsigned>(s.crc));
    s.fail(message);
  }
}

// ---------------------------------------------------------------------------------------------

namespace {

// Little-endian record builder.
class Record {
 public:
  Record& u16(std::uint16_t v) { return put(v, 2); }
  Record& u32(std::uint32_t v) { return put(v, 4); }
  Record& u64(std::uint64_t v) { return put(v, 8); }
  Record& text(const std::string& s) {
    for (char c : s) bytes_.push_back(static_cast<std::byte>(c));
    return *this;
  }
  std::span<const std::byte> bytes() const { return bytes_; }

 private:
  Record& put(std::uint64_t v, int n) {
    for (int i = 0; i < n; ++i) bytes_.push_back(static_cast<std::byte>(v >> (8 * i)));
    return *this;
  }
  std::vector<std::byte> bytes_;
};

std::uint32_t clamp32(std::uint64_t v, bool zip64) { return zip64 ? kSentinel32 : static_cast<std::uint32_t>(v); }

bool has_non_ascii(const std::string& s) {
  return std::any_of(s.begin(), s.end(), [](char c) { return static_cast<unsigned char>(c) >= 0x80; });
}

// Members carry a fixed timestamp (1980-01-01 00:00, the DOS epoch, as numpy writes) so that the
// same arrays always give byte-identical archives.
constexpr std::uint16_t kDosTime = 0;
constexpr std::uint16_t kDosDate = (1 << 5) | 1;
// Unix "made by" with regular-file permissions 0644, so unzip extracts readable files.
constexpr std::uint16_t kMadeByUnix = 3 << 8;
constexpr std::uint32_t kExternalAttributes = 0100644u << 16;

struct CentralRecord {
  std::string name;
  std::uint16_t method = 0;
  std::uint16_t flags = 0;
  std::uint32_t crc = 0;
  std::uint64_t compressed_size = 0;
  std::uint64_t size = 0;
  std::uint64_t offset = 0;
  bool local_zip64 = false;
};

}  // namespace

struct Writer::State {
  std::FILE* file;
  std::string path;
  Options options;
  std::uint64_t position = 0;
  std::vector<CentralRecord> records;
  bool member_open = false;
  CentralRecord current;
  std::uint64_t declared_size = 0;
  std::uint64_t written = 0;
  z_stream deflater{};
  bool deflater_ready = false;
  std::vector<std::byte> output;

  State(std::FILE* f, std::string p, Options o) : file(f), path(std::move(p)), options(o) {}
  ~State() {
    if (deflater_ready) deflateEnd(&deflater);
  }

  [[noreturn]] void fail_io(const char* what) const {
    const int error = errno;
    throw InputError(path, std::string(what) + (error ? std::string(": ") + std::strerror(error) : std::string()));
  }

  void put(std::span<const std::byte> bytes) {
    if (!bytes.empty() && std::fwrite(bytes.data(), 1, bytes.size(), file) != bytes.size()) fail_io("write failed");
    position += bytes.size();
  }

  void seek(std::uint64_t offset) {
    if (fseeko(file, static_cast<off_t>(offset), SEEK_SET) != 0) fail_io("seek failed");
  }

  // Runs deflate until it has consumed its input (or finished), writing each full output buffer.
  void pump(int flush) {
    for (;;) {
      deflater.next_out = reinterpret_cast<Bytef*>(output.data());
      deflater.avail_out = static_cast<uInt>(output.size());
      const int rc = deflate(&deflater, flush);
      if (rc == Z_STREAM_ERROR) throw std::logic_error("zlib deflate stream error");
      const std::size_t produced = output.size() - deflater.avail_out;
      put({output.data(), produced});
      current.compressed_size += produced;
      if (flush == Z_FINISH ? rc == Z_STREAM_END : (deflater.avail_in == 0 && deflater.avail_out != 0)) return;
    }
  }
};

Writer::Writer(std::FILE* file, std::string path) : Writer(file, std::move(path), Options{}) {}

Writer::Writer(std::FILE* file, std::string path, Options options)
    : state_(std::make_unique<State>(file, std::move(path), options)) {}

Writer::~Writer() = default;

void Writer::begin_member(const std::string& name, Method method, std::uint64_t size) {
  State& s = *state_;
  if (s.member_open) throw std::logic_error("zip::Writer::begin_member() while a member is open");
  if (name.size() > 0xFFFF) throw std::invalid_argument("zip member name longer than 65535 bytes");
  s.current = CentralRecord{};
  s.current.name = name;
  s.current.method = static_cast<std::uint16_t>(method);
  s.current.flags = has_non_ascii(name) ? kFlagUtf8Name : 0;
  s.current.offset = s.position;
  // The local header is written before the data, so it must reserve zip64 room whenever the
  // compressed size could reach 4 GiB; compressBound is zlib's worst case for deflate.
  const std::uint64_t worst_case = method == Method::Deflated ? compressBound(size) : size;
  s.current.local_zip64 = s.options.force_zip64 || worst_case >= kSentinel32;
  s.declared_size = size;
  s.written = 0;

  Record header;
  header.u32(kLocalHeaderSignature)
      .u16(s.current.local_zip64 ? kVersionZip64 : kVersionDefault)
      .u16(s.current.flags)
      .u16(s.current.method)
      .u16(kDosTime)
      .u16(kDosDate)
      .u32(0)
      .u32(clamp32(0, s.current.local_zip64))
      .u32(clamp32(0, s.current.local_zip64))
      .u16(static_cast<std::uint16_t>(name.size()))
      .u16(s.current.local_zip64 ? 20 : 0)
      .text(name);
  if (s.current.local_zip64) header.u16(kZip64ExtraId).u16(16).u64(0).u64(0);
  s.put(header.bytes());

  if (method == Method::Deflated) {
    const int rc = s.deflater_ready ? deflateReset(&s.deflater)
                                    : deflateInit2(&s.deflater, s.options.deflate_level, Z_DEFLATED, -MAX_WBITS, 8, Z_DEFAULT_STRATEGY);
    if (rc != Z_OK) throw std::bad_alloc();
    s.deflater_ready = true;
    s.output.resize(kChunk);
  }
  s.member_open = true;
}

void Writer::write(std::span<const std::byte> bytes) {
  State& s = *state_;
  if (!s.member_open) throw std::logic_error("zip::Writer::write() without an open member");
  if (bytes.size() > s.declared_size - s.written)
    throw std::logic_error("zip member '" + s.current.name + "' receives more bytes than declared");
  // Also guards crc32_z, which restarts the CRC when handed a null buffer.
  if (bytes.empty()) return;
  s.current.crc = static_cast<std::uint32_t>(crc32_z(s.current.crc, reinterpret_cast<const Bytef*>(bytes.data()), bytes.size()));
  s.written += bytes.size();
  if (s.current.method == static_cast<std::uint16_t>(Method::Stored)) {
    s.put(bytes);
    s.current.compressed_size += bytes.size();
    return;
  }
  while (!bytes.empty()) {
    const std::size_t step = std::min(bytes.size(), kMaxZlibStep);
    s.deflater.next_in = const_cast<Bytef*>(reinterpret_cast<const Bytef*>(bytes.data()));
    s.deflater.avail_in = static_cast<uInt>(step);
    s.pump(Z_NO_FLUSH);
    bytes = bytes.subspan(step);
  }
}

void Writer::end_member() {
  State& s = *state_;
  if (!s.member_open) throw std::logic_error("zip::Writer::end_member() without an open member");
  if (s.written != s.declared_size)
    throw std::logic_error("zip member '" + s.current.name + "' got " + std::to_string(s.written) + " of " +
                           std::to_string(s.declared_size) + " declared bytes");
  if (s.current.method == static_cast<std::uint16_t>(Method::Deflated)) {
    s.deflater.next_in = nullptr;
    s.deflater.avail_in = 0;
    s.pump(Z_FINISH);
  }
  s.current.size = s.written;
  if (!s.current.local_zip64 && s.current.compressed_size >= kSentinel32)
    throw std::logic_error("zip member '" + s.current.name + "' outgrew its local header");

  // Sizes and CRC are known only now: patch them into the local header.
  const bool zip64 = s.current.local_zip64;
  Record patch;
  patch.u32(s.current.crc).u32(clamp32(s.current.compressed_size, zip64)).u32(clamp32(s.current.size, zip64));
  s.seek(s.current.offset + 14);
  if (std::fwrite(patch.bytes().data(), 1, patch.bytes().size(), s.file) != patch.bytes().size()) s.fail_io("write failed");
  if (zip64) {
    Record sizes;
    sizes.u64(s.current.size).u64(s.current.compressed_size);
    s.seek(s.current.offset + kLocalHeaderSize + s.current.name.size() + 4);
    if (std::fwrite(sizes.bytes().data(), 1, sizes.bytes().size(), s.file) != sizes.bytes().size()) s.fail_io("write failed");
  }
  s.seek(s.position);
  s.records.push_back(std::move(s.current));
  s.member_open = false;
}

void Writer::finish() {
  State& s = *state_;
  if (s.member_open) throw std::logic_error("zip::Writer::finish() while member '" + s.current.name + "' is open");
  const bool force = s.options.force_zip64;
  const std::uint64_t directory_offset = s.position;
  for (const CentralRecord& r : s.records) {
    const bool big_size = force || r.size >= kSentinel32;
    const bool big_compressed = force || r.compressed_size >= kSentinel32;
    const bool big_offset = force || r.offset >= kSentinel32;
    Record extra;
    if (big_size) extra.u64(r.size);
    if (big_compressed) extra.u64(r.compressed_size);
    if (big_offset) extra.u64(r.offset);
    const auto extra_length = static_cast<std::uint16_t>(extra.bytes().size());
    const bool zip64 = r.local_zip64 || extra_length > 0;
    const std::uint16_t version = zip64 ? kVersionZip64 : kVersionDefault;

    Record header;
    header.u32(kCentralHeaderSignature)
        .u16(kMadeByUnix | version)
        .u16(version)
        .u16(r.flags)
        .u16(r.method)
        .u16(kDosTime)
        .u16(kDosDate)
        .u32(r.crc)
        .u32(clamp32(r.compressed_size, big_compressed))
        .u32(clamp32(r.size, big_size))
        .u16(static_cast<std::uint16_t>(r.name.size()))
        .u16(extra_length > 0 ? static_cast<std::uint16_t>(extra_length + 4) : 0)
        .u16(0)
        .u16(0)
        .u16(0)
        .u32(kExternalAttributes)
        .u32(clamp32(r.offset, big_offset))
        .text(r.name);
    if (extra_length > 0) header.u16(kZip64ExtraId).u16(extra_length);
    s.put(header.bytes());
    s.put(extra.bytes());
  }
  const std::uint64_t directory_size = s.position - directory_offset;
  const std::uint64_t count = s.records.size();
  const bool zip64_end = force || count >= kSentinel16 || directory_size >= kSentinel32 || directory_offset >= kSentinel32;

  Record end;
  if (zip64_end) {
    const std::uint64_t zip64_end_offset = s.position;
    end.u32(kZip64EndSignature)
        .u64(kZip64EndSize - 12)
        .u16(kMadeByUnix | kVersionZip64)
        .u16(kVersionZip64)
        .u32(0)
        .u32(0)
        .u64(count)
        .u64(count)
        .u64(directory_size)
        .u64(directory_offset);
    end.u32(kZip64LocatorSignature).u32(0).u64(zip64_end_offset).u32(1);
  }
  const std::uint16_t count16 = zip64_end ? kSentinel16 : static_cast<std::uint16_t>(count);
  end.u32(kEndSignature)
      .u16(0)
      .u16(0)
      .u16(count16)
      .u16(count16)
      .u32(clamp32(directory_size, zip64_end))
      .u32(clamp32(directory_offset, zip64_end))
      .u16(0);
  s.put(end.bytes());
  if (std::fflush(s.file) != 0) s.fail_io("write failed");
}

}  // namespace odyssey::io::zip
