#pragma once
/// YAML configuration through visitors (production code of every process that reads a
/// configuration). Each options struct declares its schema once, in a `visit(V&, Options&)`
/// function beside the struct (pplvo/core/config_schema.h); these visitors drive loading,
/// range checking, documented writing and flattening from that one list:
///
///   Options o;                                     // defaults from the struct
///   auto all = [](auto& v, Options& x) { v.section("depth_filter", "doc", [&] { visit(v, x); });
///   }; std::vector<std::string> errors = config::readConfig(config::parseYamlText(text), &o, all);
///   std::string yaml = config::dumpConfig(o, all, "# header\n");
///
/// Loading collects every problem (unknown or duplicate keys, values of the wrong type,
/// invalid enum texts, values outside their Range) and reports them together; missing keys
/// keep their values. Command lines use ConfigArgs: --config FILE, --set KEY=VALUE and
/// shortcuts (e.g. --window N = --set depth_filter.ogm.max_window=N), applied in that order,
/// then the caller's cross-module rules once on the result.
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "pplvo/core/args.h"
#include "pplvo/core/config_schema.h"

namespace pplvo {

class ConfigError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

namespace config {

// ---------------------------------------------------------------------------------------------
// Text of values.

/// A string as a YAML scalar (quoted when it would not read back as the same string).
std::string stringText(const std::string& s);

/// The value as written in the YAML (the text that reads back to the same value).
template <typename T>
std::string valueText(const T& v) {
  if constexpr (std::is_same_v<T, bool>) {
    return v ? "true" : "false";
  } else if constexpr (std::is_enum_v<T>) {
    return EnumText<T>::name(v);
  } else if constexpr (std::is_floating_point_v<T>) {
    return formatNumber(static_cast<double>(v));
  } else if constexpr (std::is_integral_v<T>) {
    return std::to_string(v);
  } else if constexpr (std::is_same_v<T, std::string>) {
    return stringText(v);
  } else {
    return configText(v);  // found by ADL beside the type
  }
}

/// Parses `node` into `value`; returns "" or the reason it cannot.
template <typename T>
std::string parseValue(const YAML::Node& node, T* value) {
  if constexpr (std::is_arithmetic_v<T> || std::is_enum_v<T> || std::is_same_v<T, std::string>) {
    if (!node.IsScalar()) return "expected a single value";
    if constexpr (std::is_enum_v<T>) {
      const std::string text = node.Scalar();
      if (!EnumText<T>::parse(text, value))
        return "invalid value '" + text + "' (choose one of: " + EnumText<T>::choices() + ")";
      return "";
    } else {
      try {
        *value = node.as<T>();
      } catch (const YAML::Exception&) {
        const char* type = std::is_same_v<T, bool>          ? "true or false"
                           : std::is_floating_point_v<T>    ? "a number"
                           : std::is_same_v<T, uint64_t>    ? "a non-negative integer"
                           : std::is_same_v<T, std::string> ? "a string"
                                                            : "an integer";
        return "cannot read '" + node.Scalar() + "' as " + type;
      }
      return "";
    }
  } else {
    return parseConfigValue(node, value);  // found by ADL beside the type
  }
}

// ---------------------------------------------------------------------------------------------
// Visitors. Each provides field(key, value, doc, range), section(key, doc, body) and
// forbid(key, reason) (pplvo/core/config_schema.h).

/// Tracks the dotted path of the current section.
class PathTracker {
 protected:
  std::string path(const std::string& key) const;
  void enter(const std::string& key) { sections_.push_back(key); }
  void leave() { sections_.pop_back(); }

 private:
  std::vector<std::string> sections_;
};

/// Reads values from a YAML tree; collects type errors, invalid enums and unknown or
/// duplicate keys. Missing keys keep their values.
class YamlReader {
 public:
  /// `foreign_root_keys`: top-level keys this schema does not list belong to other readers of
  /// the same file (a process reading only its own section) and are not errors.
  explicit YamlReader(const YAML::Node& root, bool foreign_root_keys = false);

  template <typename T>
  void field(const std::string& key, T& value, const std::string& /*doc*/,
             const Range& /*range*/ = anyValue()) {
    levels_.back().used.push_back(key);
    const YAML::Node node = child(key);
    if (!node) return;
    if (node.IsNull()) {
      errors_.push_back(path(key) + ": no value");
      return;
    }
    T parsed = value;
    const std::string error = parseValue(node, &parsed);
    if (error.empty())
      value = parsed;
    else
      errors_.push_back(path(key) + ": " + error);
  }
  void section(const std::string& key, const std::string& doc, const std::function<void()>& body);
  void forbid(const std::string& key, const std::string& reason);

