#pragma once
/// Replays one stage of the pipeline from a recorded LCM event log: the stage's input
/// messages are fed, in their recorded order, to a fresh node of that stage on a private
/// memq:// LCM, and every message it publishes is compared with the one recorded on the same
/// channel. The pipeline is deterministic, so with the configuration of the recording every
/// output is byte-identical; with another configuration the report shows what changed.
#include <cstdint>
#include <set>
#include <string>
#include <vector>

#include "pplvo/pipeline/pipeline_options.h"

namespace pplvo::replay {

/// One node, or the whole pipeline (depth filter, frontend and estimator fed the recorded
/// frames alone: what a compact recording, without depth maps and features, replays).
enum class Stage { kDepthFilter, kFrontend, kEstimator, kPipeline };
bool parseStage(const std::string& text, Stage* stage);
const char* toString(Stage stage);
/// The channels a stage's node subscribes to (their default names), which a replay feeds.
std::set<std::string> stageInputChannels(Stage stage);

struct ReplayOptions {
  std::string log;  ///< event log recorded with pplvo-run --log or pplvo-logger (all channels)
  Stage stage = Stage::kFrontend;
  pipeline::PipelineOptions pipeline;
};

/// One output channel of the stage. Channels the log does not hold (a compact recording's
/// depth maps and features) are not compared. The log ends somewhere (a cut, or the logger stopped while
/// the pipeline still worked): what the stage publishes after the last message recorded on a
/// channel has no recording to compare with. Those are counted in `after_end`, not as a
/// difference: every recorded message reproduced, in order, is identical.
struct ChannelComparison {
  std::string channel;
  int64_t recorded = 0;         ///< messages on this channel in the log
  int64_t replayed = 0;         ///< messages the replayed stage published on it
  int64_t identical = 0;        ///< byte-identical pairs (in order)
  int64_t first_mismatch = -1;  ///< index of the first differing or missing message (-1: none)
  /// Replayed beyond the last recorded message: the recording of their inputs' outputs was cut
  /// off.
  int64_t afterEnd() const { return replayed > recorded ? replayed - recorded : 0; }
  bool allIdentical() const { return replayed >= recorded && identical == recorded; }
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
