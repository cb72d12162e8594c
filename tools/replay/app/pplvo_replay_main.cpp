// pplvo-replay: feeds one stage from a recorded log and compares its output with the recorded
// one (see pplvo/replay/replay_stage.h, docs/replay.md).
#include <cstdio>

#include "pplvo/nodes/node_args.h"
#include "pplvo/replay/replay_stage.h"

namespace {
void usage() {
  std::printf(
      "usage: pplvo-replay --log LOG --stage depth-filter|frontend|estimator [options]\n"
      "Feeds the stage's recorded inputs to a fresh node (memq://, in recorded order) and\n"
      "compares everything it publishes with the recorded outputs. Exit 0 if identical,\n"
      "1 if different, 2 on bad arguments, 3 if the log cannot be read.\n"
      "  --config FILE, --set KEY=VALUE, --features LIST, --depth-model MODEL: as pplvo-run\n"
      "  (the recording's configuration reproduces it exactly)\n");
}
}  // namespace

int main(int argc, char** argv) {
  using namespace pplvo;
  nodes::NodeArgs args(argc, argv);
  if (args.help()) {
    usage();
    return 0;
  }
  replay::ReplayOptions o;
  std::string stage;
  args.pipeline(&o.pipeline);
  args.value("--log", &o.log);
  if (!args.value("--stage", &stage) || !replay::parseStage(stage, &o.stage)) {
    args.error("--stage: depth-filter, frontend or estimator");
  }
  if (o.log.empty()) args.error("--log is required");
  if (!args.finish("pplvo-replay")) {
    usage();
    return 2;
  }
  const replay::ReplayResult r = replay::replayStage(o);
  std::printf("stage %s from %s\n%s", replay::toString(o.stage), o.log.c_str(), r.text().c_str());
  if (r.failed) return 3;
  return r.allIdentical() ? 0 : 1;
}
