// The run loop of pplvo-camera with a scripted backend on memq://: frames, unplug and replug
// (failed attempts, a device clock that restarts), stalls, bad frames, rate limit, max frames.
#include <gtest/gtest.h>
#include <unistd.h>

#include <deque>
#include <lcm/lcm-cpp.hpp>
#include <pplvo_msgs/node_status_t.hpp>
#include <pplvo_msgs/rgbd_frame_t.hpp>
#include <pplvo_msgs/stream_event_t.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "camera_node.h"
#include "pplvo/core/stage_timer.h"
#include "pplvo/msgs/convert.h"

namespace pc = pplvo::camera;

namespace {

enum class Step { Frame, BadFrame, Stall, Disconnect, Throw, End };

/// A backend that plays a script. Frames are 4x3 with every pixel equal to the frame number
/// (colour) and 1000 + number (depth); device ticks are microseconds from `tick0`.
class ScriptedBackend : public pc::Backend {
 public:
  std::deque<Step> steps;
  std::deque<bool> open_results;  // results of open() after the first
  double stall_s = 0.3;
  int frame_sleep_us = 2000;  // real devices pace frames: 33333 at 30 Hz
  uint64_t tick0 = 5'000'000;
  bool registers = true;  // false: depth in the depth camera's own frame
  std::optional<pplvo::PinholeCamera> depth_intrinsics;  // deviceDepthIntrinsics()
  int opens = 0;
  int closes = 0;

  bool open(std::string* error) override {
    ++opens;
    if (opens == 1) return true;
    const bool ok = open_results.empty() ? true : open_results.front();
    if (!open_results.empty()) open_results.pop_front();
    if (!ok) {
      *error = "no device (scripted)";
      return false;
    }
    tick0 = 100;  // the device clock restarted
    frame_in_session_ = 0;
    return true;
  }
  pc::GrabStatus grab(int timeout_ms, pc::CapturedFrame* out) override {
    if (steps.empty()) return pc::GrabStatus::EndOfStream;
    const Step s = steps.front();
    switch (s) {
      case Step::Frame:
      case Step::BadFrame: {
        steps.pop_front();
        const int n = next_number_++;
        out->bgr = cv::Mat(3, 4, CV_8UC3, cv::Scalar(n, n, n));
        out->depth_u16 = cv::Mat(s == Step::BadFrame ? 2 : 3, 4, CV_16UC1, cv::Scalar(1000 + n));
        out->depth_scale = 1000;
        out->device_ticks = tick0 + 33333 * static_cast<uint64_t>(frame_in_session_++);
        out->host_arrival_utime = pplvo::hostUtime();
        usleep(frame_sleep_us);
        return pc::GrabStatus::Frame;
      }
      case Step::Stall: {
        if (stall_start_ == 0) stall_start_ = pplvo::hostUtime();
        usleep(std::min(timeout_ms, 20) * 1000);
        if (pplvo::hostUtime() - stall_start_ > stall_s * 1e6) {
          steps.pop_front();
          stall_start_ = 0;
        }
        return pc::GrabStatus::Timeout;
      }
      case Step::Disconnect:
        steps.pop_front();
        return pc::GrabStatus::Disconnected;
      case Step::Throw:
        steps.pop_front();
        throw std::runtime_error("scripted read failure");
      case Step::End:
        steps.pop_front();
        return pc::GrabStatus::EndOfStream;
    }
    return pc::GrabStatus::EndOfStream;
  }
  void close() override { ++closes; }
  std::string source() const override { return "scripted"; }
  std::optional<pplvo::PinholeCamera> deviceIntrinsics() const override { return std::nullopt; }
  std::optional<pplvo::PinholeCamera> deviceDepthIntrinsics() const override {
    return depth_intrinsics;
  }
  pc::DeviceClockOptions clockOptions() const override { return {}; }
  pc::RegistrationDecision registration() const override {
    pc::RegistrationDecision d;
    d.use_hardware = d.depth_in_colour_frame = registers;
    return d;
  }

