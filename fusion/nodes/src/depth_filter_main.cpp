// pplvo-depth-filter: see pplvo/depth_filter_node/depth_filter_node.h and docs/depth_filter.md.
#include <cstdio>
#include <string>
#include <vector>

#include "pplvo/core/allocator.h"
#include "pplvo/core/args.h"
#include "pplvo/core/stage_timer.h"
#include "pplvo/depth_filter_node/depth_filter_node.h"
#include "pplvo/msgs/node_runtime.h"
#include "pplvo/pipeline/pipeline_args.h"

namespace {

void usage() {
  std::printf(
      "usage: pplvo-depth-filter [options]\n"
      "  --lcm-url URL            LCM URL (default $LCM_DEFAULT_URL)\n"
      "%s"
      "  --prefault-mb N          heap mapped at start-up: MiB of main heap, and 8\n"
      "                           worker arenas of a quarter of it (64; 0 = none), so\n"
      "                           that the first frames take no page faults\n"
      "  --rgbd-channel NAME      in, rgbd_frame_t (PPLVO_RGBD)\n"
      "  --pose-channel NAME      in, pose_t (PPLVO_POSE)\n"
      "  --cgm-channel NAME       out, depth_map_t (PPLVO_DEPTH_CGM)\n"
      "  --fused-channel NAME     out, depth_map_t (PPLVO_DEPTH_FUSED)\n"
      "  --status-channel NAME    out, node_status_t (PPLVO_STATUS)\n"
      "  --window N               O-GM sliding window, frames (10)\n"
      "  --depth-model MODEL      sensor | cgm | ogm (ogm)\n"
      "  --max-translation-variance M2  window eviction threshold, m^2 (1e-4)\n"
      "  --max-pending N          frames waiting for their pose (30)\n"
      "  --overload-backlog N     when more than N newer frames wait for their pose, fuse\n"
      "                           over a shorter window (depth_filter.overload.backlog, 3;\n"
      "                           0 = never)\n"
      "  --overload-step N        frames the window shortens per frame of backlog beyond\n"
      "                           that, down to 2 (depth_filter.overload.window_step, 2)\n"
      "  --compress               zlib-compress published maps\n"
      "  --config FILE            pipeline YAML (config/pplvo.yaml): its depth_filter section\n"
      "  --set KEY=VALUE          one configuration value (repeatable), e.g.\n"
      "                           --set depth_filter.ogm.k_consistency=1\n",
      pplvo::msgs::kRouteUsage);
}

}  // namespace

int main(int argc, char** argv) {
  pplvo::keepFrameBuffersMapped();  // frame-sized buffers: no page faults per frame
  using namespace pplvo;
  nodes::DepthFilterNodeOptions o;
  pipeline::PipelineArgs pa;
  int window = 0;
  double max_translation_variance_m2 = 0;
  int prefault_mb = 64;
  int overload_backlog = -1, overload_step = 0;  // unset: the configuration's
  ArgParser p;
  pipeline::addPipelineOptions(p, &pa);  // --config, --set, --features (unused), --depth-model
  msgs::addRouteOption(p, &o.routes);
  p.option("--lcm-url", &o.lcm_url)
      .option("--prefault-mb", &prefault_mb, 0, 1 << 20)
      .option("--rgbd-channel", &o.rgbd_channel)
      .option("--pose-channel", &o.pose_channel)
      .option("--cgm-channel", &o.cgm_channel)
      .option("--fused-channel", &o.fused_channel)
      .option("--status-channel", &o.status_channel)
      .option("--window", &window, 1, 100)
      .option("--max-pending", &o.max_pending, 1)
      .option("--overload-backlog", &overload_backlog, 0)
      .option("--overload-step", &overload_step, 1, 100)
      .option("--max-translation-variance",
              [&](const std::string& v) -> std::string {
                double m2 = 0;
                if (!parseDouble(v, &m2) || !(m2 > 0)) {
                  return "--max-translation-variance: expected a number > 0, got '" + v + "'";
                }
                max_translation_variance_m2 = m2;
                return "";
              })
      .flag("--compress", &o.compress);
  p.parse(argsFromArgv(argc, argv));
  if (p.help()) {
    usage();
    return 0;
  }
  // The configuration's depth_filter section, then the explicit options on top.
  pipeline::PipelineOptions pl;
  pipeline::applyPipelineArgs(pa, &pl, &p);
  o.model = pl.depth_filter.model;
  o.sensor = pl.depth_filter.sensor;
  o.cgm = pl.depth_filter.cgm;
  o.ogm = pl.depth_filter.ogm;
  if (window > 0) o.ogm.max_window = window;
  o.overload_backlog = overload_backlog >= 0 ? overload_backlog : pl.depth_filter.overload.backlog;
  o.overload_step = overload_step > 0 ? overload_step : pl.depth_filter.overload.window_step;
  if (max_translation_variance_m2 > 0)
    o.ogm.max_translation_variance_m2 = max_translation_variance_m2;
  const std::vector<std::string>& errors = p.errors();
  if (!errors.empty()) {
    for (const std::string& e : errors) std::fprintf(stderr, "pplvo-depth-filter: %s\n", e.c_str());
    usage();
    return 2;
  }
  prefaultForStreaming(static_cast<size_t>(prefault_mb));  // before the LCM threads start
  try {
    msgs::installShutdownHandlers();
    msgs::BusConnections lcm(o.lcm_url, o.routes);
    nodes::DepthFilterNode node(o, lcm.bus());
    std::fprintf(stderr, "[pplvo-depth-filter] %s -> %s, %s; window %d\n", o.rgbd_channel.c_str(),
                 o.cgm_channel.c_str(), o.fused_channel.c_str(), o.ogm.max_window);
    msgs::spin(
        lcm.bus(), [] { return false; }, [&] { node.publishStatus(hostUtime()); }, 1.0);
    node.publishStatus(hostUtime());
    std::fprintf(
        stderr, "[pplvo-depth-filter] done: in %lld out %lld dropped %lld skipped %lld\n%s",
        static_cast<long long>(node.counters().frames_in),
        static_cast<long long>(node.counters().frames_out),
        static_cast<long long>(node.counters().frames_dropped),
        static_cast<long long>(node.counters().frames_skipped), node.timings().table().c_str());
    if (o.model == depth_filter::DepthModel::kOgm && o.overload_backlog > 0) {
      std::fprintf(stderr,
                   "[pplvo-depth-filter] overload: %lld fusions over a shortened window (more "
                   "than %d newer frames waiting: %d frames shorter per frame)\n",
                   static_cast<long long>(node.overloadFusions()), o.overload_backlog,
                   o.overload_step);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "pplvo-depth-filter: %s\n", e.what());
    return 1;
  }
  return 0;
}
