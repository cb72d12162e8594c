// Unit tests of the pure camera conversions (no device, no LCM).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <random>

#include "pplvo/camera/convert.h"
#include "pplvo/core/rgbd_frame.h"

namespace pc = pplvo::camera;

namespace {
std::string sharedData() {
  const char* env = std::getenv("PPLVO_SHARED_DATA");
  return env ? env : "../shared/data";
}
std::string tempPath(const std::string& name) {
  return "/tmp/pplvo_camera_test_" + std::to_string(::getpid()) + "_" + name;
}
}  // namespace

// ------------------------------------------------------------------ Kinect disparity model

TEST(KinectDisparity, KnownValuesOfTheModel) {
  const pc::KinectDisparityModel m;
  // raw 0 -> 1/b; the model is monotonic increasing in raw.
  EXPECT_NEAR(m.metresFromRaw(0), 1.0 / 3.3309495161, 1e-12);
  EXPECT_NEAR(m.metresFromRaw(800), 1.0 / (3.3309495161 - 800 * 0.0030711016), 1e-12);
  for (int r = 1; r <= m.max_valid_raw; ++r) EXPECT_GT(m.metresFromRaw(r), m.metresFromRaw(r - 1));
  EXPECT_EQ(m.metresFromRaw(2047), 0.0);
  EXPECT_EQ(m.metresFromRaw(m.max_valid_raw + 1), 0.0);
  EXPECT_EQ(m.metresFromRaw(-1), 0.0);
}

TEST(KinectDisparity, RoundTripWithinTheQuantisationBound) {
  const pc::KinectDisparityModel m;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> z_dist(0.31, 9.0);
  for (int i = 0; i < 20000; ++i) {
    const double z = z_dist(rng);
    const int raw = m.rawFromMetres(z);
    ASSERT_NE(raw, m.no_reading_raw) << z;
    const double back = m.metresFromRaw(raw);
    EXPECT_LE(std::abs(back - z), m.roundTripBoundM(z, back) * (1 + 1e-9)) << z;
    // And the bound is about half a step, (K2): 1.5e-3 z^2.
    EXPECT_LE(m.roundTripBoundM(z, back),
              0.5 * m.stepAtDepthM(z) * 1.02);  // z_back/z <= 1.014 at 9 m
  }
  // Exact raw values survive the round trip.
  for (int raw = 0; raw <= m.max_valid_raw; raw += 7) {
    EXPECT_EQ(m.rawFromMetres(m.metresFromRaw(raw)), raw);
  }
}

TEST(KinectDisparity, UnrepresentableDepthsAreNoReading) {
  const pc::KinectDisparityModel m;
  EXPECT_EQ(m.rawFromMetres(0.0), 2047);
  EXPECT_EQ(m.rawFromMetres(-1.0), 2047);
  EXPECT_EQ(m.rawFromMetres(std::nan("")), 2047);
  EXPECT_EQ(m.rawFromMetres(0.2), 2047);   // closer than 1/b
  EXPECT_EQ(m.rawFromMetres(50.0), 2047);  // beyond max_valid_raw
  cv::Mat d(2, 3, CV_32FC1);
  d.at<float>(0, 0) = 0.0f;
  d.at<float>(0, 1) = 1.0f;
  d.at<float>(0, 2) = std::nanf("");
  d.at<float>(1, 0) = 0.1f;
  d.at<float>(1, 1) = 3.0f;
  d.at<float>(1, 2) = 40.0f;
  int bad = -1;
  const cv::Mat raw = pc::kinectRawFromMetres(d, m, &bad);
  EXPECT_EQ(bad, 3);  // NaN, too close, too far (missing 0 is not counted)
  EXPECT_EQ(raw.at<uint16_t>(0, 0), 2047);
  EXPECT_EQ(raw.at<uint16_t>(0, 1), m.rawFromMetres(1.0));
  EXPECT_EQ(raw.at<uint16_t>(0, 2), 2047);
  EXPECT_EQ(raw.at<uint16_t>(1, 2), 2047);
}