 private:
  int next_number_ = 0;
  int frame_in_session_ = 0;
  int64_t stall_start_ = 0;
};

struct Collector {
  std::vector<pplvo_msgs::rgbd_frame_t> frames;
  std::vector<pplvo_msgs::stream_event_t> events;
  std::vector<pplvo_msgs::node_status_t> status;
  void onFrame(const lcm::ReceiveBuffer*, const std::string&, const pplvo_msgs::rgbd_frame_t* m) {
    frames.push_back(*m);
  }
  void onEvent(const lcm::ReceiveBuffer*, const std::string&, const pplvo_msgs::stream_event_t* m) {
    events.push_back(*m);
  }
  void onStatus(const lcm::ReceiveBuffer*, const std::string&, const pplvo_msgs::node_status_t* m) {
    status.push_back(*m);
  }
};

struct ScriptRun {
  pc::NodeRunResult result;
  Collector got;
};

ScriptRun runScript(ScriptedBackend& backend, pc::NodeOptions options,
                    const std::optional<pplvo::DepthCamera>& calib_depth = std::nullopt) {
  lcm::LCM lcm("memq://");
  ScriptRun run;
  lcm.subscribe(options.channel, &Collector::onFrame, &run.got);
  lcm.subscribe(options.stream_channel, &Collector::onEvent, &run.got);
  lcm.subscribe(options.status_channel, &Collector::onStatus, &run.got);
  std::string error;
  EXPECT_TRUE(backend.open(&error));
  pplvo::PinholeCamera camera;
  camera.width = 4;
  camera.height = 3;
  camera.fx = camera.fy = 3;
  camera.cx = 1.5;
  camera.cy = 1;
  run.result = pc::runCameraNode(options, backend, lcm, camera, "test", calib_depth);
  while (lcm.handleTimeout(0) > 0) {
  }
  return run;
}

pc::NodeOptions fastOptions() {
  pc::NodeOptions o;
  o.reconnect_period_s = 0.01;
  o.lost_after_s = 0.2;
  o.grab_timeout_ms = 20;
  return o;
}

}  // namespace

TEST(CameraNode, ReconnectsAfterUnplugAndKeepsCounting) {
  ScriptedBackend b;
  for (int i = 0; i < 5; ++i) b.steps.push_back(Step::Frame);
  b.steps.push_back(Step::Disconnect);
  b.open_results = {false, false, true};  // two failed attempts, then the device is back
  for (int i = 0; i < 5; ++i) b.steps.push_back(Step::Frame);
  b.steps.push_back(Step::End);
  const ScriptRun r = runScript(b, fastOptions());

  EXPECT_EQ(r.result.published, 10);
  EXPECT_EQ(r.result.outages, 1);
  EXPECT_EQ(r.result.reconnect_attempts, 3);
  EXPECT_TRUE(r.result.end_of_stream);
  ASSERT_EQ(r.got.frames.size(), 10u);
  for (size_t k = 0; k < r.got.frames.size(); ++k) {
    const auto& m = r.got.frames[k];
    EXPECT_EQ(m.seq, static_cast<int64_t>(k));  // seq continues across the outage
    EXPECT_EQ(m.source, "scripted");
    EXPECT_EQ(m.depth_scale, 1000.0);
    const cv::Mat bgr = pplvo::msgs::decodeImage(m.rgb);
    const cv::Mat depth = pplvo::msgs::decodeImage(m.depth);
    EXPECT_EQ(bgr.at<cv::Vec3b>(2, 3)[0], k);
    EXPECT_EQ(depth.at<uint16_t>(2, 3), 1000 + k);
    // The registered default: as before this option existed.
    EXPECT_EQ(m.depth_frame, pplvo_msgs::rgbd_frame_t::DEPTH_REGISTERED);
    EXPECT_FALSE(pplvo::msgs::fromMsg(m).depth_camera);
    if (k > 0) {
      EXPECT_GT(m.utime, r.got.frames[k - 1].utime);  // even though the device clock restarted
    }
  }
  ASSERT_EQ(r.got.events.size(), 3u);
  EXPECT_EQ(r.got.events[0].event, pplvo_msgs::stream_event_t::EVENT_START);
  EXPECT_EQ(r.got.events[1].event, pplvo_msgs::stream_event_t::EVENT_START);  // device back
  EXPECT_EQ(r.got.events[2].event, pplvo_msgs::stream_event_t::EVENT_END);
  EXPECT_EQ(r.got.events[2].frames_published, 10);
  ASSERT_FALSE(r.got.status.empty());
  EXPECT_EQ(r.got.status.back().frames_out, 10);
  EXPECT_NE(r.got.status.back().last_warning.find("device back after 3"), std::string::npos)
      << r.got.status.back().last_warning;
  EXPECT_EQ(b.closes, 2);  // at the loss and at the end
}

