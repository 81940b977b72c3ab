// Reading and writing params structs from and to YAML, with one list of keys per struct.
//
// Every params struct P in the project provides, next to its definition,
//
//   template <class V> void visit_fields(V& v, P& p) {
//     v("width_px", p.width_px);                 // key, field
//     v("exposure_ms", p.exposure_s, 1e-3);      // key with a non-SI unit: YAML value * scale
//     v.nested("camera", p.camera);              // a nested params struct
//   }
//
// and a `void validate() const` that throws ConfigError naming the field. The same list
// drives reading (YamlReader: only the keys present are applied on top of the defaults,
// unknown keys are rejected with file:line) and writing (YamlWriter: the resolved params).
// The header needs nothing but yaml-cpp, so controller params can use the visitor protocol
// without the controller library linking yaml-cpp.
#pragma once

#include <yaml-cpp/yaml.h>

#include <array>
#include <cstdint>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace lander {

// A configuration or input error: the message names the file, line and key where known.
class ConfigError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Throws ConfigError("<what>: <field> <problem>") unless `ok`. For validate() methods.
inline void require(bool ok, const std::string& field, const std::string& problem) {
  if (!ok) throw ConfigError("invalid value for '" + field + "': " + problem);
}

// "file:line" of a node, 1-based line, or just the file when the node has no mark.
std::string yaml_where(const YAML::Node& node, const std::string& file);

// Applies the keys present in a YAML mapping to a params struct and rejects unknown keys.
class YamlReader {
 public:
  // `prefix` is the dotted path of this mapping inside the file, for messages ("camera.").
  YamlReader(const YAML::Node& node, std::string file, std::string prefix = "");

  // Reads `key` into `field` if present. For floating fields, the YAML value is multiplied
  // by `scale` (e.g. 1e-3 for a *_ms key stored in seconds).
  void operator()(const char* key, double& field, double scale = 1.0);
  void operator()(const char* key, int& field);
  void operator()(const char* key, std::uint64_t& field);
  void operator()(const char* key, bool& field);
  void operator()(const char* key, std::string& field);
  void operator()(const char* key, std::vector<double>& field, double scale = 1.0);
  void operator()(const char* key, Eigen::Vector2d& field, double scale = 1.0);
  void operator()(const char* key, Eigen::Vector3d& field, double scale = 1.0);

  // Reads a nested params struct (a mapping) if present.
  template <class P>
  void nested(const char* key, P& sub) {
    YAML::Node child = take(key);
    if (!child) return;
    if (!child.IsMap()) fail(child, key, "expected a mapping");
    YamlReader r(child, file_, prefix_ + key + ".");
    visit_fields(r, sub);
    r.finish();
  }

  // Reads a list of params structs if present (replaces the default list).
  template <class P>
  void list(const char* key, std::vector<P>& items) {
    YAML::Node child = take(key);
    if (!child) return;
    if (!child.IsSequence()) fail(child, key, "expected a list");
    items.clear();
    for (std::size_t i = 0; i < child.size(); ++i) {
      if (!child[i].IsMap()) fail(child[i], key, "list items must be mappings");
      P item;
      YamlReader r(child[i], file_, prefix_ + key + "[" + std::to_string(i) + "].");
      visit_fields(r, item);
      r.finish();
      items.push_back(item);
    }
  }

  // Throws ConfigError listing the first key that no visitor consumed, with file:line.
  void finish() const;

  bool has(const char* key) const { return node_[key].IsDefined(); }
  const std::string& file() const { return file_; }

  [[noreturn]] void fail(const YAML::Node& at, const std::string& key,
                         const std::string& problem) const;

 private:
  YAML::Node take(const char* key);  // marks the key consumed; null node if absent
  template <class T>
  T scalar(const YAML::Node& n, const char* key, const char* type_name) const;

  YAML::Node node_;
  std::string file_;
  std::string prefix_;
  std::set<std::string> consumed_;
};

// Writes a params struct into a YAML node with the same keys the reader accepts.
class YamlWriter {
 public:
  explicit YamlWriter(YAML::Node node) : node_(node) {}
  void operator()(const char* key, const double& field, double scale = 1.0) {
    node_[key] = field / scale;
  }
  void operator()(const char* key, const int& field) { node_[key] = field; }
  void operator()(const char* key, const std::uint64_t& field) { node_[key] = field; }
  void operator()(const char* key, const bool& field) { node_[key] = field; }
  void operator()(const char* key, const std::string& field) { node_[key] = field; }
  void operator()(const char* key, const std::vector<double>& field, double scale = 1.0);
  void operator()(const char* key, const Eigen::Vector2d& field, double scale = 1.0);
  void operator()(const char* key, const Eigen::Vector3d& field, double scale = 1.0);
  template <class P>
  void nested(const char* key, P& sub) {
    YAML::Node child(YAML::NodeType::Map);
    YamlWriter w(child);
    visit_fields(w, sub);
    node_[key] = child;
  }
  template <class P>
  void list(const char* key, std::vector<P>& items) {
    YAML::Node seq(YAML::NodeType::Sequence);
    for (auto& item : items) {
      YAML::Node child(YAML::NodeType::Map);
      YamlWriter w(child);
      visit_fields(w, item);
      seq.push_back(child);
    }
    node_[key] = seq;
  }
  bool has(const char*) const { return false; }

 private:
  YAML::Node node_;
};

// Loads a YAML file; throws ConfigError naming the file if missing or malformed.
YAML::Node load_yaml_file(const std::string& path);

// Applies `node` on top of `p`'s defaults, rejects unknown keys, then calls p.validate().
template <class P>
void read_params(const YAML::Node& node, const std::string& file, P& p) {
  if (node && !node.IsNull()) {
    if (!node.IsMap()) throw ConfigError(yaml_where(node, file) + ": expected a mapping");
    YamlReader r(node, file);
    visit_fields(r, p);
    r.finish();
  }
  p.validate();
}

// The resolved params as a YAML node (every key, with the values in force).
template <class P>
YAML::Node params_to_yaml(const P& p) {
  YAML::Node node(YAML::NodeType::Map);
  YamlWriter w(node);
  P copy = p;
  visit_fields(w, copy);
  return node;
}

// A YAML node as text, doubles written with round-trip precision.
std::string yaml_to_string(const YAML::Node& node);

}  // namespace lander
