#pragma once
/// pplvo-estimator: the tracking policy (pplvo::tracking::FrameTracker) as an LCM process.
///
/// | channel (default)   | type          | direction | content                                   |
/// |---------------------|---------------|-----------|-------------------------------------------|
/// | PPLVO_FEATURES      | features_t    | in        | STAGE_2D of each frame                    |
/// | PPLVO_FEATURES_3D   | features_t    | in        | STAGE_3D: the reference for the next frame|
/// | PPLVO_POSE          | pose_t        | out       | T_w_c, motion + covariance, status, window|
/// | PPLVO_ODOMETRY      | odometry_t    | out       | base_link in odom, twist, covariances     |
/// | PPLVO_STATUS        | node_status_t | out       | once a second                             |
///
/// Frame k is tracked against the 3D features of the frame tracked last, which come back only
/// after its pose went round the depth filter and the frontend; with keyframes it waits for
/// them only when that frame is the next keyframe or the keyframe's estimate is rejected (and
/// for the 3D features of frame k-2, whose landmark fusion is due: FrameTracker::step),
/// so that frame k is posed while frame k-1 is fused and lifted. Frames that arrive meanwhile
/// wait (at most max_waiting; the oldest are dropped, counted, and the next one is matched to
/// the same reference over a longer motion). If the reference never comes (an upstream
/// process died or dropped it), tracking restarts at the newest waiting frame with the last
/// pose held (status REINITIALISED), so a lost message never stalls the pipeline.
#include <array>
#include <cstdint>
#include <deque>
#include <optional>
#include <lcm/lcm-cpp.hpp>
#include <pplvo_msgs/features_t.hpp>
#include <string>
#include <vector>

#include "pplvo/core/body_odometry.h"
#include "pplvo/msgs/bus.h"
#include "pplvo/msgs/channels.h"
#include "pplvo/msgs/convert.h"
#include "pplvo/msgs/frame_ledger.h"
#include "pplvo/tracking/frame_tracker.h"

namespace pplvo::nodes {

struct EstimatorNodeOptions {
  std::string lcm_url;                     ///< empty: $LCM_DEFAULT_URL
  std::vector<msgs::ChannelRoute> routes;  ///< --route: channels carried by other URLs
  std::string features_channel = channels::kFeatures;
  std::string features_3d_channel = channels::kFeatures3d;
  std::string pose_channel = channels::kPose;
  /// Body-frame odometry (odometry_t, the mounting from odometry.body); empty: not published.
  std::string odometry_channel = channels::kOdometry;
  std::string status_channel = channels::kStatus;
  /// Frames waiting for their reference; beyond this the oldest is dropped. As deep as the
  /// frontend's max_unlifted: at 30 Hz it absorbs a late loop of up to ~5 frame periods
  /// (docs/launch.md).
  int max_waiting = 5;
  /// Consecutive drops while the reference is missing before tracking restarts.
  int max_drops_without_reference = 3;
  /// The same wait bounded by time: when two or more frames wait and no pose could be made for
  /// this much stream time (frame stamps: the newest frame against the newest one at the last
  /// pose), tracking restarts at the newest. A frontend that lost its loop sends frames
  /// sparsely, so drops alone could take long. A slow loop that still delivers its references
  /// is never cut. 0 = no time bound. Lockstep never reaches it.
  int max_reference_wait_ms = 1000;
  tracking::TrackingOptions odometry;
};

/// Tracking outcome counts (per status, and why keyframes changed), for summaries and tests.
struct EstimatorCounts : TrackingStatusCounts {
  int64_t restarts_missing_reference = 0;
  /// 3D features that came after every frame that could use them was posed (posed against the
  /// keyframe, with no landmark fusion due): normal with keyframes, not an error.
  int64_t lifted_unused = 0;
  /// Keyframe tracking (odometry.reference: keyframe): keyframes chosen, and frames whose
  /// keyframe estimate failed so that the previous frame served.
  int64_t keyframes = 0, keyframe_fallbacks = 0;
  /// Earlier keyframes made active again instead of a new one (keyframe.retired_keyframes).
  int64_t keyframes_reused = 0;
  /// Keyframes chosen, by tracking::KeyframeReason.
  std::array<int64_t, tracking::kKeyframeReasons> keyframe_reasons{};
  /// The per-frame shared error of the last published pose, and which of its blocks were
  /// estimated online (odometry.tracker.frame_error_online), the others configured.
  estimator::FrameErrorSigma frame_error;
  estimator::FrameErrorSource frame_error_source;
  /// Weak estimates combined with the prediction, and estimates refused by the prediction
  /// gate (their frames are the velocity model's): estimator::MotionChain's counts.
  int64_t weak_estimates_combined = 0, estimates_gated = 0;
  /// The colour readout read from the frames (tracking.readout_from_frames): the mean of the
  /// readings, its standard error, how many, and whether frames are compensated with it.
  double readout_mean_s = 0, readout_standard_error_s = 0;
  int64_t readout_readings = 0;
  bool readout_used = false;
};

class EstimatorNode {
 public:
  static constexpr const char* kName = "pplvo-estimator";

  EstimatorNode(const EstimatorNodeOptions& options, msgs::Bus bus);
  ~EstimatorNode();
  EstimatorNode(const EstimatorNode&) = delete;
  EstimatorNode& operator=(const EstimatorNode&) = delete;

  void publishStatus(int64_t utime, bool final = false);
  const msgs::NodeCounters& counters() const { return counters_; }
  const EstimatorCounts& counts() const { return counts_; }
  StageTimings allTimings() const;

  void onFeatures(const lcm::ReceiveBuffer* rbuf, const std::string& channel,
                  const pplvo_msgs::features_t* msg);
  void onFeatures3d(const lcm::ReceiveBuffer* rbuf, const std::string& channel,
                    const pplvo_msgs::features_t* msg);

 private:
  void handleFeatures(const pplvo_msgs::features_t& msg);
  void handleFeatures3d(const pplvo_msgs::features_t& msg);
  /// Tracks waiting frames while the reference they need is in.
  void processWaiting();
  void publish(const estimator::MotionChainOutput& out, const FrameFeatures& frame,
               const tracking::TrackingStats& stats);

  EstimatorNodeOptions options_;
  msgs::Bus bus_;
  BodyOdometryIntegrator body_odometry_;
  std::vector<msgs::BusSubscription> subscriptions_;
  tracking::FrameTracker odometry_;
  /// The frame whose 3D stage the last step waited for, if it waited.
  std::optional<int64_t> awaiting_lifted_;
  std::deque<FrameFeatures> waiting_;  ///< stage 2D, oldest first
  int drops_without_reference_ = 0;
  int64_t newest_utime_ = -1;     ///< stamp of the newest stage-2D features received
  int64_t last_pose_utime_ = -1;  ///< newest_utime_ when the last pose was published
  msgs::NodeCounters counters_;
  msgs::FrameLedger ledger_{counters_};  ///< where each frame ended (its counts in counters_)
  EstimatorCounts counts_;
  StageTimings timings_;
};

}  // namespace pplvo::nodes
