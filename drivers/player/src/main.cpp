// pplvo-player: publishes a TUM-layout RGB-D folder on LCM. See docs/player.md.
#include <cstdio>

#include "pplvo/core/allocator.h"
#include "pplvo/core/args.h"
#include "pplvo/msgs/node_runtime.h"
#include "pplvo/player/player_node.h"

int main(int argc, char** argv) {
  pplvo::keepFrameBuffersMapped();  // frame-sized buffers: no page faults per frame
  using namespace pplvo;
  const std::vector<std::string> args = argsFromArgv(argc, argv);
  player::ParseResult parsed = player::parsePlayerArgs(args);
  if (parsed.help) {
    std::fputs(player::playerUsage().c_str(), stdout);
    return 0;
  }
  if (!parsed.errors.empty()) {
    for (const auto& e : parsed.errors) std::fprintf(stderr, "pplvo-player: %s\n", e.c_str());
    std::fprintf(stderr, "pplvo-player: see --help\n");
    return 2;
  }
  player::PlayerOptions& opt = parsed.options;
  opt.progress = progressEnabled(args, opt.progress);  // default: stderr is a terminal
  msgs::installShutdownHandlers();
  try {
    msgs::BusConnections lcm(opt.lcm_url, opt.routes);
    player::PlayerNode node(opt, lcm.bus());
    const auto& ds = node.dataset();
    const auto& cam = ds.camera();
    std::fprintf(stderr, "pplvo-player: %s: %zu frames; %s\n", ds.dir().c_str(), ds.size(),
                 ds.index().summary.text().c_str());
    std::fprintf(stderr,
                 "pplvo-player: camera %dx%d fx %.3f fy %.3f cx %.3f cy %.3f depth_scale %g "
                 "(from %s); publishing on %s\n",
                 cam.camera.width, cam.camera.height, cam.camera.fx, cam.camera.fy, cam.camera.cx,
                 cam.camera.cy, cam.depth_scale, cam.source.c_str(), opt.channel.c_str());
    const player::PlayerResult r = node.run();
    std::fprintf(stderr, "pplvo-player: %s\n%s", r.summaryLine().c_str(),
                 node.timings().table().c_str());
    return r.exitCode();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "pplvo-player: error: %s\n", e.what());
    return 1;
  }
}
