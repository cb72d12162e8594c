#include "pplvo/pipeline/pipeline_config.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <limits>
#include <sstream>
#include <type_traits>

namespace pplvo::pipeline {
namespace {

using depth_filter::DepthModel;
using features::PointDetector;
using geometry::LineFitOptions;

// ---------------------------------------------------------------------------------------------
// Value ranges (checked by the validator, shown in the dumped comments).

struct Range {
  double lo = -std::numeric_limits<double>::infinity();
  double hi = std::numeric_limits<double>::infinity();
  bool lo_open = false;
  bool hi_open = false;

  bool any() const { return std::isinf(lo) && std::isinf(hi); }
  bool contains(double x) const {
    if (std::isnan(x)) return false;
    const bool above = lo_open ? x > lo : x >= lo;
    const bool below = hi_open ? x < hi : x <= hi;
    return above && below;
  }
};

std::string formatNumber(double x);

/// "> 0.0", ">= 1", "[0.0, 1.0]", "(0.0, 180.0]"; integer bounds for integer fields.
std::string describe(const Range& r, bool integer) {
  if (r.any()) return "";
  auto num = [&](double x) {
    return integer ? std::to_string(static_cast<long long>(std::llround(x))) : formatNumber(x);
  };
  if (std::isinf(r.hi)) return (r.lo_open ? "> " : ">= ") + num(r.lo);
  if (std::isinf(r.lo)) return (r.hi_open ? "< " : "<= ") + num(r.hi);
  return std::string(r.lo_open ? "(" : "[") + num(r.lo) + ", " + num(r.hi) +
         (r.hi_open ? ")" : "]");
}

Range anyValue() { return {}; }
Range atLeast(double lo) { return {lo, std::numeric_limits<double>::infinity(), false, false}; }
Range positive() { return {0.0, std::numeric_limits<double>::infinity(), true, false}; }
Range between(double lo, double hi) { return {lo, hi, false, false}; }
Range openClosed(double lo, double hi) { return {lo, hi, true, false}; }

// ---------------------------------------------------------------------------------------------
// Text of values. Doubles: the shortest %g text that reads back to the same double, always
// with a '.' so that every YAML reader sees a float (0.02, 1.0e-05, 40.0).

std::string formatNumber(double x) {
  if (std::isnan(x)) return ".nan";
  if (std::isinf(x)) return x > 0 ? ".inf" : "-.inf";
  char buf[64];
  int precision = 1;
  for (; precision <= 17; ++precision) {
    std::snprintf(buf, sizeof(buf), "%.*g", precision, x);
    if (std::strtod(buf, nullptr) == x) break;
  }
  const double magnitude = std::fabs(x);
  if (magnitude >= 1e-4 && magnitude < 1e15) {
    // Plain decimal notation with the same significant digits (40.0, not 4e+01).
    const int exponent = static_cast<int>(std::floor(std::log10(magnitude)));
    const int decimals = std::max(0, precision - 1 - exponent);
    char fixed[64];
    std::snprintf(fixed, sizeof(fixed), "%.*f", decimals, x);
    if (std::strtod(fixed, nullptr) == x) std::snprintf(buf, sizeof(buf), "%s", fixed);
  }
  std::string s = buf;
  const auto e = s.find('e');
  if (s.find('.') == std::string::npos) {
    if (e == std::string::npos)
      s += ".0";
    else
      s.insert(e, ".0");
  }
  return s;
}

template <typename E>
struct EnumText;

template <>
struct EnumText<DepthModel> {
  static bool parse(const std::string& s, DepthModel* out) {
    return depth_filter::parseDepthModel(s, out);
  }
  static std::string name(DepthModel m) { return depth_filter::toString(m); }
  static const char* choices() { return "sensor, cgm, ogm"; }
};

template <>
struct EnumText<PointDetector> {
  static bool parse(const std::string& s, PointDetector* out) {
    return features::parsePointDetector(s, out);
  }
  static std::string name(PointDetector d) { return features::pointDetectorName(d); }
  static const char* choices() { return "orb, akaze, sift, brisk"; }
};

template <>
struct EnumText<LineFitOptions::Weighting> {
  static bool parse(const std::string& s, LineFitOptions::Weighting* out) {
    if (s == "residual_covariance")
      *out = LineFitOptions::Weighting::kResidualCovariance;
    else if (s == "paper_scalar")
      *out = LineFitOptions::Weighting::kPaperScalar;
    else
      return false;
    return true;
  }
  static std::string name(LineFitOptions::Weighting w) {
    return w == LineFitOptions::Weighting::kPaperScalar ? "paper_scalar" : "residual_covariance";
  }
  static const char* choices() { return "residual_covariance, paper_scalar"; }
};

template <>
struct EnumText<TrackingReference> {
  static bool parse(const std::string& s, TrackingReference* out) {
    return parseTrackingReference(s, out);
  }
  static std::string name(TrackingReference r) { return toString(r); }
  static const char* choices() { return "frame, keyframe"; }
};

std::string toText(bool b) { return b ? "true" : "false"; }
std::string toText(int i) { return std::to_string(i); }
std::string toText(uint64_t i) { return std::to_string(i); }
std::string toText(double d) { return formatNumber(d); }
std::string toText(const FeatureFamilies& f) {
  std::string s;
  auto add = [&](bool on, const char* name) {
    if (!on) return;
    s += s.empty() ? "" : ", ";
    s += name;
  };
  add(f.points, "points");
  add(f.lines, "lines");
  add(f.planes, "planes");
  return "[" + s + "]";
}
template <typename E, typename = std::enable_if_t<std::is_enum_v<E>>>
std::string toText(E e) {
  return EnumText<E>::name(e);
}

/// Parses `node` into `value`; returns an empty string or the reason it cannot.
template <typename T>
std::string fromNode(const YAML::Node& node, T* value) {
  if (!node.IsScalar()) return "expected a single value";
  if constexpr (std::is_enum_v<T>) {
    const std::string text = node.Scalar();
    if (!EnumText<T>::parse(text, value))
      return "invalid value '" + text + "' (choose one of: " + EnumText<T>::choices() + ")";
    return "";
  } else {
    try {
      *value = node.as<T>();
    } catch (const YAML::Exception&) {
      const char* type = std::is_same_v<T, bool>       ? "true or false"
                         : std::is_same_v<T, double>   ? "a number"
                         : std::is_same_v<T, uint64_t> ? "a non-negative integer"
                                                       : "an integer";
      return "cannot read '" + node.Scalar() + "' as " + type;
    }
    return "";
  }
}

std::string fromNode(const YAML::Node& node, FeatureFamilies* value) {
  std::string list;
  if (node.IsSequence()) {
    for (const auto& item : node) {
      if (!item.IsScalar()) return "expected a list of names (points, lines, planes)";
      list += (list.empty() ? "" : ",") + item.Scalar();
    }
  } else if (node.IsScalar()) {
    for (char c : node.Scalar()) {
      if (c != ' ') list += c;
    }
  } else {
    return "expected a list such as [points, lines, planes]";
  }
  if (!parseFeatureFamilies(list, value))
    return "invalid feature list '" + list +
           "' (a non-empty subset of points, lines, planes, or all)";
  return "";
}

// ---------------------------------------------------------------------------------------------
// The field lists. Every visitor V provides
//   field(key, T& value, doc, Range = anyValue())
//   section(key, doc, body)
//   forbid(key, reason): a key that must not appear here (the reader reports it).

template <class V>
void listFields(V& v, depth_filter::QuadraticSensorModel::Options& o) {
  v.field("sigma_z_coeff_per_m", o.sigma_z_coeff_per_m,
          "sigma_z = coeff * z^2 (z, sigma in m). Paper eq. 1 (Khoshelham & Elberink, "
          "sigma_d = 0.5 px): 1.425e-6 in mm = 1.425e-3 per m",
          positive());
}

template <class V>
void listFields(V& v, depth_filter::CgmOptions& o) {
  v.field("missing_centre_stays_missing", o.missing_centre_stays_missing,
          "a pixel without depth stays missing instead of taking the mixture of its 3x3 "
          "neighbours (eqs. 2-6); holes are left to O-GM");
  v.field("threads", o.threads, "threads over bands of rows (the output does not depend on it)",
          atLeast(1));
}

template <class V>
void listFields(V& v, depth_filter::OgmOptions& o) {
  v.field("max_window", o.max_window,
          "frames in the fusion sliding window, current included (paper Sec. 5: 10, O-GM_10)",
          atLeast(1));
  v.field("k_consistency", o.k_consistency,
          "points a pixel accepts before the consistency gate applies (Sec. 3.4: k = 5)",
          atLeast(1));
  v.field("gate_sigma", o.gate_sigma,
          "consistency gate half-width r_bar +- gate_sigma * sigma_r (Sec. 3.4: 3)", positive());
  v.field("max_translation_variance_m2", o.max_translation_variance_m2,
          "a window frame whose transform to the current frame has a larger translation "
          "variance (largest eigenvalue, m^2) leaves the window (Sec. 3.4; no value in the "
          "paper: (1 cm)^2)",
          positive());
  v.field("min_depth_m", o.min_depth_m,
          "projected points closer than this to the current camera are ignored (m)", atLeast(0));
  v.field("threads", o.threads,
          "threads of the fusion (OpenCV's pool; bands of the image): 1 = serial. The results "
          "do not depend on it, bit for bit",
          atLeast(1));
}

template <class V>
void listFields(V& v, DepthFilterOverloadOptions& o) {
  v.field("backlog", o.backlog,
          "when a pose comes while more than this many newer frames wait for theirs, the "
          "frame is fused over a shorter window (0 = never)",
          atLeast(0));
  v.field("window_step", o.window_step,
          "frames the window shortens per frame of backlog beyond that, down to 2", atLeast(1));
}

template <class V>
void listFields(V& v, DepthFilterOptions& o) {
  v.field("model", o.model,
          "depth used downstream: sensor (stage 1, Sec. 3.1), cgm (stages 1-2, Sec. 3.2) or "
          "ogm (all three, Sec. 3.3-3.4; the paper's full method)");
  v.section("sensor", "Stage 1: depth sensor error model (Sec. 3.1, eq. 1)",
            [&] { listFields(v, o.sensor); });
  v.section("cgm", "Stage 2: convolution of Gaussian mixtures, 3x3 kernel (Sec. 3.2, eqs. 2-6)",
            [&] { listFields(v, o.cgm); });
  v.section("ogm",
            "Stage 3: Optimal-GM temporal fusion and its constraints (Sec. 3.3-3.4, eqs. 7-8)",
            [&] { listFields(v, o.ogm); });
  v.section("overload",
            "Load shedding of pplvo-depth-filter when a live pipeline falls behind the sensor "
            "(not in the paper; pplvo-run and lockstep launches never shed, docs/depth_filter.md)",
            [&] { listFields(v, o.overload); });
}

template <class V>
void listFields(V& v, geometry::DepthNoiseModel& o) {
  v.field("sigma_z_coeff_per_m", o.sigma_z_coeff_per_m,
          "fallback depth std sigma_z = coeff * z^2 where the depth map has no variance "
          "(paper eq. 1: 1.425e-3 per m; keep equal to depth_filter.sensor)",
          positive());
  v.field("sigma_z_floor_m", o.sigma_z_floor_m, "smallest depth std used (m), keeps weights finite",
          positive());
}

template <class V>
void listFields(V& v, features::PointExtractorOptions& o) {
  // Same fields, in the same order, as PointExtractorOptions::visit (test_pipeline_config
  // checks that the two lists agree).
  v.field("detector", o.detector,
          "keypoint detector/descriptor: orb, akaze, sift or brisk (the paper's SURF is "
          "non-free and not in Debian's OpenCV; docs/features.md compares them)");
  v.field("max_points", o.max_points,
          "points kept per frame (VGA); the paper gives no count (docs/features.md)", atLeast(1));
  v.field("grid_bucketing", o.grid_bucketing,
          "spread the points over a grid_cols x grid_rows grid of cells");
  v.field("grid_cols", o.grid_cols, "bucketing grid columns", atLeast(1));
  v.field("grid_rows", o.grid_rows, "bucketing grid rows", atLeast(1));
  v.field("min_separation_px", o.min_separation_px,
          "kept points are at least this far apart (px); 0 disables", atLeast(0));
  v.field("oversample", o.oversample,
          "candidates detected before bucketing, as a multiple of max_points", atLeast(1));
  v.field("min_image_side_px", o.min_image_side_px, "smaller images give no points (px)",
          atLeast(1));
  v.field("orb_levels", o.orb_levels, "ORB pyramid levels (OpenCV default 8)", atLeast(1));
  v.field("orb_scale_factor", o.orb_scale_factor, "ORB pyramid scale factor",
          {1.0, std::numeric_limits<double>::infinity(), true, false});
  v.field("orb_fast_threshold", o.orb_fast_threshold, "ORB FAST threshold (OpenCV 20)", atLeast(0));
  v.field("orb_edge_threshold_px", o.orb_edge_threshold_px, "ORB border without features (px)",
          atLeast(0));
  v.field("akaze_threshold", o.akaze_threshold, "AKAZE detector response threshold", positive());
  v.field("sift_contrast_threshold", o.sift_contrast_threshold, "SIFT contrast threshold",
          positive());
  v.field("brisk_threshold", o.brisk_threshold, "BRISK AGAST threshold", atLeast(0));
  v.field("subpixel_refinement", o.subpixel_refinement,
          "sub-pixel keypoints: quadratic peak of the Shi-Tomasi response near the detection");
  v.field("subpixel_window_px", o.subpixel_window_px, "half-width of the structure-tensor window",
          atLeast(1));
}

template <class V>
void listFields(V& v, features::LineExtractorOptions& o) {
  // Same fields as LineExtractorOptions::visit (checked by test_pipeline_config).
  v.field("detection_scale", o.detection_scale,
          "LSD and LBD run on the image resized by this factor (Sec. 5.3 suggests QVGA = 0.5 "
          "for real time; 0.4 keeps the accuracy, docs/features.md)",
          openClosed(0, 1));
  v.field("describe_full_resolution", o.describe_full_resolution,
          "compute LBD on the full-resolution image");
  v.field("min_length_px", o.min_length_px, "shorter segments are dropped (px, VGA)", atLeast(0));
  v.field("max_lines", o.max_lines, "segments kept per frame, longest first", atLeast(1));
  v.field("lsd_refine", o.lsd_refine,
          "LSD refinement: 0 none (pplvo's LSD), 1 standard, 2 advanced (OpenCV's)", between(0, 2));
  v.field("lbd_band_width", o.lbd_band_width, "LBD band width (rows per band, LBD's 7)",
          between(1, 64));
  v.field("lbd_octaves", o.lbd_octaves,
          "LBD pyramid octaves (1 = one resolution, pplvo's LBD; more: OpenCV's)", atLeast(1));
  v.field("use_opencv", o.use_opencv, "LSD and LBD from OpenCV instead of pplvo's (slower)");
  v.field("min_image_side_px", o.min_image_side_px, "smaller images give no lines (px)",
          atLeast(1));
}

template <class V>
void listFields(V& v, geometry::PlaneFitOptions& o) {
  v.field("min_plane_distance_m", o.min_plane_distance_m,
          "reject planes closer than this to the camera centre: theta_m = N/d is singular at "
          "d = 0 (Sec. 4.3)",
          atLeast(0));
  v.field("min_condition", o.min_condition,
          "reject when the smallest/largest eigenvalue ratio of A is below this", atLeast(0));
  v.field("resolve_with_corrected_weights", o.resolve_with_corrected_weights,
          "solve again with the corrected weights 1/Sigma_ri (false: keep the paper's first "
          "solution, correct only the covariance)");
  v.field("min_points", o.min_points, "fewest points of a fit", atLeast(3));
  v.field("outlier_sigma", o.outlier_sigma,
          "one trimmed refit drops points with |theta_m P_i + 1| > k sqrt(Sigma_ri); 0 = off",
          atLeast(0));
}

template <class V>
void listFields(V& v, geometry::PlaneExtractionOptions& o) {
  v.field("cell_size_px", o.cell_size_px, "CAPE cells of N x N px (VGA: 20)", atLeast(2));
  v.section("noise", "depth noise used by the planarity tests (paper eq. 1)",
            [&] { listFields(v, o.noise); });
  v.field("pixel_variance_px2", o.pixel_variance_px2,
          "pixel quantisation variance sigma_p^2 (Sec. 4.2: 1/12 px^2)", atLeast(0));
  v.field("min_valid_fraction", o.min_valid_fraction,
          "a planar cell has at least this fraction of valid depth pixels", openClosed(0, 1));
  v.field("planarity_sigma_factor", o.planarity_sigma_factor,
          "cell planar if MSE < (k sigma_z(z) + margin)^2: k", atLeast(0));
  v.field("planarity_margin_m", o.planarity_margin_m, "... margin (m)", atLeast(0));
  v.field("jump_sigma_factor", o.jump_sigma_factor,
          "no depth jump inside a cell larger than k sigma_z(z) + margin: k", atLeast(0));
  v.field("jump_margin_m", o.jump_margin_m, "... margin (m)", atLeast(0));
  v.field("histogram_bins", o.histogram_bins, "normal histogram bins per axis", atLeast(1));
  v.field("min_seed_bin_count", o.min_seed_bin_count,
          "smallest histogram bin count that may seed a region", atLeast(1));
  v.field("grow_max_angle_deg", o.grow_max_angle_deg,
          "region growing: normal angle to the seed plane (deg; CAPE pi/12)", openClosed(0, 180));
  v.field("grow_dist_sigma_factor", o.grow_dist_sigma_factor,
          "region growing: cell centroid within k sigma_z(z) + margin of the plane: k", atLeast(0));
  v.field("grow_dist_margin_m", o.grow_dist_margin_m, "... margin (m)", atLeast(0));
  v.field("min_region_cells", o.min_region_cells, "smaller regions are not planes", atLeast(1));
  v.field("min_region_span_cells", o.min_region_span_cells,
          "a region spans at least this many cells in both image directions", atLeast(1));
  v.field("merge_max_angle_deg", o.merge_max_angle_deg,
          "merging adjacent segments: normal angle (deg)", openClosed(0, 180));
  v.field("merge_max_dist_m", o.merge_max_dist_m,
          "merging: centroid-to-other-plane distance (m; CAPE 50 mm)", atLeast(0));
  v.field("segment_sigma_factor", o.segment_sigma_factor,
          "segment kept if MSE < (k sigma_z(z) + margin)^2: k", atLeast(0));
  v.field("segment_margin_m", o.segment_margin_m, "... margin (m)", atLeast(0));
  v.field("refine_boundaries", o.refine_boundaries,
          "per-pixel refinement of the plane boundaries (false: CAPE without refinement)");
  v.field("refine_neighbourhood_cells", o.refine_neighbourhood_cells,
          "refinement candidates within R cells (1: 3x3, 2: 5x5)", between(1, 2));
  v.field("refine_sigma_factor", o.refine_sigma_factor,
          "a pixel joins a plane if |n.p + d| < k sigma_z(z) + margin: k", atLeast(0));
  v.field("refine_margin_m", o.refine_margin_m, "... margin (m)", atLeast(0));
  v.field("min_plane_points", o.min_plane_points, "pixels of a plane after refinement", atLeast(3));
  v.field("max_fit_points", o.max_fit_points,
          "the WLS fit uses a grid subsample of between this and 4x as many pixels", atLeast(3));
  v.field("max_planes", o.max_planes, "planes per frame (labels are 8-bit)", between(1, 254));
  v.field("threads", o.threads,
          "threads for the per-pixel passes and the fits (results do not depend on it)",
          atLeast(1));
  v.section("fit", "WLS plane fitting (Sec. 4.3, eqs. 11-12)", [&] { listFields(v, o.fit); });
}

template <class V>
void listFields(V& v, geometry::LineFitOptions& o) {
  v.field("resolve_with_corrected_weights", o.resolve_with_corrected_weights,
          "solve theta_m again with the corrected weights (false: the paper's literal "
          "wording, covariance corrected only)");
  v.field("min_extent_m", o.min_extent_m, "smallest spread of the samples along the line (m)",
          atLeast(0));
  v.field("weighting", o.weighting,
          "weights of the second solve: paper_scalar (w_i = 1/Sigma_ri, the paper) or "
          "residual_covariance (matrix weight, consistent covariance; docs/geometry.md)");
  v.field("zero_residual_perturbation_m", o.zero_residual_perturbation_m,
          "perturbation of P'_i where r_i = 0 (m)", positive());
}

template <class V>
void listFields(V& v, geometry::LiftOptions& o) {
  v.section("noise", "fallback depth noise where the depth map has no variance (eq. 1)",
            [&] { listFields(v, o.noise); });
  v.field("pixel_variance_px2", o.pixel_variance_px2,
          "pixel quantisation variance sigma_p^2 of eq. 10 (Sec. 4.2: 1/12 px^2)", atLeast(0));
  v.field("point_search_radius_px", o.point_search_radius_px,
          "no depth at a keypoint: use the lowest-variance pixel within this radius (px)",
          atLeast(0));
  v.field("point_max_depth_spread", o.point_max_depth_spread,
          "a keypoint on a depth discontinuity is not lifted: valid depths within the radius "
          "below span more than this fraction (max/min - 1); 0 disables",
          atLeast(0));
  v.field("point_discontinuity_radius_px", o.point_discontinuity_radius_px,
          "radius of that depth-discontinuity test (px)", atLeast(0));
  v.field("line_side_offset_px", o.line_side_offset_px,
          "a line sample on a depth step (depths this far to either side of the segment differ "
          "by more than line_max_depth_step) takes the nearer side's depth (px; 0 disables)",
          atLeast(0));
  v.field("line_max_depth_step", o.line_max_depth_step, "that depth step, as max/min - 1",
          atLeast(0));
  v.field("max_line_samples", o.max_line_samples,
          "depth pixels sampled uniformly along a 2D segment (Sec. 4.4: at most 100)", atLeast(2));
  v.field("line_ransac_threshold_m", o.line_ransac_threshold_m,
          "RANSAC on 3D point-to-line Euclidean distance (Sec. 4.4; no value in the paper, m)",
          positive());
  v.field("line_ransac_iterations", o.line_ransac_iterations, "RANSAC iterations", atLeast(1));
  v.field("min_line_samples", o.min_line_samples, "fewest valid depth samples of a 3D line",
          atLeast(3));
  v.field("min_line_inliers", o.min_line_inliers, "fewest RANSAC inliers of a 3D line", atLeast(3));
  v.field("seed", o.seed, "RANSAC seed (line i uses seed + i)");
  v.section("line_fit", "WLS line fitting (Sec. 4.4, eqs. 13-17)",
            [&] { listFields(v, o.line_fit); });
}

template <class V>
void listFields(V& v, FrontendOptions& o) {
  v.section("points", "2D points (Sec. 4.1)", [&] { listFields(v, o.points); });
  v.section("lines", "2D line segments: LSD + LBD (Sec. 4.1)", [&] { listFields(v, o.lines); });
  v.section("planes",
            "Planes: CAPE-like cell segmentation of the organised point cloud (Sec. 4.1) and "
            "WLS fit",
            [&] { listFields(v, o.planes); });
  v.section("lift", "3D lifting of points and lines (Sec. 4.2 point backprojection, 4.4 lines)",
            [&] { listFields(v, o.lift); });
  v.field("planes_from_fused_depth", o.planes_from_fused_depth,
          "extract the planes again on the fused depth once the pose is known (Sec. 5.3: "
          "\"plane extraction must be called once more after the depth fusion\")");
  v.field("parallel", o.parallel,
          "lines on a second thread during points and planes, fused-depth planes during "
          "lifting (same results)");
}

template <class V>
void listFields(V& v, PoseEstimatorOptions& o) {
  // Same fields as estimator_config.h's visit() except use_points/use_lines/use_planes, which
  // follow the top-level `features` list (checked by test_pipeline_config).
  const std::string families_reason = "the families are set once, by the top-level `features` list";
  v.forbid("use_points", families_reason);
  v.forbid("use_lines", families_reason);
  v.forbid("use_planes", families_reason);
  v.field("point_sigma_px", o.point_sigma_px,
          "keypoint pixel std: sigma_p^2 = 1/12 px^2 (Sec. 4.2, uniform quantisation)", positive());
  v.field("octave_sigma_scale", o.octave_sigma_scale,
          "point sigma multiplied by scale^octave (1 = same at every octave)", positive());
  v.field("line_sigma_px", o.line_sigma_px,
          "std of the 2D line distance at a projected endpoint (px)", positive());
  v.field("plane_scale_alpha", o.plane_scale_alpha,
          "alpha, scale of the plane terms in the joint cost E (eq. 22: 0.02, coarse tuning)",
          atLeast(0));
  v.field("covariance_sandwich", o.covariance_sandwich,
          "pose covariance H^-1 M H^-1 (true) or the paper's eq. 23 (J^T W J)^-1 (false)");
  v.field("full_whitening", o.full_whitening,
          "false (paper): w = 1/diag(Sigma_r); true: full Sigma_r^(-1/2)");
  v.field("use_tukey", o.use_tukey, "Tukey M-estimator on point and line residuals (Sec. 4.6)");
  v.field("tukey_c", o.tukey_c, "Tukey constant on the whitened residuals (4.685)", positive());
  v.field("tukey_mad_scale", o.tukey_mad_scale,
          "robust scale max(1, 1.4826 MAD) of the whitened residuals (false: 1)");
  v.field("max_irls_iterations", o.max_irls_iterations, "IRLS re-weighting iterations", atLeast(1));
  v.field("max_lm_iterations", o.max_lm_iterations, "Levenberg-Marquardt iterations per solve",
          atLeast(1));
  v.field("irls_tolerance_m", o.irls_tolerance_m, "IRLS stops below this translation step (m)",
          atLeast(0));
  v.field("irls_tolerance_rad", o.irls_tolerance_rad, "IRLS stops below this rotation step (rad)",
          atLeast(0));
  v.field("min_depth_m", o.min_depth_m,
          "points closer than this to the current image plane are dropped (m)", atLeast(0));
  v.field("min_residuals", o.min_residuals,
          "reject with fewer inlier residual rows (points, lines 2; planes 3)", atLeast(6));
  v.field("min_relative_eigenvalue", o.min_relative_eigenvalue,
          "degenerate if the smallest/largest eigenvalue of the scaled J^T W J is below this",
          atLeast(0));
  v.field("max_translation_variance_m2", o.max_translation_variance_m2,
          "reject if the largest eigenvalue of the translation covariance exceeds this (Sec. "
          "4.6 Pose Uncertainty; no value in the paper: (1 cm)^2)",
          positive());
  v.field("max_rotation_variance", o.max_rotation_variance,
          "reject if the largest eigenvalue of the q_xyz covariance exceeds this", positive());
}

template <class V>
void listFields(V& v, OdometryTrackerOptions& o) {
  v.section("estimator", "Pose estimation and its uncertainty (Sec. 4.6, eqs. 19-25)",
            [&] { listFields(v, o.estimator); });
  v.field("velocity_decay", o.velocity_decay,
          "constant-velocity motion scaled by decay^k on the k-th rejected frame", between(0, 1));
  v.field("max_velocity_model_frames", o.max_velocity_model_frames,
          "consecutive rejected frames bridged by the velocity model, then LOST", atLeast(0));
  v.field("predict_from_velocity", o.predict_from_velocity,
          "start each estimate from the constant-velocity prediction (false: identity)");
  v.field("window_length", o.window_length,
          "frames whose transform uncertainty to the current one is propagated (eq. 24), "
          "current included (paper: 10, the depth fusion window)",
          atLeast(1));
  v.field("velocity_model_sigma_t_m", o.velocity_model_sigma_t_m,
          "process noise std of the translation of a velocity-model step (m)", atLeast(0));
  v.field("velocity_model_sigma_q", o.velocity_model_sigma_q,
          "process noise std of q_xyz of a velocity-model step (~half-angle, rad)", atLeast(0));
}

template <class V>
void listFields(V& v, features::PointMatchOptions& o) {
  // Same fields as PointMatchOptions::visit (checked by test_pipeline_config).
  v.field("max_px_distance", o.max_px_distance,
          "gate: pixel distance to the previous position (Sec. 4.5; no value in the paper)",
          positive());
  v.field("predicted_max_px_distance", o.predicted_max_px_distance,
          "gate around a predicted position instead, when there is one (px)", positive());
  v.field("ratio_test", o.ratio_test, "Lowe ratio test on the two best gated candidates");
  v.field("ratio", o.ratio, "reject if best >= ratio * second best", openClosed(0, 1));
  v.field("max_hamming_bits", o.max_hamming_bits,
          "largest binary descriptor distance (bits of 256 for ORB); negative disables");
  v.field("max_l2", o.max_l2, "largest float descriptor distance (SIFT); negative disables");
  v.field("cross_check", o.cross_check, "one-to-one matches (mutual best)");
}

template <class V>
void listFields(V& v, features::LineMatchOptions& o) {
  // Same fields as LineMatchOptions::visit (checked by test_pipeline_config).
  v.field("max_angle_deg", o.max_angle_deg,
          "gate: slope angle difference of the Hessian forms (deg; Sec. 4.5, no value given)",
          openClosed(0, 180));
  v.field("max_rho_px", o.max_rho_px, "gate: difference of the distances to the origin (px)",
          positive());
  v.field("ratio_test", o.ratio_test, "ratio test on the two best gated candidates");
  v.field("ratio", o.ratio, "reject if best >= ratio * second best", openClosed(0, 1));
  v.field("max_hamming_bits", o.max_hamming_bits,
          "largest LBD distance (bits of 256); negative disables");
  v.field("cross_check", o.cross_check, "one-to-one matches (mutual best)");
}

template <class V>
void listFields(V& v, geometry::PlaneMatchOptions& o) {
  v.field("min_overlap_fraction", o.min_overlap_fraction,
          "projection overlap >= this fraction of the smaller plane's pixels (Sec. 4.5: 50%)",
          between(0, 1));
  v.field("max_normal_angle_deg", o.max_normal_angle_deg,
          "angle between the normals (Sec. 4.5: 10 deg)", openClosed(0, 180));
  v.field("max_d_diff_m", o.max_d_diff_m, "|d - d'| (Sec. 4.5: 10 cm)", positive());
  v.field("grid_step_px", o.grid_step_px, "overlap counted on every n-th pixel in u and v",
          atLeast(1));
}

template <class V>
void listFields(V& v, KeyframeOptions& o) {
  v.field("min_inlier_fraction", o.min_inlier_fraction,
          "new keyframe when the inlier rows against it fall below this fraction of the first "
          "frame's (feature overlap)",
          between(0, 1));
  v.field("max_variance_growth", o.max_variance_growth,
          "new keyframe when the pose variance relative to it grows beyond this factor of the "
          "first frame's (largest eigenvalue, translation or rotation block)",
          atLeast(1));
  v.field("max_translation_m", o.max_translation_m, "new keyframe beyond this translation (m)",
          positive());
  v.field("max_rotation_deg", o.max_rotation_deg, "new keyframe beyond this rotation (deg)",
          openClosed(0, 180));
  v.field("fuse_landmarks", o.fuse_landmarks,
          "refine the keyframe's 3D points with every frame tracked against it (information "
          "weighting, chi-square gate)");
  v.field("local_map_keyframes", o.local_map_keyframes,
          "earlier keyframes whose 3D points and lines are matched with the active one's "
          "(0: the active keyframe alone)",
          between(0, 10));
  v.field("fusion_gate_chi2", o.fusion_gate_chi2,
          "gate on the squared Mahalanobis distance of an observation (3 dof; 7.81 = 95 %)",
          positive());
}

template <class V>
void listFields(V& v, FrameOdometryOptions& o) {
  v.field("reference", o.reference,
          "what a frame is tracked against: frame (the previous one, as in the paper) or "
          "keyframe (the active keyframe, the previous frame as fallback; docs/estimator.md)");
  v.section("keyframe", "When a new keyframe is taken (reference: keyframe)",
            [&] { listFields(v, o.keyframe); });
  v.section("tracker", "Frame-to-frame tracking, pose estimation and window uncertainty",
            [&] { listFields(v, o.tracker); });
  v.section("point_matching", "Point matching (Sec. 4.5)",
            [&] { listFields(v, o.point_matching); });
  v.section("line_matching", "Line matching (Sec. 4.5)", [&] { listFields(v, o.line_matching); });
  v.section("plane_matching", "Plane matching (Sec. 4.5)",
            [&] { listFields(v, o.plane_matching); });
  v.field("predict_point_positions", o.predict_point_positions,
          "gate points around their position predicted by the constant-velocity model");
  v.field("predict_plane_positions", o.predict_plane_positions,
          "move the previous planes by the predicted motion before the plane gate");
  v.field("predict_line_positions", o.predict_line_positions,
          "gate lines around the projection of their 3D segment under the predicted motion");
}

/// The whole file. `families` stands for frontend.families and estimator.use_* together.
template <class V>
void visitPipeline(V& v, PipelineOptions& o, FeatureFamilies& families) {
  v.field("features", families,
          "primitive families used for extraction, matching and estimation (the paper's "
          "ablations): any non-empty subset of [points, lines, planes]");
  v.section("depth_filter",
            "Probabilistic depth filter (paper Sec. 3): sensor model, C-GM, O-GM fusion",
            [&] { listFields(v, o.depth_filter); });
  v.section("frontend",
            "Feature frontend (paper Sec. 4.1-4.4): extraction, back-projection, WLS fitting",
            [&] { listFields(v, o.frontend); });
  v.section("odometry",
            "Frame-to-frame odometry (paper Sec. 4.5-4.6): matching, pose estimation, "
            "pose uncertainty",
            [&] { listFields(v, o.odometry); });
}

// ---------------------------------------------------------------------------------------------
// Visitors.

/// Tracks the dotted path of the current section.
class PathTracker {
 protected:
  std::string path(const std::string& key) const {
    std::string p;
    for (const auto& s : sections_) p += s + ".";
    return p + key;
  }
  void enter(const std::string& key) { sections_.push_back(key); }
  void leave() { sections_.pop_back(); }

