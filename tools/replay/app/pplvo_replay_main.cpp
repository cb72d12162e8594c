// pplvo-replay: feeds one stage from a recorded log and compares its output with the recorded
// one (see pplvo/replay/replay_stage.h, docs/replay.md).
#include <cstdio>

#include "pplvo/core/allocator.h"
#include "pplvo/core/args.h"
#include "pplvo/pipeline/pipeline_args.h"
#include "pplvo/replay/replay_stage.h"

namespace {
void usage() {
  std::printf(
      "usage: pplvo-replay --log LOG --stage depth-filter|frontend|estimator [options]\n"
      "Feeds the stage's recorded inputs to a fresh node (memq://, in recorded order) and\n"
      "compares everything it publishes with the recorded outputs. Exit 0 if identical,\n"
      "1 if different, 2 on bad arguments, 3 if the log cannot be read.\n"
      "pipeline options (the recording's configuration reproduces it exactly):\n%s",
      pplvo::pipeline::pipelineOptionsUsage());
}
}  // namespace

int main(int argc, char** argv) {
  pplvo::keepFrameBuffersMapped();  // frame-sized buffers: no page faults per frame
  using namespace pplvo;
  replay::ReplayOptions o;
  pipeline::PipelineArgs pa;
  std::string stage;
  ArgParser p;
  pipeline::addPipelineOptions(p, &pa);
  p.option("--log", &o.log).option("--stage", &stage);
  p.parse(argsFromArgv(argc, argv));
  if (p.help()) {
    usage();
    return 0;
  }
  pipeline::applyPipelineArgs(pa, &o.pipeline, &p);
  if (!replay::parseStage(stage, &o.stage))
    p.addError("--stage: depth-filter, frontend or estimator");
  if (o.log.empty()) p.addError("--log is required");
  if (!p.ok()) {
    for (const std::string& e : p.errors()) std::fprintf(stderr, "pplvo-replay: %s\n", e.c_str());
    usage();
    return 2;
  }
  const replay::ReplayResult r = replay::replayStage(o);
  std::printf("stage %s from %s\n%s", replay::toString(o.stage), o.log.c_str(), r.text().c_str());
  if (r.failed) return 3;
  return r.allIdentical() ? 0 : 1;
}
