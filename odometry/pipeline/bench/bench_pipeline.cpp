// The LCM-free pipeline (OdometryPipeline) on a TUM-layout folder: trajectory, per-stage
// timing and the ATE/RPE against groundtruth.txt when present. For quick experiments with
// the algorithm; evaluations of the system use pplvo-run (the processes over memq://).
//   bench_pipeline DATASET [--config FILE] [--features points,lines,planes] [--depth-model ogm]
//                  [--set dotted.key=value]... [--output TRAJ] [--max-frames N]
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include "pplvo/core/allocator.h"
#include "pplvo/core/trajectory.h"
#include "pplvo/dataset/dataset.h"
#include "pplvo/pipeline/odometry_pipeline.h"
#include "pplvo/pipeline/pipeline_config.h"

int main(int argc, char** argv) {
  pplvo::keepFrameBuffersMapped();  // frame-sized buffers: no page faults per frame
  using namespace pplvo;
  if (argc < 2) {
    std::fprintf(stderr,
                 "usage: bench_pipeline DATASET [--config FILE] [--features LIST] "
                 "[--depth-model M] [--set key=value]... [--output TRAJ] [--max-frames N]\n");
    return 2;
  }
  const std::string dir = argv[1];
  pipeline::PipelineOptions options;
  std::string output;
  long max_frames = 0;
  std::vector<std::string> overrides;
  for (int i = 2; i + 1 < argc; i += 2) {
    const std::string k = argv[i], v = argv[i + 1];
    if (k == "--config") {
      options = pipeline::loadPipelineConfig(v, options);
    } else if (k == "--features") {
      overrides.push_back("features=" + v);
    } else if (k == "--depth-model") {
      overrides.push_back("depth_filter.model=" + v);
    } else if (k == "--set") {
      overrides.push_back(v);
    } else if (k == "--output") {
      output = v;
    } else if (k == "--max-frames") {
      max_frames = std::stol(v);
    } else {
      std::fprintf(stderr, "unknown option %s\n", k.c_str());
      return 2;
    }
  }
  options = pipeline::applyPipelineOverrides(overrides, options);
  const dataset::Dataset ds = dataset::Dataset::open(dir);
  pipeline::OdometryPipeline pipe(options);
  Trajectory traj;
  int counts[5] = {0, 0, 0, 0, 0};
  const size_t n = max_frames > 0 ? std::min<size_t>(ds.size(), max_frames) : ds.size();
  Stopwatch wall;
  double sum_p = 0, sum_l = 0, sum_pl = 0;
  for (size_t i = 0; i < n; ++i) {
    const RgbdFrame f = ds.loadFrame(i);
    const pipeline::PipelineFrameResult r = pipe.process(f);
    ++counts[static_cast<int>(r.pose.status)];
    sum_p += r.odometry.point_matches;
    sum_l += r.odometry.line_matches;
    sum_pl += r.odometry.plane_matches;
    traj.push_back({f.stamp, 0.0, r.pose.T_w_c});
    if (std::getenv("PPLVO_DEBUG"))
      std::printf("%zu %s pts %d/%d lines %d/%d planes %d/%d win %d\n", i, toString(r.pose.status),
                  r.odometry.point_matches, r.frontend.points, r.odometry.line_matches,
                  r.frontend.lines, r.odometry.plane_matches, r.frontend.planes,
                  r.fused_window_length);
  }
  const double secs = wall.elapsedMs() / 1000.0;
  std::printf("%zu frames in %.2f s (%.1f frames/s incl. loading)\n", n, secs, n / secs);
  std::printf("status: first %d tracking %d velocity %d lost %d reinit %d\n", counts[0], counts[1],
              counts[2], counts[3], counts[4]);
  std::printf("mean matches: points %.1f lines %.1f planes %.2f\n", sum_p / n, sum_l / n,
              sum_pl / n);
  std::printf("%s", pipe.timings().table().c_str());
  if (!output.empty()) writeTumTrajectory(output, traj);
  return 0;
}