TEST(KinectDisparity, RawToMillimetreTable) {
  const pc::KinectRawToMm conv;
  cv::Mat raw = (cv::Mat_<uint16_t>(1, 5) << 0, 500, 1000, 2047, 4000);
  const cv::Mat mm = conv.convert(raw);
  ASSERT_EQ(mm.type(), CV_16UC1);
  EXPECT_EQ(mm.at<uint16_t>(0, 0), std::lround(conv.model().metresFromRaw(0) * 1000));
  EXPECT_EQ(mm.at<uint16_t>(0, 1), std::lround(conv.model().metresFromRaw(500) * 1000));
  EXPECT_EQ(mm.at<uint16_t>(0, 2), std::lround(conv.model().metresFromRaw(1000) * 1000));
  EXPECT_EQ(mm.at<uint16_t>(0, 3), 0);  // no reading
  EXPECT_EQ(mm.at<uint16_t>(0, 4), 0);  // garbage above 11 bits
  EXPECT_THROW(conv.convert(cv::Mat(2, 2, CV_32FC1)), std::invalid_argument);
}

// ------------------------------------------------------------------ buffers

TEST(Buffers, Rgb888ToBgrWithStride) {
  const int w = 3, h = 2, stride = 12;  // 9 bytes of pixels + 3 padding per row
  std::vector<uint8_t> buf(stride * h, 0xEE);
  for (int r = 0; r < h; ++r)
    for (int c = 0; c < w; ++c)
      for (int k = 0; k < 3; ++k)
        buf[r * stride + 3 * c + k] = static_cast<uint8_t>(10 * r + 3 * c + k);
  const cv::Mat bgr = pc::bgrFromRgb888(buf.data(), w, h, stride);
  ASSERT_EQ(bgr.type(), CV_8UC3);
  for (int r = 0; r < h; ++r)
    for (int c = 0; c < w; ++c) {
      const auto px = bgr.at<cv::Vec3b>(r, c);
      EXPECT_EQ(px[0], 10 * r + 3 * c + 2);  // B from the third byte
      EXPECT_EQ(px[1], 10 * r + 3 * c + 1);
      EXPECT_EQ(px[2], 10 * r + 3 * c + 0);  // R from the first byte
    }
  EXPECT_THROW(pc::bgrFromRgb888(buf.data(), w, h, 8), std::invalid_argument);
  EXPECT_THROW(pc::bgrFromRgb888(nullptr, w, h), std::invalid_argument);
}

TEST(Buffers, DepthWithStrideAndUnits) {
  const int w = 2, h = 2;
  std::vector<uint16_t> buf = {1, 2, 99, 3, 4, 99};  // stride 3 pixels = 6 bytes
  const cv::Mat d = pc::depthU16FromBuffer(buf.data(), w, h, 6);
  EXPECT_EQ(d.at<uint16_t>(0, 0), 1);
  EXPECT_EQ(d.at<uint16_t>(0, 1), 2);
  EXPECT_EQ(d.at<uint16_t>(1, 0), 3);
  EXPECT_EQ(d.at<uint16_t>(1, 1), 4);
  EXPECT_EQ(pc::depthScaleFor(pc::DepthUnit::Millimetre), 1000.0);
  EXPECT_EQ(pc::depthScaleFor(pc::DepthUnit::HundredMicrometre), 10000.0);
  // OpenNI depth in mm read with scale 1000 gives metres.
  const cv::Mat m = pplvo::depthUnitsToMetres(d, pc::depthScaleFor(pc::DepthUnit::Millimetre));
  EXPECT_FLOAT_EQ(m.at<float>(1, 1), 0.004f);
}

TEST(Intrinsics, FromFieldOfView) {
  // Xtion / PrimeSense colour: 58 x 45 degrees at 640x480 -> fx ~ 578, fy ~ 579.
  const double h = 58.0 * M_PI / 180, v = 45.0 * M_PI / 180;
  const auto cam = pc::intrinsicsFromFov(640, 480, h, v);
  ASSERT_TRUE(cam);
  EXPECT_NEAR(cam->fx, 320.0 / std::tan(h / 2), 1e-9);
  EXPECT_NEAR(cam->fy, 240.0 / std::tan(v / 2), 1e-9);
  EXPECT_NEAR(cam->fx, 577.3, 0.5);
  EXPECT_DOUBLE_EQ(cam->cx, 319.5);
  EXPECT_DOUBLE_EQ(cam->cy, 239.5);
  // A pixel at the image edge sees a ray at half the field of view.
  EXPECT_NEAR(std::atan((639.5 - cam->cx) / cam->fx), h / 2, 1e-9);
  EXPECT_FALSE(pc::intrinsicsFromFov(640, 480, 0.0, v));
  EXPECT_FALSE(pc::intrinsicsFromFov(640, 480, M_PI, v));
  EXPECT_FALSE(pc::intrinsicsFromFov(640, 480, std::nan(""), v));
  EXPECT_FALSE(pc::intrinsicsFromFov(0, 480, h, v));
  const auto k = pc::kinectV1DefaultIntrinsics(320, 240);
  EXPECT_EQ(k.width, 320);
  EXPECT_NEAR(k.fx, 262.5, 1e-9);
}

