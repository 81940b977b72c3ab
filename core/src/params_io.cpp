#include "lander/core/params_io.h"

#include <yaml-cpp/eventhandler.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

namespace lander {

ConfigError ConfigError::invalid(const std::string& key, const std::string& problem) {
  return ConfigError("invalid value for '" + key + "': " + problem, key, problem, false);
}

ConfigError ConfigError::prefixed(const std::string& prefix) const {
  return invalid(prefix + "." + key_, problem_);
}

ConfigError ConfigError::located_at(const std::string& where, const std::string& note) const {
  return ConfigError(where + ": invalid value for '" + key_ + "'" + note + ": " + problem_, key_,
                     problem_, true);
}

namespace {
// "a.b[2].c" -> "a.b[2]" -> "a.b" -> "a" -> "".
std::string parent_path(const std::string& path) {
  const std::size_t cut = path.find_last_of(".[");
  return cut == std::string::npos ? std::string() : path.substr(0, cut);
}
}  // namespace

ConfigError locate_config_error(const ConfigError& e, const std::string& file,
                                const KeyLines& lines) {
  if (!e.locatable()) return e;
  const auto it = lines.find(e.key());
  if (it != lines.end()) return e.located_at(file + ":" + std::to_string(it->second));
  const std::string note = " (not set in this file: default value)";
  for (std::string p = parent_path(e.key()); !p.empty(); p = parent_path(p)) {
    const auto parent = lines.find(p);
    if (parent != lines.end()) {
      return e.located_at(file + ":" + std::to_string(parent->second), note);
    }
  }
  return e.located_at(file, note);
}

std::string yaml_where(const YAML::Node& node, const std::string& file) {
  const YAML::Mark m = node.Mark();
  if (m.line < 0) return file;
  return file + ":" + std::to_string(m.line + 1);
}

YamlReader::YamlReader(const YAML::Node& node, std::string file, std::string prefix,
                       KeyLines* lines)
    : node_(node), file_(std::move(file)), prefix_(std::move(prefix)), lines_(lines) {
  if (!node_.IsMap()) return;
  // yaml-cpp keeps every entry of a mapping but a lookup finds only the first: a repeated
  // key would be silently ignored. Keys must be plain strings (not lists or mappings).
  std::map<std::string, int> first_line;
  for (auto it = node_.begin(); it != node_.end(); ++it) {
    if (!it->first.IsScalar()) {
      throw ConfigError(yaml_where(it->first, file_) + ": a key in '" +
                        (prefix_.empty() ? std::string("(top level)") : prefix_) +
                        "' is not a plain name");
    }
    const std::string k = it->first.Scalar();
    const int line = it->first.Mark().line + 1;
    const auto [prev, inserted] = first_line.emplace(k, line);
    if (!inserted) {
      throw ConfigError(yaml_where(it->first, file_) + ": duplicate key '" + prefix_ + k +
                        "' (first at line " + std::to_string(prev->second) + ")");
    }
  }
}

void check_unique_keys(const YAML::Node& node, const std::string& file, const std::string& prefix) {
  if (node.IsSequence()) {
    for (std::size_t i = 0; i < node.size(); ++i) {
      check_unique_keys(node[i], file, prefix + "[" + std::to_string(i) + "]");
    }
    return;
  }
  if (!node.IsMap()) return;
  std::map<std::string, int> first_line;
  for (auto it = node.begin(); it != node.end(); ++it) {
    const std::string k = it->first.IsScalar() ? it->first.Scalar() : YAML::Dump(it->first);
    const std::string path = prefix.empty() ? k : prefix + "." + k;
    const auto [prev, inserted] = first_line.emplace(k, it->first.Mark().line + 1);
    if (!inserted) {
      throw ConfigError(yaml_where(it->first, file) + ": duplicate key '" + path + "' (first at line " +
                        std::to_string(prev->second) + ")");
    }
    check_unique_keys(it->second, file, path);
  }
}

void YamlReader::record(const std::string& path, const YAML::Node& at) {
  if (lines_ && at.Mark().line >= 0) (*lines_)[path] = at.Mark().line + 1;
}

YAML::Node YamlReader::take(const char* key) {
  consumed_.insert(key);
  if (!node_.IsMap()) return YAML::Node();
  // Look up without inserting: iterate (const lookups on yaml-cpp nodes can create keys).
  for (auto it = node_.begin(); it != node_.end(); ++it) {
    if (it->first.Scalar() == key) {
      record(prefix_ + key, it->first);
      return it->second;
    }
  }
  return YAML::Node(YAML::NodeType::Undefined);  // tests false with operator!
}

void YamlReader::fail(const YAML::Node& at, const std::string& key,
                      const std::string& problem) const {
  throw ConfigError(yaml_where(at, file_) + ": key '" + prefix_ + key + "': " + problem);
}

template <class T>
T YamlReader::scalar(const YAML::Node& n, const char* key, const char* type_name) const {
  if (!n.IsScalar()) fail(n, key, std::string("expected ") + type_name);
  try {
    return n.as<T>();
  } catch (const YAML::Exception&) {
    fail(n, key, std::string("expected ") + type_name + ", got '" + n.Scalar() + "'");
  }
}

void YamlReader::operator()(const char* key, double& field, double scale) {
  YAML::Node n = take(key);
  if (!n) return;
  const double v = scalar<double>(n, key, "a number");
  if (!std::isfinite(v)) fail(n, key, "must be finite");
  field = v * scale;
}

void YamlReader::operator()(const char* key, int& field) {
  YAML::Node n = take(key);
  if (n) field = scalar<int>(n, key, "an integer");
}

void YamlReader::operator()(const char* key, std::uint64_t& field) {
  YAML::Node n = take(key);
  if (n) field = scalar<std::uint64_t>(n, key, "a non-negative integer");
}

void YamlReader::operator()(const char* key, bool& field) {
  YAML::Node n = take(key);
  if (n) field = scalar<bool>(n, key, "true or false");
}

void YamlReader::operator()(const char* key, std::string& field) {
  YAML::Node n = take(key);
  if (n) field = scalar<std::string>(n, key, "a string");
}

void YamlReader::operator()(const char* key, YAML::Node& field) {
  YAML::Node n = take(key);
  if (!n) return;
  if (n.IsNull()) {
    field = YAML::Node(YAML::NodeType::Map);
    return;
  }
  if (!n.IsMap()) fail(n, key, "expected a mapping");
  field = YAML::Clone(n);
}

void YamlReader::operator()(const char* key, std::vector<double>& field, double scale) {
  YAML::Node n = take(key);
  if (!n) return;
  if (!n.IsSequence()) fail(n, key, "expected a list of numbers");
  field.clear();
  for (std::size_t i = 0; i < n.size(); ++i) {
    const double v = scalar<double>(n[i], key, "a list of numbers");
    if (!std::isfinite(v)) fail(n[i], key, "list items must be finite");
    field.push_back(v * scale);
  }
}

namespace {
template <int N>
void read_fixed(YamlReader& r, const YAML::Node& n, const char* key,
                Eigen::Matrix<double, N, 1>& field, double scale) {
  if (!n.IsSequence() || n.size() != static_cast<std::size_t>(N)) {
    r.fail(n, key, "expected a list of " + std::to_string(N) + " numbers");
  }
  for (int i = 0; i < N; ++i) {
    double v = 0.0;
    try {
      if (!n[i].IsScalar()) throw YAML::Exception(n[i].Mark(), "not a scalar");
      v = n[i].as<double>();
    } catch (const YAML::Exception&) {
      r.fail(n, key, "expected a list of " + std::to_string(N) + " numbers");
    }
    if (!std::isfinite(v)) r.fail(n, key, "list items must be finite");
    field[i] = v * scale;
  }
}
}  // namespace

void YamlReader::operator()(const char* key, Eigen::Vector2d& field, double scale) {
  YAML::Node n = take(key);
  if (n) read_fixed<2>(*this, n, key, field, scale);
}

void YamlReader::operator()(const char* key, Eigen::Vector3d& field, double scale) {
  YAML::Node n = take(key);
  if (n) read_fixed<3>(*this, n, key, field, scale);
}

void YamlReader::finish() const {
  if (!node_.IsMap()) return;
  for (auto it = node_.begin(); it != node_.end(); ++it) {
    const std::string k = it->first.Scalar();
    if (!consumed_.count(k)) {
      throw ConfigError(yaml_where(it->first, file_) + ": unknown key '" + prefix_ + k + "'");
    }
  }
}

void YamlWriter::operator()(const char* key, const std::vector<double>& field, double scale) {
  YAML::Node seq(YAML::NodeType::Sequence);
  for (double v : field) seq.push_back(v / scale);
  seq.SetStyle(YAML::EmitterStyle::Flow);
  node_[key] = seq;
}

void YamlWriter::operator()(const char* key, const Eigen::Vector2d& field, double scale) {
  (*this)(key, std::vector<double>{field[0], field[1]}, scale);
}

void YamlWriter::operator()(const char* key, const Eigen::Vector3d& field, double scale) {
  (*this)(key, std::vector<double>{field[0], field[1], field[2]}, scale);
}

namespace {

// Counts documents without building them, remembering where each starts.
class DocumentCounter : public YAML::EventHandler {
 public:
  std::vector<YAML::Mark> starts;
  void OnDocumentStart(const YAML::Mark& mark) override { starts.push_back(mark); }
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark&, YAML::anchor_t) override {}
  void OnAlias(const YAML::Mark&, YAML::anchor_t) override {}
  void OnScalar(const YAML::Mark&, const std::string&, YAML::anchor_t, const std::string&) override {}
  void OnSequenceStart(const YAML::Mark&, const std::string&, YAML::anchor_t, YAML::EmitterStyle::value) override {}
  void OnSequenceEnd() override {}
  void OnMapStart(const YAML::Mark&, const std::string&, YAML::anchor_t, YAML::EmitterStyle::value) override {}
  void OnMapEnd() override {}
};

}  // namespace

