#pragma once
/// Lifting 2D features to 3D with uncertainty: points by backprojection (eqs. 9-10), lines by
/// depth sampling + RANSAC + WLS line fitting (eqs. 13-17). Camera frame of the features.
#include <cstdint>
#include <string>

#include "pplvo/core/config_schema.h"
#include "pplvo/core/features.h"
#include "pplvo/core/rgbd_frame.h"
#include "pplvo/geometry/backprojection.h"
#include "pplvo/geometry/line_fit.h"

namespace pplvo::geometry {

struct LiftOptions {
  DepthNoiseModel noise;                          ///< fallback variance where var_m2 is absent or 0
  double pixel_variance_px2 = kPixelVariancePx2;  ///< sigma_p^2 = 1/12 px^2 (paper)
  /// Points: depth at the nearest pixel; if it is missing, the valid pixel of lowest variance
  /// within this Chebyshev radius (0 = nearest pixel only).
  int point_search_radius_px = 1;
  /// Points on a depth discontinuity have no single depth (the corner may belong to either
  /// surface, or be a T-junction of both): a point is not lifted when the valid depths within
  /// point_discontinuity_radius_px span more than this fraction of the nearest one
  /// (max/min - 1). 0 disables the test. On the ICL-NUIM excerpt, whose corners lie mostly on
  /// object outlines, such points biased the translation (docs/pipeline.md, "ICL-NUIM"); 0.2
  /// keeps slanted surfaces (< 3 %/px) and removes depth steps.
  double point_max_depth_spread = 0.2;
  int point_discontinuity_radius_px = 3;
  /// Lines: at most this many depth pixels sampled uniformly along the segment (paper: 100).
  int max_line_samples = 100;
  /// RANSAC on 3D point-to-line Euclidean distance (paper; threshold not given there).
  double line_ransac_threshold_m = 0.02;
  int line_ransac_iterations = 50;
  /// Lines on occluding outlines: a sample whose depths line_side_offset_px to either side of
  /// the segment differ by more than line_max_depth_step (max/min - 1) takes the nearer side's
  /// depth, since an outline moves with the nearer surface. 0 (either) disables. ICL-NUIM
  /// excerpt: RPE 10.8 -> 9.2 mm/s, ATE 11 -> 8 mm (docs/pipeline.md).
  int line_side_offset_px = 3;
  double line_max_depth_step = 0.2;
  /// Minimum valid depth samples and RANSAC inliers for a 3D line (at least 3 each).
  int min_line_samples = 3;
  /// A 3D line supported by a handful of depth samples is mostly noise (a short segment, or
  /// one that crosses a depth edge): 20 of the <= 100 samples. Whole pipeline, RPE: ICL
  /// 24.6 -> 21.3 mm/s, synthetic room 12.2 -> 11.1, TUM 13.7 -> 14.8 against 5 (docs/geometry.md).
  int min_line_inliers = 20;
  uint64_t seed = 42;  ///< RANSAC seed; line i uses seed + i, so results do not depend on order
  LineFitOptions line_fit;
};

/// Schema of LiftOptions (pplvo/core/config_schema.h): names, docs and ranges, once.
template <class V>
void visit(V& v, LiftOptions& o) {
  v.section("noise", "fallback depth noise where the depth map has no variance (eq. 1)",
            [&] { visit(v, o.noise); });
  v.field("pixel_variance_px2", o.pixel_variance_px2,
          "pixel quantisation variance sigma_p^2 of eq. 10 (Sec. 4.2: 1/12 px^2)",
          config::atLeast(0));
  v.field("point_search_radius_px", o.point_search_radius_px,
          "no depth at a keypoint: use the lowest-variance pixel within this radius (px)",
          config::atLeast(0));
  v.field("point_max_depth_spread", o.point_max_depth_spread,
          "a keypoint on a depth discontinuity is not lifted: valid depths within the radius "
          "below span more than this fraction (max/min - 1); 0 disables",
          config::atLeast(0));
  v.field("point_discontinuity_radius_px", o.point_discontinuity_radius_px,
          "radius of that depth-discontinuity test (px)", config::atLeast(0));
  v.field("line_side_offset_px", o.line_side_offset_px,
          "a line sample on a depth step (depths this far to either side of the segment differ "
          "by more than line_max_depth_step) takes the nearer side's depth (px; 0 disables)",
          config::atLeast(0));
  v.field("line_max_depth_step", o.line_max_depth_step, "that depth step, as max/min - 1",
          config::atLeast(0));
  v.field("max_line_samples", o.max_line_samples,
          "depth pixels sampled uniformly along a 2D segment (Sec. 4.4: at most 100)",
          config::atLeast(2));
  v.field("line_ransac_threshold_m", o.line_ransac_threshold_m,
          "RANSAC on 3D point-to-line Euclidean distance (Sec. 4.4; no value in the paper, m)",
          config::positive());
  v.field("line_ransac_iterations", o.line_ransac_iterations, "RANSAC iterations",
          config::atLeast(1));
  v.field("min_line_samples", o.min_line_samples, "fewest valid depth samples of a 3D line",
          config::atLeast(3));
  v.field("min_line_inliers", o.min_line_inliers, "fewest RANSAC inliers of a 3D line",
          config::atLeast(3));
  v.field("seed", o.seed, "RANSAC seed (line i uses seed + i)");
  v.section("line_fit", "WLS line fitting (Sec. 4.4, eqs. 13-17)", [&] { visit(v, o.line_fit); });
}

struct LiftStats {
  std::string error;  ///< non-empty when the input was rejected (nothing lifted)
  int points_lifted = 0, points_no_depth = 0, points_on_discontinuity = 0;
  int lines_lifted = 0, lines_too_few_samples = 0, lines_too_few_inliers = 0, lines_fit_failed = 0;
};

/// Checks that `depth` is usable with `camera` (CV_32FC1, same size, variance CV_32FC1 of the
/// same size or empty). Returns an empty string if so, else the reason.
std::string validateDepth(const DepthWithVariance& depth, const PinholeCamera& camera);

/// Sets has_3d / point for every PointFeature of `frame` (frame.camera intrinsics).
LiftStats liftPoints(FrameFeatures& frame, const DepthWithVariance& depth,
                     const LiftOptions& options = {});
/// Sets has_3d / line / n_inliers for every LineFeature of `frame`.
LiftStats liftLines(FrameFeatures& frame, const DepthWithVariance& depth,
                    const LiftOptions& options = {});

/// One line (exposed for tests): samples, RANSAC, WLS fit. `n_inliers` receives the consensus size.
LineFitResult liftLine(const PinholeCamera& camera, const DepthWithVariance& depth,
                       const Eigen::Vector2d& px1, const Eigen::Vector2d& px2,
                       const LiftOptions& options, uint64_t seed, int* n_valid_samples,
                       int* n_inliers);

}  // namespace pplvo::geometry
