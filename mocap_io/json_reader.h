// Reading a JSON document that a person wrote (scene files, batch manifests) with errors that name
// the file and the JSON path of the value at fault: "scene.json: actors[1].placement.yaw: not a
// number". A JsonValue is a view of one value and its path; typed getters throw io::InputError
// when the value has another type, and an object's allow_only() rejects keys it does not know.
// Parsing is linear in the text (nlohmann::json, whose parser keeps its own stack) and refuses
// nesting deeper than kMaxJsonDepth, so no document can exhaust the stack.
#pragma once

#include <cstddef>
#include <cstdint>
#include <initializer_list>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>

#include "mocap_io/input_file.h"

namespace odyssey::io {

inline constexpr int kMaxJsonDepth = 64;

class JsonValue {
 public:
  JsonValue(const nlohmann::json& value, std::string file, std::string path)
      : value_(&value), file_(std::move(file)), path_(std::move(path)) {}

  const std::string& path() const { return path_; }
  const nlohmann::json& raw() const { return *value_; }
  bool is_object() const { return value_->is_object(); }
  bool is_array() const { return value_->is_array(); }
  bool is_string() const { return value_->is_string(); }
  bool is_number() const { return value_->is_number(); }

  // Throws InputError "<file>: <path>: <problem>".
  [[noreturn]] void fail(const std::string& problem) const;

  // Objects. member() requires the key; find() returns nothing when absent (or null).
  JsonValue member(std::string_view key) const;
  std::optional<JsonValue> find(std::string_view key) const;
  // Throws when the object holds a key not in `known`, naming it and the keys allowed.
  void allow_only(std::initializer_list<std::string_view> known) const;

  // Arrays.
  std::size_t size() const;
  JsonValue operator[](std::size_t index) const;

  std::string string() const;
  double number() const;                       // finite
  double number_in(double low, double high) const;
  long long integer(long long low, long long high) const;
  bool boolean() const;

 private:
  void require_object() const;
  const nlohmann::json* value_;
  std::string file_, path_;
};

// A parsed document that owns its value. Throws InputError naming the file when it cannot be
// read, is not JSON (with the byte offset), or nests deeper than kMaxJsonDepth.
// The whole file as text (read_input_file: a regular file, at most `max_bytes`); throws InputError
// naming it when it cannot be read.
std::string read_text_file(const std::string& path, std::uint64_t max_bytes = kMaxJsonInputBytes);

// nlohmann::json::parse under the rules every JSON input follows: no deeper than kMaxJsonDepth, and
// a key given twice in one object refused naming its JSON path (nlohmann would keep the last).
// `also`, when given, sees every parser event after these checks. Throws InputError naming `name`.
nlohmann::json parse_json(const std::string& text, const std::string& name,
                          const nlohmann::json::parser_callback_t& also = nullptr);

class JsonDocument {
 public:
  static JsonDocument read_file(const std::string& path);
  static JsonDocument parse(const std::string& text, const std::string& name);
  JsonValue root() const { return JsonValue(json_, name_, ""); }

 private:
  nlohmann::json json_;
  std::string name_;
};

}  // namespace odyssey::io
