// pplvo-frontend: see pplvo/odometry_nodes/frontend_node.h and docs/features.md.
#include <cstdio>
#include <string>
#include <vector>

#include "pplvo/core/allocator.h"
#include "pplvo/core/args.h"
#include "pplvo/core/stage_timer.h"
#include "pplvo/msgs/node_runtime.h"
#include "pplvo/odometry_nodes/frontend_node.h"
#include "pplvo/pipeline/pipeline_args.h"

namespace {

void usage() {
  std::printf(
      "usage: pplvo-frontend [options]\n"
      "  --lcm-url URL              LCM URL (default $LCM_DEFAULT_URL)\n"
      "%s"
      "  --prefault-mb N            heap mapped at start-up: MiB of main heap, and 8\n"
      "                             worker arenas of a quarter of it (64; 0 = none), so\n"
      "                             that the first frames take no page faults\n"
      "  --rgbd-channel NAME        in, rgbd_frame_t (PPLVO_RGBD)\n"
      "  --cgm-channel NAME         in, depth_map_t (PPLVO_DEPTH_CGM)\n"
      "  --fused-channel NAME       in, depth_map_t (PPLVO_DEPTH_FUSED)\n"
      "  --features-channel NAME    out, features_t stage 2D (PPLVO_FEATURES)\n"
      "  --features-3d-channel NAME out, features_t stage 3D (PPLVO_FEATURES_3D)\n"
      "  --status-channel NAME      out, node_status_t (PPLVO_STATUS)\n"
      "  --max-pending N            frames held per queue (30)\n"
      "  --no-extract-ahead         extract 2D features in the message handler, not on a\n"
      "                             worker thread while the previous frame is lifted\n"
      "  --max-unlifted N           frames extracted but not yet lifted beyond which a new\n"
      "                             frame is dropped before extraction (5; 0 = never)\n"
      "  --max-unlifted-wait-ms MS  with that many waiting and no fused depth for MS of\n"
      "                             stream time, they are dropped instead (1000; 0 = never)\n"
      "pipeline options (the frontend section is used):\n%s",
      pplvo::msgs::kRouteUsage, pplvo::pipeline::pipelineOptionsUsage());
}

}  // namespace

int main(int argc, char** argv) {
  pplvo::keepFrameBuffersMapped();  // frame-sized buffers: no page faults per frame
  using namespace pplvo;
  nodes::FrontendNodeOptions o;
  pipeline::PipelineArgs pa;
  int prefault_mb = 64;
  ArgParser p;
  pipeline::addPipelineOptions(p, &pa);
  msgs::addRouteOption(p, &o.routes);
  p.option("--lcm-url", &o.lcm_url)
      .option("--prefault-mb", &prefault_mb, 0, 1 << 20)
      .option("--rgbd-channel", &o.rgbd_channel)
      .option("--cgm-channel", &o.cgm_channel)
      .option("--fused-channel", &o.fused_channel)
      .option("--features-channel", &o.features_channel)
      .option("--features-3d-channel", &o.features_3d_channel)
      .option("--status-channel", &o.status_channel)
      .option("--max-pending", &o.max_pending, 1)
      .flag("--no-extract-ahead", &o.extract_ahead, false)
      .option("--max-unlifted", &o.max_unlifted, 0, 1000)
      .option("--max-unlifted-wait-ms", &o.max_unlifted_wait_ms, 0, 3600000);
  p.parse(argsFromArgv(argc, argv));
  if (p.help()) {
    usage();
    return 0;
  }
  pipeline::PipelineOptions pipeline_options;
  pipeline::applyPipelineArgs(pa, &pipeline_options, &p);
  o.frontend = pipeline_options.frontend;
  if (!p.ok()) {
    for (const std::string& e : p.errors()) std::fprintf(stderr, "pplvo-frontend: %s\n", e.c_str());
    usage();
    return 2;
  }
  prefaultForStreaming(static_cast<size_t>(prefault_mb));  // before the LCM threads start
  try {
    msgs::installShutdownHandlers();
    msgs::BusConnections lcm(o.lcm_url, o.routes);
    nodes::FrontendNode node(o, lcm.bus());
    std::fprintf(stderr, "[pplvo-frontend] %s + %s -> %s; %s -> %s; features %s\n",
                 o.rgbd_channel.c_str(), o.cgm_channel.c_str(), o.features_channel.c_str(),
                 o.fused_channel.c_str(), o.features_3d_channel.c_str(),
                 pipeline::toString(o.frontend.families).c_str());
    // Checked between messages (at most 50 ms apart): a stage 2D whose predecessor's fused depth
    // never came goes out once computed.
    msgs::spin(
        lcm.bus(),
        [&] {
          node.poll();
          return false;
        },
        [&] { node.publishStatus(hostUtime()); }, 1.0);
    node.publishStatus(hostUtime());
    const msgs::NodeCounters& c = node.counters();
    std::fprintf(stderr,
                 "[pplvo-frontend] done: in %lld out %lld dropped %lld skipped %lld; %lld of the "
                 "drops before extraction, the pose -> fused depth loop behind; %lld extracted "
                 "without fused depth within the wait\n%s",
                 static_cast<long long>(c.frames_in), static_cast<long long>(c.frames_out),
                 static_cast<long long>(c.frames_dropped), static_cast<long long>(c.frames_skipped),
                 static_cast<long long>(node.droppedLoopBehind()),
                 static_cast<long long>(node.droppedUnliftedTimeout()),
                 node.allTimings().table().c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "pplvo-frontend: %s\n", e.what());
    return 1;
  }
  return 0;
}
