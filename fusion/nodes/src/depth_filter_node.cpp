#include "pplvo/depth_filter_node/depth_filter_node.h"

#include <algorithm>
#include <optional>
#include <pplvo_msgs/depth_map_t.hpp>
#include <utility>

#include "pplvo/depth_filter_node/depth_filter_convert.h"
#include "pplvo/msgs/convert_pose.h"
#include "pplvo/msgs/node_runtime.h"

namespace pplvo::nodes {

DepthFilterNode::DepthFilterNode(const DepthFilterNodeOptions& options, msgs::Bus bus)
    : options_(options),
      bus_(std::move(bus)),
      measurement_(options.filter),
      ogm_(options.filter.ogm) {
  if (options_.max_pending < 1) options_.max_pending = 1;
  subscriptions_.push_back(
      bus_.subscribe(options_.rgbd_channel, &DepthFilterNode::onFrame, this, counters_, kName));
  subscriptions_.push_back(
      bus_.subscribe(options_.pose_channel, &DepthFilterNode::onPose, this, counters_, kName));
}

DepthFilterNode::~DepthFilterNode() {
  for (const msgs::BusSubscription& s : subscriptions_) bus_.unsubscribe(s);
  if (fusion_.valid()) fusion_.wait();  // the worker uses this object's members
}

void DepthFilterNode::onFrame(const lcm::ReceiveBuffer*, const std::string&,
                              const pplvo_msgs::rgbd_frame_t* msg) {
  ledger_.arrived(msg->seq);
  msgs::guardedFrame(ledger_, counters_, kName, msg->seq, [&] { handleFrame(*msg); });
}

void DepthFilterNode::onPose(const lcm::ReceiveBuffer*, const std::string&,
                             const pplvo_msgs::pose_t* msg) {
  msgs::guarded(counters_, kName, [&] { handlePose(*msg); });
  msgs::guarded(counters_, kName, [&] { releaseDeferred(); });
}

void DepthFilterNode::poll() {
  msgs::guarded(counters_, kName, [&] { releaseDeferred(); });
  publishFusions(false);
}

bool DepthFilterNode::publishFusions(bool wait) {
  bool published = false;
  msgs::guarded(counters_, kName, [&] {
    while (fusion_.valid() &&
           (wait || fusion_.wait_for(std::chrono::seconds(0)) == std::future_status::ready)) {
      finishFusion();
      published = true;
      wait = false;
    }
  });
  return published;
}

void DepthFilterNode::publishDepth(const std::string& channel, const Pending& p,
                                   const DepthWithVariance& d, int8_t stage, int8_t reference) {
  if (!options_.compress) {
    // Straight into the packet: 2 x 1.2 MB a map (VGA) copied once, not twice.
    encodeDepthPacket(d, p.camera, p.utime, p.seq, p.stamp, stage, reference, &wire_);
    bus_.publish(channel, wire_.data(), static_cast<unsigned>(wire_.size()));
    return;
  }
  pplvo_msgs::depth_map_t m =
      depthToMsg(d, p.camera, p.utime, p.seq, p.stamp, stage, options_.compress);
  m.reference = reference;
  bus_.publish(channel, &m);
}

void DepthFilterNode::handleFrame(const pplvo_msgs::rgbd_frame_t& msg) {
  std::optional<RgbdFrame> admitted =
      msgs::admitFrame(source_guard_, ledger_, counters_, timings_, kName, msg, [&] {
        RgbdFrame f;
        {
          ScopedStageTimer t(timings_, "decode");
          // Only the depth: the colour image is the frontend's.
          f = msgs::fromMsg(msg, 65535, msgs::FrameImages::kDepth);
        }
        const PinholeCamera& depth_camera = f.depth_camera ? f.depth_camera->camera : f.camera;
        if (f.depth_m.empty() || f.depth_m.rows != depth_camera.height ||
            f.depth_m.cols != depth_camera.width) {
          throw msgs::MessageError("rgbd_frame_t: depth size disagrees with camera_info");
        }
        return f;
      });
  if (!admitted) return;
  RgbdFrame frame = std::move(*admitted);
  frame.stamp = msg.stamp;
  if (deferred_.empty() && !waitsForAlignmentPose(frame)) {
    processFrame(frame);
    return;
  }
  deferred_.push_back({std::move(frame), std::chrono::steady_clock::now()});
  releaseDeferred();
}

bool DepthFilterNode::waitsForAlignmentPose(const RgbdFrame& frame) const {
  if (!measurement_.timeAligns(frame)) return false;
  const int64_t needed = frame.seq - depth_filter::DepthTimeAligner::kPoseLag;
  if (measurement_.timeAligner().hasPose(needed)) return false;
  // Only a frame still waiting for its own pose will bring it.
  return std::any_of(pending_.begin(), pending_.end(),
                     [needed](const Pending& p) { return p.seq == needed; });
}

void DepthFilterNode::releaseDeferred() {
  const auto now = std::chrono::steady_clock::now();
  const auto max_wait = std::chrono::milliseconds(options_.max_alignment_wait_ms);
  while (!deferred_.empty()) {
    const Deferred& d = deferred_.front();
    if (waitsForAlignmentPose(d.frame)) {
      const bool too_many = static_cast<int>(deferred_.size()) > options_.max_deferred;
      if (!too_many && now - d.since < max_wait) return;
      ++alignment_waits_timed_out_;
      counters_.last_warning =
          "frame " + std::to_string(d.frame.seq) +
          ": depth moved with an older velocity (the pose of frame " +
          std::to_string(d.frame.seq - depth_filter::DepthTimeAligner::kPoseLag) +
          " did not come in time)";
    }
    const RgbdFrame frame = std::move(deferred_.front().frame);
    deferred_.pop_front();
    processFrame(frame);
  }
}

void DepthFilterNode::processFrame(const RgbdFrame& frame) {
  Pending p;
  p.seq = frame.seq;
  p.utime = frame.utime;
  p.stamp = frame.stamp;
  p.camera = frame.camera;
  p.depth = measurement_.apply(frame, timings_);
  p.stage = options_.filter.model == DepthModel::kSensor ? pplvo_msgs::depth_map_t::STAGE_SENSOR
                                                         : pplvo_msgs::depth_map_t::STAGE_CGM;
  publishDepth(options_.cgm_channel, p, p.depth, p.stage);
  pending_.push_back(std::move(p));
  while (static_cast<int>(pending_.size()) > options_.max_pending) {
    ledger_.dropped(pending_.front().seq);
    pending_.pop_front();
    counters_.last_warning = "frame dropped: no pose within the pending queue";
  }
}

std::optional<DepthFilterNode::Pending> DepthFilterNode::takePending(int64_t seq) {
  // Frames older than this pose will never get theirs: stale, drop and count.
  while (!pending_.empty() && pending_.front().seq < seq) {
    ledger_.dropped(pending_.front().seq);
    pending_.pop_front();
    counters_.last_warning = "frame dropped: its pose never came";
  }
  if (pending_.empty() || pending_.front().seq != seq) return std::nullopt;
  Pending p = std::move(pending_.front());
  pending_.pop_front();
  return p;
}

int overloadWindow(int backlog, const DepthFilterNodeOptions& o) {
  const depth_filter::DepthFilterOverloadOptions& shed = o.filter.overload;
  if (shed.backlog <= 0 || shed.window_step <= 0 || backlog <= shed.backlog) return 0;
  // Proportional to how far behind: a loop slower than the sensor must catch up before the
  // frontend's queue of frames waiting for fused depth overflows.
  const int64_t behind = backlog - shed.backlog;
  const int64_t window = std::max<int64_t>(2, o.filter.ogm.max_window - behind * shed.window_step);
  return window < o.filter.ogm.max_window ? static_cast<int>(window) : 0;
}

void DepthFilterNode::handlePose(const pplvo_msgs::pose_t& msg) {
  FramePose pose;
  try {
    pose = msgs::fromMsg(msg);  // NaN / invalid rotation / bad window arrays: MessageError
  } catch (const msgs::MessageError&) {
    // Downstream still gets the frame's own stage-1/2 map, after the fusions of the frames
    // before it; guarded() counts the skip.
    while (fusion_.valid()) finishFusion();
    if (std::optional<Pending> p = takePending(msg.seq)) {
      publishDepth(options_.fused_channel, *p, p->depth, p->stage);
      ledger_.published(p->seq);
    }
    throw;
  }
  measurement_.observePose(pose.seq, pose.utime, pose.T_w_c,
                           pose.status == TrackingStatus::kTracking);
  std::optional<Pending> taken = takePending(pose.seq);
  if (!taken) {
    ++unknown_poses_;
    ++counters_.messages_skipped;
    counters_.last_warning = "pose for unknown frame " + std::to_string(pose.seq);
    return;
  }
  Pending& p = *taken;
  if (options_.filter.model != DepthModel::kOgm) {
    publishDepth(options_.fused_channel, p, p.depth, p.stage, static_cast<int8_t>(pose.reference));
    ledger_.published(p.seq);
    return;
  }
  Fusion& f = to_fuse_.emplace_back();
  f.frame = std::move(p);
  f.pose = std::move(pose);
  startFusion();
}

void DepthFilterNode::startFusion() {
  if (fusion_.valid() || to_fuse_.empty()) return;
  fusing_ = std::move(to_fuse_.front());
  to_fuse_.pop_front();
  // Frames newer than this one already wait for their poses or their fusion: the loop is
  // behind the sensor. Without a worker a fusion starts as its pose comes (to_fuse_ empty).
  fusing_.limit = overloadWindow(static_cast<int>(pending_.size() + to_fuse_.size()), options_);
  fusing_.shortened_before = ogm_.stats().frames_fused_limited;
  auto fuse = [this] {
    const Stopwatch ogm_watch;
    const Pending& p = fusing_.frame;
    // Into fused_, whose buffers are reused frame to frame.
    ogm_.fuseOnPose(p.seq, fusing_.pose, p.camera, p.depth, &fused_, fusing_.limit);
    return ogm_watch.elapsedMs();
  };
  if (options_.fuse_on_worker) {
    fusion_ = std::async(std::launch::async, std::move(fuse));
  } else {
    std::promise<double> done;
    done.set_value(fuse());
    fusion_ = done.get_future();
    finishFusion();
  }
}

void DepthFilterNode::finishFusion() {
  std::future<double> fusion = std::move(fusion_);
  double ogm_ms = 0;
  try {
    ogm_ms = fusion.get();
  } catch (...) {
    // Downstream still gets a depth map (the frame's own stage-2 output); the next fusion
    // starts, and guarded() counts the error.
    publishDepth(options_.fused_channel, fusing_.frame, fusing_.frame.depth, fusing_.frame.stage,
                 static_cast<int8_t>(fusing_.pose.reference));
    ledger_.published(fusing_.frame.seq);
    startFusion();
    throw;
  }
  const Pending& p = fusing_.frame;
  const int8_t reference = static_cast<int8_t>(fusing_.pose.reference);
  const depth_filter::OgmResult& result = fused_;
  timings_.add("ogm", ogm_ms);
  // The shortened ones again on their own: their count shows in every status message.
  if (ogm_.stats().frames_fused_limited > fusing_.shortened_before) {
    timings_.add("ogm_shortened", ogm_ms);
  }
  if (!result.ok) {
    // Downstream still gets a depth map: the frame's own stage-2 output (counted as a stage).
    timings_.add("ogm_failed", 0.0);
    counters_.last_warning = result.warning + " (published C-GM as fused)";
    publishDepth(options_.fused_channel, p, p.depth, p.stage, reference);
  } else {
    publishDepth(options_.fused_channel, p, result.depth, pplvo_msgs::depth_map_t::STAGE_OGM,
                 reference);
  }
  ledger_.published(p.seq);
  startFusion();
}

void DepthFilterNode::publishStatus(int64_t utime, bool final) {
  msgs::guarded(counters_, kName, [&] {
    if (counters_.last_warning.empty() && !fusion_.valid() && !ogm_.stats().last_warning.empty()) {
      counters_.last_warning = ogm_.stats().last_warning;
    }
    pplvo_msgs::node_status_t m = msgs::toStatusMsg(kName, counters_, timings_, utime, final);
    msgs::appendBlockedPublishes(bus_, &m);
    bus_.publish(options_.status_channel, &m);
  });
}

}  // namespace pplvo::nodes
