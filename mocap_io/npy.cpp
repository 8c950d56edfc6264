#include "mocap_io/npy.h"

#include <unistd.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string_view>
#include <unordered_set>

#include "mocap_io/output_file.h"
#include "mocap_io/zip.h"

namespace odyssey::io {
namespace {

static_assert(std::endian::native == std::endian::little,
              "arrays are normalised to little-endian on load and written as little-endian without conversion");

constexpr std::string_view kMagic{"\x93NUMPY", 6};
constexpr std::size_t kPreambleV1 = 10;  // magic, version, 16-bit header length
constexpr std::size_t kPreambleV2 = 12;  // magic, version, 32-bit header length
// numpy writes headers of a few hundred bytes; the bound keeps a hostile length from costing memory.
constexpr std::size_t kMaxHeaderBytes = std::size_t{1} << 20;
// numpy pads headers so that the data starts on a 64-byte boundary (memory-mapping friendly).
constexpr std::size_t kDataAlignment = 64;

// Untrusted names and header text go into one-line messages: control characters become '?'.
std::string printable(std::string_view text, std::size_t limit = 80) {
  std::string out;
  for (char c : text.substr(0, limit)) out += (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) ? '?' : c;
  if (text.size() > limit) out += "...";
  return out;
}

std::string quoted(std::string_view name) { return "'" + printable(name) + "'"; }

std::string shape_text(const std::vector<std::size_t>& shape) {
  std::string out = "(";
  for (std::size_t i = 0; i < shape.size(); ++i) out += (i ? ", " : "") + std::to_string(shape[i]);
  return out + (shape.size() == 1 ? ",)" : ")");
}

// Who to blame in a message: the file, and inside an archive the member.
struct Where {
  const std::string& file;
  std::string member;  // "member 'poses'", or empty for a standalone .npy

  [[noreturn]] void fail(const std::string& problem) const {
    throw InputError(file, member.empty() ? problem : member + ": " + problem);
  }
};

std::size_t natural_item_size(DType dtype) {
  switch (dtype) {
    case DType::Bool:
    case DType::Int8:
    case DType::UInt8:
      return 1;
    case DType::Int16:
    case DType::UInt16:
      return 2;
    case DType::Int32:
    case DType::UInt32:
    case DType::Float32:
      return 4;
    case DType::Int64:
    case DType::UInt64:
    case DType::Float64:
    case DType::Object:
      return 8;
    case DType::Unicode:
    case DType::Bytes:
      return 0;
  }
  return 0;
}

bool checked_product(const std::vector<std::size_t>& shape, std::size_t& product) {
  product = 1;
  for (std::size_t d : shape)
    if (__builtin_mul_overflow(product, d, &product)) return false;
  return true;
}

// --- reading ---------------------------------------------------------------------------------

struct Descr {
  DType dtype;
  std::size_t item_size;
  bool big_endian;
};

Descr parse_descr(std::string_view descr, const Where& where) {
  auto unsupported = [&]() -> Descr { where.fail("unsupported dtype " + quoted(descr)); };
  if (descr.size() < 2 || std::string_view("<>|=").find(descr[0]) == std::string_view::npos) return unsupported();
  const bool big_endian = descr[0] == '>';
  const char kind = descr[1];
  const std::string_view digits = descr.substr(2);
  if (kind == 'O') return digits.empty() || digits == "8" ? Descr{DType::Object, 8, big_endian} : unsupported();
  if (digits.empty() || digits.size() > 12 || !std::all_of(digits.begin(), digits.end(), [](char c) { return c >= '0' && c <= '9'; }))
    return unsupported();
  const std::size_t size = std::stoull(std::string(digits));
  switch (kind) {
    case 'b':
      if (size == 1) return {DType::Bool, 1, big_endian};
      break;
    case 'i':
      if (size == 1) return {DType::Int8, 1, big_endian};
      if (size == 2) return {DType::Int16, 2, big_endian};
      if (size == 4) return {DType::Int32, 4, big_endian};
      if (size == 8) return {DType::Int64, 8, big_endian};
      break;
    case 'u':
      if (size == 1) return {DType::UInt8, 1, big_endian};
      if (size == 2) return {DType::UInt16, 2, big_endian};
      if (size == 4) return {DType::UInt32, 4, big_endian};
      if (size == 8) return {DType::UInt64, 8, big_endian};
      break;
    case 'f':
      if (size == 4) return {DType::Float32, 4, big_endian};
      if (size == 8) return {DType::Float64, 8, big_endian};
      break;
    case 'U':  // size counts UTF-32 code units
      return {DType::Unicode, size * 4, big_endian};
    case 'S':
      return {DType::Bytes, size, big_endian};
  }
  return unsupported();
}

// The header is a Python dict literal as numpy's format module writes it. Only the subset numpy
// can produce is accepted: three known keys, string / bool / tuple-of-int values, any key order,
// optional trailing comma, whitespace anywhere between tokens.
class HeaderParser {
 public:
  HeaderParser(std::string_view text, const Where& where) : text_(text), where_(where) {}

