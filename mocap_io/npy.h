// NumPy .npy arrays and .npz archives, both directions.
//
// Reading accepts what numpy writes: format versions 1.0, 2.0 and 3.0; little and big endian;
// dtypes b1, i1..i8, u1..u8, f4, f8, U (UTF-32 strings) and S (byte strings); 0-d arrays; C and
// Fortran order; npz members stored or deflated, zip64 included. Arrays are normalised on load to
// native byte order and C order, so callers only ever see one layout. Pickled object arrays ('O')
// are listed with their header but never loaded: load() on one throws InputError.
//
// Writing produces little-endian, C-order, version 1.0 headers (2.0 when the header needs it),
// deflated or stored, zip64 when a member or the archive passes 4 GiB. NpzWriter writes to a
// temporary name beside the target and renames on close(), so an interrupted or failed write
// leaves no partial file behind.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <span>
#include <string>
#include <unordered_map>
#include <vector>

#include "mocap_io/input_error.h"

namespace odyssey::io {

enum class DType { Bool, Int8, Int16, Int32, Int64, UInt8, UInt16, UInt32, UInt64, Float32, Float64, Unicode, Bytes, Object };

// numpy's name for the dtype ("float32", "<U5" style names are given as "unicode"/"bytes").
const char* dtype_name(DType dtype);

// What an .npy header says, without the data.
struct NpyHeader {
  DType dtype = DType::Float64;
  std::size_t item_size = 8;  // bytes per element as stored (U: 4 per character, S: 1 per byte)
  std::vector<std::size_t> shape;  // empty for a 0-d array
  bool fortran_order = false;      // as stored; loaded data is always C order
  bool big_endian = false;         // as stored; loaded data is always native order

  std::size_t element_count() const;  // 1 for a 0-d array
};

// An array in memory: native byte order, C order.
struct NpyArray {
  NpyHeader header;
  std::vector<std::byte> data;

  const std::vector<std::size_t>& shape() const { return header.shape; }
  DType dtype() const { return header.dtype; }
  std::size_t element_count() const { return header.element_count(); }

  // Numeric conversions from any numeric or bool dtype; throw std::invalid_argument for strings.
  std::vector<double> to_double() const;
  std::vector<float> to_float() const;
  std::vector<std::int64_t> to_int64() const;
  // Text of a U or S array (trailing NULs stripped; U decoded from UTF-32 to UTF-8).
  std::vector<std::string> to_strings() const;

  // Builders for writers: copy values, C order.
  static NpyArray from_float32(std::span<const float> values, std::vector<std::size_t> shape);
  static NpyArray from_float64(std::span<const double> values, std::vector<std::size_t> shape);
  static NpyArray from_int32(std::span<const std::int32_t> values, std::vector<std::size_t> shape);
  static NpyArray from_int64(std::span<const std::int64_t> values, std::vector<std::size_t> shape);
  static NpyArray from_uint32(std::span<const std::uint32_t> values, std::vector<std::size_t> shape);
  static NpyArray from_bool(std::span<const bool> values, std::vector<std::size_t> shape);
  // U array of the given strings, width = longest string (in UTF-32 code points).
  static NpyArray from_strings(std::span<const std::string> values, std::vector<std::size_t> shape);
  // 0-d scalars.
  static NpyArray scalar_float64(double value);
  static NpyArray scalar_string(const std::string& value);
};

// Standalone .npy files. `name` is used in error messages only.
NpyArray read_npy(const std::string& path);
NpyArray parse_npy(std::span<const std::byte> bytes, const std::string& name);
void write_npy(const std::string& path, const NpyArray& array);

// Reads the zip central directory once on construction; members are loaded on demand.
// Every problem (not a zip, truncated, CRC mismatch, bad header, missing key) throws InputError
// naming the archive path and, where there is one, the member.
class NpzReader {
 public:
  explicit NpzReader(std::string path);
  ~NpzReader();
  NpzReader(NpzReader&&) noexcept;
  NpzReader& operator=(NpzReader&&) noexcept;

  const std::string& path() const { return path_; }
  // Member names with the ".npy" suffix removed, in archive order.
  std::vector<std::string> keys() const;
  bool contains(const std::string& key) const;
  // Header only (reads just the start of the member): works for object arrays too.
  NpyHeader header(const std::string& key) const;
  NpyArray load(const std::string& key) const;

 private:
  struct Member;
  const Member& member(const std::string& key) const;

  std::string path_;
  std::vector<Member> members_;                           // archive order
  std::unordered_map<std::string, std::size_t> index_;  // key -> position in members_
};

// Writes an .npz archive. Arrays can be added whole, or streamed: begin_array() fixes dtype and
// shape, append() adds raw element bytes in C order (any chunking), and end_array() checks that
// exactly shape-product elements arrived. Memory stays bounded by the chunk size.
class NpzWriter {
 public:
  NpzWriter(std::string path, bool compress = true);
  ~NpzWriter();  // without close(): the temporary file is removed and nothing appears at `path`
  NpzWriter(const NpzWriter&) = delete;
  NpzWriter& operator=(const NpzWriter&) = delete;

  void add(const std::string& key, const NpyArray& array);
  void begin_array(const std::string& key, DType dtype, std::vector<std::size_t> shape,
                   std::size_t item_size = 0 /* 0: natural size of dtype */);
  void append(std::span<const std::byte> bytes);
  template <class T>
  void append(std::span<const T> values) { append(std::as_bytes(values)); }
  void end_array();
  // Finishes the archive and renames it to `path`.
  void close();

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace odyssey::io
