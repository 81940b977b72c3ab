#include "lander/sim/util/output_files.h"

#include "lander/core/params_io.h"

#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>

#include <fmt/format.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

namespace lander::sim {

namespace {
std::string errno_text() { return errno ? std::string(": ") + std::strerror(errno) : ""; }

// "<path>.tmp.<pid>": processes writing the same file at once (campaign shards writing
// plan.json) never share a temporary file; the last rename wins with a whole file.
std::string temporary_name(const std::string& path) {
  return path + ".tmp." + std::to_string(getpid());
}
}  // namespace

AtomicFile::AtomicFile(std::string path) : path_(std::move(path)), tmp_(temporary_name(path_)) {
  errno = 0;
  out_.open(tmp_, std::ios::binary | std::ios::trunc);
  if (!out_) throw OutputError(path_ + ": cannot create file" + errno_text());
}

AtomicFile::~AtomicFile() {
  if (committed_) return;
  out_.close();
  std::remove(tmp_.c_str());
}

void AtomicFile::commit() {
  if (committed_) return;
  errno = 0;
  out_.flush();
  const bool flushed = out_.good();
  out_.close();
  if (!flushed || out_.fail()) {
    const std::string why = errno_text();
    std::remove(tmp_.c_str());
    throw OutputError(path_ + ": write failed" + (why.empty() ? " (disk full?)" : why));
  }
  errno = 0;
  if (std::rename(tmp_.c_str(), path_.c_str()) != 0) {
    const std::string why = errno_text();
    std::remove(tmp_.c_str());
    throw OutputError(path_ + ": cannot rename the temporary file into place" + why);
  }
  committed_ = true;
}

void write_file_atomic(const std::string& path, std::string_view text) {
  AtomicFile f(path);
  f.write(text);
  f.commit();
}

std::string json_text(const nlohmann::ordered_json& j) {
  // error_handler replace: a string with invalid UTF-8 (a path from the user) is written with
  // U+FFFD instead of throwing; valid UTF-8 is kept as is.
  return j.dump(2, ' ', false, nlohmann::ordered_json::error_handler_t::replace) + "\n";
}

void write_json_file(const std::string& path, const nlohmann::ordered_json& j) {
  write_file_atomic(path, json_text(j));
}

void write_png_file(const std::string& path, const cv::Mat& img) {
  std::vector<unsigned char> png;
  cv::imencode(".png", img, png);
  write_file_atomic(path, std::string_view(reinterpret_cast<const char*>(png.data()), png.size()));
}

CsvWriter::CsvWriter(const std::string& path, std::vector<std::string> columns)
    : file_(path), columns_(columns.size()) {
  for (const auto& c : columns) text(c);
  end_row();
  rows_ = 0;  // the header is not a row
}

void CsvWriter::cell(std::string_view s) {
  if (cells_++) line_ += ',';
  line_ += s;
}

CsvWriter& CsvWriter::num(double v, int decimals) {
  if (std::isfinite(v)) {
    cell(fmt::format("{:.{}f}", v, decimals));
  } else {
    cell(std::isnan(v) ? "nan" : (v > 0 ? "inf" : "-inf"));
  }
  return *this;
}

CsvWriter& CsvWriter::integer(long long v) {
  cell(fmt::format("{}", v));
  return *this;
}

CsvWriter& CsvWriter::text(std::string_view s) {
  if (s.find_first_of(",\"\r\n") == std::string_view::npos) {
    cell(s);
    return *this;
  }
  std::string q = "\"";
  for (char c : s) {
    if (c == '"') q += '"';
    q += c;
  }
  q += '"';
  cell(q);
  return *this;
}

void CsvWriter::end_row() {
  if (cells_ != columns_) {
    throw std::logic_error(fmt::format("{}: row of {} cells, header has {} columns", path(),
                                       cells_, columns_));
  }
  line_ += '\n';
  file_.write(line_);
  if (!file_.stream()) throw OutputError(path() + ": write failed (disk full?)");
  line_.clear();
  cells_ = 0;
  ++rows_;
}

void CsvWriter::commit() { file_.commit(); }

std::string read_file_text(const std::string& path, bool missing_ok) {
  std::ifstream f(path, std::ios::binary);
  if (!f) {
    if (missing_ok) return "";
    throw ConfigError(path + ": cannot read file");
  }
  std::ostringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

}  // namespace lander::sim
