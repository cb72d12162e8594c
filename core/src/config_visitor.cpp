#include "pplvo/core/config_visitor.h"

#include <algorithm>

namespace pplvo {

YamlLoader::YamlLoader(const YAML::Node& root) {
  if (root && !root.IsNull() && !root.IsMap()) {
    errors_.push_back("configuration root must be a map");
    stack_.push_back({YAML::Node(YAML::NodeType::Map), "", {}});
  } else {
    stack_.push_back({root ? root : YAML::Node(YAML::NodeType::Map), "", {}});
  }
}

std::string YamlLoader::path(const std::string& key) const {
  std::string p;
  for (const auto& level : stack_) {
    if (!level.name.empty()) p += level.name + ".";
  }
  return p + key;
}

void YamlLoader::section(const std::string& key, const std::function<void()>& body) {
  markUsed(key);
  YAML::Node node = current()[key];
  if (node && !node.IsNull() && !node.IsMap()) {
    errors_.push_back(path(key) + ": expected a section (map)");
    return;
  }
  stack_.push_back({node && node.IsMap() ? node : YAML::Node(YAML::NodeType::Map), key, {}});
  body();
  checkUnknown(stack_.back());
  stack_.pop_back();
}

void YamlLoader::checkUnknown(const Level& level) {
  for (const auto& kv : level.node) {
    const std::string key = kv.first.as<std::string>();
    if (std::find(level.used.begin(), level.used.end(), key) == level.used.end()) {
      std::string p;
      for (const auto& l : stack_) {
        if (!l.name.empty()) p += l.name + ".";
      }
      errors_.push_back(p + key + ": unknown key");
    }
  }
}

void YamlLoader::finish() {
  while (stack_.size() > 1) stack_.pop_back();
  checkUnknown(stack_.front());
  if (!errors_.empty()) {
    std::string msg = "configuration has " + std::to_string(errors_.size()) + " error(s):";
    for (const auto& e : errors_) msg += "\n  " + e;
    throw ConfigError(msg);
  }
}

YamlDumper::YamlDumper() { out_ << YAML::BeginMap; }

void YamlDumper::section(const std::string& key, const std::function<void()>& body) {
  out_ << YAML::Key << key << YAML::Value << YAML::BeginMap;
  body();
  out_ << YAML::EndMap;
}

}  // namespace pplvo
