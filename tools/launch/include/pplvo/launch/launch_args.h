#pragma once
/// pplvo-launch's command line: the programs it starts, its options, their parsing with every
/// error reported together, and the test faults (docs/launch.md).
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace pplvo::launch {

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
  std::string camera_file;           ///< --camera: camera file for a folder without calibration
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
  bool compress = false;    ///< --compress: lossless compressed images and depth maps
  /// --log-mode compact: the player sends JPEG colour and zlib depth, and --log keeps only
  /// msgs channels::kCompactLogChannels (docs/logger.md, "Compact recordings").
  bool compact_log = false;
  bool single_url = false;  ///< --single-url: frame channels on the main URL too
  /// --preload / --no-preload: the player decodes the frames before publishing the first
  /// (default: on when free-running, where decoding would compete with the pipeline).
  std::optional<bool> preload;
  bool quiet = false;  ///< --quiet: report only
  /// --progress / --no-progress: a progress line on stderr while the sequence plays (default:
  /// when stderr is a terminal and not --quiet).
  std::optional<bool> progress;
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

}  // namespace pplvo::launch
