#pragma once
/// pplvo-launch without LCM: command line, LCM URL policy, the node command lines, the drain
/// rule, per-stage counts and the report. The LCM monitoring lives in app/pplvo_launch_main.cpp.
/// See docs/launch.md.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "pplvo/launch/supervisor.h"

namespace pplvo::launch {

/// The LCM URL used inside an isolated namespace when --lcm-url is not given
/// (LCM's default group and port, ttl=0: multicast looped back on lo only).
inline constexpr const char* kIsolatedUrl = "udpm://239.255.76.67:7667?ttl=0";

/// Names of the programs, in start order (the player last).
inline constexpr const char* kDepthFilter = "pplvo-depth-filter";
inline constexpr const char* kFrontend = "pplvo-frontend";
inline constexpr const char* kEstimator = "pplvo-estimator";
inline constexpr const char* kLogger = "pplvo-logger";
inline constexpr const char* kPlayer = "pplvo-player";
/// The nodes that publish node_status_t (the logger publishes nothing).
const std::vector<std::string>& statusNodes();
/// Every program the launch needs, start order.
const std::vector<std::string>& allPrograms();

struct LaunchOptions {
  std::string dataset_dir;           ///< --dataset (required)
  std::string output;                ///< --output: TUM trajectory written by the logger (required)
  bool lockstep = false;             ///< --lockstep: player waits for pose k before frame k+2
  int lockstep_in_flight = 2;        ///< --lockstep-in-flight: frames out without their pose
  double rate = 1.0;                 ///< --rate: player speed (1 real time, 0 as fast as possible)
  double lockstep_timeout_s = 10.0;  ///< --lockstep-timeout: player's wait per pose
  std::string config;                ///< --config: pipeline YAML for frontend and estimator
  std::string features;              ///< --features: points,lines,planes subset
  std::vector<std::string> set;      ///< --set KEY=VALUE (repeatable): frontend and estimator
  std::string depth_model;           ///< --depth-model: sensor | cgm | ogm (depth filter)
  int64_t max_frames = 0;            ///< --max-frames (0: all)
  double fps = 0.0;                  ///< --fps: frame rate of integer-stamped datasets
  std::string log;                   ///< --log: LCM event log of every PPLVO_ channel (logger)
  std::string summary;               ///< --summary: logger's YAML run summary
  std::string lcm_url;               ///< --lcm-url (empty: $LCM_DEFAULT_URL, or kIsolatedUrl)
  bool isolated = false;             ///< --isolated: private user+network namespace
  std::string bin_dir;               ///< --bin-dir (empty: the directory of pplvo-launch)
  std::string node_log_dir;          ///< --node-logs: per-process stdout/stderr (empty: temp dir)
  double timeout_s = 3600.0;         ///< --timeout: whole launch, seconds (always bounded)
  double startup_timeout_s = 20.0;   ///< --startup-timeout: wait for each node's first status
  double drain_idle_s = 2.0;         ///< --drain-idle: no new pose for this long ends the drain
  double stop_grace_s = 5.0;         ///< --stop-grace: SIGINT -> SIGKILL delay
  std::string test_kill;             ///< --test-kill NODE:POSES: SIGKILL NODE after POSES poses
  /// --test-pause NODE:POSES:SECONDS: SIGSTOP NODE after POSES poses, SIGCONT SECONDS later
  std::string test_pause;
  bool compress = false;             ///< --compress: lossless compressed images and depth maps
  bool single_url = false;           ///< --single-url: frame channels on the main URL too
  /// --preload / --no-preload: the player decodes the frames before publishing the first
  /// (default: on when free-running, where decoding would compete with the pipeline).
  std::optional<bool> preload;
  bool quiet = false;                ///< --quiet: report only
  /// --restart N: a depth filter, frontend or estimator that dies is started again, at most N
  /// times per stage (0: a dead stage fails the launch), after --restart-backoff seconds,
  /// doubled on each restart of the same stage.
  int restart_limit = 0;
  double restart_backoff_s = 0.5;  ///< --restart-backoff
};

struct ParsedArgs {
  LaunchOptions options;
  std::vector<std::string> errors;  ///< every problem found, reported together
  bool help = false;
};
ParsedArgs parseLaunchArgs(const std::vector<std::string>& args);
std::string launchUsage();

/// --test-kill NODE:POSES and --test-pause NODE:POSES:SECONDS taken apart (their form was
/// checked by parseLaunchArgs); a fault not asked for has after_poses -1.
struct TestFaultPlan {
  std::string kill_node;
  int64_t kill_after_poses = -1;
  std::string pause_node;
  int64_t pause_after_poses = -1;
  double pause_s = 0.0;
};
TestFaultPlan planTestFaults(const LaunchOptions& o);

/// The programs of allPrograms() that `bin_dir` lacks or cannot run, each as "PATH: why".
std::vector<std::string> missingPrograms(const std::string& bin_dir);

/// An LCM provider URL taken apart (only what the policy needs).
struct LcmUrl {
  std::string provider;  ///< "udpm", "memq", "file", ...
  std::string address;   ///< udpm: multicast group, e.g. 239.255.76.67
  int port = 0;          ///< udpm: port (LCM's default 7667)
  int ttl = 0;           ///< udpm: ttl option (LCM's default 0)
  bool valid = false;
  std::string error;
};
LcmUrl parseLcmUrl(const std::string& url);

/// The URL policy. Separate processes need udpm (memq:// is one process, file:// is not a
/// bus). With --isolated the URL must be a udpm multicast group with ttl=0 (a "loopback"
/// URL: traffic stays on lo of the private namespace); otherwise a ttl > 0 gives a warning.
struct UrlDecision {
  std::string url;                    ///< URL handed to every process
  /// "CHANNEL=URL" for each per-frame data channel (see frameChannelRoutes); empty with
  /// --single-url.
  std::vector<std::string> routes;
  bool compress = false;              ///< the receive buffers are too small for raw frames
  std::vector<std::string> errors;    ///< refuse to run
  std::vector<std::string> warnings;  ///< print and run
};
/// A udpm URL without `recv_buf_size` gets one: min(`rmem_max_bytes`, 16 MiB) (the kernel
/// caps SO_RCVBUF at net.core.rmem_max; LCM's default, the kernel's 208 KiB, loses the
/// fragments of 1.5 MB frames). Below 2 MiB compression is switched on (`compress`).
/// `rmem_max_bytes` < 0: unknown, the URL is left alone.
UrlDecision decideLcmUrl(const LaunchOptions& o, const char* env_lcm_default_url,
                         int64_t rmem_max_bytes = -1);
/// The per-frame data channels on ports of their own in `udpm_url`'s group, with the same
/// options, as "CHANNEL=URL": PPLVO_RGBD on port + 1, PPLVO_DEPTH_CGM + 2, PPLVO_DEPTH_FUSED
/// + 3, PPLVO_FEATURES and PPLVO_FEATURES_3D + 4. Only the processes that subscribe to a
/// channel join its port: the estimator, player, logger and launcher then never receive the
/// ~6.5 MB of images and depth maps of a 640x480 frame, nor the depth filter its own maps or
/// the ~290 KB of features; the main URL keeps poses, statuses and stream events. Empty with
/// an error when the ports would pass 65535.
std::vector<std::string> frameChannelRoutes(const std::string& udpm_url, std::string* error);

/// net.core.rmem_max of the current network namespace (-1 if unreadable).
int64_t readRmemMax();
/// Receive buffer below which raw 640x480 frames lose fragments (measured: 2 MiB worked,
/// 1 MiB lost frames in lockstep).
inline constexpr int64_t kMinRawRecvBufBytes = 2 << 20;
/// Below this even compressed 640x480 frames lose fragments (1 MiB worked, 512 KiB did not).
inline constexpr int64_t kMinCompressedRecvBufBytes = 1 << 20;

/// Builds the five process specs (binaries in `bin_dir`, logs in `log_dir`), start order:
/// depth filter, frontend, estimator, logger, player.
/// Every process gets `--lcm-url url.url` and one `--route` per entry of `url.routes`.
std::vector<ProcessSpec> buildProcessSpecs(const LaunchOptions& o, const UrlDecision& url,
                                           const std::string& bin_dir, const std::string& log_dir);

/// Counters of one node: its final node_status_t or its "done:" line.
struct NodeCounts {
  int64_t frames_in = 0, frames_out = 0, frames_dropped = 0, frames_skipped = 0, errors = 0;
  bool known = false;
  std::string source;  ///< "status" or "done line"
};

/// Parses "[pplvo-frontend] done: in 30 out 30 dropped 0 skipped 0" from a node's log
/// (the last such line wins); the player's "published N frames, skipped M" line too.
std::optional<NodeCounts> parseDoneLine(const std::string& log_text, const std::string& node);

/// Parses "[pplvo-depth-filter] overload: N fusions over a shortened window ..." (the depth
/// filter's load shedding, its last such line); -1 when the log has none.
int64_t parseOverloadFusions(const std::string& log_text);

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
  /// Once the processes are in: frames_published from the player's final counts when no END
  /// event gave it (frames_published < 0), and with `lockstep` a failure when the player
  /// counted lockstep timeouts (poses lost: the trajectory is no longer pplvo-run's).
  void takePlayerCounts();
  bool ok() const { return failures.empty(); }
  /// Table plus "launch.key: value" lines for scripts.
  std::string text() const;
};

/// Counts the pose lines of a TUM trajectory file (comments and blank lines excluded);
/// -1 when it cannot be read.
int64_t countTrajectoryLines(const std::string& path);

/// The last `max_lines` lines of a file (for failure messages).
std::string tailOfFile(const std::string& path, int max_lines);

/// Result of entering a private network namespace.
struct IsolationResult {
  bool ok = false;
  bool unavailable = false;  ///< the kernel refused the namespace (EPERM/EINVAL/ENOSPC...)
  std::string detail;        ///< what was done or why it failed
};

/// Moves the calling (single-threaded!) process into a new network namespace whose only
/// interface, lo, is up with multicast on and a 224.0.0.0/4 route: what scripts/isolated.sh
/// does with `unshare -rn` + `ip`, but in-process (unshare(2) + ioctl), so no external tool is
/// needed. As root only CLONE_NEWNET is used; otherwise (or if that is refused) a user
/// namespace mapping the caller's own uid/gid comes with it. Children inherit both.
IsolationResult enterIsolatedNetwork();

}  // namespace pplvo::launch
