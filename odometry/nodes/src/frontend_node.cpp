#include "pplvo/odometry_nodes/frontend_node.h"

#include <chrono>
#include <pplvo_msgs/features_t.hpp>
#include <pplvo_msgs/pose_t.hpp>

#include "pplvo/msgs/convert_features.h"
#include "pplvo/msgs/node_runtime.h"
#include "pplvo/pipeline/odometry_pipeline.h"

namespace pplvo::nodes {

namespace {

/// Drops the front of `q` while it holds more than `max` entries, calling `drop(entry)` on
/// each; returns how many.
template <typename Q, typename Drop>
int64_t trim(Q& q, int max, Drop&& drop) {
  int64_t dropped = 0;
  while (static_cast<int>(q.size()) > max) {
    drop(q.front());
    q.pop_front();
    ++dropped;
  }
  return dropped;
}

}  // namespace

FrontendNode::FrontendNode(const FrontendNodeOptions& options, msgs::Bus bus)
    : options_(options), bus_(std::move(bus)), frontend_(options.frontend) {
  if (options_.max_pending < 1) options_.max_pending = 1;
  subscriptions_.push_back(
      bus_.subscribe(options_.rgbd_channel, &FrontendNode::onFrame, this, counters_, kName));
  subscriptions_.push_back(
      bus_.subscribe(options_.cgm_channel, &FrontendNode::onCgm, this, counters_, kName));
  subscriptions_.push_back(
      bus_.subscribe(options_.fused_channel, &FrontendNode::onFused, this, counters_, kName));
}

FrontendNode::~FrontendNode() {
  for (const msgs::BusSubscription& s : subscriptions_) bus_.unsubscribe(s);
}

void FrontendNode::onFrame(const lcm::ReceiveBuffer*, const std::string&,
                           const pplvo_msgs::rgbd_frame_t* msg) {
  ledger_.arrived(msg->seq);
  msgs::guardedFrame(ledger_, counters_, kName, msg->seq, [&] { handleFrame(*msg); });
}
void FrontendNode::onCgm(const lcm::ReceiveBuffer*, const std::string&,
                         const pplvo_msgs::depth_map_t* msg) {
  msgs::guarded(counters_, kName, [&] { handleCgm(*msg); });
}
void FrontendNode::onFused(const lcm::ReceiveBuffer*, const std::string&,
                           const pplvo_msgs::depth_map_t* msg) {
  msgs::guarded(counters_, kName, [&] { handleFused(*msg); });
}

void FrontendNode::warn(const std::string& what) { counters_.last_warning = what; }

void FrontendNode::handleFrame(const pplvo_msgs::rgbd_frame_t& msg) {
  std::optional<RgbdFrame> admitted =
      msgs::admitFrame(source_guard_, ledger_, counters_, timings_, kName, msg, [&] {
        RgbdFrame f;
        {
          ScopedStageTimer t(timings_, "decode");
          // Only the colour: the frontend takes depth from the depth filter.
          f = msgs::fromMsg(msg, 65535, msgs::FrameImages::kColour);
        }
        if (f.bgr.empty() || f.bgr.rows != f.camera.height || f.bgr.cols != f.camera.width) {
          throw msgs::MessageError("rgbd_frame_t: colour image size disagrees with camera_info");
        }
        return f;
      });
  if (!admitted) return;
  RgbdFrame frame = std::move(*admitted);
  newest_frame_utime_ = msg.utime;
  if (msg.seq <= last_extracted_seq_) {
    ledger_.skipped(msg.seq);
    warn("frame " + std::to_string(msg.seq) + " is older than one already handled");
    return;
  }
  frames_.push_back(std::move(frame));
  if (trim(frames_, options_.max_pending, [&](const RgbdFrame& f) { ledger_.dropped(f.seq); })) {
    warn("frames dropped: no C-GM depth came for them");
  }
  extractReady();
}

void FrontendNode::handleCgm(const pplvo_msgs::depth_map_t& msg) {
  if (msg.seq <= last_extracted_seq_) {
    ++counters_.messages_skipped;
    warn("C-GM depth of frame " + std::to_string(msg.seq) + " came too late");
    return;
  }
  PendingDepth p{msg.seq, {}};
  {
    ScopedStageTimer t(timings_, "decode");
    p.depth = msgs::fromMsg(msg);
  }
  cgm_.push_back(std::move(p));
  if (const int64_t n = trim(cgm_, options_.max_pending, [](const PendingDepth&) {})) {
    counters_.messages_skipped += n;
    warn("C-GM maps dropped: their frames never came");
  }
  extractReady();
}

void FrontendNode::extractReady() {
  // Pair colour and C-GM depth by sequence number; anything older than a pair is stale.
  while (!frames_.empty() && !cgm_.empty()) {
    const int64_t fs = frames_.front().seq, ds = cgm_.front().seq;
    if (fs < ds) {
      frames_.pop_front();
      ledger_.dropped(fs);
      warn("frame " + std::to_string(fs) + " dropped: its C-GM depth never came");
      continue;
    }
    if (ds < fs) {
      cgm_.pop_front();
      ++counters_.messages_skipped;
      warn("C-GM depth " + std::to_string(ds) + " dropped: its frame never came");
      continue;
    }
    RgbdFrame frame = std::move(frames_.front());
    DepthWithVariance depth = std::move(cgm_.front().depth);
    frames_.pop_front();
    cgm_.pop_front();
    last_extracted_seq_ = frame.seq;
    auto unliftedCount = [this] {
      return awaiting_3d_.size() + (in_flight_.result.valid() ? 1 : 0);
    };
    size_t unlifted = unliftedCount();
    if (options_.max_unlifted > 0 && unlifted >= static_cast<size_t>(options_.max_unlifted) &&
        dropUnliftedIfLoopStalled(frame.utime) > 0) {
      publishWhenDue();
      unlifted = unliftedCount();
    }
    if (options_.max_unlifted > 0 && unlifted >= static_cast<size_t>(options_.max_unlifted)) {
      // The pose -> fused depth -> lifting loop is behind: extracting this frame would only
      // delay it further, and the estimator would drop the frame anyway.
      ledger_.dropped(frame.seq);
      ++dropped_loop_behind_;
      warn("frame " + std::to_string(frame.seq) + " dropped before extraction: " +
           std::to_string(unlifted) + " frames wait for their fused depth");
      continue;
    }
    auto extract = [this, frame = std::move(frame), depth = std::move(depth)] {
      Extracted e;
      e.features = frontend_.extract2d(frame, depth, &e.stats);
      const Stopwatch encode;
      e.message = msgs::toMsg(e.features, pplvo_msgs::features_t::STAGE_2D);
      e.encode_ms = encode.elapsedMs();
      return e;
    };
    if (!options_.extract_ahead) {
      publishExtracted(extract());
      continue;
    }
    finishInFlight();  // one frame on the worker at a time (extract2d is not reentrant)
    in_flight_ = {last_extracted_seq_, std::async(std::launch::async, std::move(extract))};
    publishWhenDue();
  }
}

void FrontendNode::publishExtracted(Extracted extracted) {
  if (!extracted.stats.warning.empty()) warn(extracted.stats.warning);
  timings_.add("encode", extracted.encode_ms);
  bus_.publish(options_.features_channel, &extracted.message);
  encoded_labels_.push_back({extracted.features.seq, extracted.features.plane_labels.data,
                             std::move(extracted.message.plane_labels)});
  if (static_cast<int>(encoded_labels_.size()) > options_.max_pending) encoded_labels_.pop_front();
  awaiting_3d_.push_back(std::move(extracted.features));
  if (trim(awaiting_3d_, options_.max_pending,
           [&](const FrameFeatures& f) { ledger_.dropped(f.seq); })) {
    warn("features dropped: their fused depth never came");
  }
}

void FrontendNode::finishInFlight() {
  if (!in_flight_.result.valid()) return;
  Extracted extracted;
  try {
    extracted = in_flight_.result.get();
  } catch (...) {
    ledger_.dropped(in_flight_.seq);  // a job's exception surfaces here (an error in guarded())
    throw;
  }
  publishExtracted(std::move(extracted));
}

int64_t FrontendNode::dropUnliftedIfLoopStalled(int64_t utime) {
  if (options_.max_unlifted_wait_ms <= 0 || awaiting_3d_.empty()) return 0;
  if (last_lift_utime_ < 0 || utime < last_lift_utime_) {
    last_lift_utime_ = utime;  // the first wait (or a restarted source) starts now
    return 0;
  }
  if (utime - last_lift_utime_ <= int64_t{options_.max_unlifted_wait_ms} * 1000) return 0;
  // No fused depth for that long while the queue is full: the loop lost these frames (a
  // paused or restarted estimator or depth filter). Drop them, so that features flow again and
  // the estimator can restart on new frames; the next drop needs another full wait.
  const auto dropped = static_cast<int64_t>(awaiting_3d_.size());
  warn(std::to_string(dropped) + " extracted frames dropped: no fused depth for " +
       std::to_string((utime - last_lift_utime_) / 1000) + " ms (from frame " +
       std::to_string(awaiting_3d_.front().seq) + ")");
  for (const FrameFeatures& f : awaiting_3d_) ledger_.dropped(f.seq);
  awaiting_3d_.clear();
  dropped_unlifted_timeout_ += dropped;
  last_lift_utime_ = utime;
  return dropped;
}

void FrontendNode::publishWhenDue() {
  // With no frame waiting for its fused depth there is no lifting to overlap: publish now.
  if (awaiting_3d_.empty()) finishInFlight();
}

void FrontendNode::poll() { publishStage2d(false); }

bool FrontendNode::publishStage2d(bool wait) {
  bool published = false;
  msgs::guarded(counters_, kName, [&] {
    if (in_flight_.result.valid() && (wait || in_flight_.result.wait_for(std::chrono::seconds(0)) ==
                                                  std::future_status::ready)) {
      published = true;
      finishInFlight();
    }
  });
  return published;
}

void FrontendNode::handleFused(const pplvo_msgs::depth_map_t& msg) {
  // Depth for the frame in flight (or a later one): its stage 2D cannot wait.
  if (in_flight_.result.valid() && in_flight_.seq <= msg.seq) finishInFlight();
  liftFused(msg);
  publishWhenDue();  // the next frame's stage 2D, computed while this one was lifted
}

void FrontendNode::liftFused(const pplvo_msgs::depth_map_t& msg) {
  // Stage-2D features of frames older than this map will never get theirs.
  while (!awaiting_3d_.empty() && awaiting_3d_.front().seq < msg.seq) {
    ledger_.dropped(awaiting_3d_.front().seq);
    awaiting_3d_.pop_front();
    warn("features dropped: their fused depth never came");
  }
  if (awaiting_3d_.empty() || awaiting_3d_.front().seq != msg.seq) {
    ++counters_.messages_skipped;
    warn("fused depth for unknown frame " + std::to_string(msg.seq));
    return;
  }
  FrameFeatures features = std::move(awaiting_3d_.front());
  awaiting_3d_.pop_front();
  DepthWithVariance fused;
  {
    ScopedStageTimer t(timings_, "decode");
    fused = msgs::viewOfMsg(msg);  // used only in this handler: no copy of raw maps
  }
  pipeline::FrontendStats stats;
  // What the estimator said of this frame (pose_t.reference, passed on by the depth filter);
  // anything else is "unknown": the planes are fitted.
  ReferenceRole role = ReferenceRole::kUnknown;
  if (msg.reference == pplvo_msgs::pose_t::REFERENCE_YES) role = ReferenceRole::kReference;
  if (msg.reference == pplvo_msgs::pose_t::REFERENCE_FALLBACK_ONLY)
    role = ReferenceRole::kFallbackOnly;
  frontend_.lift3d(features, fused, &stats, role);
  last_lift_utime_ = newest_frame_utime_;  // the loop delivers
  if (!stats.warning.empty()) warn(stats.warning);
  {
    ScopedStageTimer t(timings_, "encode");
    while (!encoded_labels_.empty() && encoded_labels_.front().seq < features.seq) {
      encoded_labels_.pop_front();
    }
    const pplvo_msgs::image_t* labels = nullptr;
    if (!encoded_labels_.empty() && encoded_labels_.front().seq == features.seq &&
        encoded_labels_.front().pixels == features.plane_labels.data) {
      labels = &encoded_labels_.front().message;  // the same Mat: lifting kept the labels
    }
    const pplvo_msgs::features_t m =
        msgs::toMsg(features, pplvo_msgs::features_t::STAGE_3D, labels);
    bus_.publish(options_.features_3d_channel, &m);
  }
  ledger_.published(features.seq);
}

StageTimings FrontendNode::allTimings() const {
  const StageTimings frontend = frontend_.timings();
  return pipeline::mergeTimings({&timings_, &frontend});
}

void FrontendNode::publishStatus(int64_t utime, bool final) {
  msgs::guarded(counters_, kName, [&] {
    pplvo_msgs::node_status_t m = msgs::toStatusMsg(kName, counters_, allTimings(), utime, final);
    msgs::appendBlockedPublishes(bus_, &m);
    bus_.publish(options_.status_channel, &m);
  });
}

}  // namespace pplvo::nodes
