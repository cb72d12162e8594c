// pplvo-viewer: live panels of the pipeline's channels (window or headless snapshots/video).
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <string>

#include "../node/viewer_node.h"
#include "pplvo/core/allocator.h"
#include "pplvo/msgs/node_runtime.h"

namespace {
void usage() {
  std::fprintf(stderr,
               "usage: pplvo-viewer [options]\n"
               "  --lcm-url URL          LCM URL (default $LCM_DEFAULT_URL)\n"
               "  --route CHANNEL=URL    CHANNEL is carried by URL (repeatable; docs/channels.md)\n"
               "  --replay LOG           read an LCM log (file://LOG?speed=S) instead of a bus\n"
               "  --replay-speed S       replay speed factor (default 1; 0 = as fast as possible)\n"
               "  --headless             no window\n"
               "  --snapshot-dir DIR     write canvas_NNNNNN.png every --every canvases\n"
               "                         (DIR is created if missing)\n"
               "  --every N              (default 1)\n"
               "  --video FILE.avi       MJPG video of every canvas\n"
               "  --save-window FILE.png overwrite FILE with each canvas shown\n"
               "  --max-fps F            draw at most F canvases per second (default 15)\n"
               "  --exit-after-end       stop 0.5 s after stream_event_t END\n"
               "  --timeout S            stop after S seconds\n"
               "  --groundtruth FILE     TUM ground truth shown in the trajectory views\n"
               "  --gt-fps F             stamps are frame indices at F Hz (ICL-NUIM)\n"
               "  --align first|ate      ground-truth alignment (default first)\n"
               "  --depth-range MIN,MAX  fixed depth colour range in metres (default auto)\n"
               "  --sigma-range MIN,MAX  fixed sigma colour range in metres (default auto)\n"
               "  --colormap turbo|jet   (default turbo)\n"
               "  --no-status            do not publish node_status_t\n");
}
bool parseRange(const char* s, double& lo, double& hi) {
  return std::sscanf(s, "%lf,%lf", &lo, &hi) == 2 && lo < hi;
}
}  // namespace

