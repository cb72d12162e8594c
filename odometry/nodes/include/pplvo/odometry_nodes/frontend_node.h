#pragma once
/// pplvo-frontend: the feature frontend (pplvo::pipeline::Frontend) as an LCM process.
///
/// | channel (default)   | type          | direction | content                                   |
/// |---------------------|---------------|-----------|-------------------------------------------|
/// | PPLVO_RGBD          | rgbd_frame_t  | in        | colour image of each frame                |
/// | PPLVO_DEPTH_CGM     | depth_map_t   | in        | C-GM depth of the frame (planes, stage 2D)|
/// | PPLVO_DEPTH_FUSED   | depth_map_t   | in        | fused depth once the pose is known        |
/// | PPLVO_FEATURES      | features_t    | out       | STAGE_2D: points, lines, C-GM planes      |
/// | PPLVO_FEATURES_3D   | features_t    | out       | STAGE_3D: the same lifted, fused planes   |
/// | PPLVO_STATUS        | node_status_t | out       | once a second                             |
///
/// A frame's stage 2D starts when both its colour image and its C-GM depth are in (either may
/// come first), stage 3D when its fused depth arrives. Stage 2D runs on a worker thread
/// (`extract_ahead`) so that it overlaps the lifting of the previous frame: it is published
/// after that frame's stage 3D, or at once when no frame waits for fused depth; the features do
/// not depend on it. Every queue is bounded: entries older than the newest handled sequence
/// number, or beyond max_pending, are dropped and counted.
#include <cstdint>
#include <deque>
#include <future>
#include <lcm/lcm-cpp.hpp>
#include <pplvo_msgs/depth_map_t.hpp>
#include <pplvo_msgs/features_t.hpp>
#include <pplvo_msgs/rgbd_frame_t.hpp>
#include <string>
#include <vector>

#include "pplvo/msgs/bus.h"
#include "pplvo/msgs/channels.h"
#include "pplvo/msgs/convert.h"
#include "pplvo/msgs/frame_ledger.h"
#include "pplvo/msgs/frame_source_guard.h"
#include "pplvo/pipeline/frontend.h"

namespace pplvo::nodes {

struct FrontendNodeOptions {
  std::string lcm_url;                     ///< empty: $LCM_DEFAULT_URL
  std::vector<msgs::ChannelRoute> routes;  ///< --route: channels carried by other URLs
  std::string rgbd_channel = channels::kRgbd;
  std::string cgm_channel = channels::kDepthCgm;
  std::string fused_channel = channels::kDepthFused;
  std::string features_channel = channels::kFeatures;
  std::string features_3d_channel = channels::kFeatures3d;
  std::string status_channel = channels::kStatus;
  /// Frames held per queue (1 s at 30 Hz); older ones are dropped and counted.
  int max_pending = 30;
  /// Stage 2D of a frame on a worker thread while the previous frame is lifted (above); false
  /// computes it in the handler. One frame at a time: a second one ahead measured no faster
  /// in pplvo-run (the two cores are then busy) and wastes work on frames dropped later.
  bool extract_ahead = true;
  /// Frames extracted but not yet lifted (their fused depth has not come) beyond which a new
  /// frame is dropped before extraction, counted: the loop through the estimator and the depth
  /// filter is behind, and the estimator would drop it anyway. 0 = never. Never drops in
  /// lockstep with up to max_unlifted frames in flight; 5 absorbs a loop late by a few frame
  /// periods at 30 Hz (docs/launch.md) and bounds the latency to ~170 ms.
  int max_unlifted = 5;
  /// The same wait bounded by time: when max_unlifted frames wait and no fused depth has come
  /// for this much stream time (frame stamps), the loop lost them: they are dropped, counted,
  /// instead of the new frame. Without it a loop that lost its fused depth (a paused or
  /// restarted estimator or depth filter) kept the queue full for good: every new frame dropped
  /// before extraction, so no features, no pose, no fused depth. A slow loop that still
  /// delivers is never cut. 0 = no time bound. Never reached in lockstep (fewer than
  /// max_unlifted in flight).
  int max_unlifted_wait_ms = 1000;
  pipeline::FrontendOptions frontend;
};

class FrontendNode {
 public:
  static constexpr const char* kName = "pplvo-frontend";

  FrontendNode(const FrontendNodeOptions& options, msgs::Bus bus);
  ~FrontendNode();
  FrontendNode(const FrontendNode&) = delete;
  FrontendNode& operator=(const FrontendNode&) = delete;