  NpyHeader parse() {
    std::string descr;
    bool has_descr = false, has_order = false, has_shape = false;
    NpyHeader header;
    expect('{');
    while (!accept('}')) {
      const std::string key(string_literal());
      expect(':');
      if (key == "descr") {
        mark(has_descr, key);
        skip_space();
        if (pos_ < text_.size() && text_[pos_] == '[') fail("structured dtypes are not supported");
        descr = string_literal();
      } else if (key == "fortran_order") {
        mark(has_order, key);
        header.fortran_order = boolean();
      } else if (key == "shape") {
        mark(has_shape, key);
        header.shape = shape_tuple();
      } else {
        fail("unexpected key " + quoted(key));
      }
      if (!accept(',')) {
        expect('}');
        break;
      }
    }
    skip_space();
    if (pos_ != text_.size()) fail("unexpected text after the dictionary");
    if (!has_descr) fail("missing key 'descr'");
    if (!has_order) fail("missing key 'fortran_order'");
    if (!has_shape) fail("missing key 'shape'");

    const Descr d = parse_descr(descr, where_);
    header.dtype = d.dtype;
    header.item_size = d.item_size;
    header.big_endian = d.big_endian;
    std::size_t count = 0, bytes = 0;
    if (!checked_product(header.shape, count) || __builtin_mul_overflow(count, header.item_size, &bytes))
      where_.fail("shape " + shape_text(header.shape) + " of " + quoted(descr) + " is too large to address");
    // Zero-width text elements hold no data, so their count is not backed by the file and each
    // would still cost a string in memory; numpy never writes them (it widens U0 and S0 to 1).
    if (header.item_size == 0 && count > 0)
      where_.fail("dtype " + quoted(descr) + " has zero width, yet shape " + shape_text(header.shape) + " gives it " +
                  std::to_string(count) + " elements");
    return header;
  }

 private:
  [[noreturn]] void fail(const std::string& problem) const {
    where_.fail("bad .npy header: " + problem + " in \"" + printable(text_, 160) + "\"");
  }

  void mark(bool& seen, const std::string& key) const {
    if (seen) fail("duplicate key " + quoted(key));
    seen = true;
  }

  void skip_space() {
    while (pos_ < text_.size() && (text_[pos_] == ' ' || text_[pos_] == '\t' || text_[pos_] == '\n' || text_[pos_] == '\r')) ++pos_;
  }

  bool accept(char c) {
    skip_space();
    if (pos_ < text_.size() && text_[pos_] == c) {
      ++pos_;
      return true;
    }
    return false;
  }

  void expect(char c) {
    if (!accept(c)) fail(std::string("expected '") + c + "' at offset " + std::to_string(pos_));
  }

  std::string_view string_literal() {
    skip_space();
    if (pos_ >= text_.size() || (text_[pos_] != '\'' && text_[pos_] != '"')) fail("expected a string at offset " + std::to_string(pos_));
    const char quote = text_[pos_++];
    const std::size_t start = pos_;
    while (pos_ < text_.size() && text_[pos_] != quote) {
      if (text_[pos_] == '\\' || text_[pos_] == '\n') fail("unsupported character in a string");
      ++pos_;
    }
    if (pos_ >= text_.size()) fail("unterminated string");
    return text_.substr(start, pos_++ - start);
  }

  bool word(std::string_view w) {
    if (text_.substr(pos_, w.size()) != w) return false;
    const std::size_t end = pos_ + w.size();
    if (end < text_.size() && (std::isalnum(static_cast<unsigned char>(text_[end])) || text_[end] == '_')) return false;
    pos_ = end;
    return true;
  }

  bool boolean() {
    skip_space();
    if (word("True")) return true;
    if (word("False")) return false;
    fail("fortran_order must be True or False");
  }

  std::vector<std::size_t> shape_tuple() {
    std::vector<std::size_t> shape;
    expect('(');
    bool trailing_comma = false;
    while (!accept(')')) {
      skip_space();
      const std::size_t start = pos_;
      std::size_t value = 0;
      while (pos_ < text_.size() && text_[pos_] >= '0' && text_[pos_] <= '9') {
        if (__builtin_mul_overflow(value, std::size_t{10}, &value) || __builtin_add_overflow(value, std::size_t(text_[pos_] - '0'), &value))
          fail("shape dimension too large");
        ++pos_;
      }
      if (pos_ == start) fail("shape must be a tuple of non-negative integers");
      if (pos_ < text_.size() && text_[pos_] == 'L') ++pos_;  // Python 2 long literal, seen in old AMASS files
      shape.push_back(value);
      trailing_comma = accept(',');
      if (!trailing_comma) {
        expect(')');
        break;
      }
    }
    if (shape.size() == 1 && !trailing_comma) fail("shape is not a tuple");
    return shape;
  }

