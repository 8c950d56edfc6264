// A small command-line parser for the subcommands: `--name value` options, `--flag` switches
// and positional arguments, each declared with its help text so --help is generated from the
// same table that parsing uses. Unknown options and missing values are usage errors.
#pragma once

#include <map>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

namespace odyssey::cli {

// Thrown for a malformed command line; main prints it with the subcommand's usage, exit code 2.
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

class Args {
 public:
  Args(std::string command, std::string summary) : command_(std::move(command)), summary_(std::move(summary)) {}

  Args& option(const std::string& name, const std::string& value_name, const std::string& help,
               std::optional<std::string> default_value = std::nullopt);
  Args& flag(const std::string& name, const std::string& help);
  Args& positional(const std::string& name, const std::string& help);
  // A last positional argument that may be left out (has() tells).
  Args& optional_positional(const std::string& name, const std::string& help);
  // `--name A B C ...`: every argument up to the next that starts with "--" (a shell glob expands
  // to many); the option may also repeat. get_list() returns them all, in order.
  Args& list_option(const std::string& name, const std::string& value_name, const std::string& help);
  // The positional arguments after the declared ones (at least one), e.g. "DIR...".
  Args& rest(const std::string& name, const std::string& help);

  // Returns false when --help was asked for (the help text has been printed).
  bool parse(const std::vector<std::string>& arguments);

  bool has(const std::string& name) const;
  std::string get(const std::string& name) const;  // value or default; UsageError when neither
  std::optional<std::string> get_optional(const std::string& name) const;
  double get_double(const std::string& name) const;
  long long get_int(const std::string& name) const;
  bool get_flag(const std::string& name) const;
  std::vector<std::string> get_list(const std::string& name) const;  // a list option's values, or the rest

  std::string help() const;

 private:
  struct Spec {
    std::string name, value_name, help;
    std::optional<std::string> default_value;
    bool is_flag = false;
    bool is_list = false;
    bool optional = false;
  };
  const Spec* find_option(const std::string& name) const;
  const Spec* find(const std::string& name) const;

  std::string command_, summary_;
  std::vector<Spec> options_;
  std::vector<Spec> positionals_;
  std::optional<Spec> rest_;
  std::map<std::string, std::string> values_;
  std::map<std::string, std::vector<std::string>> lists_;
  std::set<std::string> flags_;
};

}  // namespace odyssey::cli