 private:
  std::vector<std::string> sections_;
};

/// Reads values from a YAML tree; collects type errors, invalid enums and unknown or
/// duplicate keys. Missing keys keep their values.
class Reader {
 public:
  explicit Reader(const YAML::Node& root) {
    if (root && !root.IsNull() && !root.IsMap()) {
      errors_.push_back("the configuration must be a map of keys");
      levels_.push_back({YAML::Node(YAML::NodeType::Map), "", {}});
    } else {
      levels_.push_back({root && root.IsMap() ? root : YAML::Node(YAML::NodeType::Map), "", {}});
    }
  }

  template <typename T>
  void field(const std::string& key, T& value, const std::string& /*doc*/,
             const Range& /*range*/ = anyValue()) {
    levels_.back().used.push_back(key);
    const YAML::Node node = child(key);
    if (!node) return;
    if (node.IsNull()) {
      errors_.push_back(path(key) + ": no value");
      return;
    }
    T parsed = value;
    const std::string error = fromNode(node, &parsed);
    if (error.empty())
      value = parsed;
    else
      errors_.push_back(path(key) + ": " + error);
  }

  void section(const std::string& key, const std::string& /*doc*/,
               const std::function<void()>& body) {
    levels_.back().used.push_back(key);
    const YAML::Node node = child(key);
    if (node && !node.IsNull() && !node.IsMap()) {
      errors_.push_back(path(key) + ": expected a section (a map of keys)");
      return;
    }
    levels_.push_back({node && node.IsMap() ? node : YAML::Node(YAML::NodeType::Map), key, {}});
    body();
    checkKeys();
    levels_.pop_back();
  }