  std::string_view text_;
  const Where& where_;
  std::size_t pos_ = 0;
};

// Byte sources an array can be read from: a memory span, a file, a zip member. Each says how many
// bytes are left, fills a buffer exactly, and verifies its own integrity at the end.
class SpanSource {
 public:
  explicit SpanSource(std::span<const std::byte> bytes) : bytes_(bytes) {}
  std::uint64_t remaining() const { return bytes_.size() - pos_; }
  void read_exact(std::span<std::byte> out) {
    if (out.empty()) return;  // an empty array's buffer may be null, which memcpy must not see
    std::memcpy(out.data(), bytes_.data() + pos_, out.size());
    pos_ += out.size();
  }
  void finish() {}

 private:
  std::span<const std::byte> bytes_;
  std::size_t pos_ = 0;
};

struct FileCloser {
  void operator()(std::FILE* f) const { std::fclose(f); }
};
using FileHandle = std::unique_ptr<std::FILE, FileCloser>;

class FileSource {
 public:
  explicit FileSource(const std::string& path) : path_(path), file_(std::fopen(path.c_str(), "rb")) {
    if (!file_) throw InputError(path, std::string("cannot open: ") + std::strerror(errno));
    if (fseeko(file_.get(), 0, SEEK_END) != 0) throw InputError(path, "cannot seek");
    const off_t size = ftello(file_.get());
    if (size < 0 || fseeko(file_.get(), 0, SEEK_SET) != 0) throw InputError(path, "cannot seek");
    remaining_ = static_cast<std::uint64_t>(size);
  }
  std::uint64_t remaining() const { return remaining_; }
  void read_exact(std::span<std::byte> out) {
    errno = 0;
    if (std::fread(out.data(), 1, out.size(), file_.get()) != out.size())
      throw InputError(path_, std::string("read failed") + (errno ? std::string(": ") + std::strerror(errno) : " (file shrank?)"));
    remaining_ -= out.size();
  }
  void finish() {}

