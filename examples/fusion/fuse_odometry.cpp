// Fuses pplvo's body odometry (PPLVO_ODOMETRY) with a wheel odometry (WHEEL_ODOMETRY), both
// odometry_t, with the filter of twist_fusion.h (examples/fusion/README.md).
//
//   fuse_odometry --log FILE.lcmlog --output TRAJ [options]   a recorded log, every event
//   fuse_odometry --lcm-url URL --output TRAJ [options]       live: also publishes the fused
//                                                              odometry_t on FUSED_ODOMETRY
// Options:
//   --use both|pplvo|wheel         the sources fused (both); one alone is its own dead reckoning
//   --pplvo-constant-sigma V,W     replace pplvo's per-frame twist covariance by a constant
//                                  diagonal (m/s, rad/s): what a fixed covariance would do
//   --no-wheel-errors              do not estimate the wheels' yaw-rate bias and speed scale
//                                  (the two twists' information-weighted mean alone)
//   --groundtruth-base FILE        base_link in odom (TUM) for the NEES of the fused covariance
//   --pplvo-channel, --wheel-channel, --fused-channel NAME
// Prints the poses, the median twist sigmas pplvo reported, and with a ground truth the mean
// NEES (6 for a consistent 6-dof covariance) and the share inside chi2(6)'s 95 % bound.
#include <lcm/lcm-cpp.hpp>
#include <pplvo_msgs/odometry_t.hpp>

#include <algorithm>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "pplvo/msgs/convert_pose.h"
#include "tum_poses.h"
#include "twist_fusion.h"

namespace {

using namespace pplvo;
using examples::BodyTwist;

struct Args {
  std::string log, lcm_url, output, groundtruth_base, use = "both";
  std::string pplvo_channel = "PPLVO_ODOMETRY", wheel_channel = "WHEEL_ODOMETRY";
  std::string fused_channel = "FUSED_ODOMETRY";
  double constant_v = -1, constant_w = -1;
  bool estimate_wheel_errors = true;
};

Args parse(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    const std::string k = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw std::runtime_error(k + " needs a value");
      return argv[++i];
    };
    if (k == "--log") a.log = value();
    else if (k == "--lcm-url") a.lcm_url = value();
    else if (k == "--output") a.output = value();
    else if (k == "--groundtruth-base") a.groundtruth_base = value();
    else if (k == "--use") a.use = value();
    else if (k == "--pplvo-channel") a.pplvo_channel = value();
    else if (k == "--wheel-channel") a.wheel_channel = value();
    else if (k == "--fused-channel") a.fused_channel = value();
    else if (k == "--no-wheel-errors") a.estimate_wheel_errors = false;
    else if (k == "--pplvo-constant-sigma") {
      std::stringstream s(value());
      char c;
      if (!(s >> a.constant_v >> c >> a.constant_w) || a.constant_v <= 0 || a.constant_w <= 0) {
        throw std::runtime_error("--pplvo-constant-sigma V,W (m/s, rad/s, > 0)");
      }
    } else {
      throw std::runtime_error("unknown argument " + k);
    }
  }
  if ((a.log.empty() == a.lcm_url.empty()) || a.output.empty() ||
      (a.use != "both" && a.use != "pplvo" && a.use != "wheel")) {
    throw std::runtime_error("usage: fuse_odometry (--log FILE | --lcm-url URL) --output TRAJ "
                             "[--use both|pplvo|wheel] [--pplvo-constant-sigma V,W] "
                             "[--groundtruth-base FILE]");
  }
  return a;
}

/// Pairs the two sources' samples of each frame and runs the filter in frame order.
class Fusion {
 public:
  explicit Fusion(const Args& args) : args_(args), out_(args.output) {
    if (!out_) throw std::runtime_error("cannot write " + args.output);
    out_ << "# base_link in odom, fused (" << args.use << ")\n";
    if (!args.groundtruth_base.empty()) gt_ = examples::readTumByStamp(args.groundtruth_base);
  }

