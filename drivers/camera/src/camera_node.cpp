// The LCM side of pplvo-camera: messages, counters, outage handling. See camera_node.h.
#include "camera_node.h"

#include <cmath>
#include <cstdio>
#include <ctime>
#include <optional>
#include <pplvo_msgs/rgbd_frame_t.hpp>
#include <pplvo_msgs/stream_event_t.hpp>
#include <string>

#include "pplvo/core/args.h"
#include "pplvo/msgs/convert.h"
#include "pplvo/msgs/node_runtime.h"

namespace pplvo::camera {

namespace pm = pplvo::msgs;

std::string nodeUsage() {
  return std::string(
      "usage: pplvo-camera [options]\n"
      "  --backend openni2|freenect   device library (default openni2)\n"
      "  --device URI|INDEX           OpenNI2 URI (or .oni file) or index; freenect index\n"
      "  --lcm-url URL                LCM provider (default $LCM_DEFAULT_URL); e.g.\n"
      "                               'file:///tmp/cam.lcmlog?mode=w' to record to a log\n"
      "  --route CHANNEL=URL          carry CHANNEL over URL instead (repeatable;\n"
      "                               docs/channels.md)\n"
      "  --channel NAME               frame channel (default PPLVO_RGBD)\n"
      "  --stream-channel NAME        stream events (default PPLVO_STREAM)\n"
      "  --status-channel NAME        node status (default PPLVO_STATUS)\n"
      "  --width W --height H --fps F colour and depth mode (default 640 480 30)\n"
      "  --registration on|off        hardware depth-to-colour registration (default on,\n"
      "                               off with a --calib file saying depth_registered: false);\n"
      "                               off: depth published in the depth camera's own frame\n"
      "  --calib FILE                 calib_params.xml / OpenCV YAML with colour intrinsics\n"
      "                               (and the depth camera + extrinsic for unregistered depth)\n"
      "  --rgb-encoding raw|jpeg|png  (default raw)   --jpeg-quality Q (default 90)\n"
      "  --depth-encoding raw|zlib|png (default raw)\n"
      "  --max-fps F                  publish at most F frames per second (default: all)\n"
      "  --max-frames N               stop after N published frames (default: run until ^C)\n"
      "  --lost-after S               seconds without frames before reconnecting (default 3)\n"
      "  --reconnect-period S         seconds between reconnection attempts (default 1)\n"
      "  --fakenect-end stop|unplug   under fakenect, the dump's end ends the stream (stop,\n"
      "                               default) or acts as an unplugged device (tests)\n");
}

bool parseNodeArgs(int argc, const char* const* argv, NodeOptions* o, std::string* error,
                   bool* help) {
  auto choice = [](const std::string& error_text, auto apply) {
    return [error_text, apply](const std::string& v) -> std::string {
      return apply(v) ? "" : error_text;
    };
  };
  ArgParser p;
  pplvo::msgs::addRouteOption(p, &o->routes);
  p.option("--backend", &o->backend)
      .option("--device", &o->device.device)
      .option("--lcm-url", &o->lcm_url)
      .option("--channel", &o->channel)
      .option("--stream-channel", &o->stream_channel)
      .option("--status-channel", &o->status_channel)
      .option("--width", &o->device.width)
      .option("--height", &o->device.height)
      .option("--fps", &o->device.fps)
      .option("--calib", &o->calib)
      .option("--jpeg-quality", &o->jpeg_quality)
      .option("--max-fps", &o->max_fps)
      .option("--max-frames", &o->max_frames)
      .option("--lost-after", &o->lost_after_s)
      .option("--reconnect-period", &o->reconnect_period_s)
      .option("--registration", choice("--registration takes on or off",
                                       [o](const std::string& v) {
                                         if (v != "on" && v != "off") return false;
                                         o->device.registration = v == "on";
                                         o->registration_given = true;
                                         return true;
                                       }))
      .option("--rgb-encoding", choice("--rgb-encoding takes raw, jpeg or png",
                                       [o](const std::string& v) {
                                         const auto e = parseRgbEncoding(v);
                                         if (e) o->rgb_encoding = *e;
                                         return e.has_value();
                                       }))
      .option("--depth-encoding", choice("--depth-encoding takes raw, zlib or png",
                                         [o](const std::string& v) {
                                           const auto e = parseDepthEncoding(v);
                                           if (e) o->depth_encoding = *e;
                                           return e.has_value();
                                         }))
      .option("--fakenect-end", choice("--fakenect-end takes stop or unplug",
                                       [o](const std::string& v) {
                                         if (v != "stop" && v != "unplug") return false;
                                         o->device.fakenect_end_is_unplug = v == "unplug";
                                         return true;
                                       }));
  p.parse(argsFromArgv(argc, argv));
  *help = p.help();
  if (*help) return true;
  if (!p.ok()) {
    *error = p.errors().front();
    return false;
  }
  if (o->backend != "openni2" && o->backend != "freenect") {
    *error = "--backend takes openni2 or freenect";
    return false;
  }
  if (o->device.width <= 0 || o->device.height <= 0 || o->device.fps <= 0) {
    *error = "--width, --height and --fps must be positive";
    return false;
  }
  if (o->max_frames < 0 || o->max_fps < 0 || !(o->lost_after_s > 0) ||
      !(o->reconnect_period_s > 0)) {
    *error = "--max-frames, --max-fps must be >= 0; --lost-after, --reconnect-period > 0";
    return false;
  }
  if (o->jpeg_quality < 1 || o->jpeg_quality > 100) {
    *error = "--jpeg-quality must be in 1..100";
    return false;
  }
  return true;
}

namespace {

int8_t rgbCode(RgbEncoding e) {
  switch (e) {
    case RgbEncoding::Jpeg:
      return pplvo_msgs::image_t::ENCODING_JPEG;
    case RgbEncoding::Png:
      return pplvo_msgs::image_t::ENCODING_PNG;
    default:
      return pplvo_msgs::image_t::ENCODING_RAW_BGR8;
  }
}
int8_t depthCode(DepthEncoding e) {
  switch (e) {
    case DepthEncoding::Zlib:
      return pplvo_msgs::image_t::ENCODING_ZLIB_U16;
    case DepthEncoding::Png:
      return pplvo_msgs::image_t::ENCODING_PNG_U16;
    default:
      return pplvo_msgs::image_t::ENCODING_RAW_U16;
  }
}

/// The publishing side: converts captured frames to messages and keeps the counters.
class CameraPublisher {
 public:
  CameraPublisher(const NodeOptions& options, pplvo::msgs::Bus bus, pplvo::PinholeCamera camera,
                  std::optional<DepthCamera> depth_camera, std::string source)
      : options_(options),
        bus_(std::move(bus)),
        camera_(camera),
        depth_camera_(std::move(depth_camera)),
        source_(std::move(source)),
        limiter_(options.max_fps) {}

