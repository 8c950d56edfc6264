#include "mocap_io/csv_file.h"

#include <algorithm>
#include <string_view>

#include "mocap_io/input_error.h"
#include "mocap_io/input_file.h"
#include "mocap_io/json_reader.h"

namespace odyssey::io {

std::optional<std::size_t> CsvTable::column(const std::string& name) const {
  const auto found = std::find(header.begin(), header.end(), name);
  if (found == header.end()) return std::nullopt;
  return static_cast<std::size_t>(found - header.begin());
}

CsvTable parse_csv(const std::string& file_text, const std::string& file) {
  // A UTF-8 byte-order mark (spreadsheets write one) is not part of the first column's name.
  const std::string_view bom = "\xEF\xBB\xBF";
  const std::string text = std::string_view(file_text).starts_with(bom) ? file_text.substr(bom.size()) : file_text;
  CsvTable table;
  table.file = file;
  std::vector<std::vector<std::string>> records;
  std::vector<int> record_lines;
  std::vector<std::string> fields;
  std::string field;
  int line = 1, record_line = 1;
  bool quoted = false;   // inside a quoted field
  bool after_quote = false;  // a quoted field just closed: only a separator may follow
  bool record_empty = true;
  const auto end_field = [&] {
    fields.push_back(std::move(field));
    field.clear();
    after_quote = false;
  };
  const auto end_record = [&] {
    end_field();
    if (!(record_empty && fields.size() == 1 && fields[0].empty())) {
      records.push_back(std::move(fields));
      record_lines.push_back(record_line);
    }
    fields.clear();
    record_empty = true;
  };
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (quoted) {
      if (c == '"') {
        if (i + 1 < text.size() && text[i + 1] == '"') {
          field += '"';
          ++i;
        } else {
          quoted = false;
          after_quote = true;
        }
      } else {
        if (c == '\n') ++line;
        field += c;
      }
      continue;
    }
    if (c == ',') {
      end_field();
      record_empty = false;
    } else if (c == '\n' || (c == '\r' && i + 1 < text.size() && text[i + 1] == '\n')) {
      if (c == '\r') ++i;
      end_record();
      ++line;
      record_line = line;
    } else if (after_quote) {
      throw InputError(file, "line " + std::to_string(line) + ": text after a closing quote");
    } else if (c == '"') {
      if (!field.empty()) throw InputError(file, "line " + std::to_string(line) + ": a quote inside an unquoted field");
      quoted = true;
      record_empty = false;
    } else {
      field += c;
      record_empty = false;
    }
  }
  if (quoted) throw InputError(file, "line " + std::to_string(record_line) + ": a quoted field is never closed");
  end_record();

  if (records.empty()) throw InputError(file, "no header row");
  table.header = std::move(records[0]);
  for (std::size_t c = 0; c < table.header.size(); ++c) {
    const std::string& name = table.header[c];
    if (name.empty()) throw InputError(file, "line " + std::to_string(record_lines[0]) + ": column " + std::to_string(c + 1) + " has no name");
    if (std::find(table.header.begin(), table.header.begin() + static_cast<long>(c), name) != table.header.begin() + static_cast<long>(c)) {
      throw InputError(file, "line " + std::to_string(record_lines[0]) + ": column '" + name + "' appears twice");
    }
  }
  for (std::size_t r = 1; r < records.size(); ++r) {
    if (records[r].size() != table.header.size()) {
      throw InputError(file, "line " + std::to_string(record_lines[r]) + ": " + std::to_string(records[r].size()) +
                                 " fields, the header has " + std::to_string(table.header.size()));
    }
    table.rows.push_back({record_lines[r], std::move(records[r])});
  }
  return table;
}

CsvTable read_csv_file(const std::string& path) { return parse_csv(read_text_file(path, kMaxTextInputBytes), path); }

}  // namespace odyssey::io