  void forbid(const std::string& key, const std::string& reason) {
    levels_.back().used.push_back(key);
    if (child(key)) errors_.push_back(path(key) + ": not settable here (" + reason + ")");
  }

  /// Checks the root's keys and returns every error found.
  std::vector<std::string> finish() {
    checkKeys();
    return errors_;
  }

 private:
  struct Level {
    YAML::Node node;
    std::string name;
    std::vector<std::string> used;
  };

  YAML::Node child(const std::string& key) const {
    const YAML::Node& parent = levels_.back().node;
    return parent[key];
  }

  std::string path(const std::string& key) const {
    std::string p;
    for (const auto& level : levels_) {
      if (!level.name.empty()) p += level.name + ".";
    }
    return p + key;
  }

  void checkKeys() {
    const Level& level = levels_.back();
    std::vector<std::string> seen;
    for (const auto& kv : level.node) {
      const std::string key = kv.first.IsScalar() ? kv.first.Scalar() : "<non-scalar key>";
      if (std::find(seen.begin(), seen.end(), key) != seen.end()) {
        errors_.push_back(path(key) + ": duplicate key");
        continue;
      }
      seen.push_back(key);
      if (std::find(level.used.begin(), level.used.end(), key) == level.used.end())
        errors_.push_back(path(key) + ": unknown key");
    }
  }

