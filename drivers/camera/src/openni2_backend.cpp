// OpenNI2 backend (PrimeSense, Asus Xtion, Structure Sensor, Kinect v1 through the freenect
// OpenNI2 driver). Kept thin: it selects modes, switches registration and frame sync on, waits
// for frames and hands the buffers to the pure conversions. Debian's Dummy driver crashes once
// a stream starts, so this file is exercised only with real hardware (and with no device, by
// test_camera_no_device).
#include <OpenNI.h>

#include <cstdlib>

#include "backend.h"
#include "pplvo/core/stage_timer.h"

namespace pplvo::camera {
namespace {

std::vector<ModeCandidate> candidatesOf(const openni::SensorInfo* info) {
  std::vector<ModeCandidate> out;
  if (!info) return out;
  const auto& modes = info->getSupportedVideoModes();
  for (int i = 0; i < modes.getSize(); ++i) {
    out.push_back({modes[i].getResolutionX(), modes[i].getResolutionY(), modes[i].getFps(),
                   static_cast<int>(modes[i].getPixelFormat())});
  }
  return out;
}

class Openni2Backend final : public Backend {
 public:
  explicit Openni2Backend(const BackendOptions& options)
      // Frame sync keeps depth and colour within a few ms; accept a third of a period.
      : options_(options), pairer_(static_cast<uint64_t>(1e6 / (3.0 * options.fps)), 64) {}
  ~Openni2Backend() override {
    close();
    if (initialised_) openni::OpenNI::shutdown();
  }

  bool open(std::string* error) override {
    close();
    if (!initialised_) {
      if (openni::OpenNI::initialize() != openni::STATUS_OK) {
        *error =
            std::string("OpenNI2 initialisation failed: ") + openni::OpenNI::getExtendedError();
        return false;
      }
      initialised_ = true;
    }
    std::string uri;
    openni::Array<openni::DeviceInfo> devices;
    openni::OpenNI::enumerateDevices(&devices);
    if (options_.device.empty() || isIndex(options_.device)) {
      const int index = options_.device.empty() ? 0 : std::atoi(options_.device.c_str());
      if (devices.getSize() <= index) {
        *error = devices.getSize() == 0
                     ? "no OpenNI2 device found (plugged in? drivers in "
                       "/usr/lib/x86_64-linux-gnu/OpenNI2/Drivers; USB permissions)"
                     : "OpenNI2 device index " + std::to_string(index) + " not present (" +
                           std::to_string(devices.getSize()) + " found)";
        return false;
      }
      uri = devices[index].getUri();
    } else {
      uri = options_.device;  // a URI, or an .oni recording handled by the OniFile driver
    }
    if (device_.open(uri.c_str()) != openni::STATUS_OK) {
      *error = "cannot open OpenNI2 device '" + uri + "': " + openni::OpenNI::getExtendedError();
      return false;
    }
    source_ = "openni2:" + uri;
    if (!configureStream(openni::SENSOR_DEPTH, &depth_,
                         {openni::PIXEL_FORMAT_DEPTH_1_MM, openni::PIXEL_FORMAT_DEPTH_100_UM},
                         error) ||
        !configureStream(openni::SENSOR_COLOR, &colour_, {openni::PIXEL_FORMAT_RGB888}, error)) {
      close();
      return false;
    }
    const bool hw =
        device_.isImageRegistrationModeSupported(openni::IMAGE_REGISTRATION_DEPTH_TO_COLOR);
    registration_ = decideRegistration(options_.registration, hw);
    device_.setImageRegistrationMode(registration_.use_hardware
                                         ? openni::IMAGE_REGISTRATION_DEPTH_TO_COLOR
                                         : openni::IMAGE_REGISTRATION_OFF);
    if (device_.setDepthColorSyncEnabled(true) != openni::STATUS_OK) {
      sync_warning_ = "depth/colour frame sync not supported: pairing by timestamp only";
    }
    depth_.setMirroringEnabled(false);
    colour_.setMirroringEnabled(false);
    if (depth_.start() != openni::STATUS_OK || colour_.start() != openni::STATUS_OK) {
      *error = std::string("cannot start OpenNI2 streams: ") + openni::OpenNI::getExtendedError();
      close();
      return false;
    }
    intrinsics_ =
        intrinsicsFromFov(options_.width, options_.height, colour_.getHorizontalFieldOfView(),
                          colour_.getVerticalFieldOfView());
    // Depth stream's own intrinsics: used when depth is not registered (docs/cameras.md).
    depth_intrinsics_ =
        intrinsicsFromFov(options_.width, options_.height, depth_.getHorizontalFieldOfView(),
                          depth_.getVerticalFieldOfView());
    pairer_.clear();
    return true;
  }