// ------------------------------------------------------------------ calibration

TEST(Calibration, ReadsTheDatasetCalibParams) {
  const auto tum = pc::loadCalibration(
      sharedData() + "/tum_fr3_sitting_static_short/calib_params.xml", 640, 480);
  ASSERT_TRUE(tum.camera) << tum.error;
  EXPECT_DOUBLE_EQ(tum.camera->fx, 535.4);
  EXPECT_DOUBLE_EQ(tum.camera->fy, 539.2);
  EXPECT_DOUBLE_EQ(tum.camera->cx, 320.1);
  EXPECT_DOUBLE_EQ(tum.camera->cy, 247.6);
  const auto icl =
      pc::loadCalibration(sharedData() + "/icl_living_room_kt0_short/calib_params.xml", 640, 480);
  ASSERT_TRUE(icl.camera) << icl.error;
  EXPECT_DOUBLE_EQ(icl.camera->fy, -480.0);  // signed fy kept
}

TEST(Calibration, ReadsOpenCvYamlAndScales) {
  // calib_params layout written as OpenCV FileStorage YAML, calibrated at 1280x960.
  const std::string path = tempPath("calib.yaml");
  {
    std::ofstream f(path);
    f << "%YAML:1.0\n---\nwidth: 1280\nheight: 960\n"
         "RGB_intrinsic_params: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
         "   data: [ 1050., 0., 639.5, 0., 1052., 479.5, 0., 0., 1. ]\n"
         "RGB_distortion_coefficients: !!opencv-matrix\n   rows: 1\n   cols: 5\n   dt: d\n"
         "   data: [ 0.1, -0.2, 0.001, 0.002, 0.05 ]\n";
  }
  const auto c = pc::loadCalibration(path, 640, 480);
  ASSERT_TRUE(c.camera) << c.error;
  EXPECT_NEAR(c.camera->fx, 525.0, 1e-9);
  EXPECT_NEAR(c.camera->fy, 526.0, 1e-9);
  EXPECT_NEAR(c.camera->cx, 319.5, 1e-9);  // (639.5 + 0.5) / 2 - 0.5
  EXPECT_NEAR(c.camera->cy, 239.5, 1e-9);
  EXPECT_DOUBLE_EQ(c.camera->distortion[0], 0.1);
  EXPECT_DOUBLE_EQ(c.camera->distortion[4], 0.05);
  EXPECT_EQ(c.camera->width, 640);
  // A size that does not scale uniformly is refused.
  const auto bad = pc::loadCalibration(path, 640, 360);
  EXPECT_FALSE(bad.camera);
  EXPECT_NE(bad.error.find("does not scale"), std::string::npos) << bad.error;
  std::remove(path.c_str());
}

TEST(Calibration, ReadsThePlayersCameraYaml) {
  const std::string path = tempPath("camera.yaml");
  {
    std::ofstream f(path);
    f << "fx: 570.3\nfy: 570.3\ncx: 319.5\ncy: 239.5\ndistortion: [0.01, 0, 0, 0, 0]\n";
  }
  const auto c = pc::loadCalibration(path, 640, 480);
  ASSERT_TRUE(c.camera) << c.error;
  EXPECT_DOUBLE_EQ(c.camera->fx, 570.3);
  EXPECT_DOUBLE_EQ(c.camera->distortion[0], 0.01);
  EXPECT_EQ(c.camera->height, 480);
  {
    std::ofstream f(path);
    f << "fx: 570.3\nfy: 570.3\ncx: 319.5\ncy: 239.5\nfocal: 3\n";
  }
  const auto u = pc::loadCalibration(path, 640, 480);
  EXPECT_FALSE(u.camera);
  EXPECT_NE(u.error.find("unknown key 'focal'"), std::string::npos) << u.error;
  std::remove(path.c_str());
}