  std::vector<Level> levels_;
  std::vector<std::string> errors_;
};

/// Checks ranges and finiteness.
class Validator : PathTracker {
 public:
  template <typename T>
  void field(const std::string& key, T& value, const std::string& /*doc*/,
             const Range& range = anyValue()) {
    if constexpr (std::is_arithmetic_v<T> && !std::is_same_v<T, bool>) {
      const double x = static_cast<double>(value);
      if (std::is_floating_point_v<T> && !std::isfinite(x)) {
        errors.push_back(path(key) + ": " + toText(value) + " is not a finite number");
      } else if (!range.contains(x)) {
        errors.push_back(path(key) + ": " + toText(value) + " is out of range (must be " +
                         describe(range, std::is_integral_v<T>) + ")");
      }
    }
  }
  void section(const std::string& key, const std::string&, const std::function<void()>& body) {
    enter(key);
    body();
    leave();
  }
  void forbid(const std::string&, const std::string&) {}

  std::vector<std::string> errors;
};

/// Every field as (key path, value text, doc).
class Flattener : PathTracker {
 public:
  template <typename T>
  void field(const std::string& key, T& value, const std::string& doc,
             const Range& range = anyValue()) {
    std::string d = doc;
    if (!range.any()) d += ". Range: " + describe(range, std::is_integral_v<T>) + ".";
    entries.push_back({path(key), toText(value), d});
  }
  void section(const std::string& key, const std::string&, const std::function<void()>& body) {
    enter(key);
    body();
    leave();
  }
  void forbid(const std::string&, const std::string&) {}