  void publishStatus(int64_t utime, bool final = false);
  /// Publishes a stage 2D that finished on its worker thread but still waits for the previous
  /// frame's fused depth (which may never come): call it from the idle loop. Never blocks.
  void poll();
  /// Publishes the stage 2D of the worker when it is done, first waiting for it when `wait`;
  /// true if it was published. For a loop that has nothing else to do (pplvo-run).
  bool publishStage2d(bool wait);
  /// A stage 2D is running on the worker.
  bool extracting() const { return in_flight_.result.valid(); }
  const msgs::NodeCounters& counters() const { return counters_; }
  /// Of counters().frames_dropped, the frames dropped before extraction because max_unlifted
  /// frames waited for their fused depth (the loop through estimator and depth filter behind).
  int64_t droppedLoopBehind() const { return dropped_loop_behind_; }
  /// Of counters().frames_dropped, extracted frames dropped because no fused depth came for
  /// max_unlifted_wait_ms while the queue was full (the loop lost them).
  int64_t droppedUnliftedTimeout() const { return dropped_unlifted_timeout_; }
  const StageTimings& timings() const { return timings_; }
  /// Decode/encode times of this node and the frontend's own stages, in one table.
  StageTimings allTimings() const;

  void onFrame(const lcm::ReceiveBuffer* rbuf, const std::string& channel,
               const pplvo_msgs::rgbd_frame_t* msg);
  void onCgm(const lcm::ReceiveBuffer* rbuf, const std::string& channel,
             const pplvo_msgs::depth_map_t* msg);
  void onFused(const lcm::ReceiveBuffer* rbuf, const std::string& channel,
               const pplvo_msgs::depth_map_t* msg);

 private:
  struct PendingDepth {
    int64_t seq;
    DepthWithVariance depth;
  };
  void handleFrame(const pplvo_msgs::rgbd_frame_t& msg);
  void handleCgm(const pplvo_msgs::depth_map_t& msg);
  void handleFused(const pplvo_msgs::depth_map_t& msg);
  void liftFused(const pplvo_msgs::depth_map_t& msg);
  /// Runs stage 2D for every frame whose colour and C-GM depth are both in.
  void extractReady();
  /// Stage 2D computed for one frame (on the worker thread: no node state touched there).
  struct Extracted {
    FrameFeatures features;
    pipeline::FrontendStats stats;
    /// The stage-2D message, encoded where the features were extracted (the worker thread
    /// with extract_ahead: the handler thread carries the pose loop), and its encoding time.
    pplvo_msgs::features_t message;
    double encode_ms = 0;
  };
  /// Publishes stage 2D and queues the features for their fused depth.
  void publishExtracted(Extracted extracted);
  /// Waits for the stage 2D in flight, if any, and publishes it.
  void finishInFlight();
  /// Publishes stage 2D in flight while no earlier frame waits for its fused depth.
  void publishWhenDue();
  /// Drops every frame waiting for fused depth when none came for max_unlifted_wait_ms of
  /// stream time up to the frame stamped `utime`; returns how many.
  int64_t dropUnliftedIfLoopStalled(int64_t utime);
  void warn(const std::string& what);

  FrontendNodeOptions options_;
  msgs::Bus bus_;
  std::vector<msgs::BusSubscription> subscriptions_;
  pipeline::Frontend frontend_;
  std::deque<RgbdFrame> frames_;  ///< colour in, C-GM depth not yet
  std::deque<PendingDepth> cgm_;  ///< C-GM depth in, colour not yet
  /// The plane labels of a frame as its stage-2D message carried them, and their pixels: the
  /// stage-3D message reuses them when lifting kept the labels (every frame but those whose
  /// planes are refitted on the fused depth), instead of compressing them again on the
  /// handler thread, which carries the pose loop.
  struct EncodedLabels {
    int64_t seq = -1;
    const uchar* pixels = nullptr;
    pplvo_msgs::image_t message;
  };
  std::deque<EncodedLabels> encoded_labels_;
  std::deque<FrameFeatures> awaiting_3d_;  ///< stage 2D published, fused depth not yet
  int64_t last_extracted_seq_ = -1;
  int64_t dropped_loop_behind_ = 0;
  int64_t dropped_unlifted_timeout_ = 0;
  int64_t newest_frame_utime_ = -1;  ///< stamp of the newest colour frame received
  /// Stamp of the newest frame when fused depth last came (or the last drop): the loop's
  /// progress in stream time; -1 before the first wait.
  int64_t last_lift_utime_ = -1;
  /// Stage 2D under way on the worker (result invalid: none; destroyed, i.e. joined, before
  /// frontend_).
  struct InFlight {
    int64_t seq = -1;
    std::future<Extracted> result;
  };
  InFlight in_flight_;
  msgs::NodeCounters counters_;
  msgs::FrameLedger ledger_{counters_};  ///< where each frame ended (its counts in counters_)
  StageTimings timings_;
  msgs::FrameSourceGuard source_guard_;  ///< which PPLVO_RGBD frames are the followed stream
};

}  // namespace pplvo::nodes