TEST(CameraNode, StalledDeviceCountsAsLostAfterTheTimeout) {
  ScriptedBackend b;
  b.stall_s = 0.5;  // longer than lost_after (0.2 s)
  b.steps = {Step::Frame, Step::Frame, Step::Stall, Step::Frame, Step::End};
  const auto t0 = pplvo::hostUtime();
  const ScriptRun r = runScript(b, fastOptions());
  EXPECT_EQ(r.result.published, 3);
  EXPECT_EQ(r.result.outages, 1);  // one outage, however many attempts it took
  EXPECT_GE(r.result.reconnect_attempts, 1);
  EXPECT_LT(pplvo::hostUtime() - t0, 5'000'000);
}

TEST(CameraNode, ShortStallIsNotAnOutage) {
  ScriptedBackend b;
  b.stall_s = 0.05;  // shorter than lost_after
  b.steps = {Step::Frame, Step::Stall, Step::Frame, Step::End};
  const ScriptRun r = runScript(b, fastOptions());
  EXPECT_EQ(r.result.published, 2);
  EXPECT_EQ(r.result.outages, 0);
}

TEST(CameraNode, BadFramesAndReadErrorsAreCountedNotFatal) {
  ScriptedBackend b;
  b.steps = {Step::Frame, Step::BadFrame, Step::Frame, Step::Throw, Step::Frame, Step::End};
  const ScriptRun r = runScript(b, fastOptions());
  EXPECT_EQ(r.result.published, 3);
  EXPECT_EQ(r.result.outages, 1);  // the exception is handled as a lost device
  ASSERT_FALSE(r.got.status.empty());
  EXPECT_EQ(r.got.status.back().frames_skipped, 1);  // the size mismatch
  EXPECT_EQ(r.got.status.back().frames_in, 4);
}

TEST(CameraNode, RateLimitAndMaxFrames) {
  ScriptedBackend b;
  b.frame_sleep_us = 33333;  // paced like a device: mapped times follow device time
  for (int i = 0; i < 30; ++i) b.steps.push_back(Step::Frame);  // 1 s at 30 Hz
  b.steps.push_back(Step::End);
  pc::NodeOptions o = fastOptions();
  o.max_fps = 10;
  o.rgb_encoding = pc::RgbEncoding::Png;
  o.depth_encoding = pc::DepthEncoding::Zlib;
  const ScriptRun r = runScript(b, o);
  EXPECT_GE(r.result.published, 9);
  EXPECT_LE(r.result.published, 11);
  ASSERT_FALSE(r.got.frames.empty());
  EXPECT_EQ(r.got.frames[0].rgb.encoding, pplvo_msgs::image_t::ENCODING_PNG);
  EXPECT_EQ(r.got.frames[0].depth.encoding, pplvo_msgs::image_t::ENCODING_ZLIB_U16);

  ScriptedBackend b2;
  for (int i = 0; i < 30; ++i) b2.steps.push_back(Step::Frame);
  pc::NodeOptions o2 = fastOptions();
  o2.max_frames = 7;
  const ScriptRun r2 = runScript(b2, o2);
  EXPECT_EQ(r2.result.published, 7);
  EXPECT_FALSE(r2.result.end_of_stream);
  ASSERT_EQ(r2.got.events.size(), 2u);
  EXPECT_EQ(r2.got.events.back().event, pplvo_msgs::stream_event_t::EVENT_END);
}

TEST(CameraNode, ParsesOptions) {
  pc::NodeOptions o;
  std::string err;
  bool help = false;
  const char* ok[] = {"pplvo-camera",   "--backend", "freenect",       "--max-fps=15",
                      "--registration", "off",       "--rgb-encoding", "jpeg"};
  ASSERT_TRUE(pc::parseNodeArgs(8, ok, &o, &err, &help)) << err;
  EXPECT_EQ(o.backend, "freenect");
  EXPECT_DOUBLE_EQ(o.max_fps, 15);
  EXPECT_FALSE(o.device.registration);
  EXPECT_EQ(o.rgb_encoding, pc::RgbEncoding::Jpeg);
  const char* bad[] = {"pplvo-camera", "--registration", "maybe"};
  EXPECT_FALSE(pc::parseNodeArgs(3, bad, &o, &err, &help));
  EXPECT_NE(err.find("on or off"), std::string::npos);
  const char* missing[] = {"pplvo-camera", "--width"};
  EXPECT_FALSE(pc::parseNodeArgs(2, missing, &o, &err, &help));
  const char* h[] = {"pplvo-camera", "--help"};
  EXPECT_TRUE(pc::parseNodeArgs(2, h, &o, &err, &help));
  EXPECT_TRUE(help);
}

