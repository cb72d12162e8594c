#pragma once
/// pplvo-player: publishes a TUM-layout RGB-D folder as rgbd_frame_t messages. A thin LCM
/// node over pplvo_dataset; usage and channels in docs/player.md.
#include <cstdint>
#include <functional>
#include <lcm/lcm-cpp.hpp>
#include <pplvo_msgs/camera_info_t.hpp>
#include <pplvo_msgs/image_t.hpp>
#include <pplvo_msgs/pose_t.hpp>
#include <pplvo_msgs/rgbd_frame_t.hpp>
#include <string>
#include <vector>

#include "pplvo/core/stage_timer.h"
#include "pplvo/dataset/dataset.h"
#include "pplvo/msgs/bus.h"
#include "pplvo/msgs/channels.h"
#include "pplvo/msgs/convert.h"
#include "pplvo/msgs/frame_ledger.h"

namespace pplvo::player {

struct PlayerOptions {
  std::string dataset_dir;                     ///< --dataset (required)
  std::string camera_file;                     ///< --camera: YAML (or .xml) camera file
  std::string lcm_url;                         ///< --lcm-url; empty: $LCM_DEFAULT_URL
  std::vector<msgs::ChannelRoute> routes;      ///< --route: channels carried by other URLs
  std::string channel = channels::kRgbd;       ///< --channel
  std::string pose_channel = channels::kPose;  ///< --pose-channel (lockstep replies)
  std::string stream_channel = channels::kStream;
  std::string status_channel = channels::kStatus;
  /// --rate: 1 = real time from the stamps, 2 = twice as fast, 0 = as fast as possible.
  double rate = 1.0;
  /// --fps: fixed publish rate (Hz) instead of the stamps (still scaled by --rate); also the
  /// frame rate of datasets whose stamps are frame indices. 0 = from the stamps.
  double fps = 0.0;
  bool lockstep = false;            ///< --lockstep
  double lockstep_timeout_s = 5.0;  ///< --lockstep-timeout
  /// --lockstep-in-flight: frames published ahead of the last pose in lockstep. 2 lets the
  /// frontend extract frame k+1 while frame k is fused and lifted; the results are the same.
  int lockstep_in_flight = 2;
  /// Every subscriber runs in this thread (memq://, pplvo-run): a lockstep wait dispatches
  /// what is queued and ends when nothing is left, since nothing else can publish.
  bool in_process = false;
  /// In process: called when the queue is empty during a lockstep wait, for work the nodes run
  /// off this thread (pplvo-run's fusion and extraction workers). It waits for some of it to
  /// finish and publishes the results; false when none is running (the wait then ends).
  std::function<bool()> in_process_idle;
  int64_t start = 0;         ///< --start: first associated frame
  int64_t max_frames = 0;    ///< --max-frames: 0 = all
  double max_depth_m = 0.0;  ///< --max-depth-m: 0 = no limit
  bool skip_bad = false;     ///< --skip-bad
  int8_t rgb_encoding = pplvo_msgs::image_t::ENCODING_RAW_BGR8;   ///< --rgb-encoding raw|jpeg|png
  int8_t depth_encoding = pplvo_msgs::image_t::ENCODING_RAW_U16;  ///< --depth-encoding raw|zlib|png
  int jpeg_quality = 90;                                          ///< --jpeg-quality
  bool loop = false;                                              ///< --loop
  /// --preload: decode frames (up to --max-frames) before publishing the first, so that PNG
  /// decoding does not compete with the pipeline for the CPU (a camera delivers decoded
  /// frames); beyond `preload_max_mb` of decoded images the rest is decoded while playing.
  bool preload = false;
  int64_t preload_max_mb = 2048;  ///< --preload-max-mb
  bool progress = false;          ///< progress line on stderr (main: isatty)
  double status_period_s = 1.0;   ///< node_status_t period
  /// A frame later than this behind schedule re-anchors the clock (no catch-up burst), s.
  double max_lag_s = 0.5;
  std::string node_name = "pplvo-player";
};

/// Parsed command line: options plus every error found (reported together).
struct ParseResult {
  PlayerOptions options;
  std::vector<std::string> errors;
  bool help = false;
};
ParseResult parsePlayerArgs(const std::vector<std::string>& args);
std::string playerUsage();

/// The progress line (without "\r"): "[name] done/total frames, R frames/s, ETA m:ss,
/// skipped S". With total <= 0 (unknown: --loop) the total and the ETA are left out.
std::string progressLine(const std::string& name, int64_t done, int64_t total, double elapsed_s,
                         int64_t skipped);

/// What a run did.
struct PlayerResult {
  int64_t published = 0;
  int64_t skipped = 0;  ///< bad frames skipped (--skip-bad) or unencodable
  int64_t lockstep_timeouts = 0;
  int64_t loops = 0;  ///< completed passes over the dataset with --loop
  double elapsed_s = 0.0;
  bool interrupted = false;  ///< stopped by SIGINT/SIGTERM
  bool failed = false;       ///< fatal error (e.g. corrupt frame without --skip-bad)
  std::string error;
  /// Exit status of the process: 0 on success or interruption, 1 on a fatal error.
  int exitCode() const { return failed ? 1 : 0; }
  /// "published 251 frames, skipped 0, 3.20 s, 78.4 frames/s"
  std::string summaryLine() const;
};

class PlayerNode {
 public:
  /// Opens the dataset (throws dataset::DatasetError on a missing folder, index or camera)
  /// and subscribes to the pose channel when in lockstep.
  PlayerNode(const PlayerOptions& options, msgs::Bus bus);
  PlayerNode(const PlayerNode&) = delete;
  PlayerNode& operator=(const PlayerNode&) = delete;
  ~PlayerNode();

