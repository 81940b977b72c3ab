// LEGACY facade for tools/lander/cmd_batch.cpp; see json.h.
#include "lander/sim/json.h"

#include <stdexcept>

namespace lander::sim {

Json::Json(const nlohmann::ordered_json& j) {
  if (j.is_boolean()) {
    *this = Json(j.get<bool>());
  } else if (j.is_number_integer()) {
    *this = Json(j.get<long long>());
  } else if (j.is_number()) {
    *this = Json(j.get<double>());
  } else if (j.is_string()) {
    *this = Json(j.get<std::string>());
  } else if (j.is_array()) {
    type_ = Type::Array;
    for (const auto& v : j) items_.emplace_back(v);
  } else if (j.is_object()) {
    type_ = Type::Object;
    for (auto it = j.begin(); it != j.end(); ++it) {
      keys_.push_back(it.key());
      items_.emplace_back(it.value());
    }
  }
}

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

nlohmann::ordered_json Json::to_nlohmann() const {
  switch (type_) {
    case Type::Null: return nullptr;
    case Type::Bool: return bool_;
    case Type::Number: return is_int_ ? nlohmann::ordered_json(int_) : nlohmann::ordered_json(num_);
    case Type::String: return str_;
    case Type::Array: {
      nlohmann::ordered_json a = nlohmann::ordered_json::array();
      for (const auto& v : items_) a.push_back(v.to_nlohmann());
      return a;
    }
    case Type::Object: {
      nlohmann::ordered_json o = nlohmann::ordered_json::object();
      for (std::size_t i = 0; i < keys_.size(); ++i) o[keys_[i]] = items_[i].to_nlohmann();
      return o;
    }
  }
  return nullptr;
}

}  // namespace lander::sim
