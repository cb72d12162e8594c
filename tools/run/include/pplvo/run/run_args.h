#pragma once
/// pplvo-run's command line as a testable function (the main only prints and runs).
#include <optional>
#include <string>
#include <vector>

#include "pplvo/run/run_pipeline.h"

namespace pplvo::run {

struct RunArgs {
  RunOptions options;  ///< options.progress is decided by the main (below)
  bool quiet = false;  ///< --quiet: no summary on stdout
  /// --progress / --no-progress when given (the last one); unset: stderr is a terminal and not
  /// --quiet.
  std::optional<bool> progress;
  bool help = false;
  std::vector<std::string> errors;  ///< every problem, for "pplvo-run: ..." lines
};

/// Parses the arguments (no program name): run options, then the pipeline configuration
/// (--config, --set, --features, --depth-model, the cross-module rules). Never throws.
RunArgs parseRunArgs(const std::vector<std::string>& args);
std::string runUsage();

}  // namespace pplvo::run
