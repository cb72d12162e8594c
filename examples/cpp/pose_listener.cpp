// pose_listener: an LCM node of your own that reads pplvo's poses (PPLVO_POSE, pplvo_msgs::pose_t)
// and prints each with its covariance. Built against an installed pplvo (find_package(pplvo));
// see README.md "Use pplvo from your own node".
//
//   pose_listener [--url URL | --log FILE | --replay-memq FILE] [--channel CH]
//                 [--tum OUT] [--covariance OUT] [--max-poses N] [--idle-timeout S]
//
//   --url URL          any LCM URL (default: $LCM_DEFAULT_URL, as lcm::LCM does), e.g. udpm on
//                      the robot's network, or file://LOG?speed=0 to read a log
//   --log FILE         the same as --url 'file://FILE?speed=0': an event log as fast as possible
//   --replay-memq FILE reads FILE with lcm::LogFile and publishes every event on a memq://
//                      instance this node is subscribed to (memq:// connects the subscribers of
//                      one lcm::LCM object only, so the publisher has to be in this process)
//   --tum OUT          writes the poses as a TUM trajectory (the format of pplvo-run --output)
//   --covariance OUT   one line per pose: stamp and the 36 values of rel_covariance (row-major)
//
// It stops at the end of a log, after --max-poses poses, after --idle-timeout seconds without a
// message (0: never) or on Ctrl-C, and prints how many poses it read.
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <lcm/lcm-cpp.hpp>
#include <pplvo_msgs/pose_t.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "pplvo/core/trajectory.h"
#include "pplvo/msgs/convert_pose.h"

namespace {

volatile std::sig_atomic_t g_stop = 0;
void onSignal(int) { g_stop = 1; }

/// Subscribes in its constructor; the handler never lets an exception out (in LCM 1.3.1 a throw
/// out of a callback leaves lcm_handle's mutex locked): invalid messages are counted.
class PoseListener {
 public:
  PoseListener(lcm::LCM& lcm, const std::string& channel) : lcm_(lcm) {
    sub_ = lcm_.subscribe(channel, &PoseListener::onPose, this);
  }
  ~PoseListener() { lcm_.unsubscribe(sub_); }
  PoseListener(const PoseListener&) = delete;
  PoseListener& operator=(const PoseListener&) = delete;

  void onPose(const lcm::ReceiveBuffer*, const std::string&, const pplvo_msgs::pose_t* msg) {
    try {
      // fromMsg validates the message (finite values, unit quaternion) and converts it into
      // pplvo's library type: T_w_c, T_prev_curr and the 6x6 covariance of T_prev_curr.
      const pplvo::FramePose p = pplvo::msgs::fromMsg(*msg);
      print(p);
      pplvo::StampedPose s;
      s.stamp_text = p.stamp;
      s.T_w_c = p.T_w_c;
      trajectory_.push_back(s);
      covariances_.push_back(p.rel_covariance);
    } catch (const std::exception& e) {
      ++invalid_;
      std::fprintf(stderr, "pose_listener: invalid pose_t dropped: %s\n", e.what());
    }
  }

  const pplvo::Trajectory& trajectory() const { return trajectory_; }
  int64_t invalid() const { return invalid_; }

  void writeCovariances(const std::string& path) const {
    std::ofstream out(path);
    out << "# stamp, rel_covariance (6x6 row-major over xi = [t; q_xyz] of T_prev_curr)\n";
    char buf[64];
    for (size_t i = 0; i < trajectory_.size(); ++i) {
      out << trajectory_[i].stamp_text;
      for (int k = 0; k < 36; ++k) {
        std::snprintf(buf, sizeof(buf), " %.9e", covariances_[i](k / 6, k % 6));
        out << buf;
      }
      out << '\n';
    }
    if (!out) throw std::runtime_error("cannot write " + path);
  }

 private:
  void print(const pplvo::FramePose& p) {
    // stdout may be a pipe that closes early (`| head -n 3`): printing stops, listening and
    // the files asked for (--tum, --covariance) go on.
    if (!stdout_open_) return;
    const Eigen::Vector3d t = p.T_w_c.translation();
    const Eigen::Quaterniond q(p.T_w_c.linear());
    // Standard deviations of the frame-to-frame motion: translation in mm, and the rotation
    // as an angle (q_xyz is half the small rotation vector) in degrees.
    const pplvo::Matrix6d& C = p.rel_covariance;
    std::printf(
        "pose %lld %s %-14s t_w_c [m] % .4f % .4f % .4f  q_w_c [w x y z] % .4f % .4f % .4f % .4f"
        "  sigma rel. t [mm] %.2f %.2f %.2f  rot [deg] %.3f %.3f %.3f\n",
        static_cast<long long>(p.seq), p.stamp.c_str(), pplvo::toString(p.status), t.x(), t.y(),
        t.z(), q.w(), q.x(), q.y(), q.z(), 1e3 * std::sqrt(C(0, 0)), 1e3 * std::sqrt(C(1, 1)),
        1e3 * std::sqrt(C(2, 2)), 2.0 * std::sqrt(C(3, 3)) * 180.0 / M_PI,
        2.0 * std::sqrt(C(4, 4)) * 180.0 / M_PI, 2.0 * std::sqrt(C(5, 5)) * 180.0 / M_PI);
    if (std::fflush(stdout) != 0) stdout_open_ = false;
  }

