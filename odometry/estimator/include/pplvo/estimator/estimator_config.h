#pragma once
/// Field lists of the estimator's options for the YAML visitors of pplvo/core/config_visitor.h
/// (YamlLoader / YamlDumper): `visit(loader, options)` inside a section.
#include "pplvo/estimator/odometry_tracker.h"
#include "pplvo/estimator/pose_estimator.h"

namespace pplvo {

template <class V>
void visit(V& v, PoseEstimatorOptions& o) {
  v.field("use_points", o.use_points, "feature families (paper ablations)");
  v.field("use_lines", o.use_lines);
  v.field("use_planes", o.use_planes);
  v.field("point_sigma_px", o.point_sigma_px, "keypoint pixel std, sqrt(1/12) (paper)");
  v.field("octave_sigma_scale", o.octave_sigma_scale, "sigma *= scale^octave (1 = off)");
  v.field("line_sigma_px", o.line_sigma_px, "2D line distance std at an endpoint, px");
  v.field("plane_scale_alpha", o.plane_scale_alpha, "plane term scale alpha (paper 0.02)");
  v.field("covariance_sandwich", o.covariance_sandwich, "H^-1 M H^-1 (true) or paper eq. 21");
  v.field("full_whitening", o.full_whitening, "false: w = 1/diag(Sigma_r) (paper)");
  v.field("use_tukey", o.use_tukey);
  v.field("tukey_c", o.tukey_c, "Tukey constant on whitened residuals (4.685)");
  v.field("tukey_mad_scale", o.tukey_mad_scale, "robust scale max(1, 1.4826 MAD)");
  v.field("max_irls_iterations", o.max_irls_iterations);
  v.field("max_lm_iterations", o.max_lm_iterations, "per Ceres solve");
  v.field("irls_tolerance_m", o.irls_tolerance_m);
  v.field("irls_tolerance_rad", o.irls_tolerance_rad);
  v.field("min_depth_m", o.min_depth_m);
  v.field("min_residuals", o.min_residuals, "minimum inlier residual rows");
  v.field("min_relative_eigenvalue", o.min_relative_eigenvalue, "rank test on scaled J^T W J");
  v.field("max_translation_variance_m2", o.max_translation_variance_m2,
          "reject above (paper Sec. Pose Uncertainty)");
  v.field("max_rotation_variance", o.max_rotation_variance, "q_xyz block, reject above");
}

template <class V>
void visit(V& v, OdometryTrackerOptions& o) {
  v.section("estimator", [&] { visit(v, o.estimator); });
  v.field("velocity_decay", o.velocity_decay, "per rejected frame");
  v.field("max_velocity_model_frames", o.max_velocity_model_frames, "then LOST");
  v.field("predict_from_velocity", o.predict_from_velocity);
  v.field("window_length", o.window_length, "frames, current included (paper 10)");
  v.field("velocity_model_sigma_t_m", o.velocity_model_sigma_t_m, "Q of a velocity-model step");
  v.field("velocity_model_sigma_q", o.velocity_model_sigma_q);
}

}  // namespace pplvo
