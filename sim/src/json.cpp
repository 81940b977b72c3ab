#include "lander/sim/json.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <stdexcept>

namespace lander::sim {

Json& Json::operator[](const std::string& key) {
  if (type_ == Type::Null) type_ = Type::Object;
  if (type_ != Type::Object) throw std::logic_error("Json: not an object (key " + key + ")");
  for (std::size_t i = 0; i < keys_.size(); ++i) {
    if (keys_[i] == key) return items_[i];
  }
  keys_.push_back(key);
  items_.emplace_back();
  return items_.back();
}

const Json* Json::find(const std::string& key) const {
  for (std::size_t i = 0; i < keys_.size(); ++i) {
    if (keys_[i] == key) return &items_[i];
  }
  return nullptr;
}

Json& Json::push(Json v) {
  if (type_ == Type::Null) type_ = Type::Array;
  if (type_ != Type::Array) throw std::logic_error("Json: not an array");
  items_.push_back(std::move(v));
  return items_.back();
}

namespace {
void escape(std::string& out, const std::string& s) {
  out += '"';
  for (char c : s) {
    switch (c) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\n': out += "\\n"; break;
      case '\t': out += "\\t"; break;
      case '\r': out += "\\r"; break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          char buf[8];
          std::snprintf(buf, sizeof(buf), "\\u%04x", c);
          out += buf;
        } else {
          out += c;
        }
    }
  }
  out += '"';
}
}  // namespace

void Json::dump_to(std::string& out, int indent, int depth) const {
  const std::string pad = indent > 0 ? "\n" + std::string((depth + 1) * indent, ' ') : "";
  const std::string pad_end = indent > 0 ? "\n" + std::string(depth * indent, ' ') : "";
  switch (type_) {
    case Type::Null: out += "null"; break;
    case Type::Bool: out += bool_ ? "true" : "false"; break;
    case Type::Number: {
      if (!std::isfinite(num_)) {
        out += "null";
      } else if (is_int_) {
        out += std::to_string(int_);
      } else {
        char buf[32];
        std::snprintf(buf, sizeof(buf), "%.17g", num_);
        // Prefer the shortest representation that round-trips.
        for (int prec = 6; prec < 17; ++prec) {
          char shorter[32];
          std::snprintf(shorter, sizeof(shorter), "%.*g", prec, num_);
          if (std::strtod(shorter, nullptr) == num_) {
            std::snprintf(buf, sizeof(buf), "%s", shorter);
            break;
          }
        }
        out += buf;
      }
      break;
    }
    case Type::String: escape(out, str_); break;
    case Type::Raw: {
      std::string t = str_;
      while (!t.empty() && (t.back() == '\n' || t.back() == ' ')) t.pop_back();
      out += t;
      break;
    }
    case Type::Array:
      if (items_.empty()) { out += "[]"; break; }
      out += '[';
      for (std::size_t i = 0; i < items_.size(); ++i) {
        out += (i ? "," : "") + pad;
        items_[i].dump_to(out, indent, depth + 1);
      }
      out += pad_end + "]";
      break;
    case Type::Object:
      if (keys_.empty()) { out += "{}"; break; }
      out += '{';
      for (std::size_t i = 0; i < keys_.size(); ++i) {
        out += (i ? "," : "") + pad;
        escape(out, keys_[i]);
        out += indent > 0 ? ": " : ":";
        items_[i].dump_to(out, indent, depth + 1);
      }
      out += pad_end + "}";
      break;
  }
}

std::string Json::dump(int indent) const {
  std::string out;
  dump_to(out, indent, 0);
  return out + (indent > 0 ? "\n" : "");
}

void write_text_file(const std::string& path, const std::string& text) {
  const std::string tmp = path + ".tmp";
  {
    std::ofstream f(tmp, std::ios::binary);
    if (!f) throw std::runtime_error(path + ": cannot write file");
    f << text;
    if (!f) throw std::runtime_error(path + ": write failed");
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    throw std::runtime_error(path + ": cannot rename temporary file into place");
  }
}

}  // namespace lander::sim