  void setSource(const std::string& s) { source_ = s; }
  void resetClock(const DeviceClockOptions& clock) { clock_.emplace(clock); }

  void onFrame(const CapturedFrame& f) {
    const int64_t seq = seq_;  // the seq it goes out with
    ledger_.arrived(seq);
    pm::guardedFrame(ledger_, counters_, kNodeName, seq, [&] {
      pplvo::Stopwatch watch;
      const int64_t utime = clock_->map(f.device_ticks, f.host_arrival_utime);
      if (!limiter_.allow(utime)) {
        ledger_.dropped(seq);
        return;
      }
      // Depth has the colour's size when registered, the depth camera's otherwise.
      const cv::Size depth_size =
          depth_camera_ ? cv::Size(depth_camera_->camera.width, depth_camera_->camera.height)
                        : f.bgr.size();
      if (f.depth_u16.size() != depth_size) {
        throw pm::MessageError("colour " + std::to_string(f.bgr.cols) + "x" +
                               std::to_string(f.bgr.rows) + " and depth " +
                               std::to_string(f.depth_u16.cols) + "x" +
                               std::to_string(f.depth_u16.rows) + " sizes differ" +
                               (depth_camera_ ? " (depth camera " +
                                                    std::to_string(depth_size.width) + "x" +
                                                    std::to_string(depth_size.height) + ")"
                                              : std::string()));
      }
      if (f.bgr.cols != camera_.width || f.bgr.rows != camera_.height) {
        throw pm::MessageError("frame size differs from the camera model");
      }
      pplvo_msgs::rgbd_frame_t msg;
      msg.utime = utime;
      const double ticks_per_us = clock_->options().ticks_per_second * 1e-6;
      msg.depth_utime =
          utime + static_cast<int64_t>(std::llround(f.depth_minus_colour_ticks / ticks_per_us));
      msg.seq = seq_;
      msg.stamp = stampText(utime);
      msg.source = source_;
      msg.camera = pm::toMsg(camera_);
      msg.depth_scale = f.depth_scale;
      msg.rgb = pm::encodeImage(f.bgr, rgbCode(options_.rgb_encoding), options_.jpeg_quality);
      msg.depth = pm::encodeImage(f.depth_u16, depthCode(options_.depth_encoding));
      // DEPTH_REGISTERED when the device registers, else DEPTH_OWN_CAMERA (docs/cameras.md).
      pm::setDepthCamera(depth_camera_, &msg);
      bus_.publish(options_.channel, &msg);
      ++seq_;
      ledger_.published(msg.seq);
      counters_.last_seq = msg.seq;
      timings_.add("publish", watch.elapsedMs());
    });
  }

