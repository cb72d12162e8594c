#include "pplvo/run/run_pipeline.h"

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <lcm/lcm-cpp.hpp>
#include <memory>
#include <pplvo_msgs/pose_t.hpp>
#include <sstream>
#include <thread>

#include "pplvo/depth_filter_node/depth_filter_node.h"
#include "pplvo/logging/event_log.h"
#include "pplvo/msgs/convert_pose.h"
#include "pplvo/msgs/node_runtime.h"
#include "pplvo/odometry_nodes/estimator_node.h"
#include "pplvo/odometry_nodes/frontend_node.h"

namespace pplvo::run {

namespace {

/// Collects the published poses into the trajectory (the logger's job in a launch).
class PoseCollector {
 public:
  PoseCollector(lcm::LCM& lcm, RunResult& result) : lcm_(lcm), result_(result) {
    sub_ = lcm_.subscribe(channels::kPose, &PoseCollector::onPose, this);
  }
  ~PoseCollector() { lcm_.unsubscribe(sub_); }
  void onPose(const lcm::ReceiveBuffer*, const std::string&, const pplvo_msgs::pose_t* msg) {
    msgs::guarded(counters_, "pplvo-run", [&] {
      const FramePose p = msgs::fromMsg(*msg);
      StampedPose s;
      s.stamp_text = p.stamp;
      s.T_w_c = p.T_w_c;
      result_.trajectory.push_back(s);
      result_.frame_poses.push_back(p);
      ++result_.poses;
      result_.add(p.status);
    });
  }
  const msgs::NodeCounters& counters() const { return counters_; }

 private:
  lcm::LCM& lcm_;
  RunResult& result_;
  lcm::Subscription* sub_ = nullptr;
  msgs::NodeCounters counters_;
};

/// Writes every message of the run to an LCM event log (what pplvo-logger does on a network),
/// so that any stage can be replayed from it (pplvo-replay).
class EventRecorder {
 public:
  EventRecorder(lcm::LCM& lcm, const std::string& path, const std::string& channels)
      : lcm_(lcm), writer_(path) {
    sub_ = lcm_.subscribe(channels, &EventRecorder::onMessage, this);
  }
  ~EventRecorder() { lcm_.unsubscribe(sub_); }
  void onMessage(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
    msgs::guarded(counters_, "pplvo-run", [&] {
      writer_.write(channel, rbuf->recv_utime, rbuf->data, static_cast<int32_t>(rbuf->data_size));
    });
  }
  const msgs::NodeCounters& counters() const { return counters_; }

