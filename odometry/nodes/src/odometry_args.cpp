#include "pplvo/odometry_nodes/odometry_args.h"

#include "pplvo/core/args.h"
#include "pplvo/pipeline/pipeline_args.h"

namespace pplvo::nodes {
namespace {

/// Declares the options every LCM node has (--lcm-url, --route, --prefault-mb) and the
/// pipeline's, parses, and applies the configuration: `section` receives it.
template <class Args, class Declare, class Section>
void parseNodeArgs(const std::vector<std::string>& args, Args* a, Declare&& declare,
                   Section&& section) {
  pipeline::PipelineArgs pa;
  ArgParser p;
  pipeline::addPipelineOptions(p, &pa);
  msgs::addRouteOption(p, &a->options.routes);
  p.option("--lcm-url", &a->options.lcm_url).option("--prefault-mb", &a->prefault_mb, 0, 1 << 20);
  declare(p);
  p.parse(args);
  a->help = p.help();
  if (a->help) return;
  pipeline::PipelineOptions pipeline_options;
  pipeline::applyPipelineArgs(pa, &pipeline_options, &p);
  section(pipeline_options);
  a->errors = p.errors();
}

std::string nodeUsage(const char* name, const char* prefault_default) {
  return std::string("usage: ") + name +
         " [options]\n"
         "  --lcm-url URL              LCM URL (default $LCM_DEFAULT_URL)\n" +
         msgs::kRouteUsage +
         "  --prefault-mb N            heap mapped at start-up: MiB of main heap, and 8\n"
         "                             worker arenas of a quarter of it (" +
         prefault_default +
         "; 0 = none), so\n"
         "                             that the first frames take no page faults\n";
}

}  // namespace

FrontendArgs parseFrontendArgs(const std::vector<std::string>& args) {
  FrontendArgs a;
  FrontendNodeOptions& o = a.options;
  parseNodeArgs(
      args, &a,
      [&](ArgParser& p) {
        p.option("--rgbd-channel", &o.rgbd_channel)
            .option("--cgm-channel", &o.cgm_channel)
            .option("--fused-channel", &o.fused_channel)
            .option("--features-channel", &o.features_channel)
            .option("--features-3d-channel", &o.features_3d_channel)
            .option("--status-channel", &o.status_channel)
            .option("--max-pending", &o.max_pending, 1)
            .flag("--no-extract-ahead", &o.extract_ahead, false)
            .option("--max-unlifted", &o.max_unlifted, 0, 1000)
            .option("--max-unlifted-wait-ms", &o.max_unlifted_wait_ms, 0, 3600000);
      },
      [&](const pipeline::PipelineOptions& p) { o.frontend = p.frontend; });
  return a;
}

std::string frontendUsage() {
  return nodeUsage("pplvo-frontend", "64") +
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
         "pipeline options (the frontend section is used):\n" +
         pipeline::pipelineOptionsUsage();
}

EstimatorArgs parseEstimatorArgs(const std::vector<std::string>& args) {
  EstimatorArgs a;
  EstimatorNodeOptions& o = a.options;
  parseNodeArgs(
      args, &a,
      [&](ArgParser& p) {
        p.option("--features-channel", &o.features_channel)
            .option("--features-3d-channel", &o.features_3d_channel)
            .option("--pose-channel", &o.pose_channel)
            .option("--odometry-channel", &o.odometry_channel)
            .option("--status-channel", &o.status_channel)
            .option("--max-waiting", &o.max_waiting, 1)
            .option("--max-reference-wait-ms", &o.max_reference_wait_ms, 0, 3600000);
      },
      [&](const pipeline::PipelineOptions& p) { o.odometry = p.odometry; });
  return a;
}

std::string estimatorUsage() {
  return nodeUsage("pplvo-estimator", "16") +
         "  --features-channel NAME    in, features_t stage 2D (PPLVO_FEATURES)\n"
         "  --features-3d-channel NAME in, features_t stage 3D (PPLVO_FEATURES_3D)\n"
         "  --pose-channel NAME        out, pose_t (PPLVO_POSE)\n"
         "  --odometry-channel NAME    out, odometry_t: body frame, mounting from\n"
         "                             odometry.body (PPLVO_ODOMETRY; '' = none)\n"
         "  --status-channel NAME      out, node_status_t (PPLVO_STATUS)\n"
         "  --max-waiting N            frames waiting for their reference (5)\n"
         "  --max-reference-wait-ms MS restart tracking when no pose could be made for MS of\n"
         "                             stream time, two frames waiting (1000; 0 = never)\n"
         "pipeline options (the odometry section is used):\n" +
         pipeline::pipelineOptionsUsage();
}

}  // namespace pplvo::nodes