YAML::Node load_yaml_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw ConfigError(path + ": cannot open file");
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw ConfigError(path + ": read error");
  // Not YAML::LoadAll: yaml-cpp 0.7's LoadAll never returns on some malformed inputs (a lone
  // ',' makes it produce empty documents forever; found by tests/fuzz/fuzz_scenario). The
  // first document is built with YAML::Load and the documents are counted with a parser that
  // stops at the second one.
  YAML::Node doc;
  std::size_t n_docs = 0;
  YAML::Mark second;
  try {
    doc = YAML::Load(text.str());
    std::istringstream again(text.str());
    YAML::Parser parser(again);
    DocumentCounter counter;
    while (counter.starts.size() < 2 && parser.HandleNextDocument(counter)) {
    }
    n_docs = counter.starts.size();
    if (n_docs > 1) second = counter.starts[1];
  } catch (const YAML::Exception& e) {  // syntax errors, unknown anchors, ...
    const std::string where = e.mark.line >= 0 ? ":" + std::to_string(e.mark.line + 1) : "";
    throw ConfigError(path + where + ": YAML syntax error: " + e.msg);
  }
  if (!doc || doc.IsNull()) {
    throw ConfigError(path + ":1: the file is empty (no keys, only comments or a null "
                             "document); expected a YAML mapping");
  }
  if (n_docs > 1) {
    throw ConfigError(path + ":" + std::to_string(second.line + 1) +
                      ": a second YAML document ('---'); expected one mapping per file");
  }
  return doc;
}

std::string yaml_to_string(const YAML::Node& node) {
  YAML::Emitter out;
  out.SetDoublePrecision(std::numeric_limits<double>::max_digits10);
  out << node;
  return std::string(out.c_str()) + "\n";
}

std::string models_dir() {
  const char* env = std::getenv("LANDER_MODELS_DIR");
  if (env == nullptr || *env == '\0') return LANDER_MODELS_DIR;
  std::error_code ec;
  if (!std::filesystem::is_directory(env, ec)) {
    throw ConfigError(std::string("LANDER_MODELS_DIR='") + env +
                      "' (environment) is not a directory; unset it to use " + LANDER_MODELS_DIR);
  }
  return env;
}

}  // namespace lander
