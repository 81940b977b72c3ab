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
// or, with the field's allowed range, unit and a short description (field_spec.h),
//
//     v("mass_kg", p.mass_kg, range::positive, "kg", "total mass");
//     v("exposure_ms", p.exposure_s, range::positive, "ms", "exposure time", 1e-3);
//
// and a `void validate() const` that starts with check_fields(*this) (each field within its
// range) and checks the rules across fields with require(ok, "key", "problem"),
// naming the key by its path relative to the struct exactly as visit_fields spells it
// ("rate_hz", "intrinsics.width_px"), and a nested struct with validate_nested("camera",
// camera), which prefixes its keys ("camera.rate_hz"). The same list drives reading
// (YamlReader: only the keys present are applied on top of the defaults; unknown and
// duplicate keys are rejected with file:line; every key's line is recorded) and writing
// (YamlWriter: the resolved params). read_params() then validates and turns a failing key into
// "file:line: invalid value for 'camera.rate_hz': ..." with the line of that key, or of its
// nearest parent written in the file when the key itself kept its default.
// The header needs nothing but yaml-cpp, so controller params can use the visitor protocol
// without the controller library linking yaml-cpp.
#pragma once

#include <yaml-cpp/yaml.h>

#include <array>
#include <cstdint>
#include <map>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "lander/core/field_spec.h"

namespace lander {

// A configuration or input error: the message names the file, line and key where known.
class ConfigError : public std::runtime_error {
 public:
  // A finished message (file, line and key already in it, or not about one key).
  explicit ConfigError(const std::string& message) : std::runtime_error(message) {}

  // An invalid value of `key`, a dotted path relative to the struct being validated: the
  // message is "invalid value for '<key>': <problem>" until validate_nested() prefixes the
  // key and read_params() adds where it is written (located).
  static ConfigError invalid(const std::string& key, const std::string& problem);

  const std::string& key() const { return key_; }  ///< "" for a finished message
  const std::string& problem() const { return problem_; }
  bool locatable() const { return !key_.empty() && !located_; }
  // The same error with `prefix` + "." + key (for a nested struct).
  ConfigError prefixed(const std::string& prefix) const;
  // The same error located at `where` ("file:line" or "file"), with a `note` after the key.
  ConfigError located_at(const std::string& where, const std::string& note = "") const;

 private:
  ConfigError(const std::string& message, std::string key, std::string problem, bool located)
      : std::runtime_error(message), key_(std::move(key)), problem_(std::move(problem)),
        located_(located) {}
  std::string key_, problem_;
  bool located_{false};
};

// Throws ConfigError::invalid(key, problem) unless `ok`. For validate() methods; `key` is
// the path relative to the struct, as its visit_fields spells it.
inline void require(bool ok, const std::string& key, const std::string& problem) {
  if (!ok) throw ConfigError::invalid(key, problem);
}

// Validates the nested params struct `sub` that visit_fields reads under `key`: an invalid
// value of one of its keys is reported as "<key>.<its key>".
template <class P>
void validate_nested(const std::string& key, const P& sub) {
  try {
    sub.validate();
  } catch (const ConfigError& e) {
    if (!e.locatable()) throw;
    throw e.prefixed(key);
  }
}

// Same for item `i` of a list of params structs under `key` ("<key>[i].<its key>").
template <class P>
void validate_item(const std::string& key, std::size_t i, const P& item) {
  validate_nested(key + "[" + std::to_string(i) + "]", item);
}

// Where each key read from a file is written: dotted path ("camera.rate_hz",
// "vehicle.waypoints[1].t_s", and every mapping and list item on the way) -> 1-based line.
using KeyLines = std::map<std::string, int>;

// The error located in `file`: at the line of its key, else of the nearest parent written in
// the file (then noting that the key itself kept its default), else just the file.
ConfigError locate_config_error(const ConfigError& e, const std::string& file,
                                const KeyLines& lines);

// "file:line" of a node, 1-based line, or just the file when the node has no mark.
std::string yaml_where(const YAML::Node& node, const std::string& file);

// Applies the keys present in a YAML mapping to a params struct and rejects unknown keys.
class YamlReader {
 public:
  // `prefix` is the dotted path of this mapping inside the file, for messages ("camera.").
  // Records the line of every key it reads into `lines` when given. Throws ConfigError with
  // file:line for a duplicate key or a key that is not a plain string.
  YamlReader(const YAML::Node& node, std::string file, std::string prefix = "",
             KeyLines* lines = nullptr);

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
  // A free-form mapping read as it is (a plugin's own configuration): must be a mapping or
  // empty; its keys are not checked here.
  void operator()(const char* key, YAML::Node& field);
  // A field with its spec (field_spec.h): read as above; the range is check_fields()'s.
  template <class T>
  void operator()(const char* key, T& field, const Range&, const char*, const char*) {
    (*this)(key, field);
  }
  template <class T>
  void operator()(const char* key, T& field, const Range&, const char*, const char*,
                  double scale) {
    (*this)(key, field, scale);
  }

