#include "mocap_io/json_reader.h"

#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

#include "mocap_io/input_error.h"
#include "mocap_io/input_file.h"

namespace odyssey::io {
namespace {

std::string child_path(const std::string& parent, std::string_view key) {
  return parent.empty() ? std::string(key) : parent + "." + std::string(key);
}

const char* type_name(const nlohmann::json& value) {
  if (value.is_object()) return "an object";
  if (value.is_array()) return "a list";
  if (value.is_string()) return "a string";
  if (value.is_boolean()) return "true or false";
  if (value.is_number()) return "a number";
  return "null";
}

}  // namespace

void JsonValue::fail(const std::string& problem) const {
  throw InputError(file_, (path_.empty() ? std::string("top level") : path_) + ": " + problem);
}

void JsonValue::require_object() const {
  if (!value_->is_object()) fail(std::string("expected an object, got ") + type_name(*value_));
}

JsonValue JsonValue::member(std::string_view key) const {
  require_object();
  const auto found = value_->find(key);
  if (found == value_->end() || found->is_null()) JsonValue(*value_, file_, child_path(path_, key)).fail("missing");
  return JsonValue(*found, file_, child_path(path_, key));
}

std::optional<JsonValue> JsonValue::find(std::string_view key) const {
  require_object();
  const auto found = value_->find(key);
  if (found == value_->end() || found->is_null()) return std::nullopt;
  return JsonValue(*found, file_, child_path(path_, key));
}

void JsonValue::allow_only(std::initializer_list<std::string_view> known) const {
  require_object();
  for (const auto& [key, value] : value_->items()) {
    bool allowed = false;
    for (const std::string_view name : known) allowed |= key == name;
    if (allowed) continue;
    std::string names;
    for (const std::string_view name : known) names += (names.empty() ? "" : ", ") + std::string(name);
    JsonValue(value, file_, child_path(path_, key)).fail("unknown key (known here: " + names + ")");
  }
}

std::size_t JsonValue::size() const {
  if (!value_->is_array()) fail(std::string("expected a list, got ") + type_name(*value_));
  return value_->size();
}

JsonValue JsonValue::operator[](std::size_t index) const {
  if (index >= size()) fail("no element " + std::to_string(index));
  return JsonValue((*value_)[index], file_, path_ + "[" + std::to_string(index) + "]");
}

std::string JsonValue::string() const {
  if (!value_->is_string()) fail(std::string("not a string (got ") + type_name(*value_) + ")");
  return value_->get<std::string>();
}

double JsonValue::number() const {
  if (!value_->is_number()) fail(std::string("not a number (got ") + type_name(*value_) + ")");
  const double value = value_->get<double>();
  if (!std::isfinite(value)) fail("not a finite number");
  return value;
}

double JsonValue::number_in(double low, double high) const {
  const double value = number();
  if (!(value >= low && value <= high)) {
    std::ostringstream text;
    text << value << " is outside [" << low << ", " << high << "]";
    fail(text.str());
  }
  return value;
}

long long JsonValue::integer(long long low, long long high) const {
  if (!value_->is_number_integer()) fail(std::string("not a whole number (got ") + type_name(*value_) + ")");
  const long long value = value_->is_number_unsigned() && value_->get<unsigned long long>() > 9e18
                              ? high + 1
                              : value_->get<long long>();
  if (value < low || value > high) {
    fail(std::to_string(value) + " is outside [" + std::to_string(low) + ", " + std::to_string(high) + "]");
  }
  return value;
}

bool JsonValue::boolean() const {
  if (!value_->is_boolean()) fail(std::string("not true or false (got ") + type_name(*value_) + ")");
  return value_->get<bool>();
}

std::string read_text_file(const std::string& path, std::uint64_t max_bytes) { return read_input_file(path, max_bytes); }

JsonDocument JsonDocument::read_file(const std::string& path) { return parse(read_text_file(path), path); }

nlohmann::json parse_json(const std::string& text, const std::string& name, const nlohmann::json::parser_callback_t& also) {
  // nlohmann's parser keeps its own stack; the callback sees each value's depth and stops a
  // document nested deeper than any person writes before it is built. It also follows the open
  // objects and arrays, so that a key given twice in one object (nlohmann keeps the last) is an
  // error naming its JSON path.
  struct Open {
    bool array = false;
    long index = -1;       // array: the element being read
    std::string key;       // object: the key being read
    std::set<std::string> keys;
  };
  std::vector<Open> open;
  const auto path = [&] {
    std::string text;
    for (const Open& level : open) {
      text += level.array ? "[" + std::to_string(level.index) + "]" : (text.empty() ? "" : ".") + level.key;
    }
    return text;
  };
  const auto next_element = [&] {
    if (!open.empty() && open.back().array) ++open.back().index;
  };
  using Event = nlohmann::json::parse_event_t;
  const nlohmann::json::parser_callback_t follow = [&](int depth, Event event, nlohmann::json& parsed) {
    if (depth > kMaxJsonDepth) throw InputError(name, "nested deeper than " + std::to_string(kMaxJsonDepth) + " levels");
    switch (event) {
      case Event::object_start:
      case Event::array_start:
        next_element();
        open.push_back(Open{event == Event::array_start, -1, {}, {}});
        break;
      case Event::object_end:
      case Event::array_end:
        if (!open.empty()) open.pop_back();
        break;
      case Event::key: {
        const std::string key = parsed.get<std::string>();
        if (!open.empty() && !open.back().keys.insert(key).second) {
          open.back().key = key;
          throw InputError(name, path() + ": the key \"" + key + "\" is given twice in one object");
        }
        if (!open.empty()) open.back().key = key;
        break;
      }
      case Event::value:
        next_element();
        break;
    }
    return also ? also(depth, event, parsed) : true;
  };
  try {
    return nlohmann::json::parse(text, follow);
  } catch (const nlohmann::json::exception& error) {
    // parse_error, and out_of_range for a number too large for a double (1e99999).
    throw InputError(name, std::string("not valid JSON: ") + error.what());
  }
}

JsonDocument JsonDocument::parse(const std::string& text, const std::string& name) {
  JsonDocument document;
  document.name_ = name;
  document.json_ = parse_json(text, name);
  return document;
}

}  // namespace odyssey::io