  std::vector<ConfigEntry> entries;
};

/// Wraps `text` into comment lines of at most `width` characters at `indent`; `suffix` is
/// kept in one piece at the end.
void writeComment(std::ostringstream& out, const std::string& indent, const std::string& text,
                  const std::string& suffix = "", size_t width = 96) {
  std::istringstream words(text);
  std::vector<std::string> tokens;
  for (std::string word; words >> word;) tokens.push_back(word);
  if (!suffix.empty()) tokens.push_back(suffix);
  std::string line;
  for (const std::string& token : tokens) {
    if (!line.empty() && indent.size() + 1 + line.size() + 1 + token.size() > width) {
      out << indent << "#" << line << "\n";
      line.clear();
    }
    line += " " + token;
  }
  if (!line.empty()) out << indent << "#" << line << "\n";
}

/// Documented YAML: each section preceded by a blank line and its comment, each field by
/// its comment (with its range).
class Writer {
 public:
  template <typename T>
  void field(const std::string& key, T& value, const std::string& doc,
             const Range& range = anyValue()) {
    if (after_section_) out_ << "\n";
    after_section_ = false;
    opened_ = false;
    const std::string suffix =
        range.any() ? "" : "Range: " + describe(range, std::is_integral_v<T>) + ".";
    writeComment(out_, indent_, range.any() ? doc : doc + ".", suffix);
    out_ << indent_ << key << ": " << toText(value) << "\n";
  }
  void section(const std::string& key, const std::string& doc, const std::function<void()>& body) {
    if (!opened_) out_ << "\n";
    if (indent_.empty()) out_ << "# " << std::string(94, '=') << "\n";  // top-level banner
    writeComment(out_, indent_, doc);
    out_ << indent_ << key << ":\n";
    indent_ += "  ";
    opened_ = true;
    after_section_ = false;
    body();
    indent_.resize(indent_.size() - 2);
    after_section_ = true;
  }
  void forbid(const std::string&, const std::string&) {}
  void header(const std::string& text) { out_ << text << "\n"; }
  std::string str() const { return out_.str(); }