TEST(Calibration, ClearErrorsOnBadFiles) {
  const auto missing = pc::loadCalibration("/nonexistent/calib.xml", 640, 480);
  EXPECT_FALSE(missing.camera);
  EXPECT_NE(missing.error.find("calibration file"), std::string::npos) << missing.error;
  EXPECT_NE(missing.error.find("/nonexistent/calib.xml"), std::string::npos) << missing.error;

  const std::string path = tempPath("garbage.xml");
  {
    std::ofstream f(path);
    f << "<?xml version=\"1.0\"?>\n<opencv_storage><other>1</other></opencv_storage>\n";
  }
  const auto nokey = pc::loadCalibration(path, 640, 480);
  EXPECT_FALSE(nokey.camera);
  EXPECT_NE(nokey.error.find("missing RGB_intrinsic_params"), std::string::npos) << nokey.error;
  {
    std::ofstream f(path);
    f << "this is not a calibration file {{{";
  }
  const auto corrupt = pc::loadCalibration(path, 640, 480);
  EXPECT_FALSE(corrupt.camera);
  EXPECT_FALSE(corrupt.error.empty());
  std::remove(path.c_str());
}

// ------------------------------------------------------------------ time mapping

namespace {
// Simulated device: counter at `ticks_per_s` with clock error `drift_ppm`, frames at 30 Hz,
// latency = base + exponential jitter, counter masked to `bits`.
struct ClockSim {
  double ticks_per_s;
  int bits;
  double drift_ppm;
  double base_latency_us;
  double jitter_mean_us;
};
double maxErrorUs(const ClockSim& s, double seconds, double settle_s, uint64_t start_ticks,
                  pc::DeviceClockMapper* mapper, std::mt19937* rng) {
  std::exponential_distribution<double> jitter(1.0 / s.jitter_mean_us);
  const double host0 = 1.7e15;
  double max_err = 0;
  int64_t last = INT64_MIN;
  for (int k = 0; k < static_cast<int>(seconds * 30); ++k) {
    const double t_true_us = k * 1e6 / 30.0;  // capture time on the host clock since start
    const double dev_ticks =
        start_ticks + t_true_us * 1e-6 * s.ticks_per_s * (1 + s.drift_ppm * 1e-6);
    uint64_t ticks = static_cast<uint64_t>(std::llround(dev_ticks));
    if (s.bits < 64) ticks &= (uint64_t{1} << s.bits) - 1;
    const double arrival = host0 + t_true_us + s.base_latency_us + jitter(*rng);
    const int64_t mapped = mapper->map(ticks, static_cast<int64_t>(arrival));
    EXPECT_GT(mapped, last);
    EXPECT_LE(mapped, static_cast<int64_t>(arrival));
    last = mapped;
    if (t_true_us > settle_s * 1e6) {
      // The estimate is the capture time plus the smallest latency (unobservable constant).
      const double err = std::abs(mapped - (host0 + t_true_us + s.base_latency_us));
      max_err = std::max(max_err, err);
    }
  }
  return max_err;
}
}  // namespace

TEST(DeviceClock, FirstFrameOffsetThenLowerEnvelope) {
  pc::DeviceClockOptions o;
  o.max_drift_ppm = 0;  // exact arithmetic; the drift allowance is tested below
  pc::DeviceClockMapper m(o);
  EXPECT_EQ(m.map(1000, 5000000), 5000000);       // first frame: arrival
  EXPECT_EQ(m.map(34333, 5040000), 5033333);      // later: first offset + device time
  EXPECT_EQ(m.map(67666, 5066000), 5066000 - 0);  // faster arrival lowers the offset
  EXPECT_EQ(m.stats().frames, 3);
}

TEST(DeviceClock, KinectCounterWrapsAndDriftsWithinAMillisecond) {
  // 60 MHz 32-bit counter starting 10 s before its wrap, 100 s of frames, +80 ppm drift.
  std::mt19937 rng(3);
  pc::DeviceClockOptions o;
  o.ticks_per_second = 60e6;
  o.counter_bits = 32;
  pc::DeviceClockMapper m(o);
  const uint64_t start = (uint64_t{1} << 32) - static_cast<uint64_t>(10 * 60e6);
  const double err = maxErrorUs({60e6, 32, 80.0, 8000.0, 3000.0}, 100.0, 1.0, start, &m, &rng);
  EXPECT_LT(err, 1000.0);
  EXPECT_GE(m.stats().wraps, 1);
  EXPECT_EQ(m.stats().restarts, 0);
  // A device clock that runs slow is followed too.
  pc::DeviceClockMapper slow(o);
  const double err_slow =
      maxErrorUs({60e6, 32, -150.0, 8000.0, 3000.0}, 60.0, 1.0, 12345, &slow, &rng);
  EXPECT_LT(err_slow, 1000.0);
}

