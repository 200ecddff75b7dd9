// The configuration parser's readers of single values (server/config.cpp): each refuses a bad
// value with a ConfigError that names the source, the line, the field and the reason.
#pragma once

#include <cmath>
#include <filesystem>
#include <set>
#include <sstream>
#include <string>
#include <utility>

#include <yaml-cpp/yaml.h>

#include "server/config.h"

namespace mocap {

class ConfigReader {
 public:
  // `source` names the configuration in errors; relative paths are resolved against `base`.
  ConfigReader(std::string source, std::filesystem::path base)
      : source_(std::move(source)), base_(std::move(base)) {}

  const std::string& source() const { return source_; }

  [[noreturn]] void fail(const YAML::Node& node, const std::string& field,
                         const std::string& reason) const {
    std::ostringstream msg;
    msg << source_;
    if (node.IsDefined() && node.Mark().line >= 0) msg << ":" << node.Mark().line + 1;
    msg << ": " << field << ": " << reason;
    throw ConfigError(msg.str());
  }

  void onlyKeys(const YAML::Node& map, const std::string& field,
                const std::set<std::string>& allowed) const {
    if (!map.IsMap()) fail(map, field.empty() ? "(top level)" : field, "expected a map");
    for (const auto& entry : map) {
      const std::string key = entry.first.Scalar();
      if (!allowed.count(key)) {
        std::string known;
        for (const std::string& k : allowed) known += (known.empty() ? "" : ", ") + k;
        fail(entry.first, join(field, key), "unknown key (known: " + known + ")");
      }
    }
  }

  static std::string join(const std::string& parent, const std::string& key) {
    return parent.empty() ? key : parent + "." + key;
  }

  // What a value that is not a scalar is, for the error that refuses it.
  static std::string kindOf(const YAML::Node& node) {
    if (node.IsSequence()) return "a list";
    if (node.IsMap()) return "a map";
    return node.IsNull() ? "nothing" : "'" + node.Scalar() + "'";
  }

  std::string text(const YAML::Node& node, const std::string& field) const {
    if (!node.IsScalar() || node.Scalar().empty())
      fail(node, field, "expected a non-empty string, got " + kindOf(node));
    return node.Scalar();
  }

  double number(const YAML::Node& node, const std::string& field, double min, double max) const {
    if (!node.IsScalar()) fail(node, field, "expected a number, got " + kindOf(node));
    double value = 0;
    try {
      value = node.as<double>();
    } catch (const YAML::Exception&) {
      fail(node, field, "expected a number, got '" + node.Scalar() + "'");
    }
    if (!std::isfinite(value) || value < min || value > max) {
      std::ostringstream reason;
      reason << "must be between " << min << " and " << max << ", got " << node.Scalar();
      fail(node, field, reason.str());
    }
    return value;
  }

  int integer(const YAML::Node& node, const std::string& field, int min, int max) const {
    const double value = number(node, field, min, max);
    if (value != std::floor(value))
      fail(node, field, "expected a whole number, got " + node.Scalar());
    return static_cast<int>(value);
  }

  bool boolean(const YAML::Node& node, const std::string& field) const {
    try {
      return node.as<bool>();
    } catch (const YAML::Exception&) {
      fail(node, field, "expected true or false, got '" + node.Scalar() + "'");
    }
  }

  // An existing regular file, resolved against the config's directory.
  std::string existingFile(const YAML::Node& node, const std::string& field) const {
    const std::filesystem::path path = resolve(text(node, field));
    std::error_code error;
    if (!std::filesystem::is_regular_file(path, error))
      fail(node, field, "no such file: " + path.string());
    return path.string();
  }

  std::filesystem::path resolve(const std::string& path) const {
    const std::filesystem::path p(path);
    return p.is_absolute() ? p : base_ / p;
  }

 private:
  std::string source_;
  std::filesystem::path base_;
};

}  // namespace mocap
