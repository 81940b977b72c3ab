#include "lander/campaign/csv.h"

#include <fmt/format.h>

#include <algorithm>
#include <fstream>
#include <set>
#include <sstream>

#include "lander/core/params_io.h"

namespace lander::campaign {

namespace {

// A character-level reader of CSV text that tracks the current line.
class CsvScanner {
 public:
  CsvScanner(const std::string& text, const std::string& source) : s_(text), source_(source) {
    if (s_.compare(0, 3, "\xEF\xBB\xBF") == 0) i_ = 3;  // UTF-8 byte-order mark
  }

  bool done() const { return i_ >= s_.size(); }
  int line() const { return line_; }

  // Skips line breaks between records (empty lines); true when a record follows.
  bool skip_empty_lines() {
    while (!done() && (s_[i_] == '\n' || s_[i_] == '\r')) advance();
    return !done();
  }

  // Reads one record: fields up to the line break that ends it (or the end of the text).
  std::vector<std::string> record() {
    std::vector<std::string> cells;
    while (true) {
      cells.push_back(field());
      if (done()) break;
      const char c = s_[i_];
      if (c == ',') {
        advance();
        continue;
      }
      // A line break ends the record: "\r\n", "\n" or a lone "\r".
      if (c == '\r' && i_ + 1 < s_.size() && s_[i_ + 1] == '\n') advance();
      advance();
      break;
    }
    return cells;
  }

 private:
  [[noreturn]] void fail(const std::string& problem) const {
    throw ConfigError(fmt::format("{}:{}: {}", source_, line_, problem));
  }

  void advance() {
    // A line break counts once: "\r\n" at the '\n', a lone '\r' by itself.
    if (s_[i_] == '\n' || (s_[i_] == '\r' && (i_ + 1 >= s_.size() || s_[i_ + 1] != '\n'))) ++line_;
    ++i_;
  }

  bool at_field_end() const { return done() || s_[i_] == ',' || s_[i_] == '\n' || s_[i_] == '\r'; }

  // One field, quoted or not; stops before the separator or line break that follows it.
  std::string field() {
    std::string f;
    if (!done() && s_[i_] == '"') {
      const int start_line = line_;
      advance();
      while (true) {
        if (done()) {
          throw ConfigError(
              fmt::format("{}:{}: unterminated quoted field (the quote opened here is "
                          "never closed)",
                          source_, start_line));
        }
        const char c = s_[i_];
        advance();
        if (c != '"') {
          f += c;
        } else if (!done() && s_[i_] == '"') {  // a doubled quote is one quote
          f += '"';
          advance();
        } else {
          break;
        }
      }
      if (!at_field_end()) fail("text after the closing quote of a quoted field");
      return f;
    }
    while (!at_field_end()) {
      if (s_[i_] == '"')
        fail("quote inside an unquoted field (quote the whole field and double it)");
      f += s_[i_];
      advance();
    }
    return f;
  }

  const std::string& s_;
  const std::string& source_;
  std::size_t i_{0};
  int line_{1};
};

}  // namespace

int CsvTable::column(const std::string& name) const {
  const auto it = std::find(header.begin(), header.end(), name);
  return it == header.end() ? -1 : static_cast<int>(it - header.begin());
}

CsvTable parse_csv(const std::string& text, const std::string& source) {
  CsvTable t;
  t.source = source;
  CsvScanner in(text, source);
  if (!in.skip_empty_lines()) throw ConfigError(source + ": empty (no header line)");
  const int header_line = in.line();
  t.header = in.record();
  // Column names must be usable as keys.
  std::set<std::string> seen;
  for (const std::string& h : t.header) {
    if (h.empty())
      throw ConfigError(fmt::format("{}:{}: empty column name in the header", source, header_line));
    if (!seen.insert(h).second) {
      throw ConfigError(
          fmt::format("{}:{}: column '{}' appears twice in the header", source, header_line, h));
    }
  }
  while (in.skip_empty_lines()) {
    CsvTable::Record r;
    r.line = in.line();
    r.cells = in.record();
    if (r.cells.size() != t.header.size()) {
      throw ConfigError(fmt::format("{}:{}: {} fields, the header has {}", source, r.line,
                                    r.cells.size(), t.header.size()));
    }
    t.records.push_back(std::move(r));
  }
  return t;
}

CsvTable read_csv_file(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw ConfigError(path + ": cannot read file");
  std::ostringstream ss;
  ss << f.rdbuf();
  return parse_csv(ss.str(), path);
}

}  // namespace lander::campaign