TEST(DeviceClock, WithoutTheDriftAllowanceTheErrorGrows) {
  // The same +80 ppm drift with no allowance: the lower envelope cannot rise, so the error
  // grows to ~drift * time (shows the test above can fail).
  std::mt19937 rng(3);
  pc::DeviceClockOptions o;
  o.max_drift_ppm = 0.0;
  pc::DeviceClockMapper m(o);
  const double err = maxErrorUs({1e6, 64, -80.0, 8000.0, 100.0}, 100.0, 1.0, 0, &m, &rng);
  EXPECT_GT(err, 4000.0);
}

TEST(DeviceClock, RestartsAfterADeviceClockReset) {
  pc::DeviceClockMapper m;  // microseconds, 64 bit
  const int64_t host0 = 1'000'000'000;
  int64_t last = 0;
  for (int k = 0; k < 30; ++k) last = m.map(5'000'000 + k * 33333, host0 + k * 33333 + 2000);
  // The device restarts its counter near zero (replug): mapped times still increase and,
  // after restart_after_outliers frames, follow the new clock again.
  for (int k = 30; k < 60; ++k) {
    const int64_t t = m.map(static_cast<uint64_t>((k - 30) * 33333), host0 + k * 33333 + 2000);
    EXPECT_GT(t, last);
    last = t;
    if (k >= 33) {
      EXPECT_NEAR(t, host0 + k * 33333 + 2000, 2) << k;
    }
  }
  EXPECT_EQ(m.stats().restarts, 1);
  EXPECT_GE(m.stats().outliers, 2);
}

TEST(DeviceClock, LateFrameKeepsItsDeviceTime) {
  pc::DeviceClockMapper m;
  for (int k = 0; k < 10; ++k) m.map(k * 33333, 1000000 + k * 33333 + 500);
  // Frame 10 arrives 0.8 s late (host stall): it still maps to its capture time (up to the
  // drift allowance, 200 ppm of 0.33 s = 67 us).
  const int64_t t = m.map(10 * 33333, 1000000 + 10 * 33333 + 800000);
  EXPECT_NEAR(t, 1000000 + 10 * 33333 + 500, 70);
  EXPECT_EQ(m.stats().outliers, 1);
}

// ------------------------------------------------------------------ pairing, rate, options

TEST(FramePairer, PairsWithinToleranceAndDropsStaleHalves) {
  pc::FramePairer p(1000, 32);
  const cv::Mat d(1, 1, CV_16UC1, cv::Scalar(7)), c(1, 1, CV_8UC3, cv::Scalar(1, 2, 3));
  p.pushDepth(d, 10000);
  EXPECT_FALSE(p.pop());
  p.pushColour(c, 10500);
  auto pair = p.pop();
  ASSERT_TRUE(pair);
  EXPECT_EQ(pair->device_ticks, 10500u);
  EXPECT_EQ(pair->depth_minus_colour_ticks, -500);  // depth captured 500 ticks earlier
  EXPECT_EQ(pair->depth.at<uint16_t>(0, 0), 7);
  EXPECT_FALSE(p.pop());
  // A colour frame far ahead of the depth frame: the depth one is dropped, colour waits.
  p.pushDepth(d, 20000);
  p.pushColour(c, 40000);
  EXPECT_FALSE(p.pop());
  EXPECT_EQ(p.dropped(), 1);
  p.pushDepth(d, 40200);
  pair = p.pop();
  ASSERT_TRUE(pair);
  EXPECT_EQ(pair->depth_minus_colour_ticks, 200);
  // Pairing across the 32-bit wrap.
  p.pushDepth(d, 0xffffff00u);
  p.pushColour(c, 0x00000100u);
  pair = p.pop();
  ASSERT_TRUE(pair);
  EXPECT_EQ(pair->depth_minus_colour_ticks, -512);
  // Several pairs completed before the consumer pops: kept in order, up to max_ready (4).
  const int64_t before = p.dropped();
  for (uint64_t k = 0; k < 6; ++k) {
    p.pushDepth(d, 100000 + k * 2000);
    p.pushColour(c, 100000 + k * 2000 + 10);
  }
  EXPECT_EQ(p.dropped() - before, 2);
  for (uint64_t k = 2; k < 6; ++k) {
    auto q = p.pop();
    ASSERT_TRUE(q);
    EXPECT_EQ(q->device_ticks, 100000 + k * 2000 + 10);
  }
  EXPECT_FALSE(p.pop());
}

