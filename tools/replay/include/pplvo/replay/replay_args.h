#pragma once
/// pplvo-replay's command line as a testable function (the main only prints and replays).
#include <string>
#include <vector>

#include "pplvo/replay/replay_stage.h"

namespace pplvo::replay {

struct ReplayArgs {
  ReplayOptions options;
  bool help = false;
  std::vector<std::string> errors;  ///< every problem, for "pplvo-replay: ..." lines
};

/// Parses the arguments (no program name): --log, --stage and the pipeline configuration
/// (--config, --set, --features, --depth-model, the cross-module rules). Never throws.
ReplayArgs parseReplayArgs(const std::vector<std::string>& args);
std::string replayUsage();

}  // namespace pplvo::replay
