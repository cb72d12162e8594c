#include "pplvo/core/config_visitor.h"

#include <fstream>

namespace pplvo::config {
namespace {

/// Nested keys of the override assignments, in the order given.
struct OverrideTree {
  std::vector<std::pair<std::string, OverrideTree>> children;
  bool has_value = false;
  YAML::Node value;

  OverrideTree& child(const std::string& key) {
    for (auto& kv : children) {
      if (kv.first == key) return kv.second;
    }
    children.emplace_back(key, OverrideTree());
    return children.back().second;
  }
  YAML::Node toNode() const {
    if (has_value) return value;
    YAML::Node node(YAML::NodeType::Map);
    for (const auto& kv : children) node[kv.first] = kv.second.toNode();
    return node;
  }
};

/// Wraps `text` into comment lines of at most `width` characters at `indent`; `suffix` is
/// kept in one piece at the end.
void writeComment(std::ostringstream& out, const std::string& indent, const std::string& text,
                  const std::string& suffix = "", size_t width = 96) {
  std::istringstream words(text);
  std::vector<std::string> tokens;
  for (std::string word; words >> word;) tokens.push_back(word);
  if (!suffix.empty()) tokens.push_back(suffix);
  std::string line;
  for (const std::string& token : tokens) {
    if (!line.empty() && indent.size() + 1 + line.size() + 1 + token.size() > width) {
      out << indent << "#" << line << "\n";
      line.clear();
    }
    line += " " + token;
  }
  if (!line.empty()) out << indent << "#" << line << "\n";
}

}  // namespace

std::string stringText(const std::string& s) {
  YAML::Emitter out;
  out << s;
  return out.c_str();
}

std::string PathTracker::path(const std::string& key) const {
  std::string p;
  for (const auto& s : sections_) p += s + ".";
  return p + key;
}

// ---------------------------------------------------------------------------------------------

YamlReader::YamlReader(const YAML::Node& root, bool foreign_root_keys)
    : foreign_root_keys_(foreign_root_keys) {
  if (root && !root.IsNull() && !root.IsMap()) {
    errors_.push_back("the configuration must be a map of keys");
    levels_.push_back({YAML::Node(YAML::NodeType::Map), "", {}});
  } else {
    levels_.push_back({root && root.IsMap() ? root : YAML::Node(YAML::NodeType::Map), "", {}});
  }
}

void YamlReader::section(const std::string& key, const std::string& /*doc*/,
                         const std::function<void()>& body) {
  levels_.back().used.push_back(key);
  const YAML::Node node = child(key);
  if (node && !node.IsNull() && !node.IsMap()) {
    errors_.push_back(path(key) + ": expected a section (a map of keys)");
    return;
  }
  levels_.push_back({node && node.IsMap() ? node : YAML::Node(YAML::NodeType::Map), key, {}});
  body();
  checkKeys(false);
  levels_.pop_back();
}

void YamlReader::forbid(const std::string& key, const std::string& reason) {
  levels_.back().used.push_back(key);
  if (child(key)) errors_.push_back(path(key) + ": not settable here (" + reason + ")");
}

std::vector<std::string> YamlReader::finish() {
  checkKeys(foreign_root_keys_);
  return errors_;
}

YAML::Node YamlReader::child(const std::string& key) const {
  const YAML::Node& parent = levels_.back().node;
  return parent[key];
}

std::string YamlReader::path(const std::string& key) const {
  std::string p;
  for (const auto& level : levels_) {
    if (!level.name.empty()) p += level.name + ".";
  }
  return p + key;
}

void YamlReader::checkKeys(bool unknown_allowed) {
  const Level& level = levels_.back();
  std::vector<std::string> seen;
  for (const auto& kv : level.node) {
    const std::string key = kv.first.IsScalar() ? kv.first.Scalar() : "<non-scalar key>";
    if (std::find(seen.begin(), seen.end(), key) != seen.end()) {
      errors_.push_back(path(key) + ": duplicate key");
      continue;
    }
    seen.push_back(key);
    if (!unknown_allowed &&
        std::find(level.used.begin(), level.used.end(), key) == level.used.end())
      errors_.push_back(path(key) + ": unknown key");
  }
}

// ---------------------------------------------------------------------------------------------

void YamlWriter::writeField(const std::string& key, const std::string& value,
                            const std::string& doc, const std::string& range_text) {
  if (after_section_) out_ << "\n";
  after_section_ = false;
  opened_ = false;
  writeComment(out_, indent_, range_text.empty() ? doc : doc + ".", range_text);
  out_ << indent_ << key << ": " << value << "\n";
}

void YamlWriter::section(const std::string& key, const std::string& doc,
                         const std::function<void()>& body) {
  if (!opened_) out_ << "\n";
  if (indent_.empty()) out_ << "# " << std::string(94, '=') << "\n";  // top-level banner
  writeComment(out_, indent_, doc);
  out_ << indent_ << key << ":\n";
  indent_ += "  ";
  opened_ = true;
  after_section_ = false;
  body();
  indent_.resize(indent_.size() - 2);
  after_section_ = true;
}

// ---------------------------------------------------------------------------------------------

std::string joinErrors(const std::string& where, const std::vector<std::string>& errors) {
  std::string msg = where + ": configuration has " + std::to_string(errors.size()) + " error(s):";
  for (const auto& e : errors) msg += "\n  " + e;
  return msg;
}

YAML::Node parseYamlText(const std::string& text) {
  try {
    return YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw ConfigError("configuration text is not valid YAML: " + std::string(e.what()));
  }
}

YAML::Node loadYamlFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw ConfigError(path + ": cannot open the configuration file");
  std::stringstream text;
  text << in.rdbuf();
  try {
    return YAML::Load(text.str());
  } catch (const YAML::Exception& e) {
    throw ConfigError(path + ": not valid YAML: " + std::string(e.what()));
  }
}

