// pplvo-depth-filter: see pplvo/nodes/depth_filter_node.h and docs/depth_filter.md.
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "pplvo/core/stage_timer.h"
#include "pplvo/msgs/node_runtime.h"
#include "pplvo/nodes/depth_filter_node.h"

namespace {

void usage() {
  std::printf(
      "usage: pplvo-depth-filter [options]\n"
      "  --lcm-url URL            LCM URL (default $LCM_DEFAULT_URL)\n"
      "  --rgbd-channel NAME      in, rgbd_frame_t (PPLVO_RGBD)\n"
      "  --pose-channel NAME      in, pose_t (PPLVO_POSE)\n"
      "  --cgm-channel NAME       out, depth_map_t (PPLVO_DEPTH_CGM)\n"
      "  --fused-channel NAME     out, depth_map_t (PPLVO_DEPTH_FUSED)\n"
      "  --status-channel NAME    out, node_status_t (PPLVO_STATUS)\n"
      "  --window N               O-GM sliding window, frames (10)\n"
      "  --depth-model MODEL      sensor | cgm | ogm (ogm)\n"
      "  --max-translation-variance M2  window eviction threshold, m^2 (1e-4)\n"
      "  --max-pending N          frames waiting for their pose (30)\n"
      "  --compress               zlib-compress published maps\n");
}

}  // namespace

int main(int argc, char** argv) {
  using namespace pplvo;
  nodes::DepthFilterNodeOptions o;
  std::vector<std::string> errors;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&](std::string* out) {
      if (i + 1 >= argc) {
        errors.push_back(a + " needs a value");
        return false;
      }
      *out = argv[++i];
      return true;
    };
    std::string v;
    if (a == "--help" || a == "-h") {
      usage();
      return 0;
    } else if (a == "--lcm-url") {
      value(&o.lcm_url);
    } else if (a == "--rgbd-channel") {
      value(&o.rgbd_channel);
    } else if (a == "--pose-channel") {
      value(&o.pose_channel);
    } else if (a == "--cgm-channel") {
      value(&o.cgm_channel);
    } else if (a == "--fused-channel") {
      value(&o.fused_channel);
    } else if (a == "--status-channel") {
      value(&o.status_channel);
    } else if (a == "--window") {
      if (value(&v)) {
        o.ogm.max_window = std::atoi(v.c_str());
        if (o.ogm.max_window < 1 || o.ogm.max_window > 100) errors.push_back("--window: 1..100");
      }
    } else if (a == "--max-pending") {
      if (value(&v)) {
        o.max_pending = std::atoi(v.c_str());
        if (o.max_pending < 1) errors.push_back("--max-pending: >= 1");
      }
    } else if (a == "--max-translation-variance") {
      if (value(&v)) {
        o.ogm.max_translation_variance_m2 = std::atof(v.c_str());
        if (!(o.ogm.max_translation_variance_m2 > 0))
          errors.push_back("--max-translation-variance: > 0");
      }
    } else if (a == "--depth-model") {
      if (value(&v) && !nodes::parseDepthModel(v, &o.model)) {
        errors.push_back("--depth-model: sensor, cgm or ogm, not '" + v + "'");
      }
    } else if (a == "--compress") {
      o.compress = true;
    } else {
      errors.push_back("unknown option " + a);
    }
  }
  if (!errors.empty()) {
    for (const std::string& e : errors) std::fprintf(stderr, "pplvo-depth-filter: %s\n", e.c_str());
    usage();
    return 2;
  }
  try {
    msgs::installShutdownHandlers();
    auto lcm = msgs::openLcm(o.lcm_url);
    nodes::DepthFilterNode node(o, *lcm);
    std::fprintf(stderr, "[pplvo-depth-filter] %s -> %s, %s; window %d\n", o.rgbd_channel.c_str(),
                 o.cgm_channel.c_str(), o.fused_channel.c_str(), o.ogm.max_window);
    msgs::spin(
        *lcm, [] { return false; }, [&] { node.publishStatus(hostUtime()); }, 1.0);
    node.publishStatus(hostUtime());
    std::fprintf(
        stderr, "[pplvo-depth-filter] done: in %lld out %lld dropped %lld skipped %lld\n%s",
        static_cast<long long>(node.counters().frames_in),
        static_cast<long long>(node.counters().frames_out),
        static_cast<long long>(node.counters().frames_dropped),
        static_cast<long long>(node.counters().frames_skipped), node.timings().table().c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "pplvo-depth-filter: %s\n", e.what());
    return 1;
  }
  return 0;
}
