#include "pplvo/depth_filter_node/depth_filter_args.h"

#include "pplvo/core/args.h"
#include "pplvo/core/config_visitor.h"

namespace pplvo::nodes {
namespace {

/// Command-line shortcuts of depth filter keys. --features is the pipeline's key (accepted so
/// that one command line serves every process; the frontend and estimator check it).
std::vector<config::Shortcut> shortcuts() {
  std::vector<config::Shortcut> s = depth_filter::depthModelShortcut();
  s.push_back({"--window", "depth_filter.ogm.max_window", "N  O-GM sliding window, frames (10)"});
  s.push_back({"--max-translation-variance", "depth_filter.ogm.max_translation_variance_m2",
               "M2  window eviction threshold, m^2 (1e-4)"});
  s.push_back({"--overload-backlog", "depth_filter.overload.backlog",
               "N  when more than N newer frames wait for their pose, fuse over a shorter "
               "window (2; 0 = never)"});
  s.push_back({"--overload-step", "depth_filter.overload.window_step",
               "N  frames the window shortens per frame of backlog beyond that, down to 2 (2)"});
  s.push_back({"--features", "features", "LIST  the pipeline's feature families (not used here)"});
  return s;
}

const auto kVisit = [](auto& v, depth_filter::DepthFilterOptions& o) {
  depth_filter::visitConfigFile(v, o);
};

}  // namespace

DepthFilterArgs parseDepthFilterArgs(const std::vector<std::string>& args) {
  DepthFilterArgs a;
  DepthFilterNodeOptions& o = a.options;
  config::ConfigArgs config_args;
  ArgParser p;
  config::addConfigOptions(p, &config_args, shortcuts());
  msgs::addRouteOption(p, &o.routes);
  p.option("--lcm-url", &o.lcm_url)
      .option("--prefault-mb", &a.prefault_mb, 0, 1 << 20)
      .option("--rgbd-channel", &o.rgbd_channel)
      .option("--pose-channel", &o.pose_channel)
      .option("--cgm-channel", &o.cgm_channel)
      .option("--fused-channel", &o.fused_channel)
      .option("--status-channel", &o.status_channel)
      .option("--max-pending", &o.max_pending, 1)
      .option("--max-alignment-wait-ms", &o.max_alignment_wait_ms, 0)
      .flag("--compress", &o.compress)
      .flag("--fuse-on-worker", &o.fuse_on_worker);
  p.parse(args);
  a.help = p.help();
  a.errors = p.errors();
  // The file's other top-level keys (features, frontend, odometry) are the other processes'.
  const std::vector<std::string> config_errors = config::applyConfigArgs(
      config_args, shortcuts(), &o.filter, kVisit,
      [](const depth_filter::DepthFilterOptions&) { return std::vector<std::string>(); },
      /*foreign_root_keys=*/true);
  a.errors.insert(a.errors.end(), config_errors.begin(), config_errors.end());
  return a;
}

std::string depthFilterUsage() {
  return std::string(
             "usage: pplvo-depth-filter [options]\n"
             "  --lcm-url URL            LCM URL (default $LCM_DEFAULT_URL)\n") +
         msgs::kRouteUsage +
         "  --prefault-mb N          heap mapped at start-up: MiB of main heap, and 8\n"
         "                           worker arenas of a quarter of it (64; 0 = none), so\n"
         "                           that the first frames take no page faults\n"
         "  --rgbd-channel NAME      in, rgbd_frame_t (PPLVO_RGBD)\n"
         "  --pose-channel NAME      in, pose_t (PPLVO_POSE)\n"
         "  --cgm-channel NAME       out, depth_map_t (PPLVO_DEPTH_CGM)\n"
         "  --fused-channel NAME     out, depth_map_t (PPLVO_DEPTH_FUSED)\n"
         "  --status-channel NAME    out, node_status_t (PPLVO_STATUS)\n"
         "  --max-pending N          frames waiting for their pose (30)\n"
         "  --max-alignment-wait-ms N  longest wait of a frame for the pose its time\n"
         "                           alignment needs (100)\n"
         "  --compress               zlib-compress published maps\n"
         "  --fuse-on-worker         O-GM on a thread of its own: frames keep getting their\n"
         "                           C-GM maps while a frame is fused\n"
         "depth filter options (the depth_filter section of the configuration; keys of other\n"
         "sections are accepted and left to the processes that use them):\n" +
         config::configUsage("pipeline YAML (config/pplvo.yaml): its depth_filter section",
                             "depth_filter.ogm.k_consistency=1", shortcuts());
}

}  // namespace pplvo::nodes