 private:
  const std::string& path_;
  FileHandle file_;
  std::uint64_t remaining_ = 0;
};

template <class Source>
NpyHeader read_header(Source& source, const Where& where) {
  std::array<std::byte, kPreambleV2> preamble{};
  if (source.remaining() < kPreambleV1) where.fail("not an .npy array (too short)");
  source.read_exact({preamble.data(), kPreambleV1});
  if (std::memcmp(preamble.data(), kMagic.data(), kMagic.size()) != 0) where.fail("not an .npy array (bad magic bytes)");
  const unsigned major = std::to_integer<unsigned>(preamble[6]);
  const unsigned minor = std::to_integer<unsigned>(preamble[7]);
  if (major < 1 || major > 3 || minor != 0)
    where.fail("unsupported .npy format version " + std::to_string(major) + "." + std::to_string(minor));
  std::size_t header_length = std::to_integer<std::size_t>(preamble[8]) | std::to_integer<std::size_t>(preamble[9]) << 8;
  if (major >= 2) {
    if (source.remaining() < 2) where.fail("header truncated");
    source.read_exact({preamble.data() + kPreambleV1, 2});
    header_length |= std::to_integer<std::size_t>(preamble[10]) << 16 | std::to_integer<std::size_t>(preamble[11]) << 24;
  }
  if (header_length > kMaxHeaderBytes)
    where.fail("header length " + std::to_string(header_length) + " exceeds the limit of " + std::to_string(kMaxHeaderBytes) + " bytes");
  if (header_length > source.remaining())
    where.fail("header truncated: it declares " + std::to_string(header_length) + " bytes, " + std::to_string(source.remaining()) +
               " remain");
  std::string text(header_length, '\0');
  source.read_exact(std::as_writable_bytes(std::span(text)));
  return HeaderParser(text, where).parse();
}

void swap_units(std::span<std::byte> data, std::size_t unit) {
  std::byte* p = data.data();
  const std::size_t n = data.size() / unit;
  switch (unit) {
    case 2:
      for (std::size_t i = 0; i < n; ++i) {
        std::uint16_t v;
        std::memcpy(&v, p + 2 * i, 2);
        v = __builtin_bswap16(v);
        std::memcpy(p + 2 * i, &v, 2);
      }
      break;
    case 4:
      for (std::size_t i = 0; i < n; ++i) {
        std::uint32_t v;
        std::memcpy(&v, p + 4 * i, 4);
        v = __builtin_bswap32(v);
        std::memcpy(p + 4 * i, &v, 4);
      }
      break;
    case 8:
      for (std::size_t i = 0; i < n; ++i) {
        std::uint64_t v;
        std::memcpy(&v, p + 8 * i, 8);
        v = __builtin_bswap64(v);
        std::memcpy(p + 8 * i, &v, 8);
      }
      break;
  }
}

template <std::size_t Size>
void gather_row(const std::byte* src, std::size_t stride, std::size_t count, std::byte* dst) {
  for (std::size_t j = 0; j < count; ++j) std::memcpy(dst + j * Size, src + j * stride, Size);
}

// Fortran order to C order for any rank: walks the C-order destination sequentially, reading
// each innermost row from the source with the Fortran stride of the last axis.
std::vector<std::byte> fortran_to_c(const std::vector<std::byte>& src, const std::vector<std::size_t>& shape, std::size_t item) {
  std::vector<std::byte> dst(src.size());
  if (src.empty()) return dst;
  const std::size_t rank = shape.size();
  std::vector<std::size_t> stride(rank);
  for (std::size_t k = 0, s = item; k < rank; ++k) {
    stride[k] = s;
    s *= shape[k];
  }
  const std::size_t row = shape[rank - 1];
  const std::size_t row_stride = stride[rank - 1];
  std::vector<std::size_t> index(rank, 0);
  std::size_t base = 0;
  std::byte* out = dst.data();
  for (;;) {
    switch (item) {
      case 1: gather_row<1>(src.data() + base, row_stride, row, out); break;
      case 2: gather_row<2>(src.data() + base, row_stride, row, out); break;
      case 4: gather_row<4>(src.data() + base, row_stride, row, out); break;
      case 8: gather_row<8>(src.data() + base, row_stride, row, out); break;
      default:
        for (std::size_t j = 0; j < row; ++j) std::memcpy(out + j * item, src.data() + base + j * row_stride, item);
    }
    out += row * item;
    std::size_t k = rank - 1;
    for (;;) {
      if (k == 0) return dst;
      --k;
      if (++index[k] < shape[k]) {
        base += stride[k];
        break;
      }
      index[k] = 0;
      base -= stride[k] * (shape[k] - 1);
    }
  }
}

template <class Source>
NpyArray read_array(Source& source, const Where& where) {
  NpyArray array;
  array.header = read_header(source, where);
  const NpyHeader& header = array.header;
  if (header.dtype == DType::Object) {
    const std::string problem = "is a pickled object array; object arrays are not loaded";
    throw InputError(where.file, where.member.empty() ? "the array " + problem : where.member + " " + problem);
  }
  const std::size_t expected = header.element_count() * header.item_size;  // overflow-checked by the parser
  const std::uint64_t found = source.remaining();
  if (found < expected)
    where.fail("data truncated: expected " + std::to_string(expected) + " bytes, found " + std::to_string(found));
  if (found > expected)
    where.fail("data length mismatch: shape " + shape_text(header.shape) + " needs " + std::to_string(expected) + " bytes, found " +
               std::to_string(found));
  array.data.resize(expected);
  source.read_exact(array.data);
  source.finish();

  if (header.big_endian) swap_units(array.data, header.dtype == DType::Unicode ? 4 : header.item_size);
  if (header.fortran_order && header.shape.size() > 1) array.data = fortran_to_c(array.data, header.shape, header.item_size);
  return array;
}

// --- writing ---------------------------------------------------------------------------------

std::string descr_of(DType dtype, std::size_t item_size) {
  switch (dtype) {
    case DType::Bool: return "|b1";
    case DType::Int8: return "|i1";
    case DType::Int16: return "<i2";
    case DType::Int32: return "<i4";
    case DType::Int64: return "<i8";
    case DType::UInt8: return "|u1";
    case DType::UInt16: return "<u2";
    case DType::UInt32: return "<u4";
    case DType::UInt64: return "<u8";
    case DType::Float32: return "<f4";
    case DType::Float64: return "<f8";
    case DType::Unicode: return "<U" + std::to_string(item_size / 4);
    case DType::Bytes: return "|S" + std::to_string(item_size);
    case DType::Object: break;
  }
  throw std::invalid_argument("object arrays cannot be written");
}

// Checks that dtype, item size and shape can be written and returns the data size in bytes.
std::size_t data_bytes_for_writing(DType dtype, std::size_t item_size, const std::vector<std::size_t>& shape) {
  if (dtype == DType::Object) throw std::invalid_argument("object arrays cannot be written");
  const std::size_t natural = natural_item_size(dtype);
  if (natural != 0 && item_size != natural)
    throw std::invalid_argument(std::string("item size ") + std::to_string(item_size) + " does not match dtype " + dtype_name(dtype));
  if (natural == 0 && (item_size == 0 || (dtype == DType::Unicode && item_size % 4 != 0)))
    throw std::invalid_argument(std::string("bad item size ") + std::to_string(item_size) + " for a " + dtype_name(dtype) +
                                " array (unicode: 4 bytes per character)");
  std::size_t count = 0, bytes = 0;
  if (!checked_product(shape, count) || __builtin_mul_overflow(count, item_size, &bytes))
    throw std::invalid_argument("shape " + shape_text(shape) + " is too large");
  return bytes;
}

// Magic, version, length and the padded dict, exactly as numpy.lib.format writes them.
std::string npy_preamble(DType dtype, std::size_t item_size, const std::vector<std::size_t>& shape) {
  std::string dict = "{'descr': '" + descr_of(dtype, item_size) + "', 'fortran_order': False, 'shape': " + shape_text(shape) + ", }";
  auto padded = [&](std::size_t preamble) {
    const std::size_t unpadded = preamble + dict.size() + 1;  // + '\n'
    return dict + std::string((kDataAlignment - unpadded % kDataAlignment) % kDataAlignment, ' ') + '\n';
  };
  std::string header = padded(kPreambleV1);
  const bool v1 = header.size() <= 0xFFFF;
  if (!v1) header = padded(kPreambleV2);
  std::string out(kMagic);
  out += static_cast<char>(v1 ? 1 : 2);
  out += '\0';
  const std::size_t length_bytes = v1 ? 2 : 4;
  for (std::size_t i = 0; i < length_bytes; ++i) out += static_cast<char>((header.size() >> (8 * i)) & 0xFF);
  return out + header;
}

void check_data_size(const NpyArray& array) {
  std::size_t count = 0, bytes = 0;
  if (!checked_product(array.shape(), count) || __builtin_mul_overflow(count, array.header.item_size, &bytes) ||
      bytes != array.data.size())
    throw std::invalid_argument("array data holds " + std::to_string(array.data.size()) + " bytes, shape " +
                                shape_text(array.shape()) + " of " + dtype_name(array.dtype()) + " needs another size");
}

// --- conversions -----------------------------------------------------------------------------

void check_layout(const NpyArray& array) {
  const std::size_t natural = natural_item_size(array.dtype());
  if (natural != 0 && array.header.item_size != natural)
    throw std::invalid_argument(std::string("item size ") + std::to_string(array.header.item_size) + " does not match dtype " +
                                dtype_name(array.dtype()));
  check_data_size(array);
}

template <class Out, class In>
void widen(const std::byte* src, std::size_t n, Out* dst) {
  for (std::size_t i = 0; i < n; ++i) {
    In v;
    std::memcpy(&v, src + i * sizeof(In), sizeof(In));
    dst[i] = static_cast<Out>(v);
  }
}

template <class Out>
std::vector<Out> convert(const NpyArray& array, const char* target) {
  check_layout(array);
  // Refused before `out` is sized from the shape.
  if (array.dtype() == DType::Unicode || array.dtype() == DType::Bytes || array.dtype() == DType::Object)
    throw std::invalid_argument(std::string("cannot convert a ") + dtype_name(array.dtype()) + " array to " + target);
  std::vector<Out> out(array.element_count());
  const std::byte* p = array.data.data();
  const std::size_t n = out.size();
  switch (array.dtype()) {
    case DType::Bool:
      for (std::size_t i = 0; i < n; ++i) out[i] = p[i] != std::byte{0} ? Out(1) : Out(0);
      break;
    case DType::Int8: widen<Out, std::int8_t>(p, n, out.data()); break;
    case DType::Int16: widen<Out, std::int16_t>(p, n, out.data()); break;
    case DType::Int32: widen<Out, std::int32_t>(p, n, out.data()); break;
    case DType::Int64: widen<Out, std::int64_t>(p, n, out.data()); break;
    case DType::UInt8: widen<Out, std::uint8_t>(p, n, out.data()); break;
    case DType::UInt16: widen<Out, std::uint16_t>(p, n, out.data()); break;
    case DType::UInt32: widen<Out, std::uint32_t>(p, n, out.data()); break;
    case DType::UInt64: widen<Out, std::uint64_t>(p, n, out.data()); break;
    case DType::Float32: widen<Out, float>(p, n, out.data()); break;
    case DType::Float64: widen<Out, double>(p, n, out.data()); break;
    case DType::Unicode:
    case DType::Bytes:
    case DType::Object:
      break;  // refused above
  }
  return out;
}

void append_utf8(std::string& out, std::uint32_t cp) {
  if (cp > 0x10FFFF || (cp >= 0xD800 && cp <= 0xDFFF)) throw std::invalid_argument("invalid UTF-32 code point " + std::to_string(cp));
  if (cp < 0x80) {
    out += static_cast<char>(cp);
  } else if (cp < 0x800) {
    out += static_cast<char>(0xC0 | cp >> 6);
    out += static_cast<char>(0x80 | (cp & 0x3F));
  } else if (cp < 0x10000) {
    out += static_cast<char>(0xE0 | cp >> 12);
    out += static_cast<char>(0x80 | (cp >> 6 & 0x3F));
    out += static_cast<char>(0x80 | (cp & 0x3F));
  } else {
    out += static_cast<char>(0xF0 | cp >> 18);
    out += static_cast<char>(0x80 | (cp >> 12 & 0x3F));
    out += static_cast<char>(0x80 | (cp >> 6 & 0x3F));
    out += static_cast<char>(0x80 | (cp & 0x3F));
  }
}

std::vector<std::uint32_t> decode_utf8(std::string_view text) {
  std::vector<std::uint32_t> out;
  std::size_t i = 0;
  auto invalid = [&] { throw std::invalid_argument("string " + quoted(text) + " is not valid UTF-8"); };
  while (i < text.size()) {
    const auto lead = static_cast<unsigned char>(text[i]);
    const int extra = lead < 0x80 ? 0 : lead >= 0xF0 ? 3 : lead >= 0xE0 ? 2 : lead >= 0xC0 ? 1 : -1;
    if (extra < 0 || lead > 0xF4 || text.size() - i <= static_cast<std::size_t>(extra)) invalid();
    std::uint32_t cp = extra == 0 ? lead : lead & (0x3F >> extra);
    for (int k = 1; k <= extra; ++k) {
      const auto c = static_cast<unsigned char>(text[i + k]);
      if ((c & 0xC0) != 0x80) invalid();
      cp = cp << 6 | (c & 0x3F);
    }
    static constexpr std::uint32_t kMinimum[] = {0, 0x80, 0x800, 0x10000};
    if (cp < kMinimum[extra] || cp > 0x10FFFF || (cp >= 0xD800 && cp <= 0xDFFF)) invalid();
    out.push_back(cp);
    i += extra + 1;
  }
  return out;
}

template <class T>
NpyArray from_values(DType dtype, std::span<const T> values, std::vector<std::size_t> shape) {
  NpyArray array;
  array.header.dtype = dtype;
  array.header.item_size = sizeof(T);
  array.header.shape = std::move(shape);
  std::size_t count = 0;
  if (!checked_product(array.header.shape, count) || count != values.size())
    throw std::invalid_argument("shape " + shape_text(array.header.shape) + " does not hold " + std::to_string(values.size()) + " values");
  const auto bytes = std::as_bytes(values);
  array.data.assign(bytes.begin(), bytes.end());
  return array;
}

template <class M>
[[noreturn]] void fail_missing_member(const std::vector<M>& members, const std::string& key, const std::string& path) {
  constexpr std::size_t kListed = 20;
  std::string list;
  for (std::size_t i = 0; i < members.size() && i < kListed; ++i) list += (i ? ", " : "") + printable(members[i].key);
  if (members.size() > kListed) list += ", ... (" + std::to_string(members.size()) + " in all)";
  throw InputError(path, "no array " + quoted(key) + " (keys: " + list + ")");
}

std::string member_label(const std::string& key) { return "member " + quoted(key); }

// NpzWriter's state is private; deducing it keeps these helpers free functions.
template <class S>
S& live(const std::unique_ptr<S>& state) {
  if (!state) throw std::logic_error("NpzWriter used after close()");
  if (state->broken) throw std::logic_error("NpzWriter used after a failed write; the archive cannot be completed");
  return *state;
}

// Runs an archive operation; if it throws, the archive is in an unknown state and only the
// destructor (which removes the temporary file) may follow.
template <class S, class F>
void guarded(S& state, F&& operation) {
  try {
    operation();
  } catch (...) {
    state.broken = true;
    throw;
  }
}

}  // namespace

const char* dtype_name(DType dtype) {
  switch (dtype) {
    case DType::Bool: return "bool";
    case DType::Int8: return "int8";
    case DType::Int16: return "int16";
    case DType::Int32: return "int32";
    case DType::Int64: return "int64";
    case DType::UInt8: return "uint8";
    case DType::UInt16: return "uint16";
    case DType::UInt32: return "uint32";
    case DType::UInt64: return "uint64";
    case DType::Float32: return "float32";
    case DType::Float64: return "float64";
    case DType::Unicode: return "unicode";
    case DType::Bytes: return "bytes";
    case DType::Object: return "object";
  }
  return "unknown";
}

std::size_t NpyHeader::element_count() const {
  std::size_t count = 1;
  for (std::size_t d : shape) count *= d;
  return count;
}

std::vector<double> NpyArray::to_double() const { return convert<double>(*this, "float64"); }

std::vector<float> NpyArray::to_float() const { return convert<float>(*this, "float32"); }

// Integers must fit in int64 and floats must hold exact integers: an index that silently
// wrapped or lost its fraction would corrupt whatever it indexes.
std::vector<std::int64_t> NpyArray::to_int64() const {
  if (dtype() == DType::UInt64) {
    for (std::uint64_t v : convert<std::uint64_t>(*this, "int64"))
      if (v > static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max()))
        throw std::invalid_argument("uint64 value " + std::to_string(v) + " does not fit in int64");
  } else if (dtype() == DType::Float32 || dtype() == DType::Float64) {
    const std::vector<double> values = convert<double>(*this, "int64");
    std::vector<std::int64_t> out(values.size());
    for (std::size_t i = 0; i < values.size(); ++i) {
      const double v = values[i];
      if (!(v >= -0x1p63 && v < 0x1p63) || std::trunc(v) != v)
        throw std::invalid_argument("value " + std::to_string(v) + " at index " + std::to_string(i) + " is not an int64 integer");
      out[i] = static_cast<std::int64_t>(v);
    }
    return out;
  }
  return convert<std::int64_t>(*this, "int64");
}

