// A params struct's values as YAML text with each key's description, unit and range as a
// comment (from its visit_fields, field_spec.h): for files generated from the defaults
// (models/flight.yaml: `lander flight-config --defaults`), which then document every key.
#pragma once

#include <yaml-cpp/yaml.h>

#include <string>
#include <vector>

#include "lander/core/field_spec.h"
#include "lander/core/params_io.h"

namespace lander {

// `values` (a mapping, as params_to_yaml gives it) in block style, two spaces per level,
// numbers in their shortest round-trip form, lists of numbers in flow style, each key that
// `fields` describes followed by "# <doc> (<unit>; <allowed>)". `header` (lines without
// their "# ") goes first. Keys are written in the mapping's order.
std::string annotated_yaml(const YAML::Node& values, const std::vector<FieldInfo>& fields,
                           const std::vector<std::string>& header);

// The same for a params struct, without the top-level keys in `drop`.
template <class P>
std::string annotated_params_yaml(const P& p, const std::vector<std::string>& header,
                                  const std::vector<std::string>& drop = {}) {
  YAML::Node node = params_to_yaml(p);
  for (const std::string& k : drop) node.remove(k);
  std::vector<FieldInfo> fields;
  FieldLister lister(&fields);
  P copy = p;
  visit_fields(lister, copy);
  return annotated_yaml(node, fields, header);
}

}  // namespace lander