  /// A sample of one source; returns the fused odometry of every frame it completed.
  std::vector<BodyOdometry> add(const BodyOdometry& o, bool from_pplvo) {
    if (from_pplvo && args_.use == "wheel") return {};
    if (!from_pplvo && args_.use == "pplvo") return {};
    Pending& p = pending_[o.seq];
    (from_pplvo ? p.pplvo : p.wheel) = o;
    (from_pplvo ? last_pplvo_seq_ : last_wheel_seq_) = o.seq;
    if (from_pplvo) {
      pplvo_v_sigma_.push_back(std::sqrt(o.twist_covariance(0, 0)));
      pplvo_w_sigma_.push_back(std::sqrt(o.twist_covariance(5, 5)));
    }
    return flush(false);
  }

  /// Every frame still waiting, with what it has (the end of a log).
  std::vector<BodyOdometry> finish() { return flush(true); }

  void report() const {
    std::printf("fused_poses: %d\n", poses_);
    if (args_.estimate_wheel_errors && args_.use == "both") {
      std::printf("wheel_yaw_rate_bias_rad_s: %.5f\nwheel_speed_scale_error: %.4f\n",
                  wheel_errors_.yawRateBias(), wheel_errors_.speedScaleError());
    }
    if (!pplvo_v_sigma_.empty()) {
      std::printf("pplvo_twist_sigma_median: %.5f m/s, %.5f rad/s\n", median(pplvo_v_sigma_),
                  median(pplvo_w_sigma_));
    }
    if (nees_.empty()) return;
    double sum = 0;
    int inside = 0;
    for (double n : nees_) {
      sum += n;
      inside += n <= 12.592;  // chi2(6), 95 %
    }
    std::printf("nees_mean: %.2f  # 6 for a consistent 6-dof covariance, over %zu poses\n",
                sum / static_cast<double>(nees_.size()), nees_.size());
    std::printf("nees_share_inside_95: %.3f\n", inside / static_cast<double>(nees_.size()));
  }

 private:
  struct Pending {
    std::optional<BodyOdometry> pplvo, wheel;
  };

  static double median(std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
    return v[v.size() / 2];
  }

  bool complete(int64_t seq, const Pending& p) const {
    const bool need_pplvo = args_.use != "wheel", need_wheel = args_.use != "pplvo";
    // A source that has moved past this frame will not send it any more.
    const bool pplvo_done = !need_pplvo || p.pplvo || last_pplvo_seq_ > seq;
    const bool wheel_done = !need_wheel || p.wheel || last_wheel_seq_ > seq;
    return pplvo_done && wheel_done;
  }

  std::vector<BodyOdometry> flush(bool all) {
    std::vector<BodyOdometry> done;
    while (!pending_.empty() && (all || complete(pending_.begin()->first, pending_.begin()->second))) {
      done.push_back(step(pending_.begin()->second));
      pending_.erase(pending_.begin());
    }
    return done;
  }

