// Simulated wheel odometry of a differential-drive robot, from a sequence's ground truth, beside
// pplvo's body odometry of the same frames (examples/fusion/README.md).
//
// Reads the PPLVO_ODOMETRY events of a pplvo log (pplvo-run --log), the sequence's
// groundtruth.txt (camera poses) and the camera's mounting; writes an LCM log with pplvo's
// events and, after each, a WHEEL_ODOMETRY odometry_t for the same frame interval, plus the
// ground truth of base_link in odom (TUM) for the evaluation.
//
// The wheels measure the body twist over each interval as a differential drive does: forward
// speed with a wheel-radius error of +2 % and a slowly wandering slip (random walk, 0.3 % per
// frame, within +-5 %) plus 0.01 m/s noise; yaw rate with a 0.005 rad/s bias (a wheel-base
// error) plus 0.01 rad/s noise; sideways, vertical, roll and pitch rates as zero (no slip
// sideways, a flat floor). The covariance it reports is what such a node would: variances from
// the noise and a 3 % speed-proportional term, the bias not modelled (it is not known).
#include <lcm/lcm-cpp.hpp>
#include <pplvo_msgs/odometry_t.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <cstring>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "pplvo/core/body_odometry.h"
#include "pplvo/msgs/channels.h"
#include "pplvo/msgs/convert_pose.h"
#include "tum_poses.h"
#include "twist_fusion.h"

namespace {

using namespace pplvo;

struct Args {
  std::string run_log, groundtruth, output, groundtruth_base, channel = "WHEEL_ODOMETRY";
  BodyMountOptions mount;
  uint64_t seed = 1;
};

Args parse(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    const std::string k = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw std::runtime_error(k + " needs a value");
      return argv[++i];
    };
    if (k == "--run-log") a.run_log = value();
    else if (k == "--groundtruth") a.groundtruth = value();
    else if (k == "--output") a.output = value();
    else if (k == "--groundtruth-base") a.groundtruth_base = value();
    else if (k == "--channel") a.channel = value();
    else if (k == "--seed") a.seed = std::stoull(value());
    else if (k == "--mount") {
      std::stringstream s(value());
      char c;
      if (!(s >> a.mount.x_m >> c >> a.mount.y_m >> c >> a.mount.z_m >> c >> a.mount.roll_deg >> c >>
            a.mount.pitch_deg >> c >> a.mount.yaw_deg)) {
        throw std::runtime_error("--mount x,y,z,roll,pitch,yaw (m, deg)");
      }
    } else {
      throw std::runtime_error("unknown argument " + k);
    }
  }
  if (a.run_log.empty() || a.groundtruth.empty() || a.output.empty() || a.groundtruth_base.empty()) {
    throw std::runtime_error(
        "usage: simulate_wheel_odometry --run-log PPLVO.lcmlog --groundtruth GT.txt "
        "--output OUT.lcmlog --groundtruth-base BASE.txt [--mount x,y,z,roll,pitch,yaw] "
        "[--seed S] [--channel WHEEL_ODOMETRY]");
  }
  return a;
}

}  // namespace

int main(int argc, char** argv) try {
  const Args args = parse(argc, argv);
  const auto gt = examples::readTumByStamp(args.groundtruth);
  const Pose3 T_base_optical = args.mount.extrinsic().baseFromOptical();
  lcm::LogFile in(args.run_log, "r");
  lcm::LogFile out(args.output, "w");
  if (!in.good() || !out.good()) throw std::runtime_error("cannot open the logs");
  std::ofstream gt_base(args.groundtruth_base);
  gt_base << "# base_link in odom (ground truth), from " << args.groundtruth << "\n";

  std::mt19937_64 rng(args.seed);
  std::normal_distribution<double> n01(0.0, 1.0);
  constexpr double kScale = 1.02, kSlipStep = 0.003, kSlipMax = 0.05, kSpeedNoise = 0.01;
  constexpr double kYawBias = 0.005, kYawNoise = 0.01, kPlanarSigma = 0.01;
  double slip = 0.0;

  examples::TwistFusionFilter wheels;  // the wheel odometry's own dead reckoning
  std::optional<Pose3> first_base, last_base;
  double last_t = 0.0;
  int written = 0, missing_gt = 0;
  std::vector<uint8_t> buf;
  while (const lcm::LogEvent* e = in.readNextEvent()) {
    if (std::strcmp(e->channel.c_str(), pplvo::channels::kOdometry) != 0) continue;
    pplvo_msgs::odometry_t m;
    if (m.decode(e->data, 0, static_cast<int>(e->datalen)) < 0) continue;
    lcm::LogEvent copy = *e;
    out.writeEvent(&copy);
    const double t = std::stod(m.stamp);
    const Pose3* T_w_c = examples::poseAt(gt, t);
    if (T_w_c == nullptr) {
      ++missing_gt;
      continue;
    }
    const Pose3 T_w_base = *T_w_c * T_base_optical.inverse();
    if (!first_base) first_base = T_w_base;
    examples::writeTumLine(gt_base, m.stamp, first_base->inverse() * T_w_base);

    BodyOdometry w;
    w.utime = m.utime;
    w.seq = m.seq;
    w.stamp = m.stamp;
    w.status = TrackingStatus::kTracking;
    w.twist_covariance = Matrix6d::Identity() * kUnknownTwistVariance;
    if (last_base && t > last_t) {
      const double dt = t - last_t;
      const Vector6d truth = twistOfMotion(last_base->inverse() * T_w_base, dt);
      slip = std::clamp(slip + kSlipStep * n01(rng), -kSlipMax, kSlipMax);
      const double v = truth(0) * kScale * (1.0 + slip) + kSpeedNoise * n01(rng);
      const double wz = truth(5) + kYawBias + kYawNoise * n01(rng);
      w.linear_velocity = {v, 0.0, 0.0};
      w.angular_velocity = {0.0, 0.0, wz};
      Vector6d sigma;
      sigma << std::hypot(0.03 * v, kSpeedNoise), kPlanarSigma, kPlanarSigma, kPlanarSigma,
          kPlanarSigma, kYawNoise;
      w.twist_covariance = sigma.cwiseAbs2().asDiagonal();
      w.dt_s = dt;
      examples::BodyTwist twist{(Vector6d() << w.linear_velocity, w.angular_velocity).finished(),
                                w.twist_covariance};
      wheels.propagate(twist, dt);
    }
    w.T_odom_base = wheels.pose();
    w.pose_covariance = wheels.covariance();
    last_base = T_w_base;
    last_t = t;
    const pplvo_msgs::odometry_t wm = msgs::toMsg(w);
    buf.resize(static_cast<size_t>(wm.getEncodedSize()));
    wm.encode(buf.data(), 0, static_cast<int>(buf.size()));
    lcm::LogEvent ev{};
    ev.timestamp = e->timestamp;
    ev.channel = args.channel;
    ev.datalen = static_cast<int32_t>(buf.size());
    ev.data = buf.data();
    out.writeEvent(&ev);
    ++written;
  }
  std::printf("wheel odometry: %d samples on %s, %d frames without ground truth\n", written,
              args.channel.c_str(), missing_gt);
  return written > 0 ? 0 : 1;
} catch (const std::exception& e) {
  std::fprintf(stderr, "simulate_wheel_odometry: %s\n", e.what());
  return 2;
}
