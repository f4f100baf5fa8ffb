#include "io/yaml_fields.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "core/error.hpp"

namespace ridgeline::io {
namespace {

std::string kind_name(const YAML::Node& node) {
  switch (node.Type()) {
    case YAML::NodeType::Null: return "nothing (null)";
    case YAML::NodeType::Scalar: return fmt::format("'{}'", node.Scalar());
    case YAML::NodeType::Sequence: return "a list";
    case YAML::NodeType::Map: return "a mapping";
    default: return "an undefined value";
  }
}

// Levenshtein distance, for "did you mean" suggestions on misspelled keys.
std::size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

}  // namespace

double YamlValue::as_double() const {
  if (!node_.IsScalar()) throw InputError(path_, "expected a number, got " + kind_name(node_));
  double value = 0.0;
  try {
    value = node_.as<double>();
  } catch (const YAML::Exception&) {
    throw InputError(path_, "expected a number, got " + kind_name(node_));
  }
  if (!std::isfinite(value))
    throw InputError(path_, "must be a finite number, got " + node_.Scalar());
  return value;
}

long long YamlValue::as_int() const {
  const double value = as_double();
  if (value != std::floor(value) || std::abs(value) > 9.0e15)
    throw InputError(path_, "expected a whole number, got " + node_.Scalar());
  return static_cast<long long>(value);
}

bool YamlValue::as_bool() const {
  if (node_.IsScalar()) {
    try {
      return node_.as<bool>();
    } catch (const YAML::Exception&) {
    }
  }
  throw InputError(path_, "expected true or false, got " + kind_name(node_));
}

std::string YamlValue::as_string() const {
  if (!node_.IsScalar()) throw InputError(path_, "expected text, got " + kind_name(node_));
  return node_.Scalar();
}

Vec3 YamlValue::as_vec3() const {
  if (!node_.IsSequence() || node_.size() != 3) {
    throw InputError(path_, "expected a list of three numbers [x, y, z], got " +
                                (node_.IsSequence() ? fmt::format("{} values", node_.size())
                                                    : kind_name(node_)));
  }
  Vec3 v;
  for (int i = 0; i < 3; ++i) v[i] = YamlValue(node_[i], fmt::format("{}[{}]", path_, i)).as_double();
  return v;
}

YamlMap YamlValue::as_map() const {
  if (!node_.IsMap()) throw InputError(path_, "expected a mapping (key: value), got " + kind_name(node_));
  return YamlMap(node_, path_);
}

std::vector<YamlValue> YamlValue::as_list() const {
  if (!node_.IsSequence()) throw InputError(path_, "expected a list, got " + kind_name(node_));
  std::vector<YamlValue> items;
  items.reserve(node_.size());
  for (std::size_t i = 0; i < node_.size(); ++i)
    items.emplace_back(node_[i], fmt::format("{}[{}]", path_, i));
  return items;
}

YamlMap::YamlMap(YAML::Node node, std::string path) : node_(std::move(node)), path_(std::move(path)) {
  // Keys must be plain text: a list or mapping as a key is almost certainly a typo.
  for (const auto& entry : node_) {
    if (!entry.first.IsScalar())
      throw InputError(path_.empty() ? "(top level)" : path_, "a key must be plain text");
  }
}

std::string YamlMap::child_path(const std::string& key) const {
  return path_.empty() ? key : path_ + "." + key;
}

bool YamlMap::has(const std::string& key) const {
  const YAML::Node child = node_[key];
  return child.IsDefined() && !child.IsNull();
}

YamlValue YamlMap::required(const std::string& key) {
  used_.insert(key);
  const YAML::Node child = node_[key];
  if (!child.IsDefined() || child.IsNull())
    throw InputError(child_path(key), "is required but missing");
  return YamlValue(child, child_path(key));
}

std::optional<YamlValue> YamlMap::optional(const std::string& key) {
  used_.insert(key);
  if (!has(key)) return std::nullopt;
  return YamlValue(node_[key], child_path(key));
}

double YamlMap::get_double(const std::string& key, double fallback) {
  const auto v = optional(key);
  return v ? v->as_double() : fallback;
}

long long YamlMap::get_int(const std::string& key, long long fallback) {
  const auto v = optional(key);
  return v ? v->as_int() : fallback;
}

std::string YamlMap::get_string(const std::string& key, const std::string& fallback) {
  const auto v = optional(key);
  return v ? v->as_string() : fallback;
}

Vec3 YamlMap::get_vec3(const std::string& key, const Vec3& fallback) {
  const auto v = optional(key);
  return v ? v->as_vec3() : fallback;
}

void YamlMap::finish() const {
  for (const auto& entry : node_) {
    const std::string key = entry.first.Scalar();
    if (used_.count(key)) continue;
    std::string suggestion;
    std::size_t best = std::numeric_limits<std::size_t>::max();
    for (const std::string& known : used_) {
      const std::size_t d = edit_distance(key, known);
      if (d < best) {
        best = d;
        suggestion = known;
      }
    }
    std::string reason = "unknown key";
    if (!suggestion.empty() && best <= std::max<std::size_t>(2, key.size() / 3))
      reason += fmt::format(" (did you mean '{}'?)", suggestion);
    else if (!used_.empty())
      reason += fmt::format(" (expected one of: {})", fmt::join(used_, ", "));
    throw InputError(child_path(key), reason);
  }
}

YAML::Node parse_yaml(const std::string& text, const std::string& source) {
  try {
    return YAML::Load(text);
  } catch (const YAML::ParserException& e) {
    throw InputError(fmt::format("{}:{}:{}", source, e.mark.line + 1, e.mark.column + 1),
                     "malformed YAML: " + e.msg);
  }
}

}  // namespace ridgeline::io