  GrabStatus grab(int timeout_ms, CapturedFrame* out) override {
    if (!device_.isValid()) return GrabStatus::Disconnected;
    const int64_t deadline = hostUtime() + int64_t{timeout_ms} * 1000;
    openni::VideoStream* streams[] = {&depth_, &colour_};
    while (true) {
      if (auto pair = pairer_.pop()) {
        out->bgr = pair->bgr;
        out->depth_u16 = pair->depth;
        out->depth_scale = depth_scale_;
        out->device_ticks = pair->device_ticks;
        out->depth_minus_colour_ticks = pair->depth_minus_colour_ticks;
        out->host_arrival_utime = arrival_utime_;
        return GrabStatus::Frame;
      }
      const int64_t left_ms = (deadline - hostUtime()) / 1000;
      if (left_ms <= 0) return GrabStatus::Timeout;
      int ready = -1;
      const openni::Status st =
          openni::OpenNI::waitForAnyStream(streams, 2, &ready, static_cast<int>(left_ms));
      if (st == openni::STATUS_TIME_OUT) return GrabStatus::Timeout;
      if (st != openni::STATUS_OK) return GrabStatus::Disconnected;
      openni::VideoFrameRef frame;
      if (streams[ready]->readFrame(&frame) != openni::STATUS_OK || !frame.isValid()) {
        return GrabStatus::Disconnected;
      }
      arrival_utime_ = hostUtime();
      if (ready == 0) {
        depth_scale_ = frame.getVideoMode().getPixelFormat() == openni::PIXEL_FORMAT_DEPTH_100_UM
                           ? depthScaleFor(DepthUnit::HundredMicrometre)
                           : depthScaleFor(DepthUnit::Millimetre);
        pairer_.pushDepth(
            depthU16FromBuffer(static_cast<const uint16_t*>(frame.getData()), frame.getWidth(),
                               frame.getHeight(), frame.getStrideInBytes()),
            frame.getTimestamp());
      } else {
        pairer_.pushColour(
            bgrFromRgb888(static_cast<const uint8_t*>(frame.getData()), frame.getWidth(),
                          frame.getHeight(), frame.getStrideInBytes()),
            frame.getTimestamp());
      }
    }
  }

  void close() override {
    if (depth_.isValid()) {
      depth_.stop();
      depth_.destroy();
    }
    if (colour_.isValid()) {
      colour_.stop();
      colour_.destroy();
    }
    if (device_.isValid()) device_.close();
    pairer_.clear();
  }

  std::string source() const override { return source_; }
  std::optional<PinholeCamera> deviceIntrinsics() const override { return intrinsics_; }
  std::optional<PinholeCamera> deviceDepthIntrinsics() const override {
    return depth_intrinsics_;
  }
  DeviceClockOptions clockOptions() const override { return DeviceClockOptions{}; }  // us, 64 bit
  RegistrationDecision registration() const override {
    RegistrationDecision d = registration_;
    if (!sync_warning_.empty()) {
      d.warning += (d.warning.empty() ? "" : "; ") + sync_warning_;
    }
    return d;
  }
  int64_t droppedFrames() const override { return pairer_.dropped(); }

 private:
  static bool isIndex(const std::string& s) {
    if (s.empty() || s.size() > 3) return false;
    for (char c : s) {
      if (c < '0' || c > '9') return false;
    }
    return true;
  }

  bool configureStream(openni::SensorType type, openni::VideoStream* stream,
                       const std::vector<int>& formats, std::string* error) {
    const char* name = type == openni::SENSOR_DEPTH ? "depth" : "colour";
    if (!device_.hasSensor(type)) {
      *error = std::string("device has no ") + name + " sensor";
      return false;
    }
    if (stream->create(device_, type) != openni::STATUS_OK) {
      *error =
          std::string("cannot create ") + name + " stream: " + openni::OpenNI::getExtendedError();
      return false;
    }
    const auto candidates = candidatesOf(device_.getSensorInfo(type));
    const auto chosen =
        chooseMode(candidates, options_.width, options_.height, options_.fps, formats);
    if (!chosen) {
      *error = std::string("no ") + name + " mode " + std::to_string(options_.width) + "x" +
               std::to_string(options_.height) + "@" + std::to_string(options_.fps) +
               "; the device offers: " + describeModes(candidates);
      return false;
    }
    const auto& modes = device_.getSensorInfo(type)->getSupportedVideoModes();
    if (stream->setVideoMode(modes[static_cast<int>(*chosen)]) != openni::STATUS_OK) {
      *error = std::string("cannot set ") + name + " mode: " + openni::OpenNI::getExtendedError();
      return false;
    }
    return true;
  }

  BackendOptions options_;
  FramePairer pairer_;
  bool initialised_ = false;
  openni::Device device_;
  openni::VideoStream depth_, colour_;
  RegistrationDecision registration_;
  std::string sync_warning_;
  std::string source_ = "openni2";
  std::optional<PinholeCamera> intrinsics_, depth_intrinsics_;
  double depth_scale_ = 1000.0;
  int64_t arrival_utime_ = 0;
};

}  // namespace

std::unique_ptr<Backend> makeOpenni2Backend(const BackendOptions& options) {
  return std::make_unique<Openni2Backend>(options);
}

}  // namespace pplvo::camera