 private:
  std::ostringstream out_;
  std::string indent_;
  bool opened_ = false;         ///< nothing written yet in the section just opened
  bool after_section_ = false;  ///< the last thing written closed a section
};

const char* kHeader =
    "# pplvo configuration: every parameter of the pipeline (PipelineOptions).\n"
    "# Paper: Proenca & Gao, \"Probabilistic RGB-D Odometry based on Points, Lines and Planes\n"
    "# Under Depth Uncertainty\" (section numbers below refer to it). Defaults follow the\n"
    "# paper where it gives a value. Keys left out keep their defaults; unknown keys, bad values\n"
    "# and values outside the Range shown are errors (reported all together).\n"
    "# Documentation: docs/configuration.md. Written by dumpPipelineConfig(PipelineOptions());\n"
    "# the test test_pipeline_config fails if this file drifts from the code's defaults.\n";

bool familiesAgree(const PipelineOptions& o) {
  const FeatureFamilies& f = o.frontend.families;
  const PoseEstimatorOptions& e = o.odometry.tracker.estimator;
  return f.points == e.use_points && f.lines == e.use_lines && f.planes == e.use_planes;
}

std::string familiesDisagreement(const PipelineOptions& o) {
  const PoseEstimatorOptions& e = o.odometry.tracker.estimator;
  return "features: frontend.families " + toText(o.frontend.families) +
         " disagree with odometry.tracker.estimator.use_* " +
         toText(FeatureFamilies{e.use_points, e.use_lines, e.use_planes}) +
         " (set them with PipelineOptions::setFamilies)";
}

std::vector<std::string> consistencyErrors(const PipelineOptions& o) {
  std::vector<std::string> errors;
  const FeatureFamilies& f = o.frontend.families;
  if (!f.points && !f.lines && !f.planes) errors.push_back("features: no feature family selected");
  if (!familiesAgree(o)) errors.push_back(familiesDisagreement(o));
  if (o.depth_filter.model == DepthModel::kOgm &&
      o.odometry.tracker.window_length < o.depth_filter.ogm.max_window) {
    errors.push_back(
        "odometry.tracker.window_length: " + std::to_string(o.odometry.tracker.window_length) +
        " is shorter than depth_filter.ogm.max_window " +
        std::to_string(o.depth_filter.ogm.max_window) +
        " (the fusion window needs the uncertainty of every frame it holds)");
  }
  return errors;
}

std::string joinErrors(const std::string& where, const std::vector<std::string>& errors) {
  std::string msg = where + ": configuration has " + std::to_string(errors.size()) + " error(s):";
  for (const auto& e : errors) msg += "\n  " + e;
  return msg;
}

PipelineOptions parseNode(const YAML::Node& root, const PipelineOptions& base,
                          const std::string& where) {
  PipelineOptions o = base;
  FeatureFamilies families = base.frontend.families;
  Reader reader(root);
  visitPipeline(reader, o, families);
  std::vector<std::string> errors = reader.finish();
  o.setFamilies(families);
  const std::vector<std::string> invalid = validatePipelineOptions(o);
  errors.insert(errors.end(), invalid.begin(), invalid.end());
  if (!errors.empty()) throw ConfigError(joinErrors(where, errors));
  return o;
}

/// Nested keys of the override assignments, in the order given.
struct OverrideTree {
  std::vector<std::pair<std::string, OverrideTree>> children;
  bool has_value = false;
  YAML::Node value;

