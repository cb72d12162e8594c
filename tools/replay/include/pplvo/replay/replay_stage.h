#pragma once
/// Replays one stage of the pipeline from a recorded LCM event log: the stage's input
/// messages are fed, in their recorded order, to a fresh node of that stage on a private
/// memq:// LCM, and every message it publishes is compared with the one recorded on the same
/// channel. The pipeline is deterministic, so with the configuration of the recording every
/// output is byte-identical; with another configuration the report shows what changed.
#include <cstdint>
#include <string>
#include <vector>

#include "pplvo/pipeline/pipeline_options.h"

namespace pplvo::replay {

enum class Stage { kDepthFilter, kFrontend, kEstimator };
bool parseStage(const std::string& text, Stage* stage);
const char* toString(Stage stage);

struct ReplayOptions {
  std::string log;  ///< event log recorded with pplvo-run --log or pplvo-logger (all channels)
  Stage stage = Stage::kFrontend;
  pipeline::PipelineOptions pipeline;
};

struct ChannelComparison {
  std::string channel;
  int64_t recorded = 0;         ///< messages on this channel in the log
  int64_t replayed = 0;         ///< messages the replayed stage published on it
  int64_t identical = 0;        ///< byte-identical pairs (in order)
  int64_t first_mismatch = -1;  ///< index of the first differing pair (-1: none)
  bool allIdentical() const { return recorded == replayed && identical == recorded; }
};

struct ReplayResult {
  int64_t inputs_fed = 0;
  std::vector<ChannelComparison> outputs;
  bool log_truncated = false;
  bool failed = false;  ///< the log could not be read
  std::string error;
  bool allIdentical() const;
  std::string text() const;
};

/// Never throws; errors are in the result.
ReplayResult replayStage(const ReplayOptions& options);

}  // namespace pplvo::replay
