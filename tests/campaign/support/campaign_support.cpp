#include "campaign/support/campaign_support.h"

#include <stdlib.h>
#include <unistd.h>

#include <algorithm>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "common/run_binary.h"

namespace lander::test {

Result lander(const std::vector<std::string>& args) {
  const std::string dir = temp_dir("lander_cli_out");
  std::vector<std::string> argv{LANDER_BINARY};
  argv.insert(argv.end(), args.begin(), args.end());
  const BinaryRun b = run_binary(argv, dir);
  rmdir(dir.c_str());
  return Result{b.code, b.out + b.err};
}

std::string temp_dir(const std::string& prefix) {
  std::string tmpl = "/tmp/" + prefix + "_XXXXXX";
  std::vector<char> buf(tmpl.begin(), tmpl.end());
  buf.push_back('\0');
  if (!mkdtemp(buf.data())) throw std::runtime_error("mkdtemp failed for " + tmpl);
  return buf.data();
}

std::string read_text(const std::string& path) { return sim::read_file_text(path, /*missing_ok=*/true); }

Csv read_csv(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw std::runtime_error(path + ": cannot read");
  std::stringstream ss;
  ss << f.rdbuf();
  const std::string s = ss.str();
  std::vector<std::vector<std::string>> records;
  std::vector<std::string> rec;
  std::string field;
  bool quoted = false, any = false;
  for (std::size_t i = 0; i < s.size(); ++i) {
    const char c = s[i];
    if (quoted) {
      if (c == '"' && i + 1 < s.size() && s[i + 1] == '"') {
        field += '"';
        ++i;
      } else if (c == '"') {
        quoted = false;
      } else {
        field += c;
      }
    } else if (c == '"') {
      if (!field.empty()) throw std::runtime_error(path + ": quote inside an unquoted field");
      quoted = true;
    } else if (c == ',') {
      rec.push_back(field);
      field.clear();
    } else if (c == '\n') {
      rec.push_back(field);
      records.push_back(rec);
      rec.clear();
      field.clear();
    } else if (c != '\r') {
      field += c;
    }
    any = true;
  }
  if (quoted) throw std::runtime_error(path + ": unterminated quote");
  if (!field.empty() || !rec.empty()) throw std::runtime_error(path + ": last line has no line break");
  if (!any || records.empty()) throw std::runtime_error(path + ": empty");
  Csv csv;
  csv.header = records.front();
  for (std::size_t i = 1; i < records.size(); ++i) {
    if (records[i].size() != csv.header.size()) {
      throw std::runtime_error(path + ": row " + std::to_string(i) + " has " +
                               std::to_string(records[i].size()) + " cells, the header " +
                               std::to_string(csv.header.size()));
    }
    csv.rows.push_back(records[i]);
  }
  return csv;
}

std::vector<std::string> Csv::canonical_rows(const std::vector<std::string>& drop) const {
  std::vector<std::string> out;
  for (const auto& r : rows) {
    std::string line;
    for (std::size_t i = 0; i < header.size(); ++i) {
      if (std::find(drop.begin(), drop.end(), header[i]) != drop.end()) continue;
      line += header[i] + "=" + r[i] + ";";
    }
    out.push_back(line);
  }
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace lander::test
