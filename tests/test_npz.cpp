// .npy/.npz reading and writing: round trips through our own writer and reader, archives numpy
// wrote (read by us), archives we wrote (read by numpy), the SMPL-X fixture, and hostile input.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "test_support.h"
#include "mocap_io/npy.h"
#include "mocap_io/zip.h"

namespace fs = std::filesystem;
using namespace odyssey::io;

namespace {

using odyssey::test_support::numpy_python;

fs::path scratch_file(const std::string& suffix) {
  const fs::path dir = odyssey::test_support::scratch_root() / "npz";
  fs::create_directories(dir);
  const auto* test = testing::UnitTest::GetInstance()->current_test_info();
  return dir / (std::string(test->test_suite_name()) + "." + test->name() + "." + suffix);
}

// Runs `script` with the given arguments; true when it exits 0.
bool run_python(const std::string& script, const std::vector<std::string>& args) {
  const fs::path path = scratch_file("py");
  std::ofstream(path) << script;
  std::string command = numpy_python() + " '" + path.string() + "'";
  for (const std::string& arg : args) command += " '" + arg + "'";
  return std::system(command.c_str()) == 0;
}

std::vector<std::byte> read_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::vector<char> chars((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::vector<std::byte> bytes(chars.size());
  std::memcpy(bytes.data(), chars.data(), chars.size());
  return bytes;
}

void write_bytes(const fs::path& path, std::span<const std::byte> bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
}

std::vector<std::byte> as_byte_vector(std::string_view text) {
  const auto bytes = std::as_bytes(std::span(text));
  return {bytes.begin(), bytes.end()};
}

template <class T>
NpyArray make_array(DType dtype, std::vector<T> values, std::vector<std::size_t> shape) {
  NpyArray array;
  array.header.dtype = dtype;
  array.header.item_size = sizeof(T);
  array.header.shape = std::move(shape);
  const auto bytes = std::as_bytes(std::span(values));
  array.data.assign(bytes.begin(), bytes.end());
  return array;
}

template <class T>
std::vector<T> values_of(const NpyArray& array) {
  EXPECT_EQ(array.header.item_size, sizeof(T));
  std::vector<T> values(array.data.size() / sizeof(T));
  std::memcpy(values.data(), array.data.data(), values.size() * sizeof(T));
  return values;
}

template <class T>
std::vector<T> extremes() {
  return {std::numeric_limits<T>::min(), 0, 1, std::numeric_limits<T>::max()};
}

NpyArray byte_strings(const std::vector<std::string>& values, std::size_t width) {
  NpyArray array;
  array.header.dtype = DType::Bytes;
  array.header.item_size = width;
  array.header.shape = {values.size()};
  array.data.resize(values.size() * width);
  for (std::size_t i = 0; i < values.size(); ++i) std::memcpy(array.data.data() + i * width, values[i].data(), values[i].size());
  return array;
}

// Stream values that deflate cannot squeeze much, so compressed output spans many buffers.
float streamed_value(std::uint64_t i) { return static_cast<float>(i * 2654435761u % (1u << 24)); }
constexpr std::size_t kStreamedRows = 300000;

// One array of every writable dtype; NumpyReadsOurArchives builds the same set in Python.
std::vector<std::pair<std::string, NpyArray>> reference_arrays() {
  std::vector<float> f4(12);
  for (std::size_t i = 0; i < f4.size(); ++i) f4[i] = static_cast<float>(i) * 0.25f - 1.0f;
  static const bool truth[] = {true, false, true, true};
  const std::vector<std::string> text = {"walk", "h\xc3\xa9llo", "\xe6\x97\xa5\xe6\x9c\xac\xe8\xaa\x9e", ""};
  return {
      {"f4", NpyArray::from_float32(f4, {3, 4})},
      {"f8", NpyArray::from_float64(std::vector<double>{1.0 / 3.0, -2.5e300, 5e-324, 0.0}, {4})},
      {"i1", make_array(DType::Int8, extremes<std::int8_t>(), {4})},
      {"i2", make_array(DType::Int16, extremes<std::int16_t>(), {4})},
      {"i4", make_array(DType::Int32, extremes<std::int32_t>(), {2, 2})},
      {"i8", make_array(DType::Int64, extremes<std::int64_t>(), {4})},
      {"u1", make_array(DType::UInt8, extremes<std::uint8_t>(), {4})},
      {"u2", make_array(DType::UInt16, extremes<std::uint16_t>(), {4})},
      {"u4", make_array(DType::UInt32, extremes<std::uint32_t>(), {4})},
      {"u8", make_array(DType::UInt64, extremes<std::uint64_t>(), {4})},
      {"b1", NpyArray::from_bool(truth, {4})},
      {"U", NpyArray::from_strings(text, {4})},
      {"S", byte_strings({"male", "female", ""}, 6)},
      {"scalar_f8", NpyArray::scalar_float64(3.5)},
      {"scalar_U", NpyArray::scalar_string("neutral")},
      {"empty", NpyArray::from_float32({}, {0, 3})},
      {"cube", make_array(DType::Int32, std::vector<std::int32_t>{0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11}, {2, 3, 2})},
  };
}

// Writes every reference array plus a large float32 array streamed in uneven chunks.
void write_reference_archive(const fs::path& path, bool compress) {
  NpzWriter writer(path.string(), compress);
  for (const auto& [key, array] : reference_arrays()) writer.add(key, array);
  writer.begin_array("streamed", DType::Float32, {kStreamedRows, 3});
  std::vector<float> values(kStreamedRows * 3);
  for (std::size_t i = 0; i < values.size(); ++i) values[i] = streamed_value(i);
  const auto bytes = std::as_bytes(std::span(values));
  const std::size_t chunk_sizes[] = {1, 7, 4096, 13, 65536, 3};  // splits elements mid-value on purpose
  for (std::size_t pos = 0, k = 0; pos < bytes.size(); ++k) {
    const std::size_t n = std::min(chunk_sizes[k % std::size(chunk_sizes)], bytes.size() - pos);
    writer.append(bytes.subspan(pos, n));
    pos += n;
  }
  writer.end_array();
  writer.close();
}

// A bare .npy image with the given header dict, for hand-made (often broken) members.
std::vector<std::byte> raw_npy(const std::string& dict, std::span<const std::byte> data, int version = 1) {
  std::string header = dict + "\n";
  std::string out = "\x93NUMPY";
  out += static_cast<char>(version);
  out += '\0';
  const int length_bytes = version == 1 ? 2 : 4;
  for (int i = 0; i < length_bytes; ++i) out += static_cast<char>((header.size() >> (8 * i)) & 0xFF);
  std::vector<std::byte> bytes = as_byte_vector(out + header);
  bytes.insert(bytes.end(), data.begin(), data.end());
  return bytes;
}

std::vector<std::byte> doubles(std::size_t count) {
  std::vector<double> values(count);
  for (std::size_t i = 0; i < count; ++i) values[i] = static_cast<double>(i) * 0.5;
  const auto bytes = std::as_bytes(std::span(values));
  return {bytes.begin(), bytes.end()};
}

using Members = std::vector<std::pair<std::string, std::vector<std::byte>>>;

void write_zip(const fs::path& path, const Members& members, zip::Method method, zip::Writer::Options options = {}) {
  std::FILE* file = std::fopen(path.c_str(), "wb");
  ASSERT_NE(file, nullptr);
  {
    zip::Writer writer(file, path.string(), options);
    for (const auto& [name, bytes] : members) {
      writer.begin_member(name, method, bytes.size());
      writer.write(bytes);
      writer.end_member();
    }
    writer.finish();
  }
  ASSERT_EQ(std::fclose(file), 0);
}

// Runs `action`, which must throw InputError naming `file` and containing `fragment`, on one line.
template <class Action>
void expect_input_error(Action&& action, const fs::path& file, const std::string& fragment) {
  try {
    action();
    ADD_FAILURE() << "no InputError; expected one containing \"" << fragment << "\"";
  } catch (const InputError& error) {
    const std::string what = error.what();
    EXPECT_NE(what.find(file.string()), std::string::npos) << what;
    EXPECT_NE(what.find(fragment), std::string::npos) << what;
    EXPECT_EQ(what.find('\n'), std::string::npos) << what;
  }
}

void expect_same_array(const NpyArray& actual, const NpyArray& expected, const std::string& key) {
  EXPECT_EQ(actual.dtype(), expected.dtype()) << key;
  EXPECT_EQ(actual.shape(), expected.shape()) << key;
  EXPECT_EQ(actual.header.item_size, expected.header.item_size) << key;
  EXPECT_FALSE(actual.header.fortran_order) << key;
  EXPECT_FALSE(actual.header.big_endian) << key;
  EXPECT_TRUE(actual.data == expected.data) << key;
}

void expect_streamed(const NpyArray& array) {
  ASSERT_EQ(array.shape(), (std::vector<std::size_t>{kStreamedRows, 3}));
  const std::vector<float> values = array.to_float();
  for (std::size_t i = 0; i < values.size(); ++i)
    if (values[i] != streamed_value(i)) FAIL() << "streamed[" << i << "] = " << values[i];
}

// --- round trips -------------------------------------------------------------------------------

TEST(NpzRoundTrip, EveryDtypeStoredAndDeflated) {
  for (bool compress : {false, true}) {
    SCOPED_TRACE(compress ? "deflated" : "stored");
    const fs::path path = scratch_file(compress ? "deflated.npz" : "stored.npz");
    write_reference_archive(path, compress);
    const NpzReader reader(path.string());
    const auto expected = reference_arrays();
    std::vector<std::string> keys;
    for (const auto& [key, array] : expected) keys.push_back(key);
    keys.push_back("streamed");
    EXPECT_EQ(reader.keys(), keys);
    for (const auto& [key, array] : expected) {
      expect_same_array(reader.load(key), array, key);
      const NpyHeader header = reader.header(key);
      EXPECT_EQ(header.dtype, array.dtype()) << key;
      EXPECT_EQ(header.shape, array.shape()) << key;
    }
    expect_streamed(reader.load("streamed"));
  }
}

TEST(NpzRoundTrip, StandaloneNpyFile) {
  const fs::path path = scratch_file("npy");
  const NpyArray original = NpyArray::from_float64(std::vector<double>{1.5, -2.0, 1e-300, 7.0, 8.0, 9.0}, {2, 3});
  write_npy(path.string(), original);
  expect_same_array(read_npy(path.string()), original, "read_npy");
  expect_same_array(parse_npy(read_bytes(path), "memory"), original, "parse_npy");
  // The data starts 64-byte aligned, as numpy writes it.
  const auto bytes = read_bytes(path);
  EXPECT_EQ((bytes.size() - original.data.size()) % 64, 0u);
}

TEST(NpzRoundTrip, ForcedZip64Records) {
  const fs::path path = scratch_file("npz");
  const NpyArray array = NpyArray::from_float64(std::vector<double>{1, 2, 3}, {3});
  const fs::path npy = scratch_file("npy");
  write_npy(npy.string(), array);
  write_zip(path, {{"a.npy", read_bytes(npy)}, {"b.npy", read_bytes(npy)}}, zip::Method::Deflated, {.force_zip64 = true});
  const auto bytes = read_bytes(path);
  const std::string zip64_end = "PK\x06\x06";
  EXPECT_NE(std::search(bytes.begin(), bytes.end(), zip64_end.begin(), zip64_end.end(),
                        [](std::byte b, char c) { return b == static_cast<std::byte>(c); }),
            bytes.end());
  const NpzReader reader(path.string());
  EXPECT_EQ(reader.keys(), (std::vector<std::string>{"a", "b"}));
  expect_same_array(reader.load("b"), array, "b");
}

TEST(NpyConversions, NumericAndText) {
  const NpyArray ints = make_array(DType::Int16, std::vector<std::int16_t>{-32768, -1, 0, 32767}, {4});
  EXPECT_EQ(ints.to_double(), (std::vector<double>{-32768, -1, 0, 32767}));
  EXPECT_EQ(ints.to_float(), (std::vector<float>{-32768, -1, 0, 32767}));
  EXPECT_EQ(ints.to_int64(), (std::vector<std::int64_t>{-32768, -1, 0, 32767}));

  const NpyArray parents = make_array(DType::UInt32, std::vector<std::uint32_t>{4294967295u, 0, 1}, {3});
  EXPECT_EQ(parents.to_int64(), (std::vector<std::int64_t>{4294967295, 0, 1}));

  EXPECT_TRUE(NpyArray::from_bool({}, {0}).to_double().empty());
  const bool truth[] = {true, false, true};
  EXPECT_EQ(NpyArray::from_bool(truth, {3}).to_int64(), (std::vector<std::int64_t>{1, 0, 1}));

  EXPECT_EQ(NpyArray::from_float64(std::vector<double>{-3, 4e15}, {2}).to_int64(), (std::vector<std::int64_t>{-3, 4000000000000000}));
  EXPECT_THROW(NpyArray::from_float64(std::vector<double>{1.5}, {1}).to_int64(), std::invalid_argument);
  EXPECT_THROW(NpyArray::from_float64(std::vector<double>{1e19}, {1}).to_int64(), std::invalid_argument);
  EXPECT_THROW(make_array(DType::UInt64, extremes<std::uint64_t>(), {4}).to_int64(), std::invalid_argument);

  const NpyArray names = NpyArray::from_strings(std::vector<std::string>{"pelvis", "\xf0\x9f\x99\x82", ""}, {3});
  EXPECT_EQ(names.header.item_size, 6u * 4);
  EXPECT_EQ(names.to_strings(), (std::vector<std::string>{"pelvis", "\xf0\x9f\x99\x82", ""}));
  EXPECT_THROW(names.to_double(), std::invalid_argument);
  EXPECT_THROW(ints.to_strings(), std::invalid_argument);
  EXPECT_EQ(NpyArray::scalar_string("female").to_strings(), (std::vector<std::string>{"female"}));
  EXPECT_TRUE(NpyArray::scalar_string("female").shape().empty());
  EXPECT_THROW(NpyArray::from_strings(std::vector<std::string>{"\xc3"}, {1}), std::invalid_argument);
  EXPECT_THROW(NpyArray::from_float32(std::vector<float>{1, 2, 3}, {2, 2}), std::invalid_argument);
}

// --- header parsing ----------------------------------------------------------------------------

TEST(NpyHeader, AcceptsWhatNumpyCanWrite) {
  const auto data = doubles(6);
  const std::vector<std::string> dicts = {
      "{'descr': '<f8', 'fortran_order': False, 'shape': (2, 3), }",
      "{'shape': (2, 3), 'fortran_order': False, 'descr': '<f8'}",
      "{ \"descr\" : \"<f8\" ,\"fortran_order\":False,'shape':( 2 ,3 , ) ,}   ",
      "{'descr': '<f8', 'fortran_order': False, 'shape': (2L, 3L), }",
  };
  for (const std::string& dict : dicts) {
    const NpyArray array = parse_npy(raw_npy(dict, data), "ok.npy");
    EXPECT_EQ(array.shape(), (std::vector<std::size_t>{2, 3})) << dict;
    EXPECT_EQ(array.to_double(), (std::vector<double>{0, 0.5, 1, 1.5, 2, 2.5})) << dict;
  }
  for (int version : {2, 3}) {
    const NpyArray array = parse_npy(raw_npy("{'descr': '<f8', 'fortran_order': False, 'shape': (6,), }", data, version), "v.npy");
    EXPECT_EQ(array.to_double().back(), 2.5) << version;
  }
  // Fortran order, rank 2: stored column by column.
  const std::vector<std::int32_t> columns = {0, 3, 1, 4, 2, 5};
  const NpyArray fortran = parse_npy(raw_npy("{'descr': '<i4', 'fortran_order': True, 'shape': (2, 3), }", std::as_bytes(std::span(columns))), "f.npy");
  EXPECT_TRUE(fortran.header.fortran_order);
  EXPECT_EQ(fortran.to_int64(), (std::vector<std::int64_t>{0, 1, 2, 3, 4, 5}));
  const NpyArray scalar = parse_npy(raw_npy("{'descr': '<f8', 'fortran_order': False, 'shape': (), }", doubles(1)), "s.npy");
  EXPECT_TRUE(scalar.shape().empty());
  EXPECT_EQ(scalar.element_count(), 1u);
}

TEST(NpyHeader, RejectsBadHeaders) {
  const auto data = doubles(3);
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"{'descr': '<f8', 'fortran_order': False}", "missing key 'shape'"},
      {"{'descr': '<f8', 'fortran_order': maybe, 'shape': (3,), }", "True or False"},
      {"{'descr': '<f8', 'fortran_order': False, 'shape': (3), }", "not a tuple"},
      {"{'descr': '<f8', 'fortran_order': False, 'shape': (-3,), }", "non-negative"},
      {"{'descr': '<f8', 'fortran_order': False, 'shape': (3,), 'extra': 1}", "unexpected key 'extra'"},
      {"{'descr': '<f8', 'descr': '<f8', 'fortran_order': False, 'shape': (3,)}", "duplicate key"},
      {"{'descr': '<f8', 'fortran_order': False, 'shape': (3,), } junk", "after the dictionary"},
      {"{'descr': '<f8, 'fortran_order': False, 'shape': (3,), }", "bad .npy header"},
      {"{'descr': [('x', '<f8')], 'fortran_order': False, 'shape': (3,), }", "structured dtypes"},
      {"{'descr': '<c16', 'fortran_order': False, 'shape': (3,), }", "unsupported dtype '<c16'"},
      {"{'descr': '<f2', 'fortran_order': False, 'shape': (3,), }", "unsupported dtype '<f2'"},
      {"{'descr': '<M8[ns]', 'fortran_order': False, 'shape': (3,), }", "unsupported dtype"},
      {"{'descr': '<f8', 'fortran_order': False, 'shape': (4294967296, 4294967296, 16), }", "too large"},
      {"{'descr': '<f8', 'fortran_order': False, 'shape': (99999999999999999999999,), }", "too large"},
      {"{'descr': '<f8', 'fortran_order': False, 'shape': (4,), }", "data truncated: expected 32 bytes, found 24"},
      {"{'descr': '<f8', 'fortran_order': False, 'shape': (2,), }", "data length mismatch"},
      {"['descr', '<f8']", "bad .npy header"},
  };
  // Plain names rather than a structured binding: clang 14 cannot capture bindings in a lambda.
  for (const auto& bad : cases) {
    const std::string& dict = bad.first;
    SCOPED_TRACE(dict);
    expect_input_error([&] { parse_npy(raw_npy(dict, data), "bad.npy"); }, "bad.npy", bad.second);
  }
  auto bad_version = raw_npy("{'descr': '<f8', 'fortran_order': False, 'shape': (3,), }", data);
  bad_version[6] = std::byte{4};
  expect_input_error([&] { parse_npy(bad_version, "bad.npy"); }, "bad.npy", "version 4.0");
  auto long_header = raw_npy("{'descr': '<f8', 'fortran_order': False, 'shape': (3,), }", data);
  long_header[8] = long_header[9] = std::byte{0xFF};
  expect_input_error([&] { parse_npy(long_header, "bad.npy"); }, "bad.npy", "header truncated");
  expect_input_error([&] { parse_npy(as_byte_vector("PK\x03\x04 not numpy at all"), "bad.npy"); }, "bad.npy", "bad magic");
  expect_input_error([&] { parse_npy({}, "bad.npy"); }, "bad.npy", "too short");
}