  BodyOdometry step(const Pending& p) {
    const BodyOdometry& any = p.pplvo ? *p.pplvo : *p.wheel;
    std::optional<BodyTwist> v = p.pplvo ? examples::twistOf(*p.pplvo) : std::nullopt;
    if (v && args_.constant_v > 0) {
      Vector6d s;
      s << Eigen::Vector3d::Constant(args_.constant_v), Eigen::Vector3d::Constant(args_.constant_w);
      v->covariance = s.cwiseAbs2().asDiagonal();
    }
    const std::optional<BodyTwist> w = p.wheel ? examples::twistOf(*p.wheel) : std::nullopt;
    const double dt = p.pplvo && p.pplvo->dt_s > 0 ? p.pplvo->dt_s : any.dt_s;
    std::optional<BodyTwist> fused = v;
    if (v && w && args_.estimate_wheel_errors) {
      fused = wheel_errors_.fuse(*v, *w, dt);
    } else if (v && w) {
      fused = examples::fuseTwists(*v, *w);
    } else if (w) {
      fused = args_.estimate_wheel_errors ? wheel_errors_.correctWheels(*w, dt) : *w;
    }
    BodyOdometry o;
    o.utime = any.utime;
    o.seq = any.seq;
    o.stamp = any.stamp;
    o.status = any.status;
    o.twist_covariance = Matrix6d::Identity() * kUnknownTwistVariance;
    if (fused && dt > 0) {
      filter_.propagate(*fused, dt);
      o.linear_velocity = fused->xi.head<3>();
      o.angular_velocity = fused->xi.tail<3>();
      o.twist_covariance = fused->covariance;
      o.dt_s = dt;
    }
    o.T_odom_base = filter_.pose();
    o.pose_covariance = filter_.covariance();
    examples::writeTumLine(out_, o.stamp, o.T_odom_base);
    ++poses_;
    if (const Pose3* truth = gt_.empty() ? nullptr : examples::poseAt(gt_, std::stod(o.stamp));
        truth != nullptr && o.pose_covariance.trace() > 0) {
      Vector6d e;
      e.head<3>() = truth->translation() - o.T_odom_base.translation();
      const Eigen::AngleAxisd dR(truth->linear() * o.T_odom_base.linear().transpose());
      e.tail<3>() = dR.angle() * dR.axis();
      nees_.push_back(e.dot(o.pose_covariance.ldlt().solve(e)));
    }
    return o;
  }

  Args args_;
  std::ofstream out_;
  std::map<double, Pose3> gt_;
  std::map<int64_t, Pending> pending_;
  int64_t last_pplvo_seq_ = -1, last_wheel_seq_ = -1;
  examples::TwistFusionFilter filter_;
  examples::WheelErrorEstimator wheel_errors_;
  std::vector<double> pplvo_v_sigma_, pplvo_w_sigma_, nees_;
  int poses_ = 0;
};

volatile std::sig_atomic_t g_stop = 0;

std::optional<BodyOdometry> decode(const void* data, int size) {
  pplvo_msgs::odometry_t m;
  if (m.decode(data, 0, size) < 0) return std::nullopt;
  try {
    return msgs::fromMsg(m);
  } catch (const std::exception&) {
    return std::nullopt;  // a bad sample is skipped, never fused
  }
}

}  // namespace

int main(int argc, char** argv) try {
  const Args args = parse(argc, argv);
  Fusion fusion(args);
  int skipped = 0;
  if (!args.log.empty()) {
    lcm::LogFile in(args.log, "r");
    if (!in.good()) throw std::runtime_error("cannot read " + args.log);
    while (const lcm::LogEvent* e = in.readNextEvent()) {
      const bool pplvo = e->channel == args.pplvo_channel;
      if (!pplvo && e->channel != args.wheel_channel) continue;
      if (const auto o = decode(e->data, static_cast<int>(e->datalen))) {
        fusion.add(*o, pplvo);
      } else {
        ++skipped;
      }
    }
    fusion.finish();
  } else {
    lcm::LCM lcm(args.lcm_url);
    if (!lcm.good()) throw std::runtime_error("cannot open " + args.lcm_url);
    struct Handler {
      Fusion* fusion;
      lcm::LCM* lcm;
      const Args* args;
      int* skipped;
      void on(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
        const auto o = decode(rbuf->data, static_cast<int>(rbuf->data_size));
        if (!o) {
          ++*skipped;
          return;
        }
        for (const BodyOdometry& f : fusion->add(*o, channel == args->pplvo_channel)) {
          const pplvo_msgs::odometry_t m = msgs::toMsg(f);
          lcm->publish(args->fused_channel, &m);
        }
      }
    } handler{&fusion, &lcm, &args, &skipped};
    lcm.subscribe(args.pplvo_channel, &Handler::on, &handler);
    lcm.subscribe(args.wheel_channel, &Handler::on, &handler);
    std::signal(SIGINT, [](int) { g_stop = 1; });
    std::signal(SIGTERM, [](int) { g_stop = 1; });
    while (!g_stop) lcm.handleTimeout(200);
    fusion.finish();
  }
  fusion.report();
  std::printf("skipped_samples: %d\n", skipped);
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "fuse_odometry: %s\n", e.what());
  return 2;
}
