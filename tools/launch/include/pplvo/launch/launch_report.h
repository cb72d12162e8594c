#pragma once
/// What a launch reports: the drain rule, each process's counts and faults, the result and its
/// reasons, as a table and "launch.key: value" lines for scripts (docs/launch.md).
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "pplvo/launch/launch_args.h"
#include "pplvo/launch/supervisor.h"

namespace pplvo::launch {

/// Counters of one process, from the node_status_t messages it published (matched by pid, so
/// that a restarted stage's processes stay apart): the last one, which is the process's final
/// word when it says so (node_status_t.final: published as it exits).
struct NodeCounts {
  int64_t frames_in = 0, frames_out = 0, frames_dropped = 0, frames_skipped = 0, errors = 0;
  int64_t frames_pending = 0;    ///< still queued when the status was sent
  int64_t frames_lost = 0;       ///< never reached the process (numbering gaps)
  int64_t messages_skipped = 0;  ///< its other inputs' messages that served no frame
  bool known = false;  ///< a status came from the process
  bool final = false;  ///< ... and its last one was its final status
  /// Frames the depth filter fused over a shortened window (its "ogm_shortened" stage count).
  int64_t shortened_fusions = 0;
  /// Frames on PPLVO_RGBD not of the followed stream (forged, a second source), skipped (its
  /// "stray_frame" stage count; msgs::FrameSourceGuard).
  int64_t stray_frames = 0;
  /// Publishes that blocked on a slow link (the "publish_blocked:CHANNEL" stages) and the
  /// longest, ms.
  int64_t blocked_publishes = 0;
  double blocked_publish_max_ms = 0.0;

  /// in = out + dropped + skipped + pending, as every pplvo process keeps them
  /// (msgs::FrameLedger); false means a status from something else, or a bug.
  bool addsUp() const {
    return frames_in == frames_out + frames_dropped + frames_skipped + frames_pending;
  }
};

/// Decides when the pipeline has drained after the player ended: every published frame has
/// its pose, or no new pose arrived for `idle_s`.
class DrainMonitor {
 public:
  explicit DrainMonitor(double idle_s) : idle_s_(idle_s) {}
  /// `now_s` any monotonic seconds; `poses` seen so far; `published` frames (< 0: unknown).
  bool drained(double now_s, int64_t poses, int64_t published);
  bool allPosed() const { return all_posed_; }

 private:
  double idle_s_;
  int64_t last_poses_ = -1;
  double last_change_s_ = 0.0;
  bool all_posed_ = false;
};

/// Everything the report shows.
/// The progress line while the sequence plays (without "\r"): "[pplvo-launch] 120 frames
/// published, 118 posed (98 %), 2 dropped, 4.0 s". `published` < 0: not known yet.
std::string progressLine(int64_t published, int64_t posed, int64_t dropped, double elapsed_s);

struct LaunchReport {
  struct Process {
    std::string name;
    std::optional<ExitInfo> exit;
    bool stop_requested = false, killed = false;
    NodeCounts counts;
    bool has_counts = false;  ///< false for the logger
    int pauses = 0;           ///< times it was stopped (SIGSTOP: by anyone) and continued
    double paused_s = 0.0;    ///< time it spent stopped
    bool restarted = false;   ///< it died and --restart started the stage again
  };
  std::vector<Process> processes;
  int64_t frames_published = -1;  ///< from the player's END event or final status (-1 unknown)
  int64_t poses_seen = 0;         ///< pose_t messages the launcher saw
  int64_t trajectory_poses = -1;  ///< lines in the trajectory file (-1: not readable)
  std::string trajectory_path;
  int64_t overload_fusions = -1;  ///< depth filter's shortened fusions (-1: not reported)
  int restarts = 0;               ///< stages started again by --restart
  double wall_s = 0.0;
  bool lockstep = false;
  std::string url;
  std::vector<std::string> failures;  ///< why the launch failed (empty: success)

  int64_t droppedTotal() const;
  /// The faults of the processes (pauses, deaths that were not a requested stop), one line
  /// each, e.g. "pplvo-frontend paused 1 time(s), 2.0 s in all"; empty when none.
  std::vector<std::string> faults() const;
  /// Published frames without a pose in the trajectory (-1: unknown).
  int64_t framesWithoutPose() const;
  /// Adds the failure "frames lost to a fault" when there were faults() and frames without
  /// pose: a pipeline that recovered still lost them, the launch is not ok.
  void checkFramesLostToFaults();
  /// Adds a failure when the logger's trajectory holds fewer poses than the launch saw on the
  /// bus: the recording lost poses the pipeline gave.
  void checkLoggerKeptEveryPose();
  /// Once the processes are in: frames_published from the player's final counts when no END
  /// event gave it (frames_published < 0), and with `lockstep` a failure when the player
  /// counted lockstep timeouts (poses lost: the trajectory is no longer pplvo-run's).
  void takePlayerCounts();
  bool ok() const { return failures.empty(); }
  /// "FAILED" (failures), "degraded" (no failure, but published frames without a pose: a
  /// free-running launch that could not keep up) or "ok".
  std::string result() const;
  /// Table plus "launch.key: value" lines for scripts.
  std::string text() const;
};

/// Counts the pose lines of a TUM trajectory file (comments and blank lines excluded);
/// -1 when it cannot be read.
int64_t countTrajectoryLines(const std::string& path);

/// The last `max_lines` lines of a file (for failure messages).
std::string tailOfFile(const std::string& path, int max_lines);

}  // namespace pplvo::launch