TEST(RateLimiter, ThirtyHertzLimitedToTen) {
  pc::RateLimiter lim(10.0);
  std::mt19937 rng(5);
  std::normal_distribution<double> jitter(0.0, 1500.0);
  int passed = 0;
  for (int k = 0; k < 300; ++k) {  // 10 s at 30 Hz with 1.5 ms jitter
    if (lim.allow(static_cast<int64_t>(k * 33333.3 + jitter(rng)))) ++passed;
  }
  EXPECT_GE(passed, 99);
  EXPECT_LE(passed, 101);
  pc::RateLimiter off(0.0);
  for (int k = 0; k < 10; ++k) EXPECT_TRUE(off.allow(k));
}

TEST(Options, EncodingsAndRegistration) {
  EXPECT_EQ(pc::parseRgbEncoding("jpeg"), pc::RgbEncoding::Jpeg);
  EXPECT_EQ(pc::parseRgbEncoding("png"), pc::RgbEncoding::Png);
  EXPECT_EQ(pc::parseRgbEncoding("raw"), pc::RgbEncoding::Raw);
  EXPECT_FALSE(pc::parseRgbEncoding("bmp"));
  EXPECT_EQ(pc::parseDepthEncoding("zlib"), pc::DepthEncoding::Zlib);
  EXPECT_FALSE(pc::parseDepthEncoding("jpeg"));
  const auto hw = pc::decideRegistration(true, true);
  EXPECT_TRUE(hw.use_hardware && hw.depth_in_colour_frame && hw.warning.empty());
  const auto none = pc::decideRegistration(true, false);
  EXPECT_FALSE(none.use_hardware);
  EXPECT_FALSE(none.warning.empty());
  EXPECT_NE(none.warning.find("DEPTH_OWN_CAMERA"), std::string::npos) << none.warning;
  const auto off = pc::decideRegistration(false, true);
  EXPECT_FALSE(off.use_hardware);
  EXPECT_FALSE(off.depth_in_colour_frame);
  EXPECT_TRUE(off.warning.empty());  // asked for: published as DEPTH_OWN_CAMERA
  EXPECT_EQ(pc::stampText(1341845688561749), "1341845688.561749");
  EXPECT_EQ(pc::stampText(5), "0.000005");
}

TEST(Calibration, ReadsTheDepthCameraOfUnregisteredDepthAndScalesIt) {
  // The player's camera YAML with a depth camera of its own, calibrated at 1280x960.
  const std::string path = tempPath("unregistered.yaml");
  {
    std::ofstream f(path);
    f << "width: 1280\nheight: 960\nfx: 1000\nfy: 1000\ncx: 639.5\ncy: 479.5\n"
         "depth_registered: false\n"
         "depth_camera:\n  width: 1280\n  height: 960\n  fx: 1160\n  fy: 1162\n"
         "  cx: 641.5\n  cy: 481.5\n  R_c_d: [1, 0, 0, 0, 1, 0, 0, 0, 1]\n"
         "  t_c_d_m: [0.025, 0, 0.001]\n";
  }
  const auto c = pc::loadCalibration(path, 640, 480);
  ASSERT_TRUE(c.camera) << c.error;
  ASSERT_TRUE(c.depth_camera);
  EXPECT_EQ(c.depth_camera->camera.width, 640);
  EXPECT_EQ(c.depth_camera->camera.height, 480);
  EXPECT_NEAR(c.depth_camera->camera.fx, 580.0, 1e-9);
  EXPECT_NEAR(c.depth_camera->camera.fy, 581.0, 1e-9);
  EXPECT_NEAR(c.depth_camera->camera.cx, 320.5, 1e-9);  // (641.5 + 0.5) / 2 - 0.5
  EXPECT_NEAR(c.depth_camera->camera.cy, 240.5, 1e-9);
  EXPECT_NEAR(c.depth_camera->T_c_d.translation().x(), 0.025, 1e-15);
  EXPECT_NEAR(c.depth_camera->T_c_d.translation().z(), 0.001, 1e-15);
  // Registered files give none (the shared datasets' IR_* entries are ignored).
  const auto tum = pc::loadCalibration(
      sharedData() + "/tum_fr3_sitting_static_short/calib_params.xml", 640, 480);
  ASSERT_TRUE(tum.camera) << tum.error;
  EXPECT_FALSE(tum.depth_camera);
  std::remove(path.c_str());
}