// --- archives numpy wrote ----------------------------------------------------------------------

constexpr const char* kNumpyWriterScript = R"PY(
import sys
import numpy as np
out = sys.argv[1]
a = {}
a['f4'] = (np.arange(12, dtype='<f4').reshape(3, 4) * 0.25 - 1).astype('<f4')
a['f8'] = np.array([1 / 3, -2.5e300, 5e-324, 0.0], dtype='<f8')
for t in ['i1', 'i2', 'i4', 'i8', 'u1', 'u2', 'u4', 'u8']:
    info = np.iinfo(t)
    a[t] = np.array([info.min, 0, 1, info.max], dtype=t)
a['b1'] = np.array([True, False, True, True])
a['U'] = np.array(['walk', 'h\u00e9llo', '\u65e5\u672c\u8a9e', ''])
a['S'] = np.array([b'male', b'female', b''])
a['scalar_f8'] = np.array(3.5)
a['scalar_U'] = np.array('neutral')
a['scalar_S'] = np.array(b'female')
a['scalar_i2'] = np.array(-7, dtype='<i2')
a['fortran_i4'] = np.asfortranarray(np.arange(24, dtype='<i4').reshape(2, 3, 4))
a['fortran_f8'] = np.asfortranarray((np.arange(6) / 8).reshape(2, 3))
a['be_f8'] = (np.arange(6).reshape(2, 3) * 1.5).astype('>f8')
a['be_i4'] = np.array([-2, -1, 0, 1, 2**31 - 1], dtype='>i4')
a['be_U'] = np.array(['ab', 'c'], dtype='>U2')
a['fortran_be_f4'] = np.asfortranarray(np.arange(6, dtype='>f4').reshape(3, 2))
a['empty'] = np.zeros((0, 3), dtype='<f4')
a['objects'] = np.array([{'a': 1}], dtype=object)
np.savez(out + '/numpy_stored.npz', **a)
np.savez_compressed(out + '/numpy_deflated.npz', **a)
)PY";

