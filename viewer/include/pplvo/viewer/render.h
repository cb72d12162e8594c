#pragma once
/// Rendering of the viewer's panels (no LCM): every function takes library types and returns
/// a cv::Mat (CV_8UC3 BGR) so that it can be tested without a display or a bus.
/// See docs/viewer.md.
#include <Eigen/Core>
#include <cstdint>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "pplvo/core/features.h"
#include "pplvo/core/frame_pose.h"
#include "pplvo/core/rgbd_frame.h"

namespace pplvo {
namespace viewer {

/// A colour-mapped scalar image (depth or its standard deviation) with a labelled scale bar.
struct ScalarPanelOptions {
  int colormap = 20;  ///< cv::COLORMAP_TURBO (20); cv::COLORMAP_JET is 2
  /// Value range of the colour bar, metres. min >= max: automatic, from the 2nd and 98th
  /// percentiles of the valid (> 0, finite) values.
  double min_value_m = 0.0;
  double max_value_m = 0.0;
  double percentile_low = 0.02, percentile_high = 0.98;
  cv::Scalar missing_bgr = cv::Scalar(0, 0, 0);  ///< colour of missing (0 or NaN) pixels
  /// Tint of highlighted pixels (depth only through fusion): magenta, which the turbo map
  /// does not contain, blended at highlight_alpha so that the depth colour still shows.
  cv::Scalar highlight_bgr = cv::Scalar(255, 0, 255);
  double highlight_alpha = 0.6;
};

/// Range actually used for a scalar panel (after the automatic choice).
struct ValueRange {
  double min_m = 0.0, max_m = 1.0;
  int n_valid = 0;  ///< valid pixels (> 0 and finite)
};

/// Range of the valid values of a CV_32FC1 image following `options` (automatic or fixed).
ValueRange chooseRange(const cv::Mat& value_m, const ScalarPanelOptions& options);

/// Colour-maps a CV_32FC1 image on [range.min_m, range.max_m]; missing pixels get
/// options.missing_bgr. Returns CV_8UC3 of the same size.
cv::Mat colorizeScalar(const cv::Mat& value_m, const ValueRange& range,
                       const ScalarPanelOptions& options);

/// A panel of `size`: title, the colour-mapped image fitted to the left and a vertical colour
/// bar on the right with ticks labelled in metres (`unit` is printed under the bar, "[m]").
/// An empty `value_m` gives a grey panel saying "no data". A non-empty `highlight`
/// (CV_8UC1 of value_m's size) tints its pixels with options.highlight_bgr and writes
/// `highlight_legend` at the bottom left (used for depth only through fusion).
cv::Mat renderScalarPanel(const cv::Mat& value_m, const std::string& title, cv::Size size,
                          const ScalarPanelOptions& options = {}, const std::string& unit = "m",
                          const cv::Mat& highlight = cv::Mat(),
                          const std::string& highlight_legend = "");

/// Pixels of a frame that have depth only through fusion (docs/viewer.md, "Depth only through
/// fusion"): valid (> 0, finite) in the frame's fused map (PPLVO_DEPTH_FUSED, O-GM) but not in
/// the same frame's C-GM map (PPLVO_DEPTH_CGM, the frame's own depth): their depth came from
/// the window's past frames, e.g. outside a narrow depth camera's view.
struct FusionOnlyDepth {
  cv::Mat mask;           ///< CV_8UC1, 255 at fusion-only pixels, else 0; empty on error
  int n_fusion_only = 0;  ///< pixels set in `mask`
  int n_fused_valid = 0;  ///< valid pixels of the fused map
  int n_cgm_valid = 0;    ///< valid pixels of the C-GM map
  std::string error;      ///< non-empty when the maps cannot be compared (nothing computed)
  /// Share of the fused map's valid pixels that are fusion-only (0 when it has none).
  double share() const {
    return n_fused_valid > 0 ? static_cast<double>(n_fusion_only) / n_fused_valid : 0.0;
  }
};
/// Compares a frame's fused and C-GM depth maps (CV_32FC1, metres, 0 / NaN = missing; the
/// same size). Maps of another type or size give `error` and no mask, never an exception.
FusionOnlyDepth fusionOnlyPixels(const cv::Mat& fused_depth_m, const cv::Mat& cgm_depth_m);

/// Tints the pixels set in `mask` (CV_8UC1, size of `bgr`) of a CV_8UC3 image:
/// out = (1 - alpha) bgr + alpha tint. A mask of another size or type leaves `bgr` unchanged.
void tintPixels(cv::Mat& bgr, const cv::Mat& mask, const cv::Scalar& tint_bgr, double alpha);

/// Standard deviation sqrt(var) of a variance image (m^2 -> m); 0 where var <= 0 or NaN.
cv::Mat sqrtVariance(const cv::Mat& var_m2);

/// What the colour panel draws.
struct FeatureOverlayOptions {
  double plane_alpha = 0.45;  ///< opacity of the plane-label tint
  int point_radius_px = 4;
  int line_thickness_px = 2;
};

/// Colour image with features overlaid, scaled to `size`: planes tinted from the label image
/// (each label its own colour), 2D lines (thin, orange) and points (hollow red circles);
/// features lifted to 3D (`has_3d`) are drawn differently: points as filled green discs,
/// lines thick cyan. The pose's match counts and the feature counts are written on top.
/// `features` may be null (plain image). Its coordinates are in the image's pixel frame.
cv::Mat renderFeaturePanel(const cv::Mat& bgr, const FrameFeatures* features, const FramePose* pose,
                           const std::string& title, cv::Size size,
                           const FeatureOverlayOptions& options = {});

/// Where renderFeaturePanel places an image of `image_size` inside a panel of `panel_size`
/// (aspect kept, centred under the title): pixel (u, v) of the image lands at
/// rect.tl() + (u, v) * rect.width / image_size.width.
cv::Rect featureImageRect(cv::Size image_size, cv::Size panel_size);

/// Distinct BGR colour for a plane label (1..255); label 0 is black.
cv::Vec3b planeColour(int label);

/// A trajectory point in the viewer's world frame (the first camera frame, or ground truth's).
using Positions = std::vector<Eigen::Vector3d>;

/// Which two world axes a trajectory view plots (horizontal, vertical) and their signs.
struct ViewAxes {
  int horizontal = 0;  ///< index 0..2 of x, y, z
  int vertical = 2;
  double horizontal_sign = 1.0;
  double vertical_sign = 1.0;
  std::string horizontal_name = "x", vertical_name = "z";
};
/// Camera-frame conventions (x right, y down, z forward): top-down = x (right) vs z (up on
/// screen), side = z (right) vs -y (up on screen).
ViewAxes topDownAxes();
ViewAxes sideAxes();

/// A trajectory view with equal scale on both axes, a grid with labelled ticks in metres,
/// the estimate (yellow) with its current position marked, and the ground truth (green)
/// when `gt` is not empty.
cv::Mat renderTrajectoryPanel(const Positions& est, const Positions& gt, const ViewAxes& axes,
                              const std::string& title, cv::Size size);

/// Timing of one stage of a node (node_status_t.stages).
struct StageTimingView {
  std::string name;
  int64_t count = 0;
  double last_ms = 0, mean_ms = 0, max_ms = 0;
};
/// The last status of one node.
struct NodeStatusView {
  std::string node;
  int64_t last_seq = -1, frames_in = 0, frames_out = 0, frames_dropped = 0, frames_skipped = 0,
          errors = 0;
  std::vector<StageTimingView> stages;
  std::string last_warning;
};
/// Everything the text panel shows.
struct StatusPanelData {
  std::optional<FramePose> pose;
  int n_points = 0, n_lines = 0, n_planes = 0;  ///< newest features (2D)
  int n_points_3d = 0, n_lines_3d = 0;          ///< newest 3D features with has_3d
  int window_length = 0;                        ///< of the newest fused depth map (0: none)
  /// Depth only through fusion in the newest fused map (fusionOnlyPixels), when its frame's
  /// C-GM map was received; unset otherwise.
  std::optional<int> fusion_only_px;
  double fusion_only_share = 0.0;  ///< of the fused map's valid pixels
  int64_t frames_received = 0, frames_drawn = 0, frames_dropped = 0;
  double draw_fps = 0.0;
  std::string stream_state;  ///< "", "started", "ended"
  std::vector<NodeStatusView> nodes;
};
cv::Mat renderStatusPanel(const StatusPanelData& data, cv::Size size);

/// Places `panels` row-major in a grid of `cols` columns with cells of `cell` size (panels of
/// another size are resized). Missing cells are dark grey.
cv::Mat composeGrid(const std::vector<cv::Mat>& panels, int cols, cv::Size cell);

/// The newest data the viewer holds, in library types.
struct ViewerFrameData {
  std::optional<RgbdFrame> frame;                ///< newest colour + raw depth
  std::optional<RgbdFrame> feature_frame;        ///< frame matching `features` (may = frame)
  std::optional<FrameFeatures> features;         ///< to overlay on feature_frame
  std::optional<DepthWithVariance> fused_depth;  ///< PPLVO_DEPTH_FUSED (or C-GM as fallback)
  std::string fused_title = "fused depth";
  /// Pixels of fused_depth with depth only through fusion (CV_8UC1 mask, fusionOnlyPixels);
  /// empty when unknown (no C-GM map of the same frame) or not an O-GM map.
  cv::Mat fusion_only_mask;
  Positions trajectory;    ///< in the world frame shown
  Positions ground_truth;  ///< same frame, empty if unknown
  StatusPanelData status;
};

struct CanvasOptions {
  cv::Size cell{400, 450};   ///< 4 x 2 cells: a 1600 x 900 canvas
  ScalarPanelOptions depth;  ///< raw and fused depth
  ScalarPanelOptions sigma;  ///< depth standard deviation
  FeatureOverlayOptions overlay;
  /// Tint the fused depth panel's pixels that have depth only through fusion (key f).
  bool show_fusion_only = true;
};

/// The whole canvas, a 4 x 2 grid of cells:
///   [colour + features | raw depth | fused depth | depth sigma]
///   [top-down view     | side view | status (two cells wide)  ]
cv::Mat renderCanvas(const ViewerFrameData& data, const CanvasOptions& options = {});

/// Cell rectangles of renderCanvas (in canvas pixels), in the order: colour, raw depth,
/// fused depth, sigma, top-down, side, status.
std::vector<cv::Rect> canvasLayout(const CanvasOptions& options = {});

}  // namespace viewer
}  // namespace pplvo