  /// Checks the root's keys and returns every error found.
  std::vector<std::string> finish();

 private:
  struct Level {
    YAML::Node node;
    std::string name;
    std::vector<std::string> used;
  };
  YAML::Node child(const std::string& key) const;
  std::string path(const std::string& key) const;
  void checkKeys(bool unknown_allowed);

  std::vector<Level> levels_;
  std::vector<std::string> errors_;
  bool foreign_root_keys_ = false;
};

/// Checks ranges and finiteness of numbers.
class RangeValidator : PathTracker {
 public:
  template <typename T>
  void field(const std::string& key, T& value, const std::string& /*doc*/,
             const Range& range = anyValue()) {
    if constexpr (std::is_arithmetic_v<T> && !std::is_same_v<T, bool>) {
      const double x = static_cast<double>(value);
      if (std::is_floating_point_v<T> && !std::isfinite(x)) {
        errors.push_back(path(key) + ": " + valueText(value) + " is not a finite number");
      } else if (!range.contains(x)) {
        errors.push_back(path(key) + ": " + valueText(value) + " is out of range (must be " +
                         describe(range, std::is_integral_v<T>) + ")");
      }
    }
  }
  void section(const std::string& key, const std::string&, const std::function<void()>& body) {
    enter(key);
    body();
    leave();
  }
  void forbid(const std::string&, const std::string&) {}

  std::vector<std::string> errors;
};

/// One parameter: its dotted key (e.g. "depth_filter.ogm.max_window"), its value as written
/// in the YAML, and its documentation (with its range).
struct ConfigEntry {
  std::string key;
  std::string value;
  std::string doc;
};

/// Every field as (key path, value text, doc).
class Flattener : PathTracker {
 public:
  template <typename T>
  void field(const std::string& key, T& value, const std::string& doc,
             const Range& range = anyValue()) {
    std::string d = doc;
    if (!range.any()) d += ". Range: " + describe(range, std::is_integral_v<T>) + ".";
    entries.push_back({path(key), valueText(value), d});
  }
  void section(const std::string& key, const std::string&, const std::function<void()>& body) {
    enter(key);
    body();
    leave();
  }
  void forbid(const std::string&, const std::string&) {}

  std::vector<ConfigEntry> entries;
};

/// Documented YAML: each section preceded by a blank line and its comment, each field by its
/// comment (with its range); top-level sections under a banner line.
class YamlWriter {
 public:
  template <typename T>
  void field(const std::string& key, T& value, const std::string& doc,
             const Range& range = anyValue()) {
    writeField(key, valueText(value), doc,
               range.any() ? "" : "Range: " + describe(range, std::is_integral_v<T>) + ".");
  }
  void section(const std::string& key, const std::string& doc, const std::function<void()>& body);
  void forbid(const std::string&, const std::string&) {}
  void header(const std::string& text) { out_ << text << "\n"; }
  std::string str() const { return out_.str(); }

 private:
  void writeField(const std::string& key, const std::string& value, const std::string& doc,
                  const std::string& range_text);

  std::ostringstream out_;
  std::string indent_;
  bool opened_ = false;         ///< nothing written yet in the section just opened
  bool after_section_ = false;  ///< the last thing written closed a section
};

/// Passes everything to `v` except the fields at the given dotted paths, which become
/// forbid(key, reason): a composing schema takes a module's fields over (e.g. the pipeline's
/// top-level `features` list sets the estimator's use_points/use_lines/use_planes).
template <class V>
class ForbidPaths {
 public:
  ForbidPaths(V& v, std::vector<std::string> paths, std::string reason)
      : v_(v), paths_(std::move(paths)), reason_(std::move(reason)) {}

  template <typename T>
  void field(const std::string& key, T& value, const std::string& doc,
             const Range& range = anyValue()) {
    if (std::find(paths_.begin(), paths_.end(), path(key)) != paths_.end())
      v_.forbid(key, reason_);
    else
      v_.field(key, value, doc, range);
  }
  void section(const std::string& key, const std::string& doc, const std::function<void()>& body) {
    sections_.push_back(key);
    v_.section(key, doc, body);
    sections_.pop_back();
  }
  void forbid(const std::string& key, const std::string& reason) { v_.forbid(key, reason); }