TEST(NpzFromNumpy, EveryDtypeLayoutAndByteOrder) {
  REQUIRE_NUMPY();
  const fs::path dir = scratch_file("dir");
  fs::create_directories(dir);
  ASSERT_TRUE(run_python(kNumpyWriterScript, {dir.string()}));
  for (const char* name : {"numpy_stored.npz", "numpy_deflated.npz"}) {
    SCOPED_TRACE(name);
    const NpzReader npz((dir / name).string());
    EXPECT_EQ(npz.keys().size(), 25u);

    const std::vector<double> f4 = npz.load("f4").to_double();
    ASSERT_EQ(f4.size(), 12u);
    for (std::size_t i = 0; i < f4.size(); ++i) EXPECT_EQ(f4[i], static_cast<double>(i) * 0.25 - 1);
    EXPECT_EQ(values_of<double>(npz.load("f8")), (std::vector<double>{1.0 / 3.0, -2.5e300, 5e-324, 0.0}));
    EXPECT_EQ(values_of<std::int8_t>(npz.load("i1")), extremes<std::int8_t>());
    EXPECT_EQ(values_of<std::int16_t>(npz.load("i2")), extremes<std::int16_t>());
    EXPECT_EQ(values_of<std::int32_t>(npz.load("i4")), extremes<std::int32_t>());
    EXPECT_EQ(values_of<std::int64_t>(npz.load("i8")), extremes<std::int64_t>());
    EXPECT_EQ(values_of<std::uint8_t>(npz.load("u1")), extremes<std::uint8_t>());
    EXPECT_EQ(values_of<std::uint16_t>(npz.load("u2")), extremes<std::uint16_t>());
    EXPECT_EQ(values_of<std::uint32_t>(npz.load("u4")), extremes<std::uint32_t>());
    EXPECT_EQ(values_of<std::uint64_t>(npz.load("u8")), extremes<std::uint64_t>());
    EXPECT_EQ(npz.load("b1").dtype(), DType::Bool);
    EXPECT_EQ(npz.load("b1").to_int64(), (std::vector<std::int64_t>{1, 0, 1, 1}));

    const NpyArray text = npz.load("U");
    EXPECT_EQ(text.header.item_size, 5u * 4);  // U5: the longest string has 5 characters
    EXPECT_EQ(text.to_strings(), (std::vector<std::string>{"walk", "h\xc3\xa9llo", "\xe6\x97\xa5\xe6\x9c\xac\xe8\xaa\x9e", ""}));
    EXPECT_EQ(npz.load("S").dtype(), DType::Bytes);
    EXPECT_EQ(npz.load("S").to_strings(), (std::vector<std::string>{"male", "female", ""}));

    const NpyArray scalar = npz.load("scalar_f8");
    EXPECT_TRUE(scalar.shape().empty());
    EXPECT_EQ(scalar.to_double(), (std::vector<double>{3.5}));
    EXPECT_EQ(npz.load("scalar_U").to_strings(), (std::vector<std::string>{"neutral"}));
    EXPECT_EQ(npz.load("scalar_S").to_strings(), (std::vector<std::string>{"female"}));
    EXPECT_EQ(npz.load("scalar_i2").to_int64(), (std::vector<std::int64_t>{-7}));

    const NpyArray fortran = npz.load("fortran_i4");
    EXPECT_TRUE(fortran.header.fortran_order);
    EXPECT_EQ(fortran.shape(), (std::vector<std::size_t>{2, 3, 4}));
    const std::vector<std::int64_t> counted = fortran.to_int64();
    for (std::size_t i = 0; i < counted.size(); ++i) EXPECT_EQ(counted[i], static_cast<std::int64_t>(i));
    EXPECT_EQ(npz.load("fortran_f8").to_double(), (std::vector<double>{0, 0.125, 0.25, 0.375, 0.5, 0.625}));

    const NpyArray big = npz.load("be_f8");
    EXPECT_TRUE(big.header.big_endian);
    EXPECT_EQ(big.to_double(), (std::vector<double>{0, 1.5, 3, 4.5, 6, 7.5}));
    EXPECT_EQ(npz.load("be_i4").to_int64(), (std::vector<std::int64_t>{-2, -1, 0, 1, 2147483647}));
    EXPECT_EQ(npz.load("be_U").to_strings(), (std::vector<std::string>{"ab", "c"}));
    const NpyArray both = npz.load("fortran_be_f4");
    EXPECT_TRUE(both.header.fortran_order && both.header.big_endian);
    EXPECT_EQ(both.shape(), (std::vector<std::size_t>{3, 2}));
    EXPECT_EQ(both.to_double(), (std::vector<double>{0, 1, 2, 3, 4, 5}));

    EXPECT_EQ(npz.load("empty").shape(), (std::vector<std::size_t>{0, 3}));
    EXPECT_TRUE(npz.load("empty").data.empty());

    EXPECT_TRUE(npz.contains("objects"));
    EXPECT_EQ(npz.header("objects").dtype, DType::Object);
    EXPECT_EQ(npz.header("objects").shape, (std::vector<std::size_t>{1}));
    expect_input_error([&] { npz.load("objects"); }, dir / name, "member 'objects' is a pickled object array; object arrays are not loaded");
  }
}

