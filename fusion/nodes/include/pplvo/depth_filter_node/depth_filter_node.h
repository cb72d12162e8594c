#pragma once
/// pplvo-depth-filter: the paper's probabilistic depth filter (section 3) as an LCM process.
///
/// | channel (default)   | type          | direction | content                                  |
/// |---------------------|---------------|-----------|------------------------------------------|
/// | PPLVO_RGBD          | rgbd_frame_t  | in        | frames                                   |
/// | PPLVO_POSE          | pose_t        | in        | T_w_c of a frame + window uncertainties  |
/// | PPLVO_DEPTH_CGM     | depth_map_t   | out       | stage 1 or 2, at once on each frame      |
/// | PPLVO_DEPTH_FUSED   | depth_map_t   | out       | O-GM on the frame's pose (or C-GM copy)  |
/// | PPLVO_STATUS        | node_status_t | out       | once a second                            |
#include <chrono>
#include <cstdint>
#include <deque>
#include <future>
#include <lcm/lcm-cpp.hpp>
#include <optional>
#include <pplvo_msgs/pose_t.hpp>
#include <pplvo_msgs/rgbd_frame_t.hpp>
#include <string>
#include <vector>

#include "pplvo/core/frame_pose.h"
#include "pplvo/core/stage_timer.h"
#include "pplvo/depth_filter/cgm_filter.h"
#include "pplvo/depth_filter/depth_filter_options.h"
#include "pplvo/depth_filter/depth_model.h"
#include "pplvo/depth_filter/depth_time_alignment.h"
#include "pplvo/depth_filter/measurement_stages.h"
#include "pplvo/depth_filter/ogm_fusion.h"
#include "pplvo/msgs/bus.h"
#include "pplvo/msgs/channels.h"
#include "pplvo/msgs/convert.h"
#include "pplvo/msgs/frame_ledger.h"
#include "pplvo/msgs/frame_source_guard.h"

namespace pplvo::nodes {

using depth_filter::DepthModel;
using depth_filter::parseDepthModel;

struct DepthFilterNodeOptions {
  std::string lcm_url;                     ///< empty: $LCM_DEFAULT_URL
  std::vector<msgs::ChannelRoute> routes;  ///< --route: channels carried by other URLs
  std::string rgbd_channel = channels::kRgbd;
  std::string pose_channel = channels::kPose;
  std::string cgm_channel = channels::kDepthCgm;
  std::string fused_channel = channels::kDepthFused;
  std::string status_channel = channels::kStatus;
  /// Frames waiting for their pose (1 s at 30 Hz); older ones are dropped and counted.
  int max_pending = 30;
  bool compress = false;  ///< ZLIB_F32 instead of RAW_F32 on the outputs
  /// A frame whose depth is moved to the colour instant (filter.time_alignment) needs the pose
  /// of the frame two before it (DepthTimeAligner::kPoseLag). In a lockstep pipeline that pose
  /// was published before the frame, but it comes on another channel (and port) and may be
  /// handled after it: the frame then waits for it, at most this long (ms) and never while
  /// more than max_deferred frames wait, so every layout moves the depth by the same motion and
  /// a dead estimator costs only the wait.
  int max_alignment_wait_ms = 100;
  int max_deferred = 3;
  /// O-GM on a worker thread: a pose's handler queues the fusion and returns, and the fused
  /// map is published, in frame order, by poll() or publishFusions() once it is done. For
  /// nodes sharing one thread (pplvo-run): frame k is fused while frame k+1 is posed. The
  /// maps are the same either way.
  bool fuse_on_worker = false;
  /// The algorithm's options: the `depth_filter` section of the configuration (model, sensor,
  /// cgm, ogm, overload; pplvo/depth_filter/depth_filter_options.h). With model sensor or cgm
  /// the PPLVO_DEPTH_FUSED output is the stage-1/2 map, unchanged. pplvo-run and lockstep
  /// launches set filter.overload.backlog = 0 (every frame fused over the full window).
  depth_filter::DepthFilterOptions filter;
};

/// O-GM window limit of a fusion with `backlog` newer frames waiting for their poses (the
/// load shedding of depth_filter::DepthFilterOverloadOptions); 0 = the full window
/// (options.filter.ogm.max_window).
int overloadWindow(int backlog, const DepthFilterNodeOptions& options);

/// Thin LCM shell: convert, call the library, convert, publish, count; every handler inside
/// msgs::guarded(). Construct on a shared memq:// instance to run in one process.
class DepthFilterNode {
 public:
  static constexpr const char* kName = "pplvo-depth-filter";

  DepthFilterNode(const DepthFilterNodeOptions& options, msgs::Bus bus);
  ~DepthFilterNode();
  DepthFilterNode(const DepthFilterNode&) = delete;
  DepthFilterNode& operator=(const DepthFilterNode&) = delete;

