// pplvo-estimator: see pplvo/odometry_nodes/estimator_node.h and docs/estimator.md.
#include <cmath>

#include "pplvo/core/allocator.h"
#include "pplvo/core/args.h"
#include "pplvo/msgs/frame_ledger.h"
#include "pplvo/node/process.h"
#include "pplvo/odometry_nodes/odometry_args.h"

int main(int argc, char** argv) {
  pplvo::keepFrameBuffersMapped();  // frame-sized buffers: no page faults per frame
  using namespace pplvo;
  using nodes::EstimatorNode;
  const nodes::EstimatorArgs a = nodes::parseEstimatorArgs(argsFromArgv(argc, argv));
  const int code =
      node::argsExitCode(EstimatorNode::kName, a.help, a.errors, nodes::estimatorUsage());
  if (code != node::kRun) return code;
  const nodes::EstimatorNodeOptions& o = a.options;
  return node::runLcmNode<EstimatorNode>(
      {EstimatorNode::kName, o.lcm_url, o.routes, a.prefault_mb},
      [&](msgs::Bus bus) {
        auto n = std::make_unique<EstimatorNode>(o, std::move(bus));
        std::fprintf(stderr, "[pplvo-estimator] %s + %s -> %s\n", o.features_channel.c_str(),
                     o.features_3d_channel.c_str(), o.pose_channel.c_str());
        return n;
      },
      [](const EstimatorNode& n) {
        const msgs::NodeCounters& c = n.counters();
        const nodes::EstimatorCounts& k = n.counts();
        return node::format(
            "[pplvo-estimator] done: %s; tracking %lld velocity %lld lost %lld reinit %lld; "
            "keyframes %lld (fallbacks %lld, re-used %lld); weak combined %lld, gated %lld; "
            "shared frame error %.2f mm, %.3f deg (%s); colour readout read %.1f ms "
            "(standard error %.1f ms, %lld readings, %s)\n%s",
            msgs::countsText(c).c_str(), static_cast<long long>(k.tracking),
            static_cast<long long>(k.velocity_model), static_cast<long long>(k.lost),
            static_cast<long long>(k.reinitialised), static_cast<long long>(k.keyframes),
            static_cast<long long>(k.keyframe_fallbacks),
            static_cast<long long>(k.keyframes_reused),
            static_cast<long long>(k.weak_estimates_combined),
            static_cast<long long>(k.estimates_gated), 1e3 * k.frame_error.t_m,
            k.frame_error.rot_rad * 180.0 / M_PI, k.frame_error_source.describe(),
            1e3 * k.readout_mean_s, 1e3 * k.readout_standard_error_s,
            static_cast<long long>(k.readout_readings), k.readout_used ? "used" : "not used",
            n.allTimings().table().c_str());
      });
}