  lcm::LCM& lcm_;
  lcm::Subscription* sub_ = nullptr;
  pplvo::Trajectory trajectory_;
  std::vector<pplvo::Matrix6d> covariances_;
  int64_t invalid_ = 0;
  bool stdout_open_ = true;
};

struct Args {
  std::string url, log, memq_log, channel = "PPLVO_POSE", tum, covariance;
  long max_poses = 0;
  double idle_timeout_s = 0.0;
};

void usage() {
  std::fprintf(stderr,
               "usage: pose_listener [--url URL | --log FILE | --replay-memq FILE] "
               "[--channel CH] [--tum OUT] [--covariance OUT] [--max-poses N] "
               "[--idle-timeout S]\n");
}

Args parseArgs(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    const std::string k = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw std::invalid_argument(k + " needs a value");
      return argv[++i];
    };
    if (k == "--url")
      a.url = value();
    else if (k == "--log")
      a.log = value();
    else if (k == "--replay-memq")
      a.memq_log = value();
    else if (k == "--channel")
      a.channel = value();
    else if (k == "--tum")
      a.tum = value();
    else if (k == "--covariance")
      a.covariance = value();
    else if (k == "--max-poses")
      a.max_poses = std::stol(value());
    else if (k == "--idle-timeout")
      a.idle_timeout_s = std::stod(value());
    else
      throw std::invalid_argument("unknown option " + k);
  }
  if (!a.log.empty()) a.url = "file://" + a.log + "?speed=0";
  return a;
}

bool enough(const Args& a, const PoseListener& l) {
  return g_stop || (a.max_poses > 0 && static_cast<long>(l.trajectory().size()) >= a.max_poses);
}

/// Reads the log and publishes each event on the memq:// instance, handling after each one.
void replayOnMemq(const Args& a, lcm::LCM& lcm, const PoseListener& listener) {
  lcm::LogFile log(a.memq_log, "r");
  if (!log.good()) throw std::runtime_error("cannot read " + a.memq_log);
  while (const lcm::LogEvent* ev = log.readNextEvent()) {
    lcm.publish(ev->channel, ev->data, static_cast<unsigned>(ev->datalen));
    while (lcm.handleTimeout(0) > 0) {
    }
    if (enough(a, listener)) break;
  }
}

/// Handles messages until the end of a file:// log, --max-poses, --idle-timeout or Ctrl-C.
void spin(const Args& a, lcm::LCM& lcm, const PoseListener& listener) {
  double idle_s = 0.0;
  while (!enough(a, listener)) {
    const int rc = lcm.handleTimeout(100);
    if (rc < 0) break;  // end of a file:// log (or a broken provider)
    idle_s = rc > 0 ? 0.0 : idle_s + 0.1;
    if (a.idle_timeout_s > 0 && idle_s >= a.idle_timeout_s) break;
  }
}

}  // namespace

int main(int argc, char** argv) {
  Args a;
  try {
    a = parseArgs(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "pose_listener: %s\n", e.what());
    usage();
    return 2;
  }
  std::signal(SIGINT, onSignal);
  std::signal(SIGTERM, onSignal);
  // A reader of stdout that exits (`| head`) must not kill the listener before it writes --tum.
  std::signal(SIGPIPE, SIG_IGN);
  try {
    lcm::LCM lcm(a.memq_log.empty() ? a.url : std::string("memq://"));
    if (!lcm.good()) throw std::runtime_error("cannot open LCM URL '" + a.url + "'");
    PoseListener listener(lcm, a.channel);
    if (a.memq_log.empty()) {
      spin(a, lcm, listener);
    } else {
      replayOnMemq(a, lcm, listener);
    }
    if (!a.tum.empty()) pplvo::writeTumTrajectory(a.tum, listener.trajectory());
    if (!a.covariance.empty()) listener.writeCovariances(a.covariance);
    std::fprintf(stderr, "pose_listener: %zu poses, %lld invalid\n", listener.trajectory().size(),
                 static_cast<long long>(listener.invalid()));
    return listener.invalid() > 0 ? 1 : 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "pose_listener: %s\n", e.what());
    return 1;
  }
}
