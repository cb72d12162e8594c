#pragma once
/// Device backends of pplvo-camera. Kept thin: they open the device, copy its buffers and call
/// the pure conversions of pplvo_camera_convert. No LCM here.
#include <cstdint>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <string>

#include "pplvo/camera/convert.h"
#include "pplvo/core/camera.h"

namespace pplvo::camera {

struct BackendOptions {
  std::string device;  ///< OpenNI2 URI or index; libfreenect index; empty: first device
  int width = 640;
  int height = 480;
  int fps = 30;
  /// Hardware depth-to-colour registration when available; false (or a device without it):
  /// depth in the depth camera's own frame (OpenNI2 IMAGE_REGISTRATION_OFF, libfreenect
  /// FREENECT_DEPTH_MM), published as DEPTH_OWN_CAMERA (docs/cameras.md).
  bool registration = true;
  /// Under fakenect, treat the end of the dump as an unplugged device (exercises the
  /// reconnect loop without hardware) instead of the end of the stream.
  bool fakenect_end_is_unplug = false;
};

/// One synchronised pair as delivered by a device.
struct CapturedFrame {
  cv::Mat bgr;        ///< CV_8UC3
  cv::Mat depth_u16;  ///< CV_16UC1, depth_scale units per metre, 0 = missing
  double depth_scale = 1000;
  uint64_t device_ticks = 0;                ///< colour frame's device counter
  int64_t depth_minus_colour_ticks = 0;     ///< depth frame's counter minus the colour's
  int64_t host_arrival_utime = 0;
};

enum class GrabStatus { Frame, Timeout, Disconnected, EndOfStream };

class Backend {
 public:
  virtual ~Backend() = default;
  /// Opens the device; false with a message in *error when there is none or it fails.
  virtual bool open(std::string* error) = 0;
  /// Waits up to timeout_ms for the next synchronised frame.
  virtual GrabStatus grab(int timeout_ms, CapturedFrame* out) = 0;
  virtual void close() = 0;
  /// Device URI or description for rgbd_frame_t.source.
  virtual std::string source() const = 0;
  /// Intrinsics the device reports for the current colour mode, if any.
  virtual std::optional<PinholeCamera> deviceIntrinsics() const = 0;
  /// Intrinsics the device reports for its depth stream (OpenNI2: field of view, (F1)), used
  /// for unregistered depth when no calibration file gives the depth camera.
  virtual std::optional<PinholeCamera> deviceDepthIntrinsics() const { return std::nullopt; }
  virtual DeviceClockOptions clockOptions() const = 0;
  /// Registration actually in effect after open().
  virtual RegistrationDecision registration() const = 0;
  /// Frames dropped inside the backend (unpaired halves).
  virtual int64_t droppedFrames() const { return 0; }
};

std::unique_ptr<Backend> makeFreenectBackend(const BackendOptions& options);
std::unique_ptr<Backend> makeOpenni2Backend(const BackendOptions& options);

}  // namespace pplvo::camera