TEST(NpzFromNumpy, Zip64Records) {
  REQUIRE_NUMPY();
  const fs::path path = scratch_file("npz");
  // Lowering zipfile's limits makes it write every zip64 structure (local and central extra
  // fields, the zip64 end record and locator) without gigabytes of data.
  ASSERT_TRUE(run_python(R"PY(
import sys, zipfile
import numpy as np
zipfile.ZIP64_LIMIT = 64
zipfile.ZIP_FILECOUNT_LIMIT = 1
with zipfile.ZipFile(sys.argv[1], 'w', compression=zipfile.ZIP_DEFLATED, allowZip64=True) as zf:
    for i in range(3):
        with zf.open('a%d.npy' % i, 'w', force_zip64=True) as f:
            np.lib.format.write_array(f, np.arange(100, dtype='<f8') + i)
    info = zipfile.ZipInfo('stored.npy')
    info.compress_type = zipfile.ZIP_STORED
    with zf.open(info, 'w', force_zip64=True) as f:
        np.lib.format.write_array(f, np.arange(10, dtype='<i8'))
data = open(sys.argv[1], 'rb').read()
sys.exit(0 if b'PK\x06\x06' in data and b'PK\x06\x07' in data else 3)
)PY",
                         {path.string()}));
  const NpzReader npz(path.string());
  EXPECT_EQ(npz.keys(), (std::vector<std::string>{"a0", "a1", "a2", "stored"}));
  const std::vector<double> a2 = npz.load("a2").to_double();
  ASSERT_EQ(a2.size(), 100u);
  for (std::size_t i = 0; i < a2.size(); ++i) EXPECT_EQ(a2[i], static_cast<double>(i) + 2);
  EXPECT_EQ(npz.load("stored").to_int64(), (std::vector<std::int64_t>{0, 1, 2, 3, 4, 5, 6, 7, 8, 9}));
}

