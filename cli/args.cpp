#include "cli/args.h"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <sstream>

namespace odyssey::cli {

Args& Args::option(const std::string& name, const std::string& value_name, const std::string& help,
                   std::optional<std::string> default_value) {
  options_.push_back({name, value_name, help, std::move(default_value), false});
  return *this;
}

Args& Args::flag(const std::string& name, const std::string& help) {
  options_.push_back({name, "", help, std::nullopt, true});
  return *this;
}

Args& Args::optional_positional(const std::string& name, const std::string& help) {
  positionals_.push_back({name, name, help, std::nullopt, false, false, true});
  return *this;
}

Args& Args::positional(const std::string& name, const std::string& help) {
  positionals_.push_back({name, name, help, std::nullopt, false});
  return *this;
}

Args& Args::list_option(const std::string& name, const std::string& value_name, const std::string& help) {
  options_.push_back({name, value_name + "...", help, std::nullopt, false, true});
  return *this;
}

Args& Args::rest(const std::string& name, const std::string& help) {
  rest_ = Spec{name, name + "...", help, std::nullopt, false, true};
  return *this;
}

const Args::Spec* Args::find_option(const std::string& name) const {
  for (const Spec& spec : options_) {
    if (spec.name == name) return &spec;
  }
  return nullptr;
}

const Args::Spec* Args::find(const std::string& name) const {
  if (const Spec* spec = find_option(name)) return spec;
  for (const Spec& spec : positionals_) {
    if (spec.name == name) return &spec;
  }
  return nullptr;
}

bool Args::parse(const std::vector<std::string>& arguments) {
  std::size_t next_positional = 0;
  for (std::size_t i = 0; i < arguments.size(); ++i) {
    const std::string& argument = arguments[i];
    if (argument == "--help" || argument == "-h") {
      std::fputs(help().c_str(), stdout);
      return false;
    }
    if (argument.rfind("--", 0) == 0) {
      std::string name = argument.substr(2), value;
      const std::size_t equals = name.find('=');
      const bool inline_value = equals != std::string::npos;
      if (inline_value) {
        value = name.substr(equals + 1);
        name.resize(equals);
      }
      const Spec* spec = find_option(name);
      if (!spec) throw UsageError("unknown option --" + name);
      if (spec->is_list) {
        std::vector<std::string>& list = lists_[name];
        const std::size_t before = list.size();
        if (inline_value) list.push_back(value);
        while (i + 1 < arguments.size() && arguments[i + 1].rfind("--", 0) != 0) list.push_back(arguments[++i]);
        if (list.size() == before) throw UsageError("option --" + name + " needs one or more values (" + spec->value_name + ")");
        continue;
      }
      if (spec->is_flag) {
        if (inline_value) throw UsageError("option --" + name + " takes no value");
        flags_.insert(name);
        continue;
      }
      if (!inline_value) {
        if (i + 1 >= arguments.size()) throw UsageError("option --" + name + " needs a value (" + spec->value_name + ")");
        value = arguments[++i];
      }
      values_[name] = value;
    } else {
      if (next_positional >= positionals_.size() && rest_) {
        lists_[rest_->name].push_back(argument);
        continue;
      }
      if (next_positional >= positionals_.size()) throw UsageError("unexpected argument '" + argument + "'");
      values_[positionals_[next_positional++].name] = argument;
    }
  }
  if (next_positional < positionals_.size() && !positionals_[next_positional].optional) throw UsageError("missing argument " + positionals_[next_positional].name);
  if (rest_ && lists_[rest_->name].empty()) throw UsageError("missing argument " + rest_->value_name);
  return true;
}

bool Args::has(const std::string& name) const {
  return values_.count(name) > 0 || flags_.count(name) > 0 || lists_.count(name) > 0;
}

std::vector<std::string> Args::get_list(const std::string& name) const {
  const auto found = lists_.find(name);
  return found == lists_.end() ? std::vector<std::string>{} : found->second;
}

std::optional<std::string> Args::get_optional(const std::string& name) const {
  if (auto it = values_.find(name); it != values_.end()) return it->second;
  if (const Spec* spec = find(name); spec && spec->default_value) return spec->default_value;
  return std::nullopt;
}

std::string Args::get(const std::string& name) const {
  if (auto value = get_optional(name)) return *value;
  throw UsageError("missing required option --" + name);
}

double Args::get_double(const std::string& name) const {
  const std::string text = get(name);
  double value = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (error != std::errc() || end != text.data() + text.size() || !std::isfinite(value)) {
    throw UsageError("--" + name + " expects a number, got '" + text + "'");
  }
  return value;
}

long long Args::get_int(const std::string& name) const {
  const std::string text = get(name);
  long long value = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (error != std::errc() || end != text.data() + text.size()) {
    throw UsageError("--" + name + " expects an integer, got '" + text + "'");
  }
  return value;
}

bool Args::get_flag(const std::string& name) const { return flags_.count(name) > 0; }

std::string Args::help() const {
  std::ostringstream out;
  out << "usage: odyssey " << command_;
  for (const Spec& spec : positionals_) out << ' ' << (spec.optional ? "[" + spec.name + "]" : spec.name);
  if (rest_) out << ' ' << rest_->value_name;
  if (!options_.empty()) out << " [options]";
  out << "\n\n" << summary_ << "\n";
  if (!positionals_.empty() || rest_) {
    out << "\narguments:\n";
    for (const Spec& spec : positionals_) out << "  " << spec.name << "\n      " << spec.help << "\n";
    if (rest_) out << "  " << rest_->value_name << "\n      " << rest_->help << "\n";
  }
  out << "\noptions:\n";
  for (const Spec& spec : options_) {
    out << "  --" << spec.name;
    if (!spec.is_flag) out << ' ' << spec.value_name;
    out << "\n      " << spec.help;
    if (spec.default_value) out << " (default: " << *spec.default_value << ")";
    out << "\n";
  }
  out << "  --help\n      show this help\n";
  return out.str();
}

}  // namespace odyssey::cli
