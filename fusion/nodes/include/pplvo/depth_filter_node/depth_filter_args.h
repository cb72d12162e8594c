#pragma once
/// The command line of pplvo-depth-filter as a testable function. The algorithm's options come
/// from the depth filter's own schema (pplvo/depth_filter/depth_filter_options.h): the
/// `depth_filter` section of the pipeline YAML (--config; the file's other sections belong to
/// the other processes and are left to them), --set KEY=VALUE, and shortcuts of its keys
/// (--window, --depth-model, --max-translation-variance, --overload-backlog,
/// --overload-step) with the keys' own parsing and ranges. Nothing of odometry/ is linked.
#include <string>
#include <vector>

#include "pplvo/depth_filter_node/depth_filter_node.h"

namespace pplvo::nodes {

struct DepthFilterArgs {
  DepthFilterNodeOptions options;
  int prefault_mb = 64;  ///< --prefault-mb
  bool help = false;
  std::vector<std::string> errors;  ///< every problem, for "pplvo-depth-filter: ..." lines
};

/// Parses the arguments (no program name). Never throws.
DepthFilterArgs parseDepthFilterArgs(const std::vector<std::string>& args);

/// The --help text.
std::string depthFilterUsage();

}  // namespace pplvo::nodes