// --- archives we wrote, read by numpy ----------------------------------------------------------

TEST(NpzToNumpy, NumpyReadsStoredDeflatedStreamedAndZip64) {
  REQUIRE_NUMPY();
  const fs::path stored = scratch_file("stored.npz");
  const fs::path deflated = scratch_file("deflated.npz");
  const fs::path zip64 = scratch_file("zip64.npz");
  const fs::path npy = scratch_file("npy");
  write_reference_archive(stored, false);
  write_reference_archive(deflated, true);
  write_npy(npy.string(), NpyArray::from_float64(std::vector<double>{0.25, -1, 3}, {3}));
  write_zip(zip64, {{"x.npy", read_bytes(npy)}}, zip::Method::Deflated, {.force_zip64 = true});
  ASSERT_TRUE(run_python(R"PY(
import sys, zipfile
import numpy as np
def fail(message):
    print('numpy check failed:', message)
    sys.exit(1)
expected = {
    'f4': (np.arange(12, dtype='<f4') * 0.25 - 1).astype('<f4').reshape(3, 4),
    'f8': np.array([1 / 3, -2.5e300, 5e-324, 0.0]),
    'b1': np.array([True, False, True, True]),
    'U': np.array(['walk', 'h\u00e9llo', '\u65e5\u672c\u8a9e', '']),
    'S': np.array([b'male', b'female', b''], dtype='S6'),
    'scalar_f8': np.array(3.5),
    'scalar_U': np.array('neutral'),
    'empty': np.zeros((0, 3), dtype='<f4'),
    'cube': np.arange(12, dtype='<i4').reshape(2, 3, 2),
    'streamed': (np.arange(300000 * 3, dtype=np.uint64) * 2654435761 % (1 << 24)).astype('<f4').reshape(300000, 3),
}
for t in ['i1', 'i2', 'i4', 'i8', 'u1', 'u2', 'u4', 'u8']:
    info = np.iinfo(t)
    expected[t] = np.array([info.min, 0, 1, info.max], dtype=t)
expected['i4'] = expected['i4'].reshape(2, 2)
for path in sys.argv[1:3]:
    with zipfile.ZipFile(path) as zf:
        if zf.testzip() is not None:
            fail(path + ': CRC check failed')
    with np.load(path, allow_pickle=False) as npz:
        if sorted(npz.files) != sorted(expected):
            fail(path + ': keys ' + str(npz.files))
        for key, want in expected.items():
            got = npz[key]
            if got.dtype != want.dtype or got.shape != want.shape or not np.array_equal(got, want):
                fail('%s: %s is %r %s' % (path, key, got.dtype, got.shape))
with np.load(sys.argv[3]) as npz:
    if not np.array_equal(npz['x'], [0.25, -1, 3]):
        fail('zip64 archive')
)PY",
                         {stored.string(), deflated.string(), zip64.string()}));
}

