#pragma once
/// YAML configuration through visitors: each options struct lists its fields once, in a
/// `visit(Visitor&, Options&)` function, and that list drives loading, dumping and the
/// detection of unknown keys. Loading collects every error and reports them together.
///
///   template <class V> void visit(V& v, CgmOptions& o) {
///     v.field("kernel_size", o.kernel_size, "3x3 as in the paper");
///   }
///   YamlLoader loader(YAML::LoadFile(path));
///   loader.section("depth_filter", [&] { visit(loader, options.depth); });
///   loader.finish();  // throws ConfigError listing every problem
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include <yaml-cpp/yaml.h>

namespace pplvo {

class ConfigError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Reads fields from a YAML tree; missing keys keep their defaults.
class YamlLoader {
 public:
  explicit YamlLoader(const YAML::Node& root);

  template <typename T>
  void field(const std::string& key, T& value, const std::string& /*doc*/ = "") {
    const YAML::Node node = current()[key];
    markUsed(key);
    if (!node) return;
    try {
      value = node.as<T>();
    } catch (const YAML::Exception& e) {
      errors_.push_back(path(key) + ": cannot read value (" + std::string(e.what()) + ")");
    }
  }
  void section(const std::string& key, const std::function<void()>& body);
  /// Throws ConfigError with every error found (bad values, unknown keys).
  void finish();
  const std::vector<std::string>& errors() const { return errors_; }

 private:
  struct Level {
    YAML::Node node;
    std::string name;
    std::vector<std::string> used;
  };
  YAML::Node current() const { return stack_.back().node; }
  void markUsed(const std::string& key) { stack_.back().used.push_back(key); }
  void checkUnknown(const Level& level);
  std::string path(const std::string& key) const;

  std::vector<Level> stack_;
  std::vector<std::string> errors_;
};

/// Writes fields as YAML with their documentation as comments.
class YamlDumper {
 public:
  YamlDumper();
  template <typename T>
  void field(const std::string& key, T& value, const std::string& doc = "") {
    out_ << YAML::Key << key << YAML::Value << value;
    if (!doc.empty()) out_ << YAML::Comment(doc);
  }
  void section(const std::string& key, const std::function<void()>& body);
  std::string str() const { return out_.c_str(); }

 private:
  YAML::Emitter out_;
};

}  // namespace pplvo
