// Output files of a run and of the benchmarks: every file is written under a temporary name
// next to it (`<path>.tmp.<pid>`), flushed and checked, and only then renamed into place, so a run
// that stops midway (error, full disk, crash) never leaves a half file under the real name.
// A failed write throws OutputError naming the file.
//
//   CsvWriter trace(dir + "/trace.csv", {"t_s", "mode", "x_m"});
//   trace.num(t, 4).text(mode).num(x, 5).end_row();  // one cell per column, in order
//   trace.commit();                                  // flush, check, rename
//   write_json_file(dir + "/summary.json", summary); // nlohmann::ordered_json, atomically
#pragma once

#include <cstdint>
#include <fstream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

namespace cv {
class Mat;
}

namespace lander::sim {

// Writing an output file failed (cannot create, short write, disk full, cannot rename).
class OutputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// One output file written through a temporary name. Destroying it without commit() removes
// the temporary file (the real name is never touched).
class AtomicFile {
 public:
  // Creates (truncates) `<path>.tmp`. Throws OutputError naming `path`.
  explicit AtomicFile(std::string path);
  ~AtomicFile();
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  std::ostream& stream() { return out_; }
  void write(std::string_view text) { out_.write(text.data(), static_cast<std::streamsize>(text.size())); }
  // Flushes and closes the temporary file, checks that every byte was written, and renames
  // it to the real name. Throws OutputError naming the file.
  void commit();
  const std::string& path() const { return path_; }
  bool committed() const { return committed_; }

 private:
  std::string path_, tmp_;
  std::ofstream out_;
  bool committed_{false};
};

// The whole file as bytes. A file that cannot be opened throws ConfigError naming it, or
// gives "" with missing_ok (logs a crashed process may not have written).
std::string read_file_text(const std::string& path, bool missing_ok = false);

// Writes `text` to `path` atomically (AtomicFile). Throws OutputError naming `path`.
void write_file_atomic(const std::string& path, std::string_view text);

// JSON text of an output file: 2-space indent, keys in insertion order (ordered_json), numbers
// round-trip exact, NaN and infinities as null, UTF-8 kept (invalid bytes replaced), trailing
// newline.
std::string json_text(const nlohmann::ordered_json& j);
// json_text() written atomically. Throws OutputError naming `path`.
void write_json_file(const std::string& path, const nlohmann::ordered_json& j);
// An 8-bit image (grey, BGR or BGRA) as a PNG file, written atomically. Throws OutputError
// naming `path`.
void write_png_file(const std::string& path, const cv::Mat& img);

// The one CSV writer of the project (trace.csv of both run kinds). A header row of column
// names, then rows of exactly that many cells; numbers in fixed notation with a given number
// of decimals (non-finite: "nan", "inf", "-inf"), text cells quoted as RFC 4180 when they hold
// a comma, quote or line break. Rows go through AtomicFile: commit() makes the file appear.
class CsvWriter {
 public:
  CsvWriter(const std::string& path, std::vector<std::string> columns);

  CsvWriter& num(double v, int decimals);
  CsvWriter& integer(long long v);
  CsvWriter& text(std::string_view s);
  // Ends the row; throws std::logic_error when it does not have one cell per column.
  void end_row();
  // Throws OutputError naming the file when a write failed.
  void commit();
  const std::string& path() const { return file_.path(); }
  std::size_t rows() const { return rows_; }

 private:
  void cell(std::string_view s);
  AtomicFile file_;
  std::size_t columns_;
  std::size_t cells_{0};
  std::size_t rows_{0};
  std::string line_;
};

}  // namespace lander::sim
