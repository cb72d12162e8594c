#pragma once
/// The LCM side of pplvo-camera, separated from main() so that the run loop (publishing,
/// rate limit, outage and reconnection handling) is tested with a scripted backend on memq://.
/// Channels: out PPLVO_RGBD (rgbd_frame_t), PPLVO_STREAM (stream_event_t START/END),
/// PPLVO_STATUS (node_status_t, about once a second). See docs/cameras.md.
#include <cstdint>
#include <lcm/lcm-cpp.hpp>
#include <optional>
#include <string>

#include "backend.h"
#include "pplvo/camera/convert.h"
#include "pplvo/core/camera.h"
#include "pplvo/msgs/bus.h"
#include "pplvo/msgs/channels.h"

namespace pplvo::camera {

inline constexpr const char* kNodeName = "pplvo-camera";
inline constexpr int kExitOk = 0;
inline constexpr int kExitUsage = 1;     ///< bad command line or calibration file
inline constexpr int kExitNoDevice = 2;  ///< no usable device at start
inline constexpr int kExitRuntime = 3;   ///< LCM could not be opened

/// Command-line options of pplvo-camera (docs/cameras.md lists them).
struct NodeOptions {
  std::string backend = "openni2";
  BackendOptions device;
  std::string lcm_url;  ///< empty: $LCM_DEFAULT_URL
  std::vector<msgs::ChannelRoute> routes;  ///< --route: channels carried by other URLs
  std::string channel = pplvo::channels::kRgbd;
  std::string stream_channel = pplvo::channels::kStream;
  std::string status_channel = pplvo::channels::kStatus;
  std::string calib;
  /// --registration was given: a calibration file with `depth_registered: false` then does
  /// not switch the device's registration off.
  bool registration_given = false;
  RgbEncoding rgb_encoding = RgbEncoding::Raw;
  DepthEncoding depth_encoding = DepthEncoding::Raw;
  int jpeg_quality = 90;
  double max_fps = 0;               ///< 0: every frame
  int64_t max_frames = 0;           ///< 0: until stopped
  double lost_after_s = 3.0;        ///< no frame for this long: device lost
  double reconnect_period_s = 1.0;  ///< wait before each reconnection attempt
  int grab_timeout_ms = 100;        ///< one wait for a frame
};

std::string nodeUsage();
/// Parses argv; false with a message on a bad command line. *help is set for -h/--help.
bool parseNodeArgs(int argc, const char* const* argv, NodeOptions* options, std::string* error,
                   bool* help);

struct NodeRunResult {
  int64_t published = 0;
  int64_t outages = 0;             ///< times the device was lost
  int64_t reconnect_attempts = 0;  ///< open() calls after losses
  bool end_of_stream = false;      ///< stopped because the source ended (fakenect)
  /// Non-empty: nothing was published because the frames' depth camera could not be
  /// described (unregistered depth without depth intrinsics; planDepthFrame).
  std::string error;
  /// The depth camera published frames carry (unset: DEPTH_REGISTERED).
  std::optional<DepthCamera> depth_camera;
};

/// Publishes from an opened backend until shutdown is requested, --max-frames is reached or
/// the source ends; reconnects after losses. Publishes START first and END (plus a final
/// status) last. Never throws for per-frame problems (they are counted).
/// Frames carry depth_frame DEPTH_REGISTERED when the backend registers depth to colour, else
/// DEPTH_OWN_CAMERA with the depth camera of planDepthFrame (`calib_depth_camera` from the
/// calibration file, else the backend's depth intrinsics); when there is none, returns at once
/// with NodeRunResult::error set and publishes nothing.
NodeRunResult runCameraNode(const NodeOptions& options, Backend& backend, pplvo::msgs::Bus bus,
                            const PinholeCamera& camera, const std::string& camera_origin,
                            const std::optional<DepthCamera>& calib_depth_camera = std::nullopt);

}  // namespace pplvo::camera