// --- the SMPL-X fixture ------------------------------------------------------------------------

TEST(NpzFixture, SmplxModelArrays) {
  const fs::path path = fs::path(ODYSSEY_SHARED_DIR) / "fixtures/smplx/SMPLX_FIXTURE.npz";
  if (!fs::exists(path)) GTEST_SKIP() << path << " not found";
  const NpzReader npz(path.string());
  const NpyArray v_template = npz.load("v_template");
  EXPECT_EQ(v_template.dtype(), DType::Float32);
  ASSERT_EQ(v_template.shape(), (std::vector<std::size_t>{10475, 3}));
  for (double v : v_template.to_double()) ASSERT_TRUE(std::isfinite(v) && std::abs(v) < 2.0) << v;
  const NpyArray faces = npz.load("f");
  EXPECT_EQ(faces.dtype(), DType::UInt32);
  ASSERT_EQ(faces.shape(), (std::vector<std::size_t>{20908, 3}));
  for (std::int64_t index : faces.to_int64()) ASSERT_LT(index, 10475);
  const NpyArray tree = npz.load("kintree_table");
  EXPECT_EQ(tree.dtype(), DType::Int64);
  ASSERT_EQ(tree.shape(), (std::vector<std::size_t>{2, 55}));
  EXPECT_EQ(tree.to_int64()[0], 4294967295);
  EXPECT_EQ(npz.header("posedirs").shape, (std::vector<std::size_t>{10475, 3, 486}));
  EXPECT_EQ(npz.load("posedirs").data.size(), 10475u * 3 * 486 * 4);

  if (numpy_python().empty()) return;
  const fs::path dir = scratch_file("dir");
  fs::create_directories(dir);
  ASSERT_TRUE(run_python(R"PY(
import sys
import numpy as np
with np.load(sys.argv[1]) as npz:
    for key in ['v_template', 'f', 'kintree_table', 'hands_meanl']:
        np.ascontiguousarray(npz[key]).astype(npz[key].dtype.newbyteorder('<')).tofile(sys.argv[2] + '/' + key + '.bin')
)PY",
                         {path.string(), dir.string()}));
  for (const char* key : {"v_template", "f", "kintree_table", "hands_meanl"})
    EXPECT_TRUE(npz.load(key).data == read_bytes(dir / (std::string(key) + ".bin"))) << key;
}

