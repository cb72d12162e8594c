#pragma once
/// pplvo-viewer's LCM node: handlers only copy messages (inside guarded()); the main loop
/// converts the newest ones, renders with pplvo_viewer_render and shows / writes the canvas at
/// most at max_fps. See docs/viewer.md.
#include <chrono>
#include <cstdint>
#include <deque>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <memory>
#include <opencv2/videoio.hpp>
#include <optional>
#include <pplvo_msgs/depth_map_t.hpp>
#include <pplvo_msgs/features_t.hpp>
#include <pplvo_msgs/node_status_t.hpp>
#include <pplvo_msgs/pose_t.hpp>
#include <pplvo_msgs/rgbd_frame_t.hpp>
#include <pplvo_msgs/stream_event_t.hpp>
#include <string>
#include <vector>

#include "pplvo/eval/tum_file.h"
#include "pplvo/msgs/bus.h"
#include "pplvo/msgs/channels.h"
#include "pplvo/msgs/convert.h"
#include "pplvo/viewer/plot.h"
#include "pplvo/viewer/render.h"

namespace pplvo {
namespace viewer {

struct ViewerOptions {
  std::string node_name = "pplvo-viewer";
  std::string rgbd_channel = channels::kRgbd;
  std::string depth_cgm_channel = channels::kDepthCgm;
  std::string depth_fused_channel = channels::kDepthFused;
  std::string features_channel = channels::kFeatures;
  std::string features_3d_channel = channels::kFeatures3d;
  std::string pose_channel = channels::kPose;
  std::string status_channel = channels::kStatus;
  std::string stream_channel = channels::kStream;
  double max_fps = 15.0;     ///< at most this many canvases per second
  bool show_window = true;   ///< false: --headless
  std::string snapshot_dir;  ///< write canvas_<n>.png every `every` drawn canvases
  int every = 1;
  std::string video_path;        ///< MJPG AVI of every drawn canvas
  bool exit_after_end = false;   ///< stop after stream_event_t END (and a last draw)
  double timeout_s = 0.0;        ///< > 0: stop after this long
  double status_period_s = 1.0;  ///< own node_status_t on the status channel
  bool publish_status = true;
  std::string groundtruth_path;  ///< TUM file, optional
  double groundtruth_fps = 0.0;  ///< > 0: stamps are frame indices (ICL-NUIM), both files
  GtAlignment alignment = GtAlignment::kFirstPose;
  std::string window_save_path;  ///< also save each displayed canvas here (overwritten)
  CanvasOptions canvas;
  int frame_ring = 8;  ///< recent raw frames kept to show features on their frame
};

class ViewerNode {
 public:
  /// Subscribes; reads the ground truth (throws std::runtime_error when it cannot be read);
  /// opens the video writer lazily at the first canvas.
  ViewerNode(const ViewerOptions& options, msgs::Bus bus);
  ~ViewerNode();
  ViewerNode(const ViewerNode&) = delete;
  ViewerNode& operator=(const ViewerNode&) = delete;

  /// Handles every message already queued (waiting at most `wait_s` for the first), then
  /// draws if a new message arrived and 1/max_fps has passed since the last draw.
  /// Returns the number of messages handled.
  int spinOnce(double wait_s);
  /// Loops on spinOnce until shutdown, --timeout, or the stream END (--exit-after-end);
  /// draws a last canvas with the newest data before returning. Returns 0, or 1 on a failure
  /// to write outputs.
  int run();
  /// Draws now if there is anything new (used at the end of a run and in tests).
  bool drawIfNew();

  bool streamEnded() const { return stream_ended_; }
  /// LCM handle failed: the end of a file:// log (or a broken provider).
  bool inputEnded() const { return input_ended_; }
  const msgs::NodeCounters& counters() const { return counters_; }
  int64_t canvasesDrawn() const { return canvases_drawn_; }
  int64_t snapshotsWritten() const { return snapshots_written_; }
  bool outputFailed() const { return output_failed_; }
  /// The last canvas drawn (empty before the first).
  const cv::Mat& lastCanvas() const { return last_canvas_; }
  /// What the last canvas was drawn from.
  const ViewerFrameData& frameData() const { return data_; }

  void onRgbd(const lcm::ReceiveBuffer*, const std::string&, const pplvo_msgs::rgbd_frame_t* m);
  void onDepthCgm(const lcm::ReceiveBuffer*, const std::string&, const pplvo_msgs::depth_map_t* m);
  void onDepthFused(const lcm::ReceiveBuffer*, const std::string&,
                    const pplvo_msgs::depth_map_t* m);
  void onFeatures(const lcm::ReceiveBuffer*, const std::string&, const pplvo_msgs::features_t* m);
  void onFeatures3d(const lcm::ReceiveBuffer*, const std::string&, const pplvo_msgs::features_t* m);
  void onPose(const lcm::ReceiveBuffer*, const std::string&, const pplvo_msgs::pose_t* m);
  void onStatus(const lcm::ReceiveBuffer*, const std::string&, const pplvo_msgs::node_status_t* m);
  void onStream(const lcm::ReceiveBuffer*, const std::string&, const pplvo_msgs::stream_event_t* m);

 private:
  using Clock = std::chrono::steady_clock;
  void draw();
  void convertPending();
  void writeOutputs(const cv::Mat& canvas);
  void publishStatus();
  /// The fused map's pixels with depth only through fusion, against its frame's C-GM map.
  void updateFusionOnly();
  /// GUI events of the window; Esc or q requests shutdown, f toggles the fusion-only tint.
  void pollKeys(int wait_ms);
  double stampSeconds(const std::string& stamp, int64_t utime) const;

  ViewerOptions options_;
  msgs::Bus bus_;
  msgs::NodeCounters counters_;
  StageTimings timings_;

  // Raw messages copied by the handlers (newest only, plus a small ring of frames).
  std::deque<pplvo_msgs::rgbd_frame_t> frame_ring_;
  bool frame_pending_ = false;
  /// Recent C-GM maps (newest last, frame_ring of them): a fused map is compared with the
  /// C-GM map of its own frame (same seq and utime), which arrived before it.
  std::deque<pplvo_msgs::depth_map_t> cgm_ring_;
  std::optional<pplvo_msgs::depth_map_t> raw_fused_;
  std::optional<pplvo_msgs::features_t> raw_features_, raw_features_3d_;
  bool new_data_ = false;
  bool depth_cgm_pending_ = false, depth_fused_pending_ = false;
  bool shown_fused_is_raw_ = false;  ///< data_.fused_depth was converted from raw_fused_
  bool fusion_only_compared_ = false;  ///< raw_fused_ was compared with its frame's C-GM map

  // Converted state used for drawing.
  ViewerFrameData data_;
  int64_t shown_frame_seq_ = -1, shown_feature_frame_seq_ = -1;
  std::optional<FrameFeatures> features_2d_, features_3d_;
  StampedPoses est_poses_;
  std::optional<eval::TumFile> groundtruth_;
  std::map<std::string, NodeStatusView> node_status_;
  bool stream_started_ = false, stream_ended_ = false, input_ended_ = false;

  // Outputs.
  int64_t canvases_drawn_ = 0, snapshots_written_ = 0;
  bool output_failed_ = false;
  cv::Mat last_canvas_;
  std::unique_ptr<cv::VideoWriter> video_;
  bool window_open_ = false;
  Clock::time_point last_draw_{};
  Clock::time_point last_status_{};
  std::deque<Clock::time_point> draw_times_;
};

}  // namespace viewer
}  // namespace pplvo
