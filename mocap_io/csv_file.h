// CSV as people and spreadsheets write it (RFC 4180): fields separated by commas, a field in
// double quotes may hold commas, line breaks and doubled quotes (""), lines end in LF or CRLF, a
// last line may lack its line break. The first row is the header. Rows keep the line they start
// on, so a reader of the table can name "file: line 7, column quality".
#pragma once

#include <optional>
#include <string>
#include <vector>

namespace odyssey::io {

struct CsvTable {
  std::string file;
  std::vector<std::string> header;
  struct Row {
    int line = 0;  // 1-based line of the file where the row starts
    std::vector<std::string> cells;
  };
  std::vector<Row> rows;  // blank lines are skipped

  // The index of column `name` in the header, if any.
  std::optional<std::size_t> column(const std::string& name) const;
};

// Throws InputError naming the file and line: an unterminated quote, text after a closing quote,
// a row with more or fewer fields than the header, an empty or repeated header name, no header.
CsvTable parse_csv(const std::string& text, const std::string& file);
CsvTable read_csv_file(const std::string& path);

}  // namespace odyssey::io
