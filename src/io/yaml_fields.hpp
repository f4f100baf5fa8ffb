// Typed, path-aware access to a YAML document for the project's input files.
//
// Every read names the field path it is reading (`uavs[1].start.position_m`), so a wrong
// type, a NaN, a missing key or a misspelled one becomes one InputError that says where and
// why. A mapping remembers which keys were read; `finish()` rejects the ones nobody asked for
// (with a "did you mean" suggestion), so a typo never silently falls back to a default.
#pragma once

#include <yaml-cpp/yaml.h>

#include <optional>
#include <set>
#include <string>
#include <vector>

#include "core/types.hpp"

namespace ridgeline::io {

class YamlMap;

/// One YAML node with its field path.
class YamlValue {
 public:
  YamlValue(YAML::Node node, std::string path) : node_(std::move(node)), path_(std::move(path)) {}

  const std::string& path() const { return path_; }
  const YAML::Node& node() const { return node_; }

  /// A finite number.
  double as_double() const;
  /// An integer (a number without a fractional part).
  long long as_int() const;
  bool as_bool() const;
  std::string as_string() const;
  /// A sequence of exactly three finite numbers.
  Vec3 as_vec3() const;
  /// A mapping whose keys are checked by YamlMap::finish().
  YamlMap as_map() const;
  /// A sequence; each element carries the path `path[i]`.
  std::vector<YamlValue> as_list() const;

 private:
  YAML::Node node_;
  std::string path_;
};

/// A mapping that tracks which keys were read.
class YamlMap {
 public:
  YamlMap(YAML::Node node, std::string path);

  bool has(const std::string& key) const;
  /// The value at key; a missing key is an error naming the full path.
  YamlValue required(const std::string& key);
  /// The value at key, if present (a `null` value counts as absent).
  std::optional<YamlValue> optional(const std::string& key);

  double get_double(const std::string& key, double fallback);
  long long get_int(const std::string& key, long long fallback);
  std::string get_string(const std::string& key, const std::string& fallback);
  Vec3 get_vec3(const std::string& key, const Vec3& fallback);

  /// Throws for the first key that was never read: unknown or misspelled.
  void finish() const;
  const std::string& path() const { return path_; }

 private:
  std::string child_path(const std::string& key) const;

  YAML::Node node_;
  std::string path_;
  mutable std::set<std::string> used_;
};

/// Parses YAML text; a syntax error names `source:line:column`.
YAML::Node parse_yaml(const std::string& text, const std::string& source);

}  // namespace ridgeline::io
