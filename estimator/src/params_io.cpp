#include "lander/estimator/params_io.h"

#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>

namespace lander {

std::string yaml_where(const YAML::Node& node, const std::string& file) {
  const YAML::Mark m = node.Mark();
  if (m.line < 0) return file;
  return file + ":" + std::to_string(m.line + 1);
}

YamlReader::YamlReader(const YAML::Node& node, std::string file, std::string prefix)
    : node_(node), file_(std::move(file)), prefix_(std::move(prefix)) {}

YAML::Node YamlReader::take(const char* key) {
  consumed_.insert(key);
  if (!node_.IsMap()) return YAML::Node();
  // Look up without inserting: iterate (const lookups on yaml-cpp nodes can create keys).
  for (auto it = node_.begin(); it != node_.end(); ++it) {
    if (it->first.as<std::string>() == key) return it->second;
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

void YamlReader::operator()(const char* key, std::vector<double>& field, double scale) {
  YAML::Node n = take(key);
  if (!n) return;
  if (!n.IsSequence()) fail(n, key, "expected a list of numbers");
  field.clear();
  for (std::size_t i = 0; i < n.size(); ++i) {
    field.push_back(scalar<double>(n[i], key, "a list of numbers") * scale);
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
    try {
      field[i] = n[i].as<double>() * scale;
    } catch (const YAML::Exception&) {
      r.fail(n, key, "expected a list of " + std::to_string(N) + " numbers");
    }
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
    const std::string k = it->first.as<std::string>();
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

YAML::Node load_yaml_file(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw ConfigError(path + ": cannot open file");
  try {
    return YAML::Load(in);
  } catch (const YAML::ParserException& e) {
    throw ConfigError(path + ":" + std::to_string(e.mark.line + 1) + ": YAML syntax error: " +
                      e.msg);
  }
}

std::string yaml_to_string(const YAML::Node& node) {
  YAML::Emitter out;
  out.SetDoublePrecision(std::numeric_limits<double>::max_digits10);
  out << node;
  return std::string(out.c_str()) + "\n";
}

}  // namespace lander