YAML::Node overridesToYaml(const std::vector<std::string>& assignments,
                           std::vector<std::string>* errors) {
  OverrideTree root;
  for (const std::string& a : assignments) {
    const auto eq = a.find('=');
    const std::string key = a.substr(0, eq);
    const std::string text = eq == std::string::npos ? "" : a.substr(eq + 1);
    if (eq == std::string::npos || key.empty() || text.empty()) {
      errors->push_back("'" + a + "': expected key=value (e.g. depth_filter.ogm.max_window=5)");
      continue;
    }
    OverrideTree* node = &root;
    std::stringstream parts(key);
    std::string part;
    bool ok = true;
    while (std::getline(parts, part, '.')) {
      if (part.empty() || node->has_value) {
        ok = false;
        break;
      }
      node = &node->child(part);
    }
    if (!ok || !node->children.empty()) {
      errors->push_back("'" + a + "': invalid or conflicting key '" + key + "'");
      continue;
    }
    try {
      node->value = YAML::Load(text);
    } catch (const YAML::Exception& e) {
      errors->push_back("'" + a + "': value is not valid YAML (" + e.what() + ")");
      continue;
    }
    node->has_value = true;
  }
  return root.toNode();
}

// ---------------------------------------------------------------------------------------------

void addConfigOptions(ArgParser& parser, ConfigArgs* args, const std::vector<Shortcut>& shortcuts) {
  parser.option("--config", &args->config)
      .option("--set", [args](const std::string& v) -> std::string {
        args->overrides.push_back(v);
        return "";
      });
  for (const Shortcut& s : shortcuts) {
    const std::string flag = s.flag;
    parser.option(flag, [args, flag](const std::string& v) -> std::string {
      args->shortcuts.emplace_back(flag, v);
      return "";
    });
  }
}

std::string configUsage(const std::string& config_doc, const std::string& set_example,
                        const std::vector<Shortcut>& shortcuts) {
  const std::string indent(26, ' ');
  std::string s =
      "  --config FILE           " + config_doc + "\n" +
      "  --set KEY=VALUE         one configuration value by dotted key (repeatable), e.g.\n" +
      indent + "--set " + set_example + "\n";
  for (const Shortcut& sc : shortcuts) {
    const auto space = sc.usage.find("  ");
    std::string head = "  " + sc.flag + " " + sc.usage.substr(0, space);
    std::string doc = space == std::string::npos ? "" : sc.usage.substr(space);
    while (!doc.empty() && doc[0] == ' ') doc.erase(0, 1);
    if (head.size() < indent.size()) {
      head.resize(indent.size(), ' ');
    } else {
      s += head + "\n";
      head = indent;
    }
    // The documentation wrapped at 90 columns, then the key it sets (kept in one piece).
    std::istringstream text(doc);
    std::vector<std::string> words;
    for (std::string word; text >> word;) words.push_back(word);
    words.push_back("(= --set " + sc.key + ")");
    std::string line = head;
    bool empty = true;
    for (const std::string& word : words) {
      if (!empty && line.size() + 1 + word.size() > 90) {
        s += line + "\n";
        line = indent;
        empty = true;
      }
      line += (empty ? "" : " ") + word;
      empty = false;
    }
    s += line + "\n";
  }
  return s;
}

}  // namespace pplvo::config
