// pplvo-replay: feeds one stage from a recorded log and compares its output with the recorded
// one (see pplvo/replay/replay_stage.h, docs/replay.md).
#include <cstdio>

#include "pplvo/core/allocator.h"
#include "pplvo/core/args.h"
#include "pplvo/node/process.h"
#include "pplvo/replay/replay_args.h"

int main(int argc, char** argv) {
  pplvo::keepFrameBuffersMapped();  // frame-sized buffers: no page faults per frame
  using namespace pplvo;
  const replay::ReplayArgs a = replay::parseReplayArgs(argsFromArgv(argc, argv));
  const int code = node::argsExitCode("pplvo-replay", a.help, a.errors, replay::replayUsage());
  if (code != node::kRun) return code;
  const replay::ReplayResult r = replay::replayStage(a.options);
  std::printf("stage %s from %s\n%s", replay::toString(a.options.stage), a.options.log.c_str(),
              r.text().c_str());
  if (r.failed) return 3;
  return r.allIdentical() ? 0 : 1;
}
