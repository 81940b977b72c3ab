// Reading CSV files as RFC 4180 defines them: fields separated by commas, records by line
// breaks (CRLF or LF), a field that holds a comma, a quote or a line break is enclosed in
// double quotes, and a quote inside such a field is doubled. campaign.csv is written that way
// (merge.cpp): the `detail` column may hold all three.
#pragma once

#include <string>
#include <vector>

namespace lander::campaign {

// A CSV file: the header's column names and the records below it, each with the line of the
// file where it starts (1-based; a quoted line break makes a record span several lines).
struct CsvTable {
  struct Record {
    int line{0};
    std::vector<std::string> cells;  ///< as many as the header has
  };
  std::string source;  ///< the file, for messages
  std::vector<std::string> header;
  std::vector<Record> records;

  // Index of the column named `name`, or -1.
  int column(const std::string& name) const;
};

// Parses CSV text. Empty lines between records are skipped; a UTF-8 byte-order mark is dropped;
// the last record may end without a line break. Throws ConfigError "<source>:<line>: ..." for
// a quote inside an unquoted field, text after a closing quote, an unterminated quote, a
// record whose number of fields differs from the header's, an empty or duplicate column name,
// or a file without a header.
CsvTable parse_csv(const std::string& text, const std::string& source);

// Reads and parses a file. Throws ConfigError naming the file when it cannot be read.
CsvTable read_csv_file(const std::string& path);

}  // namespace lander::campaign
