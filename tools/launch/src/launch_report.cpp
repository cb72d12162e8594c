#include "pplvo/launch/launch_report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <regex>
#include <sstream>

namespace pplvo::launch {

bool DrainMonitor::drained(double now_s, int64_t poses, int64_t published) {
  if (poses != last_poses_) {
    last_poses_ = poses;
    last_change_s_ = now_s;
  }
  if (published >= 0 && poses >= published) {
    all_posed_ = true;
    return true;
  }
  return now_s - last_change_s_ >= idle_s_;
}

int64_t LaunchReport::droppedTotal() const {
  int64_t n = 0;
  for (const Process& p : processes) {
    if (p.has_counts && p.counts.known) n += p.counts.frames_dropped;
  }
  return n;
}

std::string LaunchReport::text() const {
  std::ostringstream out;
  char buf[512];
  std::snprintf(buf, sizeof buf, "pplvo-launch report (%s, %s, %.2f s wall)\n",
                lockstep ? "lockstep" : "free-running", url.c_str(), wall_s);
  out << buf;
  std::snprintf(buf, sizeof buf, "  %-20s %-34s %7s %7s %8s %8s %8s %7s %9s %7s\n", "process",
                "ended", "in", "out", "dropped", "skipped", "pending", "lost", "msg-skip",
                "errors");
  out << buf;
  for (const Process& p : processes) {
    std::string ended = p.exit ? p.exit->text() : "still running";
    if (p.killed)
      ended += " after SIGKILL";
    else if (p.stop_requested && p.exit)
      ended += " (stopped)";
    if (p.has_counts && p.counts.known && !p.counts.final) ended += ", counts not final";
    if (p.has_counts && p.counts.known) {
      const NodeCounts& c = p.counts;
      std::snprintf(buf, sizeof buf,
                    "  %-20s %-34s %7lld %7lld %8lld %8lld %8lld %7lld %9lld %7lld\n",
                    p.name.c_str(), ended.c_str(), static_cast<long long>(c.frames_in),
                    static_cast<long long>(c.frames_out), static_cast<long long>(c.frames_dropped),
                    static_cast<long long>(c.frames_skipped),
                    static_cast<long long>(c.frames_pending), static_cast<long long>(c.frames_lost),
                    static_cast<long long>(c.messages_skipped), static_cast<long long>(c.errors));
    } else {
      std::snprintf(buf, sizeof buf, "  %-20s %-34s %7s %7s %8s %8s %8s %7s %9s %7s\n",
                    p.name.c_str(), ended.c_str(), "-", "-", "-", "-", "-", "-", "-", "-");
    }
    out << buf;
  }
  // Frames the RGB-D subscribers never received (lost in transport or not yet published).
  const Process* player = nullptr;
  for (const Process& p : processes) {
    if (p.name == kPlayer) player = &p;
  }
  int64_t not_received = 0;
  bool transport_known = false;
  if (player && player->counts.known) {
    for (const Process& p : processes) {
      if ((p.name == kDepthFilter || p.name == kFrontend) && p.counts.known) {
        not_received += std::max<int64_t>(0, player->counts.frames_out - p.counts.frames_in);
        transport_known = true;
      }
    }
  }
  out << "launch.frames_published: " << frames_published << "\n";
  out << "launch.poses_seen: " << poses_seen << "\n";
  out << "launch.trajectory_poses: " << trajectory_poses << "  # " << trajectory_path << "\n";
  out << "launch.dropped_total: " << droppedTotal()
      << "  # sum of frames_dropped over nodes (a frame dropped upstream may count again "
         "downstream)\n";
  if (frames_published >= 0 && trajectory_poses >= 0) {
    out << "launch.frames_without_pose: "
        << std::max<int64_t>(0, frames_published - trajectory_poses)
        << "  # published minus trajectory poses\n";
  }
  if (transport_known) {
    out << "launch.frames_not_received: " << not_received
        << "  # player out minus depth-filter/frontend in\n";
  }
  if (overload_fusions >= 0) {
    out << "launch.overload_fusions: " << overload_fusions
        << "  # frames the depth filter fused over a shortened window to catch up\n";
  }
  if (lockstep && player && player->counts.known) {
    out << "launch.lockstep_timeouts: " << player->counts.errors
        << "  # poses the player gave up waiting for (player errors)\n";
  }
  out << "launch.restarts: " << restarts << "\n";
  for (const std::string& f : faults()) out << "launch.fault: " << f << "\n";
  out << "launch.wall_s: " << wall_s << "\n";
  out << "launch.result: " << result() << "\n";
  for (const std::string& f : failures) out << "launch.failure: " << f << "\n";
  return out.str();
}

std::string progressLine(int64_t published, int64_t posed, int64_t dropped, double elapsed_s) {
  char buf[160];
  if (published <= 0) {
    std::snprintf(buf, sizeof buf, "[pplvo-launch] %lld posed, %.1f s",
                  static_cast<long long>(posed), elapsed_s);
  } else {
    std::snprintf(buf, sizeof buf,
                  "[pplvo-launch] %lld frames published, %lld posed (%.0f %%), %lld dropped, %.1f s",
                  static_cast<long long>(published), static_cast<long long>(posed),
                  100.0 * static_cast<double>(posed) / static_cast<double>(published),
                  static_cast<long long>(dropped), elapsed_s);
  }
  return buf;
}

std::vector<std::string> LaunchReport::faults() const {
  std::vector<std::string> f;
  char buf[256];
  for (const Process& p : processes) {
    if (p.pauses > 0) {
      std::snprintf(buf, sizeof buf, "%s paused %d time(s), %.1f s in all", p.name.c_str(),
                    p.pauses, p.paused_s);
      f.push_back(buf);
    }
    if (p.has_counts && p.counts.known && !p.counts.addsUp()) {
      f.push_back(p.name + "'s counts do not add up (in " + std::to_string(p.counts.frames_in) +
                  " != out + dropped + skipped + pending): a status from another program?");
    }
    if (p.has_counts && p.counts.stray_frames > 0) {
      f.push_back(p.name + " skipped " + std::to_string(p.counts.stray_frames) +
                  " stray frame(s) (forged, or a second source on the frame channel)");
    }
    if (p.has_counts && p.counts.blocked_publishes > 0) {
      std::snprintf(buf, sizeof buf,
                    "%s: %lld publish(es) blocked, up to %.0f ms (a link or receiver slower than "
                    "the data; docs/networking.md)",
                    p.name.c_str(), static_cast<long long>(p.counts.blocked_publishes),
                    p.counts.blocked_publish_max_ms);
      f.push_back(buf);
    }
    if (p.exit && !p.stop_requested && !p.exit->clean()) {
      f.push_back(p.name + " ended early (" + p.exit->text() + ")" +
                  (p.restarted ? ", restarted" : ""));
    }
  }
  return f;
}

int64_t LaunchReport::framesWithoutPose() const {
  if (frames_published < 0 || trajectory_poses < 0) return -1;
  return std::max<int64_t>(0, frames_published - trajectory_poses);
}

void LaunchReport::takePlayerCounts() {
  for (const auto& p : processes) {
    if (frames_published < 0 && p.name == kPlayer && p.counts.known) {
      frames_published = p.counts.frames_out;
    }
  }
  if (lockstep) {
    // A pose the player stopped waiting for was lost (UDP loss, a dead node): the lockstep
    // promise (trajectory equal to pplvo-run's) no longer holds, so the launch fails.
    for (const auto& p : processes) {
      if (p.name == kPlayer && p.counts.known && p.counts.errors > 0) {
        failures.push_back(std::to_string(p.counts.errors) +
                           " lockstep timeout(s): poses lost (receive buffers too small? see "
                           "docs/launch.md)");
      }
    }
  }
}

std::string LaunchReport::result() const {
  if (!ok()) return "FAILED";
  return framesWithoutPose() > 0 ? "degraded" : "ok";
}

void LaunchReport::checkLoggerKeptEveryPose() {
  if (trajectory_poses < 0 || trajectory_poses >= poses_seen) return;
  failures.push_back("the logger's trajectory has " + std::to_string(trajectory_poses) +
                     " of the " + std::to_string(poses_seen) + " poses the launch saw");
}

void LaunchReport::checkFramesLostToFaults() {
  const std::vector<std::string> f = faults();
  const int64_t lost = framesWithoutPose();
  if (f.empty() || lost == 0) return;
  std::string why = f.front();
  for (size_t i = 1; i < f.size(); ++i) why += "; " + f[i];
  failures.push_back("frames lost to a fault: " +
                     (lost < 0 ? std::string("unknown number") : std::to_string(lost)) + " of " +
                     std::to_string(frames_published) + " published frames without pose (" + why +
                     ")");
}

int64_t countTrajectoryLines(const std::string& path) {
  std::ifstream in(path);
  if (!in) return -1;
  int64_t n = 0;
  for (std::string line; std::getline(in, line);) {
    const size_t first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    ++n;
  }
  return n;
}

std::string tailOfFile(const std::string& path, int max_lines) {
  std::ifstream in(path);
  if (!in) return {};
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) {
    lines.push_back(line);
    if (static_cast<int>(lines.size()) > max_lines) lines.erase(lines.begin());
  }
  std::string s;
  for (const std::string& l : lines) s += l + "\n";
  return s;
}

}  // namespace pplvo::launch