  /// Publishes node_status_t (counters, stage timings).
  void publishStatus(int64_t utime, bool final = false);
  /// Between messages (runLcmNode): releases frames that waited max_alignment_wait_ms and
  /// publishes finished fusions (fuse_on_worker).
  void poll();
  /// With fuse_on_worker: publishes the fusions that are done, first waiting for one when
  /// `wait`; true if any was published. Exceptions are counted, as in handlers.
  bool publishFusions(bool wait);
  /// Fusions queued or running on the worker (fuse_on_worker).
  bool fusing() const { return fusion_.valid() || !to_fuse_.empty(); }
  /// Longest wait for a message before poll() (runLcmNode): 1 ms while a fusion runs on the
  /// worker, so that its map goes out within a millisecond of being done, else 50.
  int pollWaitMs() const { return fusion_.valid() ? 1 : 50; }
  /// Frames that waited for a pose to move their depth and went on without it.
  int64_t alignmentWaitsTimedOut() const { return alignment_waits_timed_out_; }
  int deferred() const { return static_cast<int>(deferred_.size()); }

  const msgs::NodeCounters& counters() const { return counters_; }
  /// Read these with no fusion running (fusing() false).
  const depth_filter::OgmStats& ogmStats() const { return ogm_.stats(); }
  const StageTimings& timings() const { return timings_; }
  int64_t unknownPoses() const { return unknown_poses_; }
  int pending() const { return static_cast<int>(pending_.size()); }
  /// Fusions the load shedding (filter.overload) shortened: past frames were left out.
  int64_t overloadFusions() const { return ogm_.stats().frames_fused_limited; }

  void onFrame(const lcm::ReceiveBuffer* rbuf, const std::string& channel,
               const pplvo_msgs::rgbd_frame_t* msg);
  void onPose(const lcm::ReceiveBuffer* rbuf, const std::string& channel,
              const pplvo_msgs::pose_t* msg);

 private:
  struct Pending {
    int64_t seq = 0;
    int64_t utime = 0;
    std::string stamp;
    int8_t stage = 0;
    PinholeCamera camera;
    DepthWithVariance depth;
  };
  struct Deferred {
    RgbdFrame frame;
    std::chrono::steady_clock::time_point since;
  };
  void handleFrame(const pplvo_msgs::rgbd_frame_t& msg);
  /// Stages 0-2 of one decoded frame: publish its stage-1/2 map and queue it for its pose.
  void processFrame(const RgbdFrame& frame);
  /// True while `frame` should wait for the pose its time alignment needs.
  bool waitsForAlignmentPose(const RgbdFrame& frame) const;
  /// Processes the waiting frames, in order, that no longer wait (or waited long enough).
  void releaseDeferred();
  /// Handles a pose; a pose msgs::fromMsg rejects (NaN, invalid rotation, inconsistent window
  /// arrays) releases its frame's stage-1/2 map as the fused output and rethrows the
  /// MessageError, which guarded() counts in frames_skipped.
  void handlePose(const pplvo_msgs::pose_t& msg);
  /// A frame with its pose, to be fused.
  struct Fusion {
    Pending frame;
    FramePose pose;
    int limit = 0;  ///< overloadWindow() when it starts
    int64_t shortened_before = 0;
  };
  /// Starts the next queued fusion on the worker (or runs it here without fuse_on_worker).
  void startFusion();
  /// Publishes the fusion in fusion_ (waiting for it) and starts the next one.
  void finishFusion();
  /// Drops (and counts) pending frames older than seq; returns the frame seq if it is next.
  std::optional<Pending> takePending(int64_t seq);
  /// `reference`: the frame's pose_t.reference on the fused channel (0, unknown, otherwise).
  void publishDepth(const std::string& channel, const Pending& p, const DepthWithVariance& d,
                    int8_t stage, int8_t reference = 0);

  DepthFilterNodeOptions options_;
  msgs::Bus bus_;
  std::vector<msgs::BusSubscription> subscriptions_;
  depth_filter::MeasurementStages measurement_;  ///< stages 0-2
  depth_filter::OgmFusion ogm_;
  depth_filter::OgmResult fused_;  ///< reused output buffers of the fusion
  std::deque<Fusion> to_fuse_;     ///< posed frames waiting for the worker, oldest first
  Fusion fusing_;                  ///< the one fusion_ runs (touched by it alone meanwhile)
  std::future<double> fusion_;     ///< its O-GM time (ms); the worker owns ogm_ and fused_
  std::vector<uint8_t> wire_;      ///< reused packet of an uncompressed depth map
  std::deque<Pending> pending_;
  std::deque<Deferred> deferred_;
  int64_t alignment_waits_timed_out_ = 0;
  msgs::NodeCounters counters_;
  msgs::FrameLedger ledger_{counters_};  ///< where each frame ended (its counts in counters_)
  StageTimings timings_;
  msgs::FrameSourceGuard source_guard_;  ///< which PPLVO_RGBD frames are the followed stream
  int64_t unknown_poses_ = 0;
};

}  // namespace pplvo::nodes