  void publishEvent(int8_t event) {
    pm::guarded(counters_, kNodeName, [&] {
      pplvo_msgs::stream_event_t ev;
      ev.utime = pplvo::hostUtime();
      ev.source = source_;
      ev.event = event;
      ev.frames_published = counters_.frames_out;
      ev.frames_skipped = counters_.frames_skipped;
      bus_.publish(options_.stream_channel, &ev);
    });
  }

  void publishStatus(int64_t backend_dropped, bool final = false) {
    pm::guarded(counters_, kNodeName, [&] {
      pm::NodeCounters c = counters_;
      c.frames_lost += backend_dropped;  // dropped by the driver: they never reached us
      auto msg = pm::toStatusMsg(kNodeName, c, timings_, pplvo::hostUtime(), final);
      pm::appendBlockedPublishes(bus_, &msg);
      bus_.publish(options_.status_channel, &msg);
    });
  }

  void warn(const std::string& w) {
    counters_.last_warning = w;
    std::fprintf(stderr, "[%s] %s\n", kNodeName, w.c_str());
  }
  int64_t published() const { return counters_.frames_out; }

 private:
  const NodeOptions& options_;
  pplvo::msgs::Bus bus_;
  pplvo::PinholeCamera camera_;
  std::optional<DepthCamera> depth_camera_;  ///< unset: depth registered to colour
  std::string source_;
  std::optional<DeviceClockMapper> clock_;
  RateLimiter limiter_;
  pm::NodeCounters counters_;
  pm::FrameLedger ledger_{counters_};  ///< each captured frame: published, dropped or skipped
  pplvo::StageTimings timings_;
  int64_t seq_ = 0;
};

}  // namespace

NodeRunResult runCameraNode(const NodeOptions& options, Backend& backend, pplvo::msgs::Bus bus,
                            const PinholeCamera& camera, const std::string& camera_origin,
                            const std::optional<DepthCamera>& calib_depth_camera) {
  std::string error;
  NodeRunResult result;
  const auto reg = backend.registration();
  const DepthFramePlan plan = planDepthFrame(reg, calib_depth_camera,
                                             backend.deviceDepthIntrinsics(), camera.width,
                                             camera.height);
  if (!plan.error.empty()) {
    result.error = plan.error;
    std::fprintf(stderr, "[%s] %s\n", kNodeName, plan.error.c_str());
    backend.close();
    return result;
  }
  result.depth_camera = plan.depth_camera;
  CameraPublisher publisher(options, bus, camera, plan.depth_camera, backend.source());
  publisher.resetClock(backend.clockOptions());
  if (!reg.warning.empty()) publisher.warn(reg.warning);
  if (!plan.warning.empty()) publisher.warn(plan.warning);
  std::fprintf(stderr, "[%s] streaming from %s, %dx%d, fx %.2f fy %.2f cx %.2f cy %.2f (%s)\n",
               kNodeName, backend.source().c_str(), camera.width, camera.height, camera.fx,
               camera.fy, camera.cx, camera.cy, camera_origin.c_str());
  if (plan.depth_camera) {
    const PinholeCamera& d = plan.depth_camera->camera;
    const Eigen::Vector3d t = plan.depth_camera->T_c_d.translation();
    std::fprintf(stderr,
                 "[%s] depth in its own camera (DEPTH_OWN_CAMERA): %dx%d, fx %.2f fy %.2f cx "
                 "%.2f cy %.2f, t_c_d [m] %.4f %.4f %.4f (%s)\n",
                 kNodeName, d.width, d.height, d.fx, d.fy, d.cx, d.cy, t.x(), t.y(), t.z(),
                 plan.origin.c_str());
  }
  publisher.publishEvent(pplvo_msgs::stream_event_t::EVENT_START);

  // Main loop. A lost device (error from the library, or no frame for --lost-after seconds)
  // starts an outage: one message, then attempts every --reconnect-period seconds (waiting
  // before each, so a device that opens but fails at once cannot spin), until a frame arrives.
  int64_t last_status = pplvo::hostUtime();
  int64_t last_frame = last_status;
  bool end_of_stream = false;
  bool in_outage = false;
  int attempts = 0;
  bool device_open = true;
  auto sleepUntil = [](int64_t until) {
    while (!pm::shutdownRequested() && pplvo::hostUtime() < until) {
      struct timespec ts {
        0, 20000000
      };
      nanosleep(&ts, nullptr);
    }
  };
  while (!pm::shutdownRequested() && !end_of_stream &&
         (options.max_frames == 0 || publisher.published() < options.max_frames)) {
    const int64_t now = pplvo::hostUtime();
    if (now - last_status >= 1000000) {
      publisher.publishStatus(backend.droppedFrames());
      last_status = now;
    }
    if (!device_open) {
      sleepUntil(pplvo::hostUtime() + static_cast<int64_t>(options.reconnect_period_s * 1e6));
      if (pm::shutdownRequested()) break;
      ++attempts;
      ++result.reconnect_attempts;
      if (backend.open(&error)) {
        device_open = true;
        publisher.setSource(backend.source());
        publisher.resetClock(backend.clockOptions());
        last_frame = pplvo::hostUtime();
      } else if (attempts <= 3 || attempts % 30 == 0) {
        std::fprintf(stderr, "[%s] reconnect attempt %d failed: %s\n", kNodeName, attempts,
                     error.c_str());
      }
      continue;
    }
    CapturedFrame frame;
    GrabStatus st;
    try {
      st = backend.grab(options.grab_timeout_ms, &frame);
    } catch (const std::exception& e) {  // e.g. a device buffer with impossible sizes
      publisher.warn(std::string("device read failed: ") + e.what());
      st = GrabStatus::Disconnected;
    }
    bool lost = false;
    switch (st) {
      case GrabStatus::Frame:
        if (in_outage) {
          in_outage = false;
          publisher.warn("device back after " + std::to_string(attempts) + " reconnect attempt(s)");
          publisher.publishEvent(pplvo_msgs::stream_event_t::EVENT_START);
        }
        last_frame = pplvo::hostUtime();
        publisher.onFrame(frame);
        break;
      case GrabStatus::Timeout:
        lost = pplvo::hostUtime() - last_frame > static_cast<int64_t>(options.lost_after_s * 1e6);
        break;
      case GrabStatus::Disconnected:
        lost = true;
        break;
      case GrabStatus::EndOfStream:
        end_of_stream = true;
        break;
    }
    if (lost) {
      if (!in_outage) {
        in_outage = true;
        ++result.outages;
        attempts = 0;
        // No stream event here: consumers (pplvo-logger --until-end) take END and ERROR as
        // the end of the stream, and the node has not given up. The outage shows in the
        // status' last_warning; a new START marks the restart.
        publisher.warn("device lost (unplugged or stalled): reconnecting every " +
                       std::to_string(options.reconnect_period_s) + " s, ^C to stop");
        publisher.publishStatus(backend.droppedFrames());
      }
      backend.close();
      device_open = false;
    }
  }
  publisher.publishEvent(pplvo_msgs::stream_event_t::EVENT_END);
  publisher.publishStatus(backend.droppedFrames(), /*final=*/true);
  backend.close();
  std::fprintf(stderr, "[%s] %s after %lld frames\n", kNodeName,
               end_of_stream ? "end of stream" : "stopped",
               static_cast<long long>(publisher.published()));
  result.published = publisher.published();
  result.end_of_stream = end_of_stream;
  return result;
}

}  // namespace pplvo::camera
