// pplvo-depth-filter: see pplvo/depth_filter_node/depth_filter_node.h and docs/depth_filter.md.
#include "pplvo/core/allocator.h"
#include "pplvo/core/args.h"
#include "pplvo/msgs/frame_ledger.h"
#include "pplvo/node/process.h"
#include "pplvo/depth_filter_node/depth_filter_args.h"

int main(int argc, char** argv) {
  pplvo::keepFrameBuffersMapped();  // frame-sized buffers: no page faults per frame
  using namespace pplvo;
  using nodes::DepthFilterNode;
  const nodes::DepthFilterArgs a = nodes::parseDepthFilterArgs(argsFromArgv(argc, argv));
  const int code =
      node::argsExitCode(DepthFilterNode::kName, a.help, a.errors, nodes::depthFilterUsage());
  if (code != node::kRun) return code;
  const nodes::DepthFilterNodeOptions& o = a.options;
  return node::runLcmNode<DepthFilterNode>(
      {DepthFilterNode::kName, o.lcm_url, o.routes, a.prefault_mb},
      [&](msgs::Bus bus) {
        auto n = std::make_unique<DepthFilterNode>(o, std::move(bus));
        std::fprintf(stderr, "[pplvo-depth-filter] %s -> %s, %s; window %d\n",
                     o.rgbd_channel.c_str(), o.cgm_channel.c_str(), o.fused_channel.c_str(),
                     o.filter.ogm.max_window);
        return n;
      },
      [&](const DepthFilterNode& n) {
        const msgs::NodeCounters& c = n.counters();
        std::string s = node::format(
            "[pplvo-depth-filter] done: %s\n%s", msgs::countsText(c).c_str(),
            n.timings().table().c_str());
        const depth_filter::DepthFilterOverloadOptions& shed = o.filter.overload;
        if (o.filter.model == depth_filter::DepthModel::kOgm && shed.backlog > 0) {
          s += node::format(
              "[pplvo-depth-filter] overload: %lld fusions over a shortened window (more than %d "
              "newer frames waiting: %d frames shorter per frame)\n",
              static_cast<long long>(n.overloadFusions()), shed.backlog, shed.window_step);
        }
        return s;
      });
}