  OverrideTree& child(const std::string& key) {
    for (auto& kv : children) {
      if (kv.first == key) return kv.second;
    }
    children.emplace_back(key, OverrideTree());
    return children.back().second;
  }
  YAML::Node toNode() const {
    if (has_value) return value;
    YAML::Node node(YAML::NodeType::Map);
    for (const auto& kv : children) node[kv.first] = kv.second.toNode();
    return node;
  }
};

}  // namespace

PipelineOptions applyPipelineOverrides(const std::vector<std::string>& assignments,
                                       const PipelineOptions& base) {
  OverrideTree root;
  std::vector<std::string> errors;
  for (const std::string& a : assignments) {
    const auto eq = a.find('=');
    const std::string key = a.substr(0, eq);
    const std::string text = eq == std::string::npos ? "" : a.substr(eq + 1);
    if (eq == std::string::npos || key.empty() || text.empty()) {
      errors.push_back("'" + a + "': expected key=value (e.g. depth_filter.ogm.max_window=5)");
      continue;
    }
    OverrideTree* node = &root;
    std::stringstream parts(key);
    std::string part;
    bool ok = true;
    while (std::getline(parts, part, '.')) {
      if (part.empty() || node->has_value) {
        ok = false;
        break;
      }
      node = &node->child(part);
    }
    if (!ok || !node->children.empty()) {
      errors.push_back("'" + a + "': invalid or conflicting key '" + key + "'");
      continue;
    }
    try {
      node->value = YAML::Load(text);
    } catch (const YAML::Exception& e) {
      errors.push_back("'" + a + "': value is not valid YAML (" + e.what() + ")");
      continue;
    }
    node->has_value = true;
  }
  if (!errors.empty()) throw ConfigError(joinErrors("overrides", errors));
  return parseNode(root.toNode(), base, "overrides");
}

PipelineOptions parsePipelineConfig(const std::string& yaml_text, const PipelineOptions& base) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    throw ConfigError("configuration text is not valid YAML: " + std::string(e.what()));
  }
  return parseNode(root, base, "configuration text");
}