 private:
  std::string path(const std::string& key) const {
    std::string p;
    for (const auto& s : sections_) p += s + ".";
    return p + key;
  }
  V& v_;
  std::vector<std::string> paths_;
  std::string reason_;
  std::vector<std::string> sections_;
};

// ---------------------------------------------------------------------------------------------
// Documents.

/// "WHERE: configuration has N error(s):\n  e1\n  e2".
std::string joinErrors(const std::string& where, const std::vector<std::string>& errors);
/// YAML text to a tree; throws ConfigError "configuration text is not valid YAML: ...".
YAML::Node parseYamlText(const std::string& text);
/// A file to a tree; throws ConfigError naming `path` (cannot open, not valid YAML).
YAML::Node loadYamlFile(const std::string& path);
/// "dotted.key=value" assignments (value in YAML syntax) as one tree; malformed entries
/// (no '=', empty key or value, a key both a value and a section, invalid YAML) go to `errors`.
YAML::Node overridesToYaml(const std::vector<std::string>& assignments,
                           std::vector<std::string>* errors);

/// Range errors of `options` under the schema `visit` (a callable visit(visitor, options)).
template <class Options, class Visit>
std::vector<std::string> rangeErrors(const Options& options, Visit&& visit) {
  Options o = options;  // visitors take non-const references
  RangeValidator validator;
  visit(validator, o);
  return validator.errors;
}

/// Reads `root` onto `*options` (keys left out keep their values): parse errors, then range
/// errors. `*options` is changed only when there are none.
template <class Options, class Visit>
std::vector<std::string> readConfig(const YAML::Node& root, Options* options, Visit&& visit,
                                    bool foreign_root_keys = false) {
  Options o = *options;
  YamlReader reader(root, foreign_root_keys);
  visit(reader, o);
  std::vector<std::string> errors = reader.finish();
  const std::vector<std::string> range = rangeErrors(o, visit);
  errors.insert(errors.end(), range.begin(), range.end());
  if (errors.empty()) *options = o;
  return errors;
}

template <class Options, class Visit>
std::vector<ConfigEntry> flattenConfig(const Options& options, Visit&& visit) {
  Options o = options;
  Flattener flattener;
  visit(flattener, o);
  return flattener.entries;
}

template <class Options, class Visit>
std::string dumpConfig(const Options& options, Visit&& visit, const std::string& header) {
  Options o = options;
  YamlWriter writer;
  writer.header(header);
  visit(writer, o);
  return writer.str();
}

// ---------------------------------------------------------------------------------------------
// Command lines.

/// --config FILE, --set KEY=VALUE (repeatable) and shortcuts, as given.
struct ConfigArgs {
  std::string config;
  std::vector<std::string> overrides;  ///< --set, in order
  /// (shortcut flag, value), in command-line order
  std::vector<std::pair<std::string, std::string>> shortcuts;
};

/// Declares --config, --set and the shortcuts on `parser`, filling `args`.
void addConfigOptions(ArgParser& parser, ConfigArgs* args, const std::vector<Shortcut>& shortcuts);

/// Usage lines of --config, --set (with an example key) and the shortcuts.
std::string configUsage(const std::string& config_doc, const std::string& set_example,
                        const std::vector<Shortcut>& shortcuts);

/// Applies `args` to `*options` in order: the file, the --set assignments, each shortcut; then,
/// when all of them were accepted, the cross-module `rules(options)` once on the result.
/// Returns every problem (one string per step that failed, each naming where it came from).
template <class Options, class Visit, class Rules>
std::vector<std::string> applyConfigArgs(const ConfigArgs& args,
                                         const std::vector<Shortcut>& shortcuts, Options* options,
                                         Visit&& visit, Rules&& rules,
                                         bool foreign_root_keys = false) {
  std::vector<std::string> errors;
  auto read = [&](const YAML::Node& root, const std::string& where) {
    const std::vector<std::string> e = readConfig(root, options, visit, foreign_root_keys);
    if (!e.empty()) errors.push_back(joinErrors(where, e));
    return e.empty();
  };
  try {
    bool ok = args.config.empty() || read(loadYamlFile(args.config), args.config);
    if (ok && !args.overrides.empty()) {
      std::vector<std::string> malformed;
      const YAML::Node tree = overridesToYaml(args.overrides, &malformed);
      if (!malformed.empty())
        errors.push_back(joinErrors("overrides", malformed));
      else
        read(tree, "overrides");
    }
  } catch (const ConfigError& e) {
    errors.push_back(e.what());
  }
  for (const auto& [flag, value] : args.shortcuts) {
    std::string key;
    for (const Shortcut& s : shortcuts) {
      if (s.flag == flag) key = s.key;
    }
    std::vector<std::string> malformed;
    const YAML::Node tree = overridesToYaml({key + "=" + value}, &malformed);
    std::vector<std::string> e =
        malformed.empty() ? readConfig(tree, options, visit, foreign_root_keys) : malformed;
    for (const std::string& problem : e) errors.push_back(flag + " " + value + ": " + problem);
  }
  if (errors.empty()) errors = rules(*options);
  return errors;
}

}  // namespace config
}  // namespace pplvo