// --- hostile and broken input ------------------------------------------------------------------

TEST(NpzBadInput, TruncatedArchive) {
  const fs::path whole = scratch_file("whole.npz");
  const fs::path half = scratch_file("half.npz");
  write_reference_archive(whole, true);
  auto bytes = read_bytes(whole);
  bytes.resize(bytes.size() / 2);
  write_bytes(half, bytes);
  expect_input_error([&] { NpzReader reader(half.string()); }, half, "truncated");
}

TEST(NpzBadInput, NotAZipArchive) {
  const fs::path text = scratch_file("npz");
  write_bytes(text, as_byte_vector("poses, trans, betas: this is a text file, not an archive\n"));
  expect_input_error([&] { NpzReader reader(text.string()); }, text, "not a zip archive");
  const fs::path empty = scratch_file("empty.npz");
  write_bytes(empty, {});
  expect_input_error([&] { NpzReader reader(empty.string()); }, empty, "not a zip archive");
  const fs::path missing = scratch_file("missing.npz");
  expect_input_error([&] { NpzReader reader(missing.string()); }, missing, "cannot open");
}

TEST(NpzBadInput, CorruptDeflateData) {
  const fs::path path = scratch_file("npz");
  std::vector<std::int32_t> values(200000);
  for (std::size_t i = 0; i < values.size(); ++i) values[i] = static_cast<std::int32_t>(i * i % 251);
  {
    NpzWriter writer(path.string(), true);
    writer.add("poses", make_array(DType::Int32, values, {values.size()}));
    writer.close();
  }
  auto bytes = read_bytes(path);
  for (std::size_t i = bytes.size() / 2; i < bytes.size() / 2 + 16; ++i) bytes[i] ^= std::byte{0xA5};
  write_bytes(path, bytes);
  const NpzReader npz(path.string());
  expect_input_error([&] { npz.load("poses"); }, path, "member 'poses'");
}

TEST(NpzBadInput, CrcMismatch) {
  const fs::path path = scratch_file("npz");
  {
    NpzWriter writer(path.string(), false);
    writer.add("trans", NpyArray::from_float64(std::vector<double>(3000, 1.25), {1000, 3}));
    writer.close();
  }
  auto bytes = read_bytes(path);
  bytes[bytes.size() / 2] ^= std::byte{0x01};
  write_bytes(path, bytes);
  const NpzReader npz(path.string());
  EXPECT_EQ(npz.header("trans").shape, (std::vector<std::size_t>{1000, 3}));
  expect_input_error([&] { npz.load("trans"); }, path, "member 'trans': CRC-32 mismatch");
}