  // Reads a nested params struct (a mapping) if present.
  template <class P>
  void nested(const char* key, P& sub) {
    YAML::Node child = take(key);
    if (!child) return;
    if (!child.IsMap()) fail(child, key, "expected a mapping");
    YamlReader r(child, file_, prefix_ + key + ".", lines_);
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
      const std::string item_key = std::string(key) + "[" + std::to_string(i) + "]";
      if (!child[i].IsMap()) fail(child[i], item_key, "list items must be mappings");
      record(prefix_ + item_key, child[i]);
      P item;
      YamlReader r(child[i], file_, prefix_ + item_key + ".", lines_);
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
  void record(const std::string& path, const YAML::Node& at);  // path -> line in lines_
  template <class T>
  T scalar(const YAML::Node& n, const char* key, const char* type_name) const;

  YAML::Node node_;
  std::string file_;
  std::string prefix_;
  std::set<std::string> consumed_;
  KeyLines* lines_ = nullptr;
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
  // A free-form mapping, written in block style whatever style it was read in (so that
  // writing, reading and writing again gives the same text).
  void operator()(const char* key, const YAML::Node& field) {
    if (!field.IsDefined() || field.IsNull() || field.size() == 0) {
      node_[key] = YAML::Node(YAML::NodeType::Map);
      return;
    }
    YAML::Node copy = YAML::Clone(field);
    copy.SetStyle(YAML::EmitterStyle::Block);
    node_[key] = copy;
  }
  template <class T>
  void operator()(const char* key, const T& field, const Range&, const char*, const char*) {
    (*this)(key, field);
  }
  template <class T>
  void operator()(const char* key, const T& field, const Range&, const char*, const char*,
                  double scale) {
    (*this)(key, field, scale);
  }
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

// Loads a YAML file holding one document; throws ConfigError naming the file (and line) if
// it is missing, malformed, empty (nothing but comments or a null document) or holds more
// than one document.
YAML::Node load_yaml_file(const std::string& path);

// Throws ConfigError "file:line: duplicate key 'a.b' (first at line N)" for the first key
// that a mapping anywhere in `node` repeats (yaml-cpp keeps both entries, and a lookup finds
// only the first: the second would be silently ignored). For files read without a
// YamlReader (campaign files); `prefix` is the dotted path of `node`.
void check_unique_keys(const YAML::Node& node, const std::string& file, const std::string& prefix = "");

// The directory of the default configuration files (flight.yaml, world.xml, target.yaml,
// vehicle.yaml, ...): the environment variable LANDER_MODELS_DIR if set (a binary copied or
// installed away from its source tree, or an older binary run against its own models), else
// the source tree's models/ the binary was built from. Throws ConfigError naming the variable
// if it is set but not a directory.
std::string models_dir();

// Applies `node` on top of `p`'s defaults, rejects unknown and duplicate keys, then calls
// p.validate(); its errors are located in `file` (locate_config_error). A null node applies
// nothing (the defaults are validated).
template <class P>
void read_params(const YAML::Node& node, const std::string& file, P& p) {
  KeyLines lines;
  if (node && !node.IsNull()) {
    if (!node.IsMap()) throw ConfigError(yaml_where(node, file) + ": expected a mapping");
    YamlReader r(node, file, "", &lines);
    visit_fields(r, p);
    r.finish();
  }
  try {
    p.validate();
  } catch (const ConfigError& e) {
    if (!e.locatable()) throw;
    throw locate_config_error(e, file, lines);
  }
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
