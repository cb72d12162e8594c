// libfreenect (Kinect v1) backend: the asynchronous API driven from grab(), so that the node
// owns the loop (no hidden thread), timeouts are bounded and an unplugged device surfaces as
// an error code instead of a hang.
#include <libfreenect.h>
#include <sys/time.h>

#include <cstdlib>
#include <cstring>

#include "backend.h"
#include "pplvo/core/stage_timer.h"

namespace pplvo::camera {
namespace {

constexpr double kKinectTicksPerSecond = 60e6;  // the camera's 60 MHz frame counter
constexpr int kWidth = 640;
constexpr int kHeight = 480;

class FreenectBackend final : public Backend {
 public:
  explicit FreenectBackend(const BackendOptions& options)
      : options_(options),
        // Depth and colour of one Kinect v1 frame pair are less than half a 30 Hz period apart.
        pairer_(static_cast<uint64_t>(kKinectTicksPerSecond / 60.0), 32),
        under_fakenect_(std::getenv("FAKENECT_PATH") != nullptr) {}
  ~FreenectBackend() override { close(); }

  bool open(std::string* error) override {
    close();
    if (options_.width != kWidth || options_.height != kHeight) {
      *error = "libfreenect backend supports only 640x480 depth and colour (asked " +
               std::to_string(options_.width) + "x" + std::to_string(options_.height) + ")";
      return false;
    }
    if (options_.fps != 30) {
      *error = "libfreenect backend runs at 30 fps only (use --max-fps to publish fewer frames)";
      return false;
    }
    int index = 0;
    if (!options_.device.empty()) {
      char* end = nullptr;
      const long v = std::strtol(options_.device.c_str(), &end, 10);
      if (*end != '\0' || v < 0) {
        *error =
            "libfreenect backend takes a device index (0, 1, ...), not '" + options_.device + "'";
        return false;
      }
      index = static_cast<int>(v);
    }
    if (freenect_init(&ctx_, nullptr) < 0 || !ctx_) {
      ctx_ = nullptr;
      *error = "libfreenect initialisation failed (libusb unavailable?)";
      return false;
    }
    freenect_set_log_level(ctx_, FREENECT_LOG_ERROR);
    freenect_select_subdevices(ctx_, FREENECT_DEVICE_CAMERA);
    const int n = freenect_num_devices(ctx_);
    if (n <= index) {
      *error = n <= 0 ? "no Kinect v1 found by libfreenect (is it plugged in and powered? "
                        "permissions: udev rule for 045e:02ae)"
                      : "Kinect index " + std::to_string(index) + " not present (" +
                            std::to_string(n) + " found)";
      close();
      return false;
    }
    if (freenect_open_device(ctx_, &dev_, index) < 0 || !dev_) {
      dev_ = nullptr;
      *error = "cannot open Kinect " + std::to_string(index) +
               " (in use by another program, or no permission on the USB device)";
      close();
      return false;
    }
    freenect_set_user(dev_, this);
    source_ = std::string(under_fakenect_ ? "fakenect:" : "freenect:") + std::to_string(index);

    // Registered depth (mm, aligned to colour) when the library offers it; libfreenect 0.5.3
    // does on real hardware, Debian's fakenect 0.5.3 offers only the 11-bit mode (and aborts
    // when asked for another one), so enumerate instead of calling find_depth_mode.
    // Without registration: millimetres in the depth camera's frame (FREENECT_DEPTH_MM) when
    // offered, else 11-bit disparity converted with (K1).
    bool have_registered = false, have_11bit = false, have_mm = false;
    freenect_frame_mode registered_mode{}, raw_mode{}, mm_mode{};
    for (int i = 0; i < freenect_get_depth_mode_count(); ++i) {
      const freenect_frame_mode m = freenect_get_depth_mode(i);
      if (!m.is_valid || m.resolution != FREENECT_RESOLUTION_MEDIUM) continue;
      if (m.depth_format == FREENECT_DEPTH_REGISTERED) {
        have_registered = true;
        registered_mode = m;
      } else if (m.depth_format == FREENECT_DEPTH_11BIT) {
        have_11bit = true;
        raw_mode = m;
      } else if (m.depth_format == FREENECT_DEPTH_MM) {
        have_mm = true;
        mm_mode = m;
      }
    }
    registration_ = decideRegistration(options_.registration, have_registered);
    if (registration_.use_hardware) {
      depth_in_mm_ = true;
      if (freenect_set_depth_mode(dev_, registered_mode) < 0) {
        *error = "cannot set registered depth mode";
        close();
        return false;
      }
    } else if (have_mm && !under_fakenect_) {
      depth_in_mm_ = true;
      if (freenect_set_depth_mode(dev_, mm_mode) < 0) {
        *error = "cannot set unregistered millimetre depth mode";
        close();
        return false;
      }
    } else {
      depth_in_mm_ = false;
      if (!have_11bit || freenect_set_depth_mode(dev_, raw_mode) < 0) {
        *error = "cannot set 11-bit depth mode";
        close();
        return false;
      }
      if (under_fakenect_ && options_.registration) {
        registration_.warning =
            "fakenect offers only raw 11-bit depth: converting it with the Kinect disparity "
            "model; the dump's depth is assumed registered (pplvo-tum-to-fakenect writes it so)";
        registration_.depth_in_colour_frame = true;
      }
    }
    const freenect_frame_mode video =
        freenect_find_video_mode(FREENECT_RESOLUTION_MEDIUM, FREENECT_VIDEO_RGB);
    if (!video.is_valid || freenect_set_video_mode(dev_, video) < 0) {
      *error = "cannot set 640x480 RGB video mode";
      close();
      return false;
    }
    freenect_set_depth_callback(dev_, &FreenectBackend::depthCallback);
    freenect_set_video_callback(dev_, &FreenectBackend::videoCallback);
    if (freenect_start_depth(dev_) < 0 || freenect_start_video(dev_) < 0) {
      *error = "cannot start the Kinect streams";
      close();
      return false;
    }
    streaming_ = true;
    pairer_.clear();
    return true;
  }