TEST(NpzBadInput, BrokenMembers) {
  const fs::path path = scratch_file("npz");
  const std::string f8_3 = "{'descr': '<f8', 'fortran_order': False, 'shape': (3,), }";
  write_zip(path,
            {{"ok.npy", raw_npy(f8_3, doubles(3))},
             {"poses.npy", raw_npy("{'descr': '<f8', 'fortran_order': False, 'shape': (100,), }", doubles(62))},
             {"dict.npy", raw_npy("{'descr': '<f8', 'fortran_order': maybe, 'shape': (3,), }", doubles(3))},
             {"complex.npy", raw_npy("{'descr': '<c16', 'fortran_order': False, 'shape': (3,), }", doubles(6))},
             {"product.npy", raw_npy("{'descr': '<f8', 'fortran_order': False, 'shape': (3, 4), }", doubles(10))},
             {"long.npy", raw_npy(f8_3, doubles(5))},
             {"huge.npy", raw_npy("{'descr': '<f8', 'fortran_order': False, 'shape': (4294967296, 4294967296, 16), }", {})},
             {"text.npy", as_byte_vector("not an array")}},
            zip::Method::Deflated);
  const NpzReader npz(path.string());
  EXPECT_EQ(npz.load("ok").to_double(), (std::vector<double>{0, 0.5, 1}));
  expect_input_error([&] { npz.load("poses"); }, path, "member 'poses': data truncated: expected 800 bytes, found 496");
  expect_input_error([&] { npz.load("dict"); }, path, "member 'dict': bad .npy header");
  expect_input_error([&] { npz.header("dict"); }, path, "member 'dict': bad .npy header");
  expect_input_error([&] { npz.load("complex"); }, path, "member 'complex': unsupported dtype '<c16'");
  expect_input_error([&] { npz.load("product"); }, path, "member 'product': data truncated: expected 96 bytes, found 80");
  expect_input_error([&] { npz.load("long"); }, path, "member 'long': data length mismatch");
  expect_input_error([&] { npz.load("huge"); }, path, "member 'huge': shape (4294967296, 4294967296, 16)");
  expect_input_error([&] { npz.load("text"); }, path, "member 'text': not an .npy array");
  expect_input_error([&] { npz.load("nope"); }, path, "no array 'nope' (keys: ok, poses, dict, complex, product, long, huge, text)");
  expect_input_error([&] { npz.header("nope"); }, path, "no array 'nope'");
}

TEST(NpzBadInput, DuplicateMembers) {
  const fs::path path = scratch_file("npz");
  const auto member = raw_npy("{'descr': '<f8', 'fortran_order': False, 'shape': (1,), }", doubles(1));
  write_zip(path, {{"betas.npy", member}, {"betas.npy", member}}, zip::Method::Stored);
  expect_input_error([&] { NpzReader reader(path.string()); }, path, "duplicate member 'betas.npy'");
}

// --- writer behaviour --------------------------------------------------------------------------

bool has_partial_files(const fs::path& target) {
  for (const auto& entry : fs::directory_iterator(target.parent_path()))
    if (entry.path().filename().string().starts_with(target.filename().string() + ".partial")) return true;
  return false;
}

TEST(NpzWriterTest, NoCloseLeavesNoFile) {
  const fs::path path = scratch_file("npz");
  fs::remove(path);
  {
    NpzWriter writer(path.string());
    writer.add("trans", NpyArray::from_float64(std::vector<double>{1, 2, 3}, {1, 3}));
    writer.begin_array("poses", DType::Float32, {10, 3});
    writer.append(std::span<const float>(std::vector<float>(6, 1.0f)));
  }
  EXPECT_FALSE(fs::exists(path));
  EXPECT_FALSE(has_partial_files(path));
}

TEST(NpzWriterTest, ExistingFileIsReplacedOnlyOnClose) {
  const fs::path path = scratch_file("npz");
  {
    NpzWriter writer(path.string());
    writer.add("v", NpyArray::scalar_float64(1.0));
    writer.close();
  }
  {
    NpzWriter writer(path.string());
    writer.add("v", NpyArray::scalar_float64(2.0));
  }
  EXPECT_EQ(NpzReader(path.string()).load("v").to_double(), (std::vector<double>{1.0}));
  {
    NpzWriter writer(path.string());
    writer.add("v", NpyArray::scalar_float64(2.0));
    writer.close();
  }
  EXPECT_EQ(NpzReader(path.string()).load("v").to_double(), (std::vector<double>{2.0}));
  EXPECT_FALSE(has_partial_files(path));
}

TEST(NpzWriterTest, MisuseIsRejected) {
  const fs::path path = scratch_file("npz");
  NpzWriter writer(path.string());
  EXPECT_THROW(writer.begin_array("names", DType::Unicode, {3}), std::invalid_argument);
  EXPECT_THROW(writer.begin_array("names", DType::Unicode, {3}, 6), std::invalid_argument);
  EXPECT_THROW(writer.begin_array("x", DType::Float32, {3}, 8), std::invalid_argument);
  EXPECT_THROW(writer.begin_array("x", DType::Object, {3}), std::invalid_argument);
  EXPECT_THROW(writer.append(std::span<const float>()), std::logic_error);
  writer.begin_array("x", DType::Float64, {2});
  const double one = 1.0;
  writer.append(std::span<const double>(&one, 1));
  EXPECT_THROW(writer.end_array(), std::logic_error);
  EXPECT_THROW(writer.close(), std::logic_error);
  writer.append(std::span<const double>(&one, 1));
  EXPECT_THROW(writer.append(std::span<const double>(&one, 1)), std::invalid_argument);
  writer.end_array();
  EXPECT_THROW(writer.add("x", NpyArray::scalar_float64(1)), std::invalid_argument);
  writer.begin_array("names", DType::Bytes, {1}, 4);
  writer.append(std::as_bytes(std::span("abcd", 4)));
  writer.end_array();
  writer.close();
  EXPECT_THROW(writer.close(), std::logic_error);
  const NpzReader npz(path.string());
  EXPECT_EQ(npz.load("x").to_double(), (std::vector<double>{1, 1}));
  EXPECT_EQ(npz.load("names").to_strings(), (std::vector<std::string>{"abcd"}));
}

TEST(NpzWriterTest, UnwritableDirectory) {
  const fs::path path = scratch_file("no-such-dir") / "out.npz";
  expect_input_error([&] { NpzWriter writer(path.string()); }, path, "does not exist");
}

}  // namespace
