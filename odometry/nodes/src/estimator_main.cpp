// pplvo-estimator: see pplvo/odometry_nodes/estimator_node.h and docs/estimator.md.
#include <cstdio>
#include <string>
#include <vector>

#include "pplvo/core/allocator.h"
#include "pplvo/core/args.h"
#include "pplvo/core/stage_timer.h"
#include "pplvo/msgs/node_runtime.h"
#include "pplvo/odometry_nodes/estimator_node.h"
#include "pplvo/pipeline/pipeline_args.h"

namespace {

void usage() {
  std::printf(
      "usage: pplvo-estimator [options]\n"
      "  --lcm-url URL              LCM URL (default $LCM_DEFAULT_URL)\n"
      "%s"
      "  --prefault-mb N            heap mapped at start-up: MiB of main heap, and 8\n"
      "                             worker arenas of a quarter of it (16; 0 = none), so\n"
      "                             that the first frames take no page faults\n"
      "  --features-channel NAME    in, features_t stage 2D (PPLVO_FEATURES)\n"
      "  --features-3d-channel NAME in, features_t stage 3D (PPLVO_FEATURES_3D)\n"
      "  --pose-channel NAME        out, pose_t (PPLVO_POSE)\n"
      "  --status-channel NAME      out, node_status_t (PPLVO_STATUS)\n"
      "  --max-waiting N            frames waiting for their reference (5)\n"
      "  --max-reference-wait-ms MS restart tracking when no pose could be made for MS of\n"
      "                             stream time, two frames waiting (1000; 0 = never)\n"
      "pipeline options (the odometry section is used):\n%s",
      pplvo::msgs::kRouteUsage, pplvo::pipeline::pipelineOptionsUsage());
}

}  // namespace

int main(int argc, char** argv) {
  pplvo::keepFrameBuffersMapped();  // frame-sized buffers: no page faults per frame
  using namespace pplvo;
  nodes::EstimatorNodeOptions o;
  pipeline::PipelineArgs pa;
  int prefault_mb = 16;  // features and poses only
  ArgParser p;
  pipeline::addPipelineOptions(p, &pa);
  msgs::addRouteOption(p, &o.routes);
  p.option("--lcm-url", &o.lcm_url)
      .option("--prefault-mb", &prefault_mb, 0, 1 << 20)
      .option("--features-channel", &o.features_channel)
      .option("--features-3d-channel", &o.features_3d_channel)
      .option("--pose-channel", &o.pose_channel)
      .option("--status-channel", &o.status_channel)
      .option("--max-waiting", &o.max_waiting, 1)
      .option("--max-reference-wait-ms", &o.max_reference_wait_ms, 0, 3600000);
  p.parse(argsFromArgv(argc, argv));
  if (p.help()) {
    usage();
    return 0;
  }
  pipeline::PipelineOptions pipeline_options;
  pipeline::applyPipelineArgs(pa, &pipeline_options, &p);
  o.odometry = pipeline_options.odometry;
  if (!p.ok()) {
    for (const std::string& e : p.errors())
      std::fprintf(stderr, "pplvo-estimator: %s\n", e.c_str());
    usage();
    return 2;
  }
  prefaultForStreaming(static_cast<size_t>(prefault_mb));  // before the LCM threads start
  try {
    msgs::installShutdownHandlers();
    msgs::BusConnections lcm(o.lcm_url, o.routes);
    nodes::EstimatorNode node(o, lcm.bus());
    std::fprintf(stderr, "[pplvo-estimator] %s + %s -> %s\n", o.features_channel.c_str(),
                 o.features_3d_channel.c_str(), o.pose_channel.c_str());
    msgs::spin(
        lcm.bus(), [] { return false; }, [&] { node.publishStatus(hostUtime()); }, 1.0);
    node.publishStatus(hostUtime());
    const msgs::NodeCounters& c = node.counters();
    const nodes::EstimatorCounts& k = node.counts();
    std::fprintf(stderr,
                 "[pplvo-estimator] done: in %lld out %lld dropped %lld skipped %lld; tracking "
                 "%lld velocity %lld lost %lld reinit %lld; keyframes %lld (fallbacks %lld)\n%s",
                 static_cast<long long>(c.frames_in), static_cast<long long>(c.frames_out),
                 static_cast<long long>(c.frames_dropped), static_cast<long long>(c.frames_skipped),
                 static_cast<long long>(k.tracking), static_cast<long long>(k.velocity_model),
                 static_cast<long long>(k.lost), static_cast<long long>(k.reinitialised),
                 static_cast<long long>(k.keyframes), static_cast<long long>(k.keyframe_fallbacks),
                 node.allTimings().table().c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "pplvo-estimator: %s\n", e.what());
    return 1;
  }
  return 0;
}