std::vector<std::string> NpyArray::to_strings() const {
  if (dtype() != DType::Unicode && dtype() != DType::Bytes)
    throw std::invalid_argument(std::string("cannot read a ") + dtype_name(dtype()) + " array as strings");
  check_data_size(*this);
  const std::size_t n = element_count();
  const std::size_t item = header.item_size;
  std::vector<std::string> out(n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::byte* p = data.data() + i * item;
    if (dtype() == DType::Bytes) {
      std::size_t length = item;
      while (length > 0 && p[length - 1] == std::byte{0}) --length;
      out[i].assign(reinterpret_cast<const char*>(p), length);
    } else {
      auto unit = [p](std::size_t k) {
        std::uint32_t v;
        std::memcpy(&v, p + 4 * k, 4);
        return v;
      };
      std::size_t length = item / 4;
      while (length > 0 && unit(length - 1) == 0) --length;
      for (std::size_t k = 0; k < length; ++k) append_utf8(out[i], unit(k));
    }
  }
  return out;
}

NpyArray NpyArray::from_float32(std::span<const float> values, std::vector<std::size_t> shape) {
  return from_values(DType::Float32, values, std::move(shape));
}
NpyArray NpyArray::from_float64(std::span<const double> values, std::vector<std::size_t> shape) {
  return from_values(DType::Float64, values, std::move(shape));
}
NpyArray NpyArray::from_int32(std::span<const std::int32_t> values, std::vector<std::size_t> shape) {
  return from_values(DType::Int32, values, std::move(shape));
}
NpyArray NpyArray::from_int64(std::span<const std::int64_t> values, std::vector<std::size_t> shape) {
  return from_values(DType::Int64, values, std::move(shape));
}
NpyArray NpyArray::from_uint32(std::span<const std::uint32_t> values, std::vector<std::size_t> shape) {
  return from_values(DType::UInt32, values, std::move(shape));
}