 private:
  lcm::LCM& lcm_;
  logging::EventLogWriter writer_;
  lcm::Subscription* sub_ = nullptr;
  msgs::NodeCounters counters_;
};

}  // namespace

double RunResult::pipelineMsPerFrame() const {
  double ms = 0;
  for (const NodeReport& n : nodes) {
    if (n.name == "pplvo-player") continue;
    for (const StageStats& s : n.timings.stages()) {
      // Stages that run once per frame; per-frame cost = total / frames.
      if (poses > 0) ms += s.total_ms / static_cast<double>(poses);
    }
  }
  return ms;
}

std::string RunResult::text() const {
  std::ostringstream out;
  char buf[256];
  std::snprintf(buf, sizeof buf,
                "frames: published %lld, skipped %lld, posed %lld (first %lld, tracking %lld, "
                "velocity model %lld, lost %lld, reinitialised %lld)\n",
                static_cast<long long>(frames_published), static_cast<long long>(frames_skipped),
                static_cast<long long>(poses), static_cast<long long>(first),
                static_cast<long long>(tracking), static_cast<long long>(velocity_model),
                static_cast<long long>(lost), static_cast<long long>(reinitialised));
  out << buf;
  if (!index.source.empty()) out << "dataset: " << index.text() << "\n";
  if (keyframes > 0) {
    std::snprintf(buf, sizeof buf, "keyframes: %lld (fallbacks to the previous frame %lld)\n",
                  static_cast<long long>(keyframes), static_cast<long long>(keyframe_fallbacks));
    out << buf << "  chosen for: " << keyframe_reasons << "\n";
    if (keyframes_reused > 0) out << "  earlier keyframes re-used: " << keyframes_reused << "\n";
  }
  if (poses > 1) {
    std::snprintf(buf, sizeof buf, "shared frame error: %.2f mm, %.3f deg per axis (%s)\n",
                  1e3 * frame_error_sigma_t_m, frame_error_sigma_rot_deg,
                  frame_error_source.describe());
    out << buf;
  }
  if (readout_readings > 0) {
    std::snprintf(buf, sizeof buf,
                  "colour readout read from the frames: %.1f ms (standard error %.1f ms, %lld "
                  "readings; %s)\n",
                  1e3 * readout_mean_s, 1e3 * readout_standard_error_s,
                  static_cast<long long>(readout_readings),
                  readout_used ? "compensated" : "not clear of zero: frames as read");
    out << buf;
  }
  if (weak_estimates_combined > 0 || estimates_gated > 0) {
    std::snprintf(buf, sizeof buf,
                  "weak estimates combined with the prediction: %lld; estimates refused by the "
                  "prediction gate: %lld\n",
                  static_cast<long long>(weak_estimates_combined),
                  static_cast<long long>(estimates_gated));
    out << buf;
  }
  for (const NodeReport& n : nodes) {
    out << n.name << ": " << msgs::countsText(n.counters) << "\n";
    if (!n.counters.last_warning.empty())
      out << "  last warning: " << n.counters.last_warning << "\n";
    std::istringstream table(n.timings.table());
    for (std::string line; std::getline(table, line);) out << "  " << line << "\n";
  }
  std::snprintf(buf, sizeof buf,
                "throughput: %.1f frames/s end to end (%.2f s wall%s), pipeline %.1f ms/frame "
                "(sum of stages, excluding the player)\n",
                framesPerSecond(), elapsed_s - preload_s,
                preload_s > 0 ? ", after the frames were decoded" : "", pipelineMsPerFrame());
  out << buf;
  if (failed) out << "FAILED: " << error << "\n";
  return out.str();
}

std::string RunResult::yaml() const {
  std::ostringstream out;
  out << "frames_published: " << frames_published << "\n"
      << "frames_skipped: " << frames_skipped << "\n"
      << "poses: " << poses << "\n"
      << "status: {first: " << first << ", tracking: " << tracking
      << ", velocity_model: " << velocity_model << ", lost: " << lost
      << ", reinitialised: " << reinitialised << "}\n"
      << "keyframes: {taken: " << keyframes << ", fallbacks: " << keyframe_fallbacks
      << ", reused: " << keyframes_reused << "}\n"
      << "frame_error: {sigma_t_m: " << frame_error_sigma_t_m
      << ", sigma_rot_deg: " << frame_error_sigma_rot_deg
      << ", estimated: " << (frame_error_source.online() ? "true" : "false")
      << ", translation_estimated: " << (frame_error_source.translation_online ? "true" : "false")
      << ", rotation_estimated: " << (frame_error_source.rotation_online ? "true" : "false")
      << "}\n"
      << "readout_from_frames: {mean_s: " << readout_mean_s
      << ", standard_error_s: " << readout_standard_error_s << ", readings: " << readout_readings
      << ", used: " << (readout_used ? "true" : "false") << "}\n"
      << "weak_estimates_combined: " << weak_estimates_combined << "\n"
      << "estimates_gated: " << estimates_gated << "\n"
      << "elapsed_s: " << elapsed_s << "\n"
      << "preload_s: " << preload_s << "\n"
      << "frames_per_s: " << framesPerSecond() << "\n"
      << "pipeline_ms_per_frame: " << pipelineMsPerFrame() << "\n"
      << "failed: " << (failed ? "true" : "false") << "\n"
      << "index: {listed: " << index.listed << ", malformed_lines: " << index.malformed_lines
      << ", missing_rgb_files: " << index.missing_rgb_files
      << ", missing_depth_files: " << index.missing_depth_files
      << ", unassociated_rgb: " << index.unassociated_rgb
      << ", out_of_order: " << index.out_of_order
      << ", duplicate_stamps: " << index.duplicate_stamps << "}\n";
  if (failed) out << "error: \"" << error << "\"\n";
  out << "nodes:\n";
  for (const NodeReport& n : nodes) {
    out << "  " << n.name << ":\n"
        << "    frames_in: " << n.counters.frames_in << "\n"
        << "    frames_out: " << n.counters.frames_out << "\n"
        << "    frames_dropped: " << n.counters.frames_dropped << "\n"
        << "    frames_skipped: " << n.counters.frames_skipped << "\n"
        << "    frames_pending: " << n.counters.frames_pending << "\n"
        << "    frames_lost: " << n.counters.frames_lost << "\n"
        << "    messages_skipped: " << n.counters.messages_skipped << "\n"
        << "    errors: " << n.counters.errors << "\n"
        << "    stages_mean_ms:\n";
    for (const StageStats& s : n.timings.stages()) {
      out << "      " << s.name << ": " << s.meanMs() << "\n";
    }
  }
  return out.str();
}

RunResult runPipeline(const RunOptions& options) {
  RunResult result;
  try {
    lcm::LCM lcm("memq://");
    if (!lcm.good()) throw std::runtime_error("cannot open memq:// LCM");

    nodes::DepthFilterNodeOptions df;
    df.filter = options.pipeline.depth_filter;
    df.filter.overload.backlog =
        0;  // every frame fused over the full window (in_flight is bounded)
    // The fusion of frame k runs on a worker while frame k+1 is posed on this thread
    // (FrameTracker::step needs frame k's 3D features only for a keyframe or a fallback).
    df.fuse_on_worker = true;
    // Off the loop, the fusion is what the loop waits for on every other frame (a frame's
    // landmark fusion is due two frames later): with "auto" threads it takes two bands, so the
    // loop's core, idle while it waits, fuses one of them (measured: docs/pipeline.md).
    if (df.filter.ogm.threads == 0) {
      df.filter.ogm.threads =
          std::clamp(static_cast<int>(std::thread::hardware_concurrency()), 1, 2);
    }
    nodes::DepthFilterNode depth_filter(df, lcm);

    nodes::FrontendNodeOptions fe;
    fe.frontend = options.pipeline.frontend;
    // The player bounds the frames in flight: none is dropped for waiting (every frame posed).
    fe.max_unlifted = 0;
    nodes::FrontendNode frontend(fe, lcm);

    nodes::EstimatorNodeOptions es;
    es.odometry = options.pipeline.odometry;
    es.max_waiting = std::max(es.max_waiting, options.in_flight);
    nodes::EstimatorNode estimator(es, lcm);

    PoseCollector collector(lcm, result);
    std::unique_ptr<EventRecorder> recorder;
    if (!options.log.empty()) recorder = std::make_unique<EventRecorder>(lcm, options.log, options.log_channels);

    player::PlayerOptions po;
    po.dataset_dir = options.dataset_dir;
    po.camera_file = options.camera_file;
    po.rate = 0.0;  // as fast as possible
    // Every handler runs in this thread (the fusion and the extraction on workers): the player
    // dispatches memq's messages one at a time and publishes the next frame as soon as fewer
    // than in_flight frames lack their pose.
    po.lockstep = true;
    po.lockstep_in_flight = std::max(1, options.in_flight);
    po.in_process = true;
    po.fps = options.fps;
    po.start = options.start;
    po.max_frames = options.max_frames;
    po.skip_bad = options.skip_bad;
    po.progress = options.progress;
    po.preload = options.preload;
    po.status_period_s = 1e9;  // no status messages inside one process
    if (options.compact_log) {
      po.rgb_encoding = pplvo_msgs::image_t::ENCODING_JPEG;
      po.jpeg_quality = options.jpeg_quality;
      po.depth_encoding = pplvo_msgs::image_t::ENCODING_ZLIB_U16;
    }
    // Nothing queued: publish what the workers finished, waiting for the first of them.
    po.in_process_idle = [&] {
      while (depth_filter.fusing() || frontend.extracting()) {
        const bool fused = depth_filter.publishFusions(false);
        if (frontend.publishStage2d(false) || fused) return true;
        std::this_thread::sleep_for(std::chrono::microseconds(50));
      }
      return false;
    };
    player::PlayerNode player(po, lcm);

    result.index = player.dataset().index().summary;
    const player::PlayerResult pr = player.run();
    result.frames_published = pr.published;
    result.frames_skipped = pr.skipped;
    result.elapsed_s = pr.elapsed_s;
    if (const StageStats* preload = player.timings().find("preload")) {
      result.preload_s = preload->total_ms / 1000.0;
    }
    if (pr.failed) {
      result.failed = true;
      result.error = pr.error;
    }
    result.nodes.push_back({"pplvo-player", player.counters(), player.timings()});
    result.nodes.push_back(
        {nodes::DepthFilterNode::kName, depth_filter.counters(), depth_filter.timings()});
    result.nodes.push_back(
        {nodes::FrontendNode::kName, frontend.counters(), frontend.allTimings()});
    result.nodes.push_back(
        {nodes::EstimatorNode::kName, estimator.counters(), estimator.allTimings()});
    result.keyframes = estimator.counts().keyframes;
    result.keyframe_fallbacks = estimator.counts().keyframe_fallbacks;
    result.keyframes_reused = estimator.counts().keyframes_reused;
    result.frame_error_sigma_t_m = estimator.counts().frame_error.t_m;
    result.frame_error_sigma_rot_deg = estimator.counts().frame_error.rot_rad * 180.0 / M_PI;
    result.frame_error_source = estimator.counts().frame_error_source;
    result.weak_estimates_combined = estimator.counts().weak_estimates_combined;
    result.estimates_gated = estimator.counts().estimates_gated;
    result.readout_mean_s = estimator.counts().readout_mean_s;
    result.readout_standard_error_s = estimator.counts().readout_standard_error_s;
    result.readout_readings = estimator.counts().readout_readings;
    result.readout_used = estimator.counts().readout_used;
    for (int r = 1; r < tracking::kKeyframeReasons; ++r) {
      result.keyframe_reasons += (r > 1 ? ", " : "");
      result.keyframe_reasons += tracking::toString(static_cast<tracking::KeyframeReason>(r));
      result.keyframe_reasons += " " + std::to_string(estimator.counts().keyframe_reasons[r]);
    }
    if (recorder && recorder->counters().errors > 0) {
      result.failed = true;
      result.error = "event log: " + recorder->counters().last_warning;
    }
    if (collector.counters().frames_skipped + collector.counters().errors > 0) {
      result.failed = true;
      result.error = "invalid pose messages: " + collector.counters().last_warning;
    }
  } catch (const std::exception& e) {
    result.failed = true;
    result.error = e.what();
  }
  return result;
}

std::string outputFileError(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) return "is a directory";
  const bool existed = std::filesystem::exists(path, ec);
  std::FILE* f = std::fopen(path.c_str(), "a");
  if (f == nullptr) return std::strerror(errno);
  std::fclose(f);
  if (!existed) std::filesystem::remove(path, ec);
  return "";
}

}  // namespace pplvo::run