PipelineOptions loadPipelineConfig(const std::string& path, const PipelineOptions& base) {
  std::ifstream in(path);
  if (!in) throw ConfigError(path + ": cannot open the configuration file");
  std::stringstream text;
  text << in.rdbuf();
  YAML::Node root;
  try {
    root = YAML::Load(text.str());
  } catch (const YAML::Exception& e) {
    throw ConfigError(path + ": not valid YAML: " + std::string(e.what()));
  }
  return parseNode(root, base, path);
}

std::vector<std::string> validatePipelineOptions(const PipelineOptions& options) {
  PipelineOptions o = options;  // visit() takes non-const references
  FeatureFamilies families = o.frontend.families;
  Validator validator;
  visitPipeline(validator, o, families);
  std::vector<std::string> errors = validator.errors;
  const std::vector<std::string> consistency = consistencyErrors(options);
  errors.insert(errors.end(), consistency.begin(), consistency.end());
  return errors;
}

std::string dumpPipelineConfig(const PipelineOptions& options) {
  if (!familiesAgree(options))
    throw ConfigError("dumpPipelineConfig: " + familiesDisagreement(options));
  PipelineOptions o = options;
  FeatureFamilies families = o.frontend.families;
  Writer writer;
  writer.header(kHeader);
  visitPipeline(writer, o, families);
  return writer.str();
}

std::vector<ConfigEntry> flattenPipelineConfig(const PipelineOptions& options) {
  PipelineOptions o = options;
  FeatureFamilies families = o.frontend.families;
  Flattener flattener;
  visitPipeline(flattener, o, families);
  return flattener.entries;
}

std::vector<std::string> diffPipelineOptions(const PipelineOptions& a, const PipelineOptions& b) {
  const std::vector<ConfigEntry> ea = flattenPipelineConfig(a);
  const std::vector<ConfigEntry> eb = flattenPipelineConfig(b);
  std::vector<std::string> diff;
  for (size_t i = 0; i < ea.size() && i < eb.size(); ++i) {
    if (ea[i].value != eb[i].value)
      diff.push_back(ea[i].key + ": " + ea[i].value + " != " + eb[i].value);
  }
  // flatten() of two PipelineOptions always has the same keys; the estimator's use_* are
  // covered by `features` only when they agree with it, so compare them directly.
  const PoseEstimatorOptions& xa = a.odometry.tracker.estimator;
  const PoseEstimatorOptions& xb = b.odometry.tracker.estimator;
  const FeatureFamilies ua{xa.use_points, xa.use_lines, xa.use_planes};
  const FeatureFamilies ub{xb.use_points, xb.use_lines, xb.use_planes};
  if (toText(ua) != toText(ub))
    diff.push_back("odometry.tracker.estimator.use_*: " + toText(ua) + " != " + toText(ub));
  return diff;
}

}  // namespace pplvo::pipeline