  GrabStatus grab(int timeout_ms, CapturedFrame* out) override {
    if (!ctx_ || !dev_) return GrabStatus::Disconnected;
    const int64_t deadline = hostUtime() + int64_t{timeout_ms} * 1000;
    while (true) {
      if (auto pair = pairer_.pop()) {
        out->bgr = pair->bgr;
        if (depth_in_mm_) {
          out->depth_u16 = pair->depth;  // already millimetres, 0 = no data
        } else {
          out->depth_u16 = raw_to_mm_.convert(pair->depth);
        }
        out->depth_scale = 1000.0;
        out->device_ticks = pair->device_ticks;
        out->depth_minus_colour_ticks = pair->depth_minus_colour_ticks;
        out->host_arrival_utime = arrival_utime_;
        return GrabStatus::Frame;
      }
      const int64_t left_us = deadline - hostUtime();
      if (left_us <= 0) return GrabStatus::Timeout;
      timeval tv{};
      tv.tv_sec = static_cast<time_t>(left_us / 1000000);
      tv.tv_usec = static_cast<suseconds_t>(left_us % 1000000);
      const int rc = freenect_process_events_timeout(ctx_, &tv);
      if (rc < 0) {
        // fakenect returns -1 at the end of its INDEX.txt; real hardware when the USB device
        // went away (LIBUSB_ERROR_NO_DEVICE, LIBUSB_ERROR_IO).
        if (under_fakenect_ && !options_.fakenect_end_is_unplug) return GrabStatus::EndOfStream;
        return GrabStatus::Disconnected;
      }
    }
  }

  void close() override {
    if (dev_) {
      if (streaming_) {
        freenect_stop_depth(dev_);
        freenect_stop_video(dev_);
      }
      freenect_close_device(dev_);
      dev_ = nullptr;
    }
    streaming_ = false;
    if (ctx_) {
      freenect_shutdown(ctx_);
      ctx_ = nullptr;
    }
    pairer_.clear();
  }

  std::string source() const override { return source_; }
  std::optional<PinholeCamera> deviceIntrinsics() const override {
    // libfreenect reports no colour intrinsics; nominal Kinect v1 values (docs/cameras.md).
    return kinectV1DefaultIntrinsics(kWidth, kHeight);
  }
  DeviceClockOptions clockOptions() const override {
    DeviceClockOptions o;
    o.ticks_per_second = kKinectTicksPerSecond;
    o.counter_bits = 32;
    return o;
  }
  RegistrationDecision registration() const override { return registration_; }
  int64_t droppedFrames() const override { return pairer_.dropped() + callback_errors_; }

 private:
  static void depthCallback(freenect_device* dev, void* data, uint32_t timestamp) {
    auto* self = static_cast<FreenectBackend*>(freenect_get_user(dev));
    if (!self || !data) return;
    self->arrival_utime_ = hostUtime();
    // Both modes deliver 640x480 uint16 (11-bit raw or mm); copy out of libfreenect's buffer.
    // Nothing may throw through libfreenect's C frames.
    try {
      self->pairer_.pushDepth(
          depthU16FromBuffer(static_cast<const uint16_t*>(data), kWidth, kHeight), timestamp);
    } catch (...) {
      ++self->callback_errors_;
    }
  }
  static void videoCallback(freenect_device* dev, void* data, uint32_t timestamp) {
    auto* self = static_cast<FreenectBackend*>(freenect_get_user(dev));
    if (!self || !data) return;
    self->arrival_utime_ = hostUtime();
    try {
      self->pairer_.pushColour(bgrFromRgb888(static_cast<const uint8_t*>(data), kWidth, kHeight),
                               timestamp);
    } catch (...) {
      ++self->callback_errors_;
    }
  }

  BackendOptions options_;
  FramePairer pairer_;
  KinectRawToMm raw_to_mm_;
  bool under_fakenect_;
  freenect_context* ctx_ = nullptr;
  freenect_device* dev_ = nullptr;
  bool streaming_ = false;
  bool depth_in_mm_ = false;  ///< FREENECT_DEPTH_REGISTERED or _MM: no (K1) conversion
  RegistrationDecision registration_;
  std::string source_ = "freenect";
  int64_t arrival_utime_ = 0;
  int64_t callback_errors_ = 0;
};

}  // namespace

std::unique_ptr<Backend> makeFreenectBackend(const BackendOptions& options) {
  return std::make_unique<FreenectBackend>(options);
}

}  // namespace pplvo::camera
