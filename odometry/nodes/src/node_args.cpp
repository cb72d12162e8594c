#include "pplvo/nodes/node_args.h"

#include <cstdio>
#include <stdexcept>

#include "pplvo/pipeline/pipeline_config.h"

namespace pplvo::nodes {

NodeArgs::NodeArgs(int argc, const char* const* argv) {
  for (int i = 1; i < argc; ++i) args_.push_back({argv[i], false});
}

NodeArgs::NodeArgs(std::vector<std::string> args) {
  for (std::string& a : args) args_.push_back({std::move(a), false});
}

bool NodeArgs::help() const {
  for (const Arg& a : args_) {
    if (a.text == "--help" || a.text == "-h") return true;
  }
  return false;
}

bool NodeArgs::take(const std::string& key, bool needs_value, std::string* text) {
  bool found = false;
  for (size_t i = 0; i < args_.size(); ++i) {
    Arg& a = args_[i];
    if (a.used) continue;
    if (a.text == key) {
      a.used = true;
      if (!needs_value) {
        *text = "true";
        return true;
      }
      if (i + 1 < args_.size() && !args_[i + 1].used) {
        args_[i + 1].used = true;
        *text = args_[i + 1].text;
        return true;
      }
      errors_.push_back(key + " needs a value");
      return false;
    }
    if (a.text.rfind(key + "=", 0) == 0) {
      a.used = true;
      *text = a.text.substr(key.size() + 1);
      return true;
    }
  }
  return false;
}

std::vector<std::string> NodeArgs::values(const std::string& key) {
  std::vector<std::string> out;
  std::string t;
  while (take(key, true, &t)) out.push_back(t);
  return out;
}

bool NodeArgs::value(const std::string& key, std::string* out) {
  const std::vector<std::string> all = values(key);
  if (all.empty()) return false;
  *out = all.back();  // the last occurrence wins
  return true;
}

bool NodeArgs::value(const std::string& key, int* out) {
  long long v = 0;
  if (!value(key, &v)) return false;
  *out = static_cast<int>(v);
  return true;
}

bool NodeArgs::value(const std::string& key, long long* out) {
  std::string t;
  if (!value(key, &t)) return false;
  try {
    size_t end = 0;
    const long long v = std::stoll(t, &end);
    if (end != t.size()) throw std::invalid_argument(t);
    *out = v;
    return true;
  } catch (const std::exception&) {
    errors_.push_back(key + ": expected an integer, not '" + t + "'");
    return false;
  }
}

bool NodeArgs::value(const std::string& key, double* out) {
  std::string t;
  if (!value(key, &t)) return false;
  try {
    size_t end = 0;
    const double v = std::stod(t, &end);
    if (end != t.size()) throw std::invalid_argument(t);
    *out = v;
    return true;
  } catch (const std::exception&) {
    errors_.push_back(key + ": expected a number, not '" + t + "'");
    return false;
  }
}

bool NodeArgs::flag(const std::string& key, bool* out) {
  std::string t;
  if (!take(key, false, &t)) return false;
  if (t == "true" || t == "1" || t == "yes") *out = true;
  else if (t == "false" || t == "0" || t == "no") *out = false;
  else errors_.push_back(key + ": expected true or false, not '" + t + "'");
  return true;
}

void NodeArgs::pipeline(pipeline::PipelineOptions* options) {
  std::string path;
  if (value("--config", &path)) {
    try {
      *options = pipeline::loadPipelineConfig(path);
    } catch (const std::exception& e) {
      errors_.push_back(e.what());
    }
  }
  const std::vector<std::string> overrides = values("--set");
  std::string text;
  if (!overrides.empty()) {
    try {
      *options = pipeline::applyPipelineOverrides(overrides, *options);
    } catch (const std::exception& e) {
      errors_.push_back(e.what());
    }
  }
  if (value("--features", &text)) {
    pipeline::FeatureFamilies f;
    if (pipeline::parseFeatureFamilies(text, &f)) options->setFamilies(f);
    else errors_.push_back("--features: a list of points, lines, planes, not '" + text + "'");
  }
  if (value("--depth-model", &text) &&
      !depth_filter::parseDepthModel(text, &options->depth_filter.model)) {
    errors_.push_back("--depth-model: sensor, cgm or ogm, not '" + text + "'");
  }
}

bool NodeArgs::finish(const std::string& program) {
  for (const Arg& a : args_) {
    if (!a.used && a.text != "--help" && a.text != "-h") errors_.push_back("unknown option " + a.text);
  }
  for (const std::string& e : errors_) std::fprintf(stderr, "%s: %s\n", program.c_str(), e.c_str());
  return errors_.empty();
}

}  // namespace pplvo::nodes