  /// Publishes the stream. Never throws: failures are returned in the result.
  PlayerResult run();

  const dataset::Dataset& dataset() const { return dataset_; }
  const msgs::NodeCounters& counters() const { return counters_; }
  const StageTimings& timings() const { return timings_; }

 private:
  void onPose(const lcm::ReceiveBuffer* rbuf, const std::string& channel,
              const pplvo_msgs::pose_t* msg);
  void runLoop(PlayerResult& result);
  /// Counts (and reports) the frames the reader skipped since `*skipped_before`.
  void countSkipped(const dataset::ReadStats& stats, int64_t* skipped_before);
  /// The frame as a message; false when encoding failed (counted by msgs::guarded).
  bool encodeFrame(const dataset::DatasetReader::Item& item, const dataset::DatasetEntry& entry,
                   int64_t utime, const pplvo_msgs::camera_info_t& camera_msg,
                   pplvo_msgs::rgbd_frame_t* msg);
  /// Publishes the frame and counts it.
  void publishFrame(const pplvo_msgs::rgbd_frame_t& msg);
  void publishStream(int8_t event, const PlayerResult& result);
  void periodic(bool force);
  void drain();
  /// In process with nothing queued: whether in_process_idle published a worker's result.
  bool inProcessWorkPublished() const {
    return options_.in_process_idle && options_.in_process_idle();
  }
  void waitUntil(double target_s);
  bool waitForPose(int64_t seq);
  /// Waits (dispatching messages) for the pose of `seq`; counts and reports a timeout.
  void lockstepWait(int64_t seq, PlayerResult& result);
  double nowS() const;

  PlayerOptions options_;
  msgs::Bus bus_;
  dataset::Dataset dataset_;
  msgs::BusSubscription pose_sub_;
  msgs::NodeCounters counters_;
  msgs::FrameLedger ledger_{counters_};  ///< each frame read: published, skipped or dropped
  StageTimings timings_;
  int64_t last_pose_seq_ = -1;
  double start_s_ = 0.0;
  double last_status_s_ = -1e9;
  double last_progress_s_ = -1e9;
  int64_t published_ = 0;
};

}  // namespace pplvo::player
