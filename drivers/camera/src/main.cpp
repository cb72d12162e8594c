// pplvo-camera: publishes rgbd_frame_t from a live RGB-D sensor (OpenNI2 or libfreenect), the
// same messages as the dataset player. Thin: the backend copies device buffers, the
// conversions live in pplvo_camera_convert, camera_node.cpp maps to messages and publishes.
#include <cstdio>
#include <memory>
#include <optional>
#include <string>

#include "backend.h"
#include "camera_node.h"
#include "pplvo/core/allocator.h"
#include "pplvo/msgs/node_runtime.h"

namespace pc = pplvo::camera;
namespace pm = pplvo::msgs;

int main(int argc, char** argv) {
  pplvo::keepFrameBuffersMapped();  // frame-sized buffers: no page faults per frame
  pc::NodeOptions options;
  std::string error;
  bool help = false;
  if (!pc::parseNodeArgs(argc, argv, &options, &error, &help)) {
    std::fprintf(stderr, "%s: %s\n%s", pc::kNodeName, error.c_str(), pc::nodeUsage().c_str());
    return pc::kExitUsage;
  }
  if (help) {
    std::fputs(pc::nodeUsage().c_str(), stdout);
    return pc::kExitOk;
  }
  pm::installShutdownHandlers();

  std::optional<pplvo::PinholeCamera> calib_camera;
  std::optional<pplvo::DepthCamera> calib_depth_camera;
  if (!options.calib.empty()) {
    const auto loaded =
        pc::loadCalibration(options.calib, options.device.width, options.device.height);
    if (!loaded.camera) {
      std::fprintf(stderr, "%s: %s\n", pc::kNodeName, loaded.error.c_str());
      return pc::kExitUsage;
    }
    calib_camera = loaded.camera;
    calib_depth_camera = loaded.depth_camera;
    // A file describing unregistered depth asks for it, unless --registration says otherwise
    // (with --registration on its depth camera is used only if the device cannot register).
    if (calib_depth_camera && !options.registration_given) options.device.registration = false;
  }

  std::unique_ptr<pc::Backend> backend = options.backend == "freenect"
                                             ? pc::makeFreenectBackend(options.device)
                                             : pc::makeOpenni2Backend(options.device);
  if (!backend->open(&error)) {
    std::fprintf(stderr, "%s: no usable %s device: %s\n", pc::kNodeName, options.backend.c_str(),
                 error.c_str());
    return pc::kExitNoDevice;
  }

  std::unique_ptr<pm::BusConnections> lcm;
  try {
    lcm = std::make_unique<pm::BusConnections>(options.lcm_url, options.routes);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: %s\n", pc::kNodeName, e.what());
    return pc::kExitRuntime;
  }

  pplvo::PinholeCamera camera;
  std::string origin;
  if (calib_camera) {
    camera = *calib_camera;
    origin = "calibration file " + options.calib;
  } else if (auto dev = backend->deviceIntrinsics()) {
    camera = *dev;
    origin =
        options.backend == "freenect" ? "nominal Kinect v1 intrinsics" : "device field of view";
  } else {
    camera = pc::kinectV1DefaultIntrinsics(options.device.width, options.device.height);
    origin = "nominal Kinect v1 intrinsics";
  }
  const pc::NodeRunResult result =
      pc::runCameraNode(options, *backend, lcm->bus(), camera, origin, calib_depth_camera);
  if (!result.error.empty()) {
    std::fprintf(stderr, "%s: %s\n", pc::kNodeName, result.error.c_str());
    return pc::kExitUsage;
  }
  return pc::kExitOk;
}
