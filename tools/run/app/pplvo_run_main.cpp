// pplvo-run: the whole pipeline in one process over memq:// (see pplvo/run/run_pipeline.h).
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <string>

#include "pplvo/core/allocator.h"
#include "pplvo/core/args.h"
#include "pplvo/eval/pose_records.h"
#include "pplvo/pipeline/pipeline_args.h"
#include "pplvo/run/run_pipeline.h"

namespace {

void usage() {
  std::printf(
      "usage: pplvo-run --dataset DIR [--output TRAJ] [options]\n"
      "Runs player, depth filter, frontend and estimator in one process over memq://,\n"
      "every frame processed in order; writes the TUM trajectory and prints per-stage timing.\n"
      "  --dataset DIR           TUM-layout folder (rgb.txt/depth.txt or associations.txt)\n"
      "  --output TRAJ           TUM trajectory (stamp tx ty tz qx qy qz qw), stamps verbatim\n"
      "  --max-frames N          stop after N frames (0 = all)\n"
      "  --start N               first associated frame (0)\n"
      "  --fps HZ                frame rate of integer-stamped datasets (ICL-NUIM: 30)\n"
      "  --skip-bad              skip (and count) corrupt frames instead of stopping\n"
      "  --progress/--no-progress  progress line (frames, frames/s, ETA) on stderr (default:\n"
      "                          when stderr is a terminal and not --quiet)\n"
      "  --in-flight N           frames published before the previous one's pose (2: the next\n"
      "                          frame's features are extracted while this one is fused;\n"
      "                          1: one frame at a time; same trajectory either way)\n"
      "  --preload               decode every frame before the first is published (as from a\n"
      "                          camera); the throughput then leaves the decoding out\n"
      "  --summary FILE          write the run summary as YAML\n"
      "  --log FILE              record every message as an LCM event log (pplvo-replay)\n"
      "  --covariance FILE       relative pose T_prev_curr and its 6x6 covariance per frame\n"
      "                          (docs/evaluation.md; pplvo-eval --nees)\n"
      "  --quiet                 no summary on stdout\n%s",
      pplvo::pipeline::pipelineOptionsUsage());
}

}  // namespace

int main(int argc, char** argv) {
  pplvo::keepFrameBuffersMapped();  // frame-sized buffers: no page faults per frame
  using namespace pplvo;
  run::RunOptions o;
  pipeline::PipelineArgs pa;
  bool quiet = false;
  bool progress = false;
  ArgParser p;
  pipeline::addPipelineOptions(p, &pa);
  p.option("--dataset", &o.dataset_dir)
      .option("--output", &o.output)
      .option("--summary", &o.summary)
      .option("--log", &o.log)
      .option("--covariance", &o.covariance)
      .option("--max-frames", &o.max_frames, int64_t{0})
      .option("--in-flight", &o.in_flight, 1, 1000)
      .option("--start", &o.start, int64_t{0})
      .option("--fps", &o.fps, 0.0)
      .flag("--skip-bad", &o.skip_bad)
      .flag("--progress", &progress)
      .flag("--no-progress", &progress, false)
      .flag("--preload", &o.preload)
      .flag("--quiet", &quiet);
  p.parse(argsFromArgv(argc, argv));
  if (p.help()) {
    usage();
    return 0;
  }
  pipeline::applyPipelineArgs(pa, &o.pipeline, &p);
  if (o.dataset_dir.empty()) p.addError("--dataset is required");
  if (!p.ok()) {
    for (const std::string& e : p.errors()) std::fprintf(stderr, "pplvo-run: %s\n", e.c_str());
    usage();
    return 2;
  }
  // Outputs are checked before the first frame, not found unwritable after the whole run.
  for (const std::string* path : {&o.output, &o.summary, &o.log, &o.covariance}) {
    const std::string why = path->empty() ? "" : run::outputFileError(*path);
    if (!why.empty()) {
      std::fprintf(stderr, "pplvo-run: cannot write %s: %s\n", path->c_str(), why.c_str());
      return 1;
    }
  }
  o.progress = !quiet && isatty(STDERR_FILENO);
  for (const std::string& a : argsFromArgv(argc, argv)) {
    if (a == "--progress" || a == "--no-progress") o.progress = progress;  // explicit choice
  }
  std::fprintf(stderr, "[pplvo-run] %s: features %s, depth model %s\n", o.dataset_dir.c_str(),
               pipeline::toString(o.pipeline.families()).c_str(),
               depth_filter::toString(o.pipeline.depth_filter.model));
  const run::RunResult r = run::runPipeline(o);
  if (!quiet) std::printf("%s", r.text().c_str());
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
