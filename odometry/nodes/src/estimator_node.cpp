#include "pplvo/odometry_nodes/estimator_node.h"

#include <algorithm>
#include <optional>
#include <pplvo_msgs/pose_t.hpp>

#include "pplvo/msgs/convert_features.h"
#include "pplvo/msgs/convert_pose.h"
#include "pplvo/msgs/node_runtime.h"
#include "pplvo/pipeline/odometry_pipeline.h"

namespace pplvo::nodes {

EstimatorNode::EstimatorNode(const EstimatorNodeOptions& options, msgs::Bus bus)
    : options_(options),
      bus_(std::move(bus)),
      body_odometry_(options.odometry.body.extrinsic()),
      odometry_(options.odometry) {
  if (options_.max_waiting < 1) options_.max_waiting = 1;
  subscriptions_.push_back(bus_.subscribe(options_.features_channel, &EstimatorNode::onFeatures,
                                          this, counters_, kName));
  subscriptions_.push_back(bus_.subscribe(options_.features_3d_channel,
                                          &EstimatorNode::onFeatures3d, this, counters_, kName));
}

EstimatorNode::~EstimatorNode() {
  for (const msgs::BusSubscription& s : subscriptions_) bus_.unsubscribe(s);
}

void EstimatorNode::onFeatures(const lcm::ReceiveBuffer*, const std::string&,
                               const pplvo_msgs::features_t* msg) {
  ledger_.arrived(msg->seq);
  msgs::guardedFrame(ledger_, counters_, kName, msg->seq, [&] { handleFeatures(*msg); });
}
void EstimatorNode::onFeatures3d(const lcm::ReceiveBuffer*, const std::string&,
                                 const pplvo_msgs::features_t* msg) {
  msgs::guarded(counters_, kName, [&] { handleFeatures3d(*msg); });
}

void EstimatorNode::handleFeatures(const pplvo_msgs::features_t& msg) {
  counters_.last_seq = msg.seq;
  newest_utime_ = msg.utime;
  if (msg.stage != pplvo_msgs::features_t::STAGE_2D) {
    throw msgs::MessageError("features_t on the 2D channel is not STAGE_2D");
  }
  const std::optional<int64_t> last = odometry_.lastPosed();
  if (last && msg.seq <= *last) {
    ledger_.skipped(msg.seq);
    counters_.last_warning = "features of frame " + std::to_string(msg.seq) + " came too late";
    return;
  }
  FrameFeatures frame;
  {
    ScopedStageTimer t(timings_, "decode");
    frame = msgs::fromMsg(msg);
  }
  if (!last) {  // first frame of the stream: the origin of the world frame
    const estimator::MotionChainOutput out = odometry_.initialise(frame);
    publish(out, frame, {});
    return;
  }
  waiting_.push_back(std::move(frame));
  while (static_cast<int>(waiting_.size()) > options_.max_waiting) {
    ledger_.dropped(waiting_.front().seq);
    waiting_.pop_front();
    ++drops_without_reference_;
    counters_.last_warning = "frame dropped: the reference of the last pose is late";
  }
  processWaiting();
  // The reference is missing for too long in stream time (the loop lost it): the newest frame
  // is that far beyond the newest frame at the last pose.
  const bool waited_too_long =
      options_.max_reference_wait_ms > 0 && waiting_.size() >= 2 && last_pose_utime_ >= 0 &&
      waiting_.back().utime - last_pose_utime_ > int64_t{options_.max_reference_wait_ms} * 1000;
  if (!waiting_.empty() &&
      (drops_without_reference_ > options_.max_drops_without_reference || waited_too_long)) {
    // The reference is not coming: restart at the newest frame, holding the last pose.
    FrameFeatures newest = std::move(waiting_.back());
    waiting_.pop_back();
    for (const FrameFeatures& f : waiting_) ledger_.dropped(f.seq);
    waiting_.clear();
    ++counts_.restarts_missing_reference;
    const int64_t awaited = awaiting_lifted_.value_or(odometry_.lastPosed().value_or(-1));
    counters_.last_warning = "no 3D features for frame " + std::to_string(awaited) +
                             ": tracking restarted at " + std::to_string(newest.seq);
    estimator::MotionChainOutput out = odometry_.restart(newest);
    awaiting_lifted_.reset();
    drops_without_reference_ = 0;
    publish(out, newest, {});
  }
}

void EstimatorNode::handleFeatures3d(const pplvo_msgs::features_t& msg) {
  if (msg.stage != pplvo_msgs::features_t::STAGE_3D) {
    throw msgs::MessageError("features_t on the 3D channel is not STAGE_3D");
  }
  if (!odometry_.wantsLifted(msg.seq)) {
    const std::optional<int64_t> last = odometry_.lastPosed();
    if (last && msg.seq <= *last) {
      ++counts_.lifted_unused;  // its successor was posed without it
      return;
    }
    // Only the last posed frame (a reference) and frames whose landmark fusion is due serve.
    ++counters_.messages_skipped;
    counters_.last_warning = "3D features of frame " + std::to_string(msg.seq) +
                             " are not needed (last posed " + std::to_string(last.value_or(-1)) +
                             ")";
    return;
  }
  FrameFeatures lifted;
  {
    ScopedStageTimer t(timings_, "decode");
    lifted = msgs::fromMsg(msg);
  }
  odometry_.addLifted(std::move(lifted));
  processWaiting();
}

void EstimatorNode::processWaiting() {
  while (!waiting_.empty()) {
    const tracking::TrackingStep step = odometry_.step(waiting_.front());
    awaiting_lifted_ = step.awaiting_lifted;
    if (!step.posed()) return;  // a 3D stage it needs is not in yet
    const tracking::TrackingStats& stats = step.stats;
    FrameFeatures current = std::move(waiting_.front());
    waiting_.pop_front();
    counts_.keyframes = odometry_.keyframes().insertedCount();
    if (stats.new_keyframe) ++counts_.keyframe_reasons[static_cast<int>(stats.keyframe_reason)];
    if (stats.keyframe_fallback) ++counts_.keyframe_fallbacks;
    if (stats.reused_keyframe) ++counts_.keyframes_reused;
    drops_without_reference_ = 0;
    publish(*step.pose, current, stats);
  }
}

void EstimatorNode::publish(const estimator::MotionChainOutput& out, const FrameFeatures& frame,
                            const tracking::TrackingStats& stats) {
  last_pose_utime_ = std::max(newest_utime_, frame.utime);
  FramePose pose = estimator::toFramePose(out);
  pose.utime = frame.utime;
  pose.seq = frame.seq;
  pose.stamp = frame.stamp;
  pose.reference = odometry_.referenceRole(frame.seq);
  (void)stats;  // pose_t carries the inliers the estimate used (estimator::toFramePose)
  counts_.add(pose.status);
  counts_.frame_error = out.frame_error;
  counts_.frame_error_source = out.frame_error_source;
  counts_.weak_estimates_combined = odometry_.tracker().fusedEstimates();
  counts_.estimates_gated = odometry_.tracker().gatedEstimates();
  const tracking::ReadoutEstimator& readout = odometry_.readoutEstimator();
  counts_.readout_mean_s = readout.mean_s();
  counts_.readout_standard_error_s = readout.standardError_s();
  counts_.readout_readings = readout.readings();
  counts_.readout_used = readout.readout_s().has_value();
  {
    ScopedStageTimer t(timings_, "encode");
    const pplvo_msgs::pose_t m = msgs::toMsg(pose);
    bus_.publish(options_.pose_channel, &m);
    if (!options_.odometry_channel.empty()) {
      const pplvo_msgs::odometry_t o =
          msgs::toMsg(body_odometry_.add(pose, static_cast<double>(pose.utime) * 1e-6));
      bus_.publish(options_.odometry_channel, &o);
    }
  }
  ledger_.published(frame.seq);
}

StageTimings EstimatorNode::allTimings() const {
  return pipeline::mergeTimings({&timings_, &odometry_.timings()});
}

void EstimatorNode::publishStatus(int64_t utime, bool final) {
  msgs::guarded(counters_, kName, [&] {
    pplvo_msgs::node_status_t m = msgs::toStatusMsg(kName, counters_, allTimings(), utime, final);
    msgs::appendBlockedPublishes(bus_, &m);
    bus_.publish(options_.status_channel, &m);
  });
}

}  // namespace pplvo::nodes
