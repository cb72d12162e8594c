#pragma once
/// Trajectory plots for finished runs (pplvo-plot) and the ground-truth alignment of the live
/// trajectory views. No LCM, no file I/O: callers read the TUM files and write the outputs.
#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <string>
#include <utility>
#include <vector>

#include "pplvo/core/geometry.h"
#include "pplvo/eval/ate.h"
#include "pplvo/eval/tum_file.h"
#include "pplvo/viewer/render.h"

namespace pplvo {
namespace viewer {

/// One estimated run, aligned onto the ground truth with the ATE alignment (pplvo_eval).
struct PlotRun {
  std::string label;
  std::vector<double> t_s;      ///< every estimated pose, seconds from PlotData::t0_s
  Positions p_aligned_m;        ///< R_gt_est * p_est + t_gt_est, ground-truth frame
  std::vector<double> err_t_s;  ///< stamps of the associated pairs, seconds from t0_s
  std::vector<double> err_m;    ///< translational error of each associated pair
  double ate_rmse_m = 0.0;
  int n_pairs = 0;
};

struct PlotData {
  double t0_s = 0.0;  ///< first ground-truth stamp (the time axis origin)
  std::vector<double> gt_t_s;
  Positions gt_m;
  std::vector<PlotRun> runs;
  /// World axes of the top view (horizontal, vertical): the two axes along which the ground
  /// truth spreads most (the third is the one of least spread).
  int top_h = 0, top_v = 1;
};

struct PlotPrepareResult {
  bool ok = false;
  std::string error;  ///< names the run whose ATE failed
  PlotData data;
};

/// Aligns every estimate onto `gt` with evaluateAte (TUM association + Horn alignment) and
/// collects the series to plot. `labels` may be shorter than `est` (file names are used).
/// Only the ground truth within [first, last] estimated stamp +- gt_margin_s is kept for the
/// plot (the alignment uses the whole file); a negative margin keeps all of it.
PlotPrepareResult preparePlot(const eval::TumFile& gt, const std::vector<eval::TumFile>& est,
                              const std::vector<std::string>& labels,
                              const eval::AteOptions& options = {}, double gt_margin_s = 1.0);

/// Plot layout: top view on the left; x(t), y(t), z(t) and the translational error over time
/// stacked on the right; title and legend on top. White background.
/// Each axes draws one polyline per series that has at least two points:
/// top view and x/y/z: ground truth + every run; error: every run.
cv::Mat renderPlotImage(const PlotData& data, cv::Size size = {1400, 900},
                        const std::string& title = "");

/// The same figure as a standalone SVG document (polyline, line, rect and text elements).
std::string renderPlotSvg(const PlotData& data, cv::Size size = {1400, 900},
                          const std::string& title = "");

/// NEES over time (pplvo-eval --nees --nees-data, read with eval::readNeesData), one run.
struct NeesPlotData {
  std::string label;
  std::vector<double> t_s;                   ///< seconds from the first pair
  std::vector<double> nees, nees_t, nees_r;  ///< 6 dof, translation (3), rotation (3)
  double confidence = 0.95;                  ///< of the chi-square bounds drawn
};

/// Three stacked axes (6 dof, translation, rotation), log10 of the NEES over time, with the
/// dof (ideal mean), the one-sided upper bound chi2_c(dof) and the two-sided band
/// [chi2_(1-c)/2, chi2_(1+c)/2] as horizontal lines; the legend gives mean and share inside.
cv::Mat renderNeesPlotImage(const NeesPlotData& data, cv::Size size = {1400, 900},
                            const std::string& title = "");
std::string renderNeesPlotSvg(const NeesPlotData& data, cv::Size size = {1400, 900},
                              const std::string& title = "");

/// How the live viewer places the ground truth next to the estimate.
enum class GtAlignment {
  kFirstPose,  ///< the first associated pair's poses coincide: T_w_gt = T_w_c0 * T_gt_c0^-1
  kAte,        ///< evaluateAte's rigid alignment over all associated pairs so far
};

/// Estimated poses with their stamps in seconds (already divided by fps for frame indices).
using StampedPoses = std::vector<std::pair<double, Pose3>>;

struct GroundTruthView {
  Positions gt_in_world_m;  ///< ground truth expressed in the estimate's world frame
  bool aligned = false;     ///< false: no associated pair yet (gt_in_world_m empty)
  int n_pairs = 0;
};

/// Expresses the ground truth in the estimate's world frame (the first camera frame), so that
/// the camera-convention views (topDownAxes, sideAxes) apply to both.
GroundTruthView alignGroundTruth(const eval::TumFile& gt, const StampedPoses& est, GtAlignment mode,
                                 const eval::AssociationOptions& assoc = {});

}  // namespace viewer
}  // namespace pplvo
