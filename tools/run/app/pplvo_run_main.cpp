// pplvo-run: the whole pipeline in one process over memq:// (see pplvo/run/run_pipeline.h).
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <string>

#include "pplvo/core/allocator.h"
#include "pplvo/core/args.h"
#include "pplvo/eval/pose_records.h"
#include "pplvo/node/process.h"
#include "pplvo/run/run_args.h"

int main(int argc, char** argv) {
  pplvo::keepFrameBuffersMapped();  // frame-sized buffers: no page faults per frame
  using namespace pplvo;
  run::RunArgs a = run::parseRunArgs(argsFromArgv(argc, argv));
  const int exit_code = node::argsExitCode("pplvo-run", a.help, a.errors, run::runUsage());
  if (exit_code != node::kRun) return exit_code;
  run::RunOptions& o = a.options;
  // Outputs are checked before the first frame, not found unwritable after the whole run.
  for (const std::string* path : {&o.output, &o.summary, &o.log, &o.covariance}) {
    const std::string why = path->empty() ? "" : run::outputFileError(*path);
    if (!why.empty()) {
      std::fprintf(stderr, "pplvo-run: cannot write %s: %s\n", path->c_str(), why.c_str());
      return 1;
    }
  }
  o.progress = a.progress.value_or(!a.quiet && isatty(STDERR_FILENO));
  std::fprintf(stderr, "[pplvo-run] %s: features %s, depth model %s\n", o.dataset_dir.c_str(),
               pipeline::toString(o.pipeline.families()).c_str(),
               depth_filter::toString(o.pipeline.depth_filter.model));
  const run::RunResult r = run::runPipeline(o);
  if (!a.quiet) std::printf("%s", r.text().c_str());
  int code = r.failed ? 1 : 0;
  if (r.failed) std::fprintf(stderr, "pplvo-run: %s\n", r.error.c_str());
  if (!o.output.empty()) {
    try {
      writeTumTrajectory(o.output, r.trajectory);
      std::fprintf(stderr, "[pplvo-run] trajectory: %s (%zu poses)\n", o.output.c_str(),
                   r.trajectory.size());
    } catch (const std::exception& e) {
      std::fprintf(stderr, "pplvo-run: cannot write %s: %s\n", o.output.c_str(), e.what());
      code = 1;
    }
  }
  if (!o.covariance.empty()) {
    std::ofstream out(o.covariance);
    out << pplvo::eval::relativePoseFileHeader();
    for (const auto& rec : pplvo::eval::relativePoseRecords(r.frame_poses, o.fps)) {
      out << pplvo::eval::formatRelativePoseLine(rec);
    }
    out.flush();
    if (!out) {
      std::fprintf(stderr, "pplvo-run: cannot write %s\n", o.covariance.c_str());
      code = 1;
    }
  }
  if (!o.summary.empty()) {
    std::ofstream out(o.summary);
    out << r.yaml();
    if (!out) {
      std::fprintf(stderr, "pplvo-run: cannot write %s\n", o.summary.c_str());
      code = 1;
    }
  }
  return code;
}
