#include "lander/core/annotated_yaml.h"

#include <fmt/format.h>

#include <cerrno>
#include <cstdlib>
#include <map>
#include <sstream>

namespace lander {
namespace {

// A scalar as YAML text: numbers in their shortest round-trip form (0.8, not
// 0.80000000000000004), anything else as yaml-cpp quotes it.
std::string scalar_text(const YAML::Node& n) {
  const std::string& s = n.Scalar();
  if (!s.empty() && s != "true" && s != "false") {
    char* end = nullptr;
    errno = 0;
    const double x = std::strtod(s.c_str(), &end);
    if (end == s.c_str() + s.size() && errno == 0 && s.find_first_of("xX") == std::string::npos) {
      const bool integral = s.find_first_of(".eEnN") == std::string::npos;
      return integral ? s : fmt::format("{}", x);
    }
  }
  YAML::Emitter e;
  e << n;
  return e.c_str();
}

std::string comment_of(const FieldInfo* f) {
  if (f == nullptr) return "";
  std::string detail = f->unit;
  if (!f->allowed.empty()) detail += (detail.empty() ? "" : "; ") + f->allowed;
  std::string c = f->doc;
  if (!detail.empty()) c += (c.empty() ? "(" : " (") + detail + ")";
  return c.empty() ? "" : "  # " + c;
}

bool scalar_list(const YAML::Node& n) {
  for (const auto& item : n) {
    if (!item.IsScalar()) return false;
  }
  return true;
}

class Writer {
 public:
  explicit Writer(const std::vector<FieldInfo>& fields) {
    for (const FieldInfo& f : fields) by_key_[f.key] = &f;
  }
  std::string text() const { return out_.str(); }

  void mapping(const YAML::Node& node, const std::string& prefix, int depth) {
    const std::string indent(2 * depth, ' ');
    for (const auto& kv : node) {
      const std::string key = kv.first.Scalar();
      const YAML::Node& v = kv.second;
      const FieldInfo* f = find(prefix + key);
      if (v.IsMap() && v.size() > 0) {
        out_ << indent << key << ":\n";
        mapping(v, prefix + key + ".", depth + 1);
      } else if (v.IsSequence() && !scalar_list(v)) {
        out_ << indent << key << ":" << comment_of(f) << "\n";
        block_list(v, indent);
      } else {
        out_ << indent << key << ": " << value_text(v) << comment_of(f) << "\n";
      }
    }
  }

 private:
  const FieldInfo* find(const std::string& key) const {
    const auto it = by_key_.find(key);
    return it == by_key_.end() ? nullptr : it->second;
  }
  static std::string value_text(const YAML::Node& v) {
    if (v.IsMap()) return "{}";
    if (!v.IsSequence()) return scalar_text(v);
    std::string s = "[";
    for (std::size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + scalar_text(v[i]);
    return s + "]";
  }
  // A list of mappings (a list of params structs): written as yaml-cpp writes it, indented.
  void block_list(const YAML::Node& v, const std::string& indent) {
    YAML::Emitter e;
    e.SetDoublePrecision(17);
    e << v;
    std::istringstream lines(e.c_str());
    for (std::string line; std::getline(lines, line);) out_ << indent << line << "\n";
  }

  std::map<std::string, const FieldInfo*> by_key_;
  std::ostringstream out_;
};

}  // namespace

std::string annotated_yaml(const YAML::Node& values, const std::vector<FieldInfo>& fields,
                           const std::vector<std::string>& header) {
  std::string text;
  for (const std::string& line : header) text += line.empty() ? "#\n" : "# " + line + "\n";
  Writer w(fields);
  w.mapping(values, "", 0);
  return text + w.text();
}

}  // namespace lander
