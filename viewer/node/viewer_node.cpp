#include "viewer_node.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <opencv2/highgui.hpp>
#include <opencv2/imgcodecs.hpp>
#include <stdexcept>
#include <thread>

#include "pplvo/msgs/convert_features.h"
#include "pplvo/msgs/convert_pose.h"
#include "pplvo/msgs/node_runtime.h"

namespace pplvo {
namespace viewer {

namespace {
constexpr const char* kWindowName = "pplvo-viewer";
double secondsSince(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}
}  // namespace

ViewerNode::ViewerNode(const ViewerOptions& options, msgs::Bus bus)
    : options_(options), bus_(std::move(bus)) {
  if (!(options_.max_fps > 0)) throw std::invalid_argument("max_fps must be > 0");
  if (options_.every < 1) throw std::invalid_argument("every must be >= 1");
  if (options_.frame_ring < 1) options_.frame_ring = 1;
  if (!options_.snapshot_dir.empty()) {
    // --snapshot-dir DIR need not exist (as mkdir -p).
    std::error_code ec;
    std::filesystem::create_directories(options_.snapshot_dir, ec);
    if (ec) {
      throw std::runtime_error("cannot create snapshot folder " + options_.snapshot_dir + ": " +
                               ec.message());
    }
  }
  if (!options_.groundtruth_path.empty()) {
    eval::TumReadOptions ro;
    ro.fps = options_.groundtruth_fps;
    eval::TumReadResult r = eval::readTumFile(options_.groundtruth_path, ro);
    if (!r.ok) throw std::runtime_error("ground truth: " + r.error);
    groundtruth_ = std::move(r.file);
  }
  bus_.subscribe(options_.rgbd_channel, &ViewerNode::onRgbd, this, counters_, options_.node_name);
  bus_.subscribe(options_.depth_cgm_channel, &ViewerNode::onDepthCgm, this, counters_,
                 options_.node_name);
  bus_.subscribe(options_.depth_fused_channel, &ViewerNode::onDepthFused, this, counters_,
                 options_.node_name);
  bus_.subscribe(options_.features_channel, &ViewerNode::onFeatures, this, counters_,
                 options_.node_name);
  bus_.subscribe(options_.features_3d_channel, &ViewerNode::onFeatures3d, this, counters_,
                 options_.node_name);
  bus_.subscribe(options_.pose_channel, &ViewerNode::onPose, this, counters_, options_.node_name);
  bus_.subscribe(options_.status_channel, &ViewerNode::onStatus, this, counters_,
                 options_.node_name);
  bus_.subscribe(options_.stream_channel, &ViewerNode::onStream, this, counters_,
                 options_.node_name);
  last_status_ = Clock::now();
  last_draw_ = Clock::now() - std::chrono::hours(1);
}

ViewerNode::~ViewerNode() {
  if (video_) video_->release();
  if (window_open_) {
    try {
      cv::destroyWindow(kWindowName);
    } catch (...) {
    }
  }
}

// ---------------- handlers: copy (or cheap convert) only ----------------

void ViewerNode::onRgbd(const lcm::ReceiveBuffer*, const std::string&,
                        const pplvo_msgs::rgbd_frame_t* m) {
  msgs::guarded(counters_, options_.node_name.c_str(), [&] {
    ++counters_.frames_in;
    counters_.last_seq = m->seq;
    if (frame_pending_) ++counters_.frames_dropped;  // the previous newest was never drawn
    frame_ring_.push_back(*m);
    while (static_cast<int>(frame_ring_.size()) > options_.frame_ring) frame_ring_.pop_front();
    frame_pending_ = true;
    new_data_ = true;
  });
}

void ViewerNode::onDepthCgm(const lcm::ReceiveBuffer*, const std::string&,
                            const pplvo_msgs::depth_map_t* m) {
  msgs::guarded(counters_, options_.node_name.c_str(), [&] {
    cgm_ring_.push_back(*m);
    while (static_cast<int>(cgm_ring_.size()) > options_.frame_ring) cgm_ring_.pop_front();
    depth_cgm_pending_ = true;
    new_data_ = true;
  });
}

void ViewerNode::onDepthFused(const lcm::ReceiveBuffer*, const std::string&,
                              const pplvo_msgs::depth_map_t* m) {
  msgs::guarded(counters_, options_.node_name.c_str(), [&] {
    raw_fused_ = *m;
    depth_fused_pending_ = true;
    new_data_ = true;
  });
}

void ViewerNode::onFeatures(const lcm::ReceiveBuffer*, const std::string&,
                            const pplvo_msgs::features_t* m) {
  msgs::guarded(counters_, options_.node_name.c_str(), [&] {
    raw_features_ = *m;
    new_data_ = true;
  });
}

void ViewerNode::onFeatures3d(const lcm::ReceiveBuffer*, const std::string&,
                              const pplvo_msgs::features_t* m) {
  msgs::guarded(counters_, options_.node_name.c_str(), [&] {
    raw_features_3d_ = *m;
    new_data_ = true;
  });
}

void ViewerNode::onPose(const lcm::ReceiveBuffer*, const std::string&,
                        const pplvo_msgs::pose_t* m) {
  msgs::guarded(counters_, options_.node_name.c_str(), [&] {
    FramePose pose = msgs::fromMsg(*m);  // throws MessageError on NaN / bad rotation
    data_.trajectory.push_back(pose.T_w_c.translation());
    est_poses_.emplace_back(stampSeconds(pose.stamp, pose.utime), pose.T_w_c);
    data_.status.pose = std::move(pose);
    new_data_ = true;
  });
}

void ViewerNode::onStatus(const lcm::ReceiveBuffer*, const std::string&,
                          const pplvo_msgs::node_status_t* m) {
  msgs::guarded(counters_, options_.node_name.c_str(), [&] {
    if (m->node == options_.node_name) return;  // our own status: shown from the counters
    NodeStatusView v;
    v.node = m->node;
    v.last_seq = m->last_seq;
    v.frames_in = m->frames_in;
    v.frames_out = m->frames_out;
    v.frames_dropped = m->frames_dropped;
    v.frames_skipped = m->frames_skipped;
    v.errors = m->errors;
    v.last_warning = m->last_warning;
    for (const pplvo_msgs::stage_timing_t& s : m->stages) {
      v.stages.push_back(StageTimingView{s.name, s.count, s.last_ms, s.mean_ms, s.max_ms});
    }
    node_status_[m->node] = std::move(v);
    new_data_ = true;
  });
}

void ViewerNode::onStream(const lcm::ReceiveBuffer*, const std::string&,
                          const pplvo_msgs::stream_event_t* m) {
  msgs::guarded(counters_, options_.node_name.c_str(), [&] {
    if (m->event == pplvo_msgs::stream_event_t::EVENT_START) stream_started_ = true;
    if (m->event == pplvo_msgs::stream_event_t::EVENT_END ||
        m->event == pplvo_msgs::stream_event_t::EVENT_ERROR) {
      stream_ended_ = true;
    }
    new_data_ = true;
  });
}

double ViewerNode::stampSeconds(const std::string& stamp, int64_t utime) const {
  char* end = nullptr;
  double s = std::strtod(stamp.c_str(), &end);
  if (stamp.empty() || end == stamp.c_str() || !std::isfinite(s)) {
    s = static_cast<double>(utime) * 1e-6;
  } else if (options_.groundtruth_fps > 0) {
    s /= options_.groundtruth_fps;  // frame-index stamps, as the ground truth is read
  }
  return s;
}

// ---------------- main loop side ----------------

void ViewerNode::convertPending() {
  const char* name = options_.node_name.c_str();
  if (frame_pending_ && !frame_ring_.empty()) {
    msgs::guarded(counters_, name, [&] {
      const pplvo_msgs::rgbd_frame_t& m = frame_ring_.back();
      if (m.seq != shown_frame_seq_) {
        shown_frame_seq_ = m.seq;
        data_.frame = msgs::fromMsg(m);
      }
    });
  }
  // Features: the newest of 2D and 3D (3D wins on the same seq), shown on their own frame.
  if (raw_features_) {
    msgs::guarded(counters_, name, [&] { features_2d_ = msgs::fromMsg(*raw_features_); });
    raw_features_.reset();  // a bad message is counted once, not at every draw
  }
  if (raw_features_3d_) {
    msgs::guarded(counters_, name, [&] { features_3d_ = msgs::fromMsg(*raw_features_3d_); });
    raw_features_3d_.reset();
  }
  const FrameFeatures* newest = nullptr;
  if (features_3d_) newest = &*features_3d_;
  if (features_2d_ && (!newest || features_2d_->seq > newest->seq)) newest = &*features_2d_;
  if (newest) {
    data_.features = *newest;
    if (data_.frame && data_.frame->seq == newest->seq) {
      data_.feature_frame = data_.frame;
      shown_feature_frame_seq_ = newest->seq;
    } else if (shown_feature_frame_seq_ != newest->seq) {
      data_.feature_frame.reset();
      for (const auto& m : frame_ring_) {
        if (m.seq != newest->seq) continue;
        shown_feature_frame_seq_ = newest->seq;  // tried once, even if it fails to decode
        msgs::guarded(counters_, name, [&] { data_.feature_frame = msgs::fromMsg(m); });
        break;
      }
    }
  } else {
    data_.feature_frame.reset();
  }
  if (depth_fused_pending_ && raw_fused_) {
    shown_fused_is_raw_ = false;
    fusion_only_compared_ = false;
    msgs::guarded(counters_, name, [&] {
      data_.fused_depth = msgs::fromMsg(*raw_fused_);
      data_.fused_title = "fused depth (seq " + std::to_string(raw_fused_->seq) + ")";
      shown_fused_is_raw_ = true;
    });
    updateFusionOnly();
    depth_fused_pending_ = false;
  } else if (depth_cgm_pending_ && !cgm_ring_.empty() && !raw_fused_) {
    // No fused map yet: show the C-GM (or sensor-model) map in its place.
    const pplvo_msgs::depth_map_t& cgm = cgm_ring_.back();
    msgs::guarded(counters_, name, [&] {
      data_.fused_depth = msgs::fromMsg(cgm);
      data_.fused_title = std::string(cgm.stage == pplvo_msgs::depth_map_t::STAGE_SENSOR
                                          ? "sensor-model depth"
                                          : "C-GM depth") +
                          " (seq " + std::to_string(cgm.seq) + ")";
    });
    data_.fusion_only_mask = cv::Mat();
    data_.status.fusion_only_px.reset();
  } else if (depth_cgm_pending_ && raw_fused_ && !fusion_only_compared_) {
    updateFusionOnly();  // the fused map came before its frame's C-GM map (other routes)
  }
  depth_cgm_pending_ = false;
}

void ViewerNode::updateFusionOnly() {
  data_.fusion_only_mask = cv::Mat();
  data_.status.fusion_only_px.reset();
  if (!raw_fused_ || !data_.fused_depth || !shown_fused_is_raw_) return;
  // Only an O-GM map can hold depth from other frames (the depth filter publishes its C-GM
  // map as the fused one when O-GM is off or fails).
  if (raw_fused_->stage != pplvo_msgs::depth_map_t::STAGE_OGM) return;
  const pplvo_msgs::depth_map_t* cgm = nullptr;
  for (const auto& m : cgm_ring_) {
    if (m.seq == raw_fused_->seq && m.utime == raw_fused_->utime) cgm = &m;
  }
  if (!cgm) return;  // its frame's C-GM map was not received (or fell out of the ring)
  fusion_only_compared_ = true;  // once per fused map: a bad pair is counted once
  msgs::guarded(counters_, options_.node_name.c_str(), [&] {
    const DepthWithVariance cgm_depth = msgs::viewOfMsg(*cgm);
    FusionOnlyDepth f = fusionOnlyPixels(data_.fused_depth->depth_m, cgm_depth.depth_m);
    if (!f.error.empty()) throw msgs::MessageError("fusion-only depth: " + f.error);
    data_.fusion_only_mask = std::move(f.mask);
    data_.status.fusion_only_px = f.n_fusion_only;
    data_.status.fusion_only_share = f.share();
  });
}

void ViewerNode::pollKeys(int wait_ms) {
  const int key = cv::waitKey(wait_ms);
  if (key == 27 || key == 'q' || key == 'Q') msgs::requestShutdown();  // Esc or q closes
  if (key == 'f' || key == 'F') {  // toggles the tint of depth only through fusion
    options_.canvas.show_fusion_only = !options_.canvas.show_fusion_only;
    new_data_ = true;
  }
}

bool ViewerNode::drawIfNew() {
  if (!new_data_) return false;
  draw();
  return true;
}

void ViewerNode::draw() {
  Stopwatch watch;
  {
    ScopedStageTimer t(timings_, "convert");
    convertPending();
  }
  StatusPanelData& s = data_.status;
  s.n_points = s.n_lines = s.n_planes = s.n_points_3d = s.n_lines_3d = 0;
  if (features_2d_) {
    s.n_points = static_cast<int>(features_2d_->points.size());
    s.n_lines = static_cast<int>(features_2d_->lines.size());
    s.n_planes = static_cast<int>(features_2d_->planes.size());
  }
  if (features_3d_) {
    for (const auto& p : features_3d_->points) s.n_points_3d += p.has_3d ? 1 : 0;
    for (const auto& l : features_3d_->lines) s.n_lines_3d += l.has_3d ? 1 : 0;
    if (!features_2d_) s.n_planes = static_cast<int>(features_3d_->planes.size());
  }
  s.window_length = data_.fused_depth ? data_.fused_depth->window_length : 0;
  s.frames_received = counters_.frames_in;
  s.frames_drawn = counters_.frames_out + (frame_pending_ ? 1 : 0);
  s.frames_dropped = counters_.frames_dropped;
  s.stream_state = stream_ended_ ? "ended" : (stream_started_ ? "started" : "");
  const auto now = Clock::now();
  draw_times_.push_back(now);
  while (draw_times_.size() > 1 &&
         std::chrono::duration<double>(now - draw_times_.front()).count() > 2.0) {
    draw_times_.pop_front();
  }
  s.draw_fps =
      draw_times_.size() > 1
          ? (draw_times_.size() - 1) /
                std::max(1e-6, std::chrono::duration<double>(now - draw_times_.front()).count())
          : 0.0;
  s.nodes.clear();
  for (const auto& kv : node_status_) s.nodes.push_back(kv.second);
  if (groundtruth_ && !est_poses_.empty()) {
    data_.ground_truth =
        alignGroundTruth(*groundtruth_, est_poses_, options_.alignment).gt_in_world_m;
  }
  cv::Mat canvas;
  msgs::guarded(counters_, options_.node_name.c_str(), [&] {
    ScopedStageTimer t(timings_, "render");
    canvas = renderCanvas(data_, options_.canvas);
  });
  if (frame_pending_) ++counters_.frames_out;
  frame_pending_ = false;
  new_data_ = false;
  last_draw_ = Clock::now();
  if (canvas.empty()) return;
  last_canvas_ = canvas;
  ++canvases_drawn_;
  {
    ScopedStageTimer t(timings_, "output");
    writeOutputs(canvas);
  }
  timings_.add("draw_total", watch.elapsedMs());
}

void ViewerNode::writeOutputs(const cv::Mat& canvas) {
  msgs::guarded(counters_, options_.node_name.c_str(), [&] {
    if (!options_.snapshot_dir.empty() && (canvases_drawn_ - 1) % options_.every == 0) {
      char name[64];
      std::snprintf(name, sizeof name, "/canvas_%06lld.png",
                    static_cast<long long>(canvases_drawn_ - 1));
      if (cv::imwrite(options_.snapshot_dir + name, canvas)) {
        ++snapshots_written_;
      } else {
        output_failed_ = true;
        throw std::runtime_error("cannot write " + options_.snapshot_dir + name);
      }
    }
    if (!options_.video_path.empty()) {
      if (!video_) {
        video_ = std::make_unique<cv::VideoWriter>(options_.video_path,
                                                   cv::VideoWriter::fourcc('M', 'J', 'P', 'G'),
                                                   options_.max_fps, canvas.size(), true);
        if (!video_->isOpened()) {
          output_failed_ = true;
          throw std::runtime_error("cannot open video " + options_.video_path);
        }
      }
      if (video_->isOpened()) video_->write(canvas);
    }
    if (!options_.window_save_path.empty() && !cv::imwrite(options_.window_save_path, canvas)) {
      output_failed_ = true;
      throw std::runtime_error("cannot write " + options_.window_save_path);
    }
    if (options_.show_window) {
      if (!window_open_) {
        cv::namedWindow(kWindowName, cv::WINDOW_AUTOSIZE | cv::WINDOW_GUI_NORMAL);
        window_open_ = true;
      }
      cv::imshow(kWindowName, canvas);
      pollKeys(1);
    }
  });
}

void ViewerNode::publishStatus() {
  if (!options_.publish_status) return;
  msgs::guarded(counters_, options_.node_name.c_str(), [&] {
    counters_.frames_pending = frame_pending_ ? 1 : 0;  // the newest frame, not drawn yet
    pplvo_msgs::node_status_t msg =
        msgs::toStatusMsg(options_.node_name, counters_, timings_, hostUtime());
    msgs::appendBlockedPublishes(bus_, &msg);
    bus_.publish(options_.status_channel, &msg);
  });
  last_status_ = Clock::now();
}

int ViewerNode::spinOnce(double wait_s) {
  int handled = 0;
  const int wait_ms = std::max(0, static_cast<int>(std::lround(wait_s * 1000.0)));
  int rc = bus_.handleTimeout(wait_ms);
  const double period_s = 1.0 / options_.max_fps;
  const double drain_budget_s = std::max(period_s, 0.05);
  const auto start = Clock::now();
  // Drain what is queued, but not for so long that drawing starves.
  while (rc > 0) {
    ++handled;
    if (secondsSince(start) > drain_budget_s) break;
    rc = bus_.handleTimeout(0);
  }
  if (rc < 0 && !input_ended_) {
    // A file:// log at its end (or a broken provider): nothing more will arrive.
    input_ended_ = true;
    counters_.last_warning = "LCM input ended (end of log or provider failure)";
    std::fprintf(stderr, "[%s] %s\n", options_.node_name.c_str(), counters_.last_warning.c_str());
  }
  if (new_data_ && secondsSince(last_draw_) >= period_s) draw();
  if (window_open_) pollKeys(1);
  if (secondsSince(last_status_) >= options_.status_period_s) publishStatus();
  return handled;
}

int ViewerNode::run() {
  const auto start = Clock::now();
  std::optional<Clock::time_point> end_seen;
  while (!msgs::shutdownRequested()) {
    const double until_draw = 1.0 / options_.max_fps - secondsSince(last_draw_);
    if (input_ended_) {
      // Nothing more can arrive: stop, or keep the window up until --timeout.
      if (options_.timeout_s <= 0) break;
      drawIfNew();
      if (window_open_)
        pollKeys(50);
      else
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
    } else {
      spinOnce(std::clamp(new_data_ ? until_draw : 0.05, 0.0, 0.05));
    }
    if (options_.timeout_s > 0 && secondsSince(start) >= options_.timeout_s) break;
    if (options_.exit_after_end && stream_ended_) {
      // Let the last frame's downstream messages (pose, fused depth) arrive.
      if (!end_seen) end_seen = Clock::now();
      if (secondsSince(*end_seen) >= 0.5) break;
    }
  }
  drawIfNew();
  publishStatus();
  if (video_) video_->release();  // finish the AVI index now, not at destruction
  return output_failed_ ? 1 : 0;
}

}  // namespace viewer
}  // namespace pplvo
