#include "pplvo/replay/replay_args.h"

#include "pplvo/core/args.h"
#include "pplvo/pipeline/pipeline_args.h"

namespace pplvo::replay {

ReplayArgs parseReplayArgs(const std::vector<std::string>& args) {
  ReplayArgs a;
  ReplayOptions& o = a.options;
  pipeline::PipelineArgs pa;
  std::string stage;
  ArgParser p;
  pipeline::addPipelineOptions(p, &pa);
  p.option("--log", &o.log).option("--stage", &stage);
  p.parse(args);
  a.help = p.help();
  if (a.help) return a;
  pipeline::applyPipelineArgs(pa, &o.pipeline, &p);
  if (!parseStage(stage, &o.stage)) {
    p.addError("--stage: depth-filter, frontend, estimator or pipeline");
  }
  if (o.log.empty()) p.addError("--log is required");
  a.errors = p.errors();
  return a;
}

std::string replayUsage() {
  return std::string(
             "usage: pplvo-replay --log LOG --stage depth-filter|frontend|estimator|pipeline "
             "[options]\n"
             "Feeds the stage's recorded inputs to a fresh node (memq://, in recorded order) and\n"
             "compares everything it publishes with the recorded outputs. Exit 0 if identical,\n"
             "1 if different, 2 on bad arguments, 3 if the log cannot be read.\n"
             "--stage pipeline feeds the recorded frames (PPLVO_RGBD) alone to the three nodes,\n"
             "one frame at a time, and compares the poses and every derived channel the log\n"
             "holds: what a compact recording (pplvo-run/pplvo-launch --log-mode compact) replays.\n"
             "pipeline options (the recording's configuration reproduces it exactly):\n") +
         pipeline::pipelineOptionsUsage();
}

}  // namespace pplvo::replay
