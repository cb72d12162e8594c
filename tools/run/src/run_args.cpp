#include "pplvo/run/run_args.h"

#include "pplvo/core/args.h"
#include "pplvo/msgs/channels.h"
#include "pplvo/pipeline/pipeline_args.h"

namespace pplvo::run {

RunArgs parseRunArgs(const std::vector<std::string>& args) {
  RunArgs a;
  RunOptions& o = a.options;
  pipeline::PipelineArgs pa;
  bool progress = false;
  std::string log_mode = "full";
  ArgParser p;
  pipeline::addPipelineOptions(p, &pa);
  p.option("--dataset", &o.dataset_dir)
      .option("--camera", &o.camera_file)
      .option("--output", &o.output)
      .option("--summary", &o.summary)
      .option("--log", &o.log)
      .option("--log-channels", &o.log_channels)
      .option("--log-mode", &log_mode)
      .option("--jpeg-quality", &o.jpeg_quality, 1, 100)
      .option("--covariance", &o.covariance)
      .option("--max-frames", &o.max_frames, int64_t{0})
      .option("--in-flight", &o.in_flight, 1, 1000)
      .option("--start", &o.start, int64_t{0})
      .option("--fps", &o.fps, 0.0)
      .flag("--skip-bad", &o.skip_bad)
      .flag("--progress", &progress)
      .flag("--no-progress", &progress, false)
      .flag("--preload", &o.preload)
      .flag("--quiet", &a.quiet);
  p.parse(args);
  a.help = p.help();
  if (a.help) return a;
  pipeline::applyPipelineArgs(pa, &o.pipeline, &p);
  if (o.dataset_dir.empty()) p.addError("--dataset is required");
  if (log_mode == "compact") {
    o.compact_log = true;
    if (!p.given("--log-channels")) o.log_channels = channels::kCompactLogChannels;
  } else if (log_mode != "full") {
    p.addError("--log-mode: full or compact, not '" + log_mode + "'");
  }
  if (p.given("--progress") || p.given("--no-progress")) a.progress = progress;
  a.errors = p.errors();
  return a;
}

std::string runUsage() {
  return std::string(
             "usage: pplvo-run --dataset DIR [--output TRAJ] [options]\n"
             "Runs player, depth filter, frontend and estimator in one process over memq://,\n"
             "every frame processed in order; writes the TUM trajectory and prints per-stage "
             "timing.\n"
             "  --dataset DIR           TUM-layout folder (rgb.txt/depth.txt or associations.txt)\n"
             "  --camera FILE           camera file (YAML, or .xml) instead of "
             "DIR/calib_params.xml;\n"
             "                          config/cameras/ has TUM fr1/fr2/fr3, ICL-NUIM, Kinect v1\n"
             "  --output TRAJ           TUM trajectory (stamp tx ty tz qx qy qz qw), stamps "
             "verbatim\n"
             "  --max-frames N          stop after N frames (0 = all)\n"
             "  --start N               first associated frame (0)\n"
             "  --fps HZ                frame rate of integer-stamped datasets (ICL-NUIM: 30)\n"
             "  --skip-bad              skip (and count) corrupt frames instead of stopping\n"
             "  --progress/--no-progress  progress line (frames, frames/s, ETA) on stderr "
             "(default:\n"
             "                          when stderr is a terminal and not --quiet)\n"
             "  --in-flight N           frames published before the previous one's pose (2: the "
             "next\n"
             "                          frame's features are extracted while this one is fused;\n"
             "                          1: one frame at a time; same trajectory either way)\n"
             "  --preload               decode every frame before the first is published (as from "
             "a\n"
             "                          camera); the throughput then leaves the decoding out\n"
             "  --summary FILE          write the run summary as YAML\n"
             "  --log FILE              record every message as an LCM event log (pplvo-replay)\n"
             "  --log-channels REGEX    only these channels in --log (LCM regex, whole name;\n"
             "                          e.g. 'PPLVO_(POSE|ODOMETRY)': the outputs alone)\n"
             "  --log-mode full|compact compact: frames sent as JPEG colour + lossless zlib depth\n"
             "                          (the pipeline runs on them), --log keeps the frames,\n"
             "                          poses, odometry, status: ~200 KB/frame instead of 6.7 MB;\n"
             "                          pplvo-replay --stage pipeline replays it exactly\n"
             "  --jpeg-quality Q        JPEG quality of compact frames (90)\n"
             "  --covariance FILE       relative pose T_prev_curr and its 6x6 covariance per "
             "frame\n"
             "                          (docs/evaluation.md; pplvo-eval --nees)\n"
             "  --quiet                 no summary on stdout\n") +
         pipeline::pipelineOptionsUsage();
}

}  // namespace pplvo::run
