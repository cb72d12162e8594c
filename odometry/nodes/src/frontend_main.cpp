// pplvo-frontend: see pplvo/odometry_nodes/frontend_node.h and docs/features.md.
#include "pplvo/core/allocator.h"
#include "pplvo/core/args.h"
#include "pplvo/msgs/frame_ledger.h"
#include "pplvo/node/process.h"
#include "pplvo/odometry_nodes/odometry_args.h"

int main(int argc, char** argv) {
  pplvo::keepFrameBuffersMapped();  // frame-sized buffers: no page faults per frame
  using namespace pplvo;
  using nodes::FrontendNode;
  const nodes::FrontendArgs a = nodes::parseFrontendArgs(argsFromArgv(argc, argv));
  const int code =
      node::argsExitCode(FrontendNode::kName, a.help, a.errors, nodes::frontendUsage());
  if (code != node::kRun) return code;
  const nodes::FrontendNodeOptions& o = a.options;
  // poll() between messages (at most 50 ms apart): a stage 2D whose predecessor's fused depth
  // never came goes out once computed.
  return node::runLcmNode<FrontendNode>(
      {FrontendNode::kName, o.lcm_url, o.routes, a.prefault_mb},
      [&](msgs::Bus bus) {
        auto n = std::make_unique<FrontendNode>(o, std::move(bus));
        std::fprintf(stderr, "[pplvo-frontend] %s + %s -> %s; %s -> %s; features %s\n",
                     o.rgbd_channel.c_str(), o.cgm_channel.c_str(), o.features_channel.c_str(),
                     o.fused_channel.c_str(), o.features_3d_channel.c_str(),
                     pipeline::toString(o.frontend.families).c_str());
        return n;
      },
      [](const FrontendNode& n) {
        const msgs::NodeCounters& c = n.counters();
        return node::format(
            "[pplvo-frontend] done: %s; %lld of the drops before extraction, the pose -> "
            "fused depth loop behind; %lld extracted without fused depth within the wait\n%s",
            msgs::countsText(c).c_str(), static_cast<long long>(n.droppedLoopBehind()),
            static_cast<long long>(n.droppedUnliftedTimeout()), n.allTimings().table().c_str());
      });
}