NpyArray NpyArray::from_bool(std::span<const bool> values, std::vector<std::size_t> shape) {
  std::vector<std::uint8_t> bytes(values.begin(), values.end());
  NpyArray array = from_values(DType::UInt8, std::span<const std::uint8_t>(bytes), std::move(shape));
  array.header.dtype = DType::Bool;
  return array;
}

NpyArray NpyArray::from_strings(std::span<const std::string> values, std::vector<std::size_t> shape) {
  std::size_t count = 0;
  if (!checked_product(shape, count) || count != values.size())
    throw std::invalid_argument("shape " + shape_text(shape) + " does not hold " + std::to_string(values.size()) + " strings");
  std::vector<std::vector<std::uint32_t>> decoded;
  decoded.reserve(values.size());
  std::size_t width = 1;  // numpy's narrowest string dtype is U1
  for (const std::string& value : values) {
    decoded.push_back(decode_utf8(value));
    width = std::max(width, decoded.back().size());
  }
  std::vector<std::uint32_t> units(values.size() * width, 0);
  for (std::size_t i = 0; i < decoded.size(); ++i) std::copy(decoded[i].begin(), decoded[i].end(), units.begin() + i * width);
  NpyArray array;
  array.header.dtype = DType::Unicode;
  array.header.item_size = width * 4;
  array.header.shape = std::move(shape);
  const auto bytes = std::as_bytes(std::span(units));
  array.data.assign(bytes.begin(), bytes.end());
  return array;
}