int main(int argc, char** argv) {
  pplvo::keepFrameBuffersMapped();  // frame-sized buffers: no page faults per frame
  using pplvo::viewer::ViewerOptions;
  ViewerOptions o;
  std::string url, replay;
  std::vector<pplvo::msgs::ChannelRoute> routes;
  double replay_speed = 1.0;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> const char* {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "pplvo-viewer: %s needs a value\n", a.c_str());
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--lcm-url") {
      url = next();
    } else if (a == "--route") {
      pplvo::msgs::ChannelRoute r;
      const std::string error = pplvo::msgs::parseChannelRoute(next(), &r);
      if (!error.empty()) {
        std::fprintf(stderr, "pplvo-viewer: --route: %s\n", error.c_str());
        return 2;
      }
      routes.push_back(r);
    } else if (a == "--replay")
      replay = next();
    else if (a == "--replay-speed")
      replay_speed = std::atof(next());
    else if (a == "--headless")
      o.show_window = false;
    else if (a == "--snapshot-dir")
      o.snapshot_dir = next();
    else if (a == "--every")
      o.every = std::atoi(next());
    else if (a == "--video")
      o.video_path = next();
    else if (a == "--save-window")
      o.window_save_path = next();
    else if (a == "--max-fps")
      o.max_fps = std::atof(next());
    else if (a == "--exit-after-end")
      o.exit_after_end = true;
    else if (a == "--timeout")
      o.timeout_s = std::atof(next());
    else if (a == "--groundtruth")
      o.groundtruth_path = next();
    else if (a == "--gt-fps")
      o.groundtruth_fps = std::atof(next());
    else if (a == "--align") {
      const std::string m = next();
      if (m == "first")
        o.alignment = pplvo::viewer::GtAlignment::kFirstPose;
      else if (m == "ate")
        o.alignment = pplvo::viewer::GtAlignment::kAte;
      else {
        std::fprintf(stderr, "pplvo-viewer: --align first|ate\n");
        return 2;
      }
    } else if (a == "--depth-range") {
      if (!parseRange(next(), o.canvas.depth.min_value_m, o.canvas.depth.max_value_m)) {
        std::fprintf(stderr, "pplvo-viewer: --depth-range MIN,MAX with MIN < MAX\n");
        return 2;
      }
    } else if (a == "--sigma-range") {
      if (!parseRange(next(), o.canvas.sigma.min_value_m, o.canvas.sigma.max_value_m)) {
        std::fprintf(stderr, "pplvo-viewer: --sigma-range MIN,MAX with MIN < MAX\n");
        return 2;
      }
    } else if (a == "--colormap") {
      const std::string m = next();
      int cm = m == "turbo" ? 20 : (m == "jet" ? 2 : -1);
      if (cm < 0) {
        std::fprintf(stderr, "pplvo-viewer: --colormap turbo|jet\n");
        return 2;
      }
      o.canvas.depth.colormap = o.canvas.sigma.colormap = cm;
    } else if (a == "--no-status")
      o.publish_status = false;
    else if (a == "-h" || a == "--help") {
      usage();
      return 0;
    } else {
      std::fprintf(stderr, "pplvo-viewer: unknown option %s\n", a.c_str());
      usage();
      return 2;
    }
  }
  if (!(o.max_fps > 0) || o.every < 1) {
    std::fprintf(stderr, "pplvo-viewer: --max-fps must be > 0 and --every >= 1\n");
    return 2;
  }
  if (o.show_window && !std::getenv("DISPLAY") && !std::getenv("WAYLAND_DISPLAY")) {
    // Qt's highgui aborts the process when it cannot reach a display: fail clearly instead.
    std::fprintf(stderr,
                 "pplvo-viewer: no DISPLAY for the window; use --headless (with "
                 "--snapshot-dir / --video) or run under xvfb-run\n");
    return 2;
  }
  if (!replay.empty()) {
    if (!url.empty() || !routes.empty()) {
      std::fprintf(stderr, "pplvo-viewer: --replay or --lcm-url/--route, not both\n");
      return 2;
    }
    char speed[32];
    std::snprintf(speed, sizeof speed, "%g", replay_speed);
    url = "file://" + replay + "?mode=r&speed=" + speed;
    o.publish_status = false;  // a read-only log provider cannot publish
  }
  try {
    pplvo::msgs::installShutdownHandlers();
    pplvo::msgs::BusConnections lcm(url, routes);
    pplvo::viewer::ViewerNode node(o, lcm.bus());
    char timeout_buf[48];
    std::snprintf(timeout_buf, sizeof timeout_buf, ", timeout %g s", o.timeout_s);
    const std::string timeout_text = timeout_buf;
    std::fprintf(
        stderr, "[pplvo-viewer] %s, max %.1f fps%s%s%s%s, ground truth %s (align %s)\n",
        o.show_window ? "window" : "headless", o.max_fps,
        o.snapshot_dir.empty()
            ? ""
            : (", snapshots every " + std::to_string(o.every) + " in " + o.snapshot_dir).c_str(),
        o.video_path.empty() ? "" : (", video " + o.video_path).c_str(),
        o.exit_after_end ? ", exit after END" : "", o.timeout_s > 0 ? timeout_text.c_str() : "",
        o.groundtruth_path.empty() ? "none" : o.groundtruth_path.c_str(),
        o.alignment == pplvo::viewer::GtAlignment::kAte ? "ate" : "first");
    const int rc = node.run();
    std::fprintf(stderr,
                 "[pplvo-viewer] frames %lld drawn %lld dropped %lld canvases %lld snapshots %lld "
                 "skipped %lld errors %lld\n",
                 static_cast<long long>(node.counters().frames_in),
                 static_cast<long long>(node.counters().frames_out),
                 static_cast<long long>(node.counters().frames_dropped),
                 static_cast<long long>(node.canvasesDrawn()),
                 static_cast<long long>(node.snapshotsWritten()),
                 static_cast<long long>(node.counters().frames_skipped),
                 static_cast<long long>(node.counters().errors));
    return rc;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "pplvo-viewer: %s\n", e.what());
    return 1;
  }
}