// ------------------------------------------------------------------ unregistered depth

namespace {

/// A depth camera unlike the colour camera (4x3, fx 3): other intrinsics, distortion, a
/// rotation of 3 deg about y and 2.5 cm of baseline.
pplvo::DepthCamera calibratedDepthCamera() {
  pplvo::DepthCamera d;
  d.camera.width = 4;
  d.camera.height = 3;
  d.camera.fx = 2.5;
  d.camera.fy = 2.6;
  d.camera.cx = 1.4;
  d.camera.cy = 1.1;
  d.camera.distortion[0] = 0.05;
  d.T_c_d.linear() =
      Eigen::AngleAxisd(3.0 * M_PI / 180.0, Eigen::Vector3d::UnitY()).toRotationMatrix();
  d.T_c_d.translation() = Eigen::Vector3d(0.025, -0.001, 0.002);
  return d;
}

void expectSameDepthCamera(const pplvo::DepthCamera& got, const pplvo::DepthCamera& want) {
  EXPECT_EQ(got.camera.width, want.camera.width);
  EXPECT_EQ(got.camera.height, want.camera.height);
  EXPECT_DOUBLE_EQ(got.camera.fx, want.camera.fx);
  EXPECT_DOUBLE_EQ(got.camera.fy, want.camera.fy);
  EXPECT_DOUBLE_EQ(got.camera.cx, want.camera.cx);
  EXPECT_DOUBLE_EQ(got.camera.cy, want.camera.cy);
  for (int i = 0; i < 5; ++i) EXPECT_DOUBLE_EQ(got.camera.distortion[i], want.camera.distortion[i]);
  EXPECT_LT((got.T_c_d.matrix() - want.T_c_d.matrix()).cwiseAbs().maxCoeff(), 1e-15);
}

}  // namespace

TEST(CameraNode, UnregisteredDepthCarriesTheCalibratedDepthCamera) {
  ScriptedBackend b;
  b.registers = false;
  b.depth_intrinsics = pplvo::PinholeCamera{};  // ignored: the calibration wins
  b.steps = {Step::Frame, Step::Frame, Step::Frame, Step::End};
  const pplvo::DepthCamera want = calibratedDepthCamera();
  const ScriptRun r = runScript(b, fastOptions(), want);
  EXPECT_TRUE(r.result.error.empty()) << r.result.error;
  ASSERT_TRUE(r.result.depth_camera);
  ASSERT_EQ(r.got.frames.size(), 3u);
  for (const auto& m : r.got.frames) {
    EXPECT_EQ(m.depth_frame, pplvo_msgs::rgbd_frame_t::DEPTH_OWN_CAMERA);
    EXPECT_EQ(m.depth_camera.width, 4);
    EXPECT_EQ(m.depth_camera.height, 3);
    EXPECT_DOUBLE_EQ(m.depth_camera.fx, 2.5);
    EXPECT_DOUBLE_EQ(m.depth_camera.fy, 2.6);
    EXPECT_DOUBLE_EQ(m.depth_camera.cx, 1.4);
    EXPECT_DOUBLE_EQ(m.depth_camera.cy, 1.1);
    EXPECT_DOUBLE_EQ(m.camera.fx, 3.0);  // the colour camera stays the colour camera
    const Eigen::Matrix3d R = want.T_c_d.linear();
    for (int i = 0; i < 9; ++i) EXPECT_DOUBLE_EQ(m.R_c_d[i], R(i / 3, i % 3)) << i;
    EXPECT_DOUBLE_EQ(m.t_c_d_m[0], 0.025);
    EXPECT_DOUBLE_EQ(m.t_c_d_m[1], -0.001);
    EXPECT_DOUBLE_EQ(m.t_c_d_m[2], 0.002);
    // What the depth filter decodes (pplvo-depth-filter: fromMsg(msg, 65535, kDepth)).
    const pplvo::RgbdFrame depth_only =
        pplvo::msgs::fromMsg(m, 65535, pplvo::msgs::FrameImages::kDepth);
    ASSERT_TRUE(depth_only.depth_camera);
    expectSameDepthCamera(*depth_only.depth_camera, want);
    EXPECT_EQ(depth_only.depth_m.size(), cv::Size(4, 3));
    EXPECT_FLOAT_EQ(depth_only.depth_m.at<float>(1, 1), (1000.0f + m.seq) / 1000.0f);
    const pplvo::RgbdFrame both = pplvo::msgs::fromMsg(m);
    ASSERT_TRUE(both.depth_camera);
    expectSameDepthCamera(*both.depth_camera, want);
  }
}