TEST(Options, PlanDepthFrame) {
  pc::RegistrationDecision registered;
  registered.use_hardware = registered.depth_in_colour_frame = true;
  pc::RegistrationDecision own;  // registration off or not supported
  pplvo::DepthCamera calib;
  calib.camera = pplvo::PinholeCamera{};
  calib.camera.width = 640;
  calib.camera.height = 480;
  calib.camera.fx = calib.camera.fy = 580;
  calib.T_c_d.translation() = Eigen::Vector3d(-0.025, 0, 0);
  const auto fov = pc::intrinsicsFromFov(640, 480, 58.0 * M_PI / 180, 45.0 * M_PI / 180);
  ASSERT_TRUE(fov);

  // Registered: nothing, whatever else is known (the default stays DEPTH_REGISTERED).
  const auto reg = pc::planDepthFrame(registered, calib, fov, 640, 480);
  EXPECT_FALSE(reg.depth_camera);
  EXPECT_TRUE(reg.error.empty() && reg.warning.empty());
  // The calibration's depth camera and extrinsic win over the device's field of view.
  const auto from_file = pc::planDepthFrame(own, calib, fov, 640, 480);
  ASSERT_TRUE(from_file.depth_camera) << from_file.error;
  EXPECT_DOUBLE_EQ(from_file.depth_camera->camera.fx, 580);
  EXPECT_DOUBLE_EQ(from_file.depth_camera->T_c_d.translation().x(), -0.025);
  EXPECT_TRUE(from_file.warning.empty());
  // A calibration without a size takes the depth images'.
  pplvo::DepthCamera sizeless = calib;
  sizeless.camera.width = sizeless.camera.height = 0;
  const auto taken = pc::planDepthFrame(own, sizeless, std::nullopt, 640, 480);
  ASSERT_TRUE(taken.depth_camera) << taken.error;
  EXPECT_EQ(taken.depth_camera->camera.width, 640);
  // The device's field of view with an identity extrinsic, and a warning saying so.
  const auto from_device = pc::planDepthFrame(own, std::nullopt, fov, 640, 480);
  ASSERT_TRUE(from_device.depth_camera) << from_device.error;
  EXPECT_NEAR(from_device.depth_camera->camera.fx, 320.0 / std::tan(29.0 * M_PI / 180), 1e-9);
  EXPECT_TRUE(from_device.depth_camera->T_c_d.isApprox(pplvo::Pose3::Identity()));
  EXPECT_NE(from_device.warning.find("extrinsic"), std::string::npos);
  // Neither: a clear error. A size that is not the depth images' : an error.
  const auto none = pc::planDepthFrame(own, std::nullopt, std::nullopt, 640, 480);
  EXPECT_FALSE(none.depth_camera);
  EXPECT_NE(none.error.find("--calib"), std::string::npos) << none.error;
  const auto wrong = pc::planDepthFrame(own, calib, std::nullopt, 320, 240);
  EXPECT_FALSE(wrong.depth_camera);
  EXPECT_NE(wrong.error.find("320x240"), std::string::npos) << wrong.error;
}

TEST(Options, ChooseDeviceMode) {
  const std::vector<pc::ModeCandidate> modes = {
      {320, 240, 30, 100}, {640, 480, 30, 101}, {640, 480, 30, 100}, {640, 480, 60, 100}};
  EXPECT_EQ(pc::chooseMode(modes, 640, 480, 30, {100, 101}), 2u);  // preferred format first
  EXPECT_EQ(pc::chooseMode(modes, 640, 480, 30, {101}), 1u);
  EXPECT_FALSE(pc::chooseMode(modes, 1280, 1024, 30, {100}));
  EXPECT_NE(pc::describeModes(modes).find("640x480@60"), std::string::npos);
}
