#pragma once
/// Command-line options shared by the odometry processes and pplvo-run: `--key value` or
/// `--key=value`, typed, every error collected and reported together by finish().
///
///   NodeArgs args(argc, argv);
///   if (args.help()) { usage(); return 0; }
///   args.pipeline(&options);          // --config FILE, --features LIST, --depth-model M
///   args.value("--lcm-url", &url);
///   if (!args.finish("pplvo-x")) return 2;   // unknown options and bad values
#include <string>
#include <vector>

#include "pplvo/pipeline/pipeline_options.h"

namespace pplvo::nodes {

class NodeArgs {
 public:
  NodeArgs(int argc, const char* const* argv);
  explicit NodeArgs(std::vector<std::string> args);

  bool help() const;
  /// Reads --key's value into *out if present (the last occurrence wins). Returns true if so.
  bool value(const std::string& key, std::string* out);
  /// Every value of a repeatable option, in order.
  std::vector<std::string> values(const std::string& key);
  bool value(const std::string& key, int* out);
  bool value(const std::string& key, long long* out);
  bool value(const std::string& key, double* out);
  /// A flag without value (--key), or --key=true/false.
  bool flag(const std::string& key, bool* out);
  /// --config FILE (loaded first), then every --set dotted.key=value (repeatable, e.g.
  /// --set odometry.tracker.estimator.plane_scale_alpha=1), then --features LIST and
  /// --depth-model MODEL.
  void pipeline(pipeline::PipelineOptions* options);
  void error(const std::string& message) { errors_.push_back(message); }

  /// Prints every error (and unknown option) prefixed by `program`; true if there were none.
  bool finish(const std::string& program);
  const std::vector<std::string>& errors() const { return errors_; }

 private:
  /// Finds --key (or --key=...) and consumes it; `text` receives the value.
  bool take(const std::string& key, bool needs_value, std::string* text);

  struct Arg {
    std::string text;
    bool used = false;
  };
  std::vector<Arg> args_;
  std::vector<std::string> errors_;
};

}  // namespace pplvo::nodes