TEST(CameraNode, UnregisteredDepthFallsBackToTheDevicesDepthIntrinsics) {
  ScriptedBackend b;
  b.registers = false;
  pplvo::PinholeCamera fov = *pc::intrinsicsFromFov(4, 3, 1.0, 0.8);
  b.depth_intrinsics = fov;
  b.steps = {Step::Frame, Step::Frame, Step::End};
  const ScriptRun r = runScript(b, fastOptions());
  EXPECT_TRUE(r.result.error.empty()) << r.result.error;
  ASSERT_EQ(r.got.frames.size(), 2u);
  const pplvo::RgbdFrame f = pplvo::msgs::fromMsg(r.got.frames[0], 65535,
                                                  pplvo::msgs::FrameImages::kDepth);
  ASSERT_TRUE(f.depth_camera);
  expectSameDepthCamera(*f.depth_camera, pplvo::DepthCamera{fov, pplvo::Pose3::Identity()});
  // The assumed extrinsic is reported.
  ASSERT_FALSE(r.got.status.empty());
  EXPECT_NE(r.got.status.back().last_warning.find("identity"), std::string::npos)
      << r.got.status.back().last_warning;
}

TEST(CameraNode, RegisteringDeviceIgnoresTheCalibratedDepthCamera) {
  // --registration on with a file describing a depth camera: the device registers, so frames
  // stay DEPTH_REGISTERED (the file's depth camera is only the fallback).
  ScriptedBackend b;
  b.steps = {Step::Frame, Step::End};
  const ScriptRun r = runScript(b, fastOptions(), calibratedDepthCamera());
  ASSERT_EQ(r.got.frames.size(), 1u);
  EXPECT_EQ(r.got.frames[0].depth_frame, pplvo_msgs::rgbd_frame_t::DEPTH_REGISTERED);
  EXPECT_FALSE(r.result.depth_camera);
}

TEST(CameraNode, UnregisteredDepthWithoutIntrinsicsIsRefusedClearly) {
  ScriptedBackend b;
  b.registers = false;  // and neither a calibration nor device depth intrinsics
  b.steps = {Step::Frame, Step::End};
  const ScriptRun r = runScript(b, fastOptions());
  EXPECT_NE(r.result.error.find("depth camera's intrinsics"), std::string::npos)
      << r.result.error;
  EXPECT_TRUE(r.got.frames.empty());
  EXPECT_TRUE(r.got.events.empty());
  EXPECT_EQ(r.result.published, 0);

  // A calibrated depth camera of another size than the depth images is refused too.
  ScriptedBackend b2;
  b2.registers = false;
  b2.steps = {Step::Frame, Step::End};
  pplvo::DepthCamera wrong = calibratedDepthCamera();
  wrong.camera.width = 8;
  wrong.camera.height = 6;
  const ScriptRun r2 = runScript(b2, fastOptions(), wrong);
  EXPECT_NE(r2.result.error.find("8x6"), std::string::npos) << r2.result.error;
  EXPECT_TRUE(r2.got.frames.empty());
}

TEST(CameraNode, UnregisteredDepthOfTheWrongSizeIsCountedNotFatal) {
  ScriptedBackend b;
  b.registers = false;
  b.steps = {Step::Frame, Step::BadFrame, Step::Frame, Step::End};
  const ScriptRun r = runScript(b, fastOptions(), calibratedDepthCamera());
  EXPECT_EQ(r.result.published, 2);
  ASSERT_FALSE(r.got.status.empty());
  EXPECT_EQ(r.got.status.back().frames_skipped, 1);
}

TEST(CameraNode, RegistrationFlagIsRemembered) {
  pc::NodeOptions o;
  std::string err;
  bool help = false;
  const char* none[] = {"pplvo-camera", "--calib", "cam.yaml"};
  ASSERT_TRUE(pc::parseNodeArgs(3, none, &o, &err, &help)) << err;
  EXPECT_FALSE(o.registration_given);  // a file with depth_registered: false may switch it off
  EXPECT_TRUE(o.device.registration);
  const char* on[] = {"pplvo-camera", "--registration", "on"};
  pc::NodeOptions o2;
  ASSERT_TRUE(pc::parseNodeArgs(3, on, &o2, &err, &help)) << err;
  EXPECT_TRUE(o2.registration_given);
  EXPECT_TRUE(o2.device.registration);
}