NpyArray NpyArray::scalar_float64(double value) { return from_float64(std::span<const double>(&value, 1), {}); }

NpyArray NpyArray::scalar_string(const std::string& value) { return from_strings(std::span<const std::string>(&value, 1), {}); }

NpyArray read_npy(const std::string& path) {
  return naming_out_of_memory(path, [&] {
    FileSource source(path);
    return read_array(source, Where{path, {}});
  });
}

NpyArray parse_npy(std::span<const std::byte> bytes, const std::string& name) {
  return naming_out_of_memory(name, [&] {
    SpanSource source(bytes);
    return read_array(source, Where{name, {}});
  });
}

void write_npy(const std::string& path, const NpyArray& array) {
  data_bytes_for_writing(array.dtype(), array.header.item_size, array.shape());
  check_data_size(array);
  const std::string preamble = npy_preamble(array.dtype(), array.header.item_size, array.shape());
  TempFile file(path);
  file.write(std::as_bytes(std::span(preamble)));
  file.write(array.data);
  file.commit();
}

// --- NpzReader ---------------------------------------------------------------------------------

struct NpzReader::Member {
  std::string key;
  zip::Entry entry;
};

// Keys are looked up through a hash map, so an archive of n members costs O(n) to open and to
// read whole, not O(n^2).
NpzReader::NpzReader(std::string path) : path_(std::move(path)) {
  naming_out_of_memory(path_, [&] {
    std::vector<zip::Entry> entries = zip::read_directory(path_);
    members_.reserve(entries.size());
    index_.reserve(entries.size());
    for (zip::Entry& entry : entries) {
      std::string key = entry.name;
      if (key.ends_with(".npy")) key.resize(key.size() - 4);
      if (!index_.emplace(key, members_.size()).second) throw InputError(path_, "duplicate member " + quoted(entry.name));
      members_.push_back({std::move(key), std::move(entry)});
    }
  });
}

NpzReader::~NpzReader() = default;
NpzReader::NpzReader(NpzReader&&) noexcept = default;
NpzReader& NpzReader::operator=(NpzReader&&) noexcept = default;

std::vector<std::string> NpzReader::keys() const {
  std::vector<std::string> out;
  out.reserve(members_.size());
  for (const Member& m : members_) out.push_back(m.key);
  return out;
}

bool NpzReader::contains(const std::string& key) const { return index_.contains(key); }

const NpzReader::Member& NpzReader::member(const std::string& key) const {
  const auto it = index_.find(key);
  if (it == index_.end()) fail_missing_member(members_, key, path_);
  return members_[it->second];
}

NpyHeader NpzReader::header(const std::string& key) const {
  return naming_out_of_memory(path_, [&] {
    zip::MemberReader reader(path_, member(key).entry, member_label(key));
    return read_header(reader, Where{path_, member_label(key)});
  });
}

NpyArray NpzReader::load(const std::string& key) const {
  return naming_out_of_memory(path_, [&] {
    zip::MemberReader reader(path_, member(key).entry, member_label(key));
    return read_array(reader, Where{path_, member_label(key)});
  });
}

// --- NpzWriter ---------------------------------------------------------------------------------

struct NpzWriter::State {
  TempFile file;  // declared before the zip writer, which uses its FILE* until destroyed
  zip::Writer zip;
  zip::Method method;
  std::unordered_set<std::string> keys;
  bool array_open = false;
  std::string array_key;
  std::uint64_t bytes_left = 0;
  bool broken = false;

  State(const std::string& path, bool compress)
      : file(path), zip(file.get(), path), method(compress ? zip::Method::Deflated : zip::Method::Stored) {}
};

NpzWriter::NpzWriter(std::string path, bool compress) : state_(std::make_unique<State>(path, compress)) {}

NpzWriter::~NpzWriter() = default;

void NpzWriter::add(const std::string& key, const NpyArray& array) {
  check_data_size(array);
  begin_array(key, array.dtype(), array.shape(), array.header.item_size);
  append(array.data);
  end_array();
}

void NpzWriter::begin_array(const std::string& key, DType dtype, std::vector<std::size_t> shape, std::size_t item_size) {
  State& s = live(state_);
  if (s.array_open) throw std::logic_error("begin_array(" + quoted(key) + ") while array " + quoted(s.array_key) + " is open");
  if (key.empty()) throw std::invalid_argument("npz keys must not be empty");
  if (s.keys.contains(key)) throw std::invalid_argument("duplicate npz key " + quoted(key));
  if (item_size == 0) item_size = natural_item_size(dtype);
  const std::size_t data_bytes = data_bytes_for_writing(dtype, item_size, shape);
  const std::string preamble = npy_preamble(dtype, item_size, shape);
  guarded(s, [&] {
    s.zip.begin_member(key + ".npy", s.method, preamble.size() + data_bytes);
    s.zip.write(std::as_bytes(std::span(preamble)));
  });
  s.keys.insert(key);
  s.array_open = true;
  s.array_key = key;
  s.bytes_left = data_bytes;
}

void NpzWriter::append(std::span<const std::byte> bytes) {
  State& s = live(state_);
  if (!s.array_open) throw std::logic_error("NpzWriter::append() without begin_array()");
  if (bytes.size() > s.bytes_left)
    throw std::invalid_argument("array " + quoted(s.array_key) + " receives more bytes than its shape holds");
  guarded(s, [&] { s.zip.write(bytes); });
  s.bytes_left -= bytes.size();
}

void NpzWriter::end_array() {
  State& s = live(state_);
  if (!s.array_open) throw std::logic_error("NpzWriter::end_array() without begin_array()");
  if (s.bytes_left != 0)
    throw std::logic_error("array " + quoted(s.array_key) + " ended " + std::to_string(s.bytes_left) + " bytes short of its shape");
  guarded(s, [&] { s.zip.end_member(); });
  s.array_open = false;
}

void NpzWriter::close() {
  State& s = live(state_);
  if (s.array_open) throw std::logic_error("NpzWriter::close() while array " + quoted(s.array_key) + " is open");
  try {
    s.zip.finish();
    s.file.commit();
  } catch (...) {
    state_.reset();
    throw;
  }
  state_.reset();
}

}  // namespace odyssey::io
