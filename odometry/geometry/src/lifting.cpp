#include "pplvo/geometry/lifting.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include "line_inliers.h"

namespace pplvo::geometry {

std::string validateDepth(const DepthWithVariance& depth, const PinholeCamera& camera) {
  if (depth.depth_m.empty()) return "empty depth map";
  if (depth.depth_m.type() != CV_32FC1) return "depth map is not CV_32FC1";
  if (!depth.var_m2.empty() &&
      (depth.var_m2.type() != CV_32FC1 || depth.var_m2.size() != depth.depth_m.size()))
    return "variance map is not CV_32FC1 of the depth map's size";
  if (camera.width != depth.depth_m.cols || camera.height != depth.depth_m.rows)
    return "camera size differs from depth map size";
  if (!(std::isfinite(camera.fx) && std::isfinite(camera.fy) && camera.fx != 0 && camera.fy != 0))
    return "invalid camera intrinsics";
  return {};
}

namespace {

/// max/min - 1 of the valid depths within the Chebyshev radius (0 if fewer than two).
double depthSpread(const cv::Mat& depth_m, int u0, int v0, int radius) {
  float zmin = std::numeric_limits<float>::max(), zmax = 0.f;
  const int r = std::max(0, radius);
  for (int v = std::max(0, v0 - r); v <= std::min(depth_m.rows - 1, v0 + r); ++v) {
    const float* row = depth_m.ptr<float>(v);
    for (int u = std::max(0, u0 - r); u <= std::min(depth_m.cols - 1, u0 + r); ++u) {
      const float z = row[u];
      if (!(z > 0.f) || !std::isfinite(z)) continue;
      zmin = std::min(zmin, z);
      zmax = std::max(zmax, z);
    }
  }
  return zmax > zmin ? static_cast<double>(zmax) / zmin - 1.0 : 0.0;
}

}  // namespace

LiftStats liftPoints(FrameFeatures& frame, const DepthWithVariance& depth,
                     const LiftOptions& options) {
  LiftStats st;
  for (auto& f : frame.points) f.has_3d = false;
  st.error = validateDepth(depth, frame.camera);
  if (!st.error.empty()) {
    st.points_no_depth = static_cast<int>(frame.points.size());
    return st;
  }
  const int r = std::max(0, options.point_search_radius_px);
  for (auto& f : frame.points) {
    if (!f.px.allFinite()) {
      ++st.points_no_depth;
      continue;
    }
    const int u0 = static_cast<int>(std::lround(f.px.x()));
    const int v0 = static_cast<int>(std::lround(f.px.y()));
    double z = 0, var = 0;
    bool found = depthAt(depth, u0, v0, options.noise, &z, &var);
    if (!found) {
      double best_var = 1e300;
      for (int dv = -r; dv <= r; ++dv) {
        for (int du = -r; du <= r; ++du) {
          double zz, vv;
          if (depthAt(depth, u0 + du, v0 + dv, options.noise, &zz, &vv) && vv < best_var) {
            best_var = vv;
            z = zz;
            var = vv;
            found = true;
          }
        }
      }
    }
    if (!found) {
      ++st.points_no_depth;
      continue;
    }
    if (options.point_max_depth_spread > 0.0 &&
        depthSpread(depth.depth_m, u0, v0, options.point_discontinuity_radius_px) >
            options.point_max_depth_spread) {
      ++st.points_on_discontinuity;
      continue;
    }
    f.point =
        backprojectWithCov(frame.camera, f.px.x(), f.px.y(), z, var, options.pixel_variance_px2);
    f.has_3d = true;
    ++st.points_lifted;
  }
  return st;
}

LineFitResult liftLine(const PinholeCamera& camera, const DepthWithVariance& depth,
                       const Eigen::Vector2d& px1, const Eigen::Vector2d& px2,
                       const LiftOptions& options, uint64_t seed, int* n_valid_samples,
                       int* n_inliers) {
  LineFitResult bad;
  *n_valid_samples = 0;
  *n_inliers = 0;
  if (!px1.allFinite() || !px2.allFinite()) return bad;
  const double len = (px2 - px1).norm();
  const int n_samples = std::max(
      2, std::min(std::max(2, options.max_line_samples), static_cast<int>(std::floor(len)) + 1));
  std::vector<Eigen::Vector3d> P;
  std::vector<Eigen::Matrix3d> C;
  std::vector<double> V;
  P.reserve(n_samples);
  C.reserve(n_samples);
  V.reserve(n_samples);
  // Unit normal of the segment in the image, for the foreground test below.
  const Eigen::Vector2d dir = len > 0 ? Eigen::Vector2d((px2 - px1) / len) : Eigen::Vector2d(1, 0);
  const Eigen::Vector2d normal(-dir.y(), dir.x());
  const int side_px = std::max(0, options.line_side_offset_px);
  int last_u = -1, last_v = -1;
  for (int k = 0; k < n_samples; ++k) {
    const double t = static_cast<double>(k) / (n_samples - 1);
    const Eigen::Vector2d px = px1 + t * (px2 - px1);
    const int u = static_cast<int>(std::lround(px.x()));
    const int v = static_cast<int>(std::lround(px.y()));
    if (u == last_u && v == last_v) continue;  // same depth pixel twice
    last_u = u;
    last_v = v;
    double z, var;
    bool found = depthAt(depth, u, v, options.noise, &z, &var);
    if (side_px > 0 && options.line_max_depth_step > 0.0) {
      // A segment on an occluding outline moves with the nearer surface: where the depths on
      // its two sides differ by more than the step, take the nearer side's depth.
      double za, va, zb, vb;
      const Eigen::Vector2d a = px + side_px * normal, b = px - side_px * normal;
      const bool ok_a = depthAt(depth, static_cast<int>(std::lround(a.x())),
                                static_cast<int>(std::lround(a.y())), options.noise, &za, &va);
      const bool ok_b = depthAt(depth, static_cast<int>(std::lround(b.x())),
                                static_cast<int>(std::lround(b.y())), options.noise, &zb, &vb);
      if (ok_a && ok_b && std::max(za, zb) > (1.0 + options.line_max_depth_step) * std::min(za, zb)) {
        z = za < zb ? za : zb;
        var = za < zb ? va : vb;
        found = true;
      }
    }
    if (!found) continue;
    const Point3WithCov p = backprojectWithCov(camera, u, v, z, var, options.pixel_variance_px2);
    P.push_back(p.p);
    C.push_back(p.cov);
    V.push_back(var);
  }
  const int n = static_cast<int>(P.size());
  *n_valid_samples = n;
  if (n < std::max(3, options.min_line_samples)) return bad;

  // RANSAC on the Euclidean point-to-line distance; hypotheses from two samples.
  std::mt19937_64 rng(seed);
  std::uniform_int_distribution<int> pick(0, n - 1);
  std::vector<char> best, cur(n);
  int best_count = 0;
  const double thr2 = options.line_ransac_threshold_m * options.line_ransac_threshold_m;
  detail::PointColumns columns;
  columns.assign(P);
  for (int it = 0; it < options.line_ransac_iterations; ++it) {
    const int i = pick(rng);
    int j = pick(rng);
    if (i == j) j = (j + 1) % n;
    const Eigen::Vector3d d = P[j] - P[i];
    const double dn2 = d.squaredNorm();
    if (!(dn2 > 1e-12)) continue;
    const int count = detail::markLineInliers(columns, P[i], d, dn2, thr2, cur.data());
    if (count > best_count) {
      best_count = count;
      best = cur;
    }
  }
  *n_inliers = best_count;
  if (best_count < std::max(3, options.min_line_inliers)) {
    bad.status = FitStatus::kTooFewPoints;
    return bad;
  }
  std::vector<Eigen::Vector3d> Pi;
  std::vector<Eigen::Matrix3d> Ci;
  std::vector<double> Vi;
  for (int q = 0; q < n; ++q) {
    if (!best[q]) continue;
    Pi.push_back(P[q]);
    Ci.push_back(C[q]);
    Vi.push_back(V[q]);
  }
  // Measured endpoints: the extreme inliers in sampling order (px1 side first).
  return fitLineWls(Pi, Ci, Vi, Pi.front(), Pi.back(), options.line_fit);
}

LiftStats liftLines(FrameFeatures& frame, const DepthWithVariance& depth,
                    const LiftOptions& options) {
  LiftStats st;
  for (auto& l : frame.lines) {
    l.has_3d = false;
    l.n_inliers = 0;
  }
  st.error = validateDepth(depth, frame.camera);
  if (!st.error.empty()) {
    st.lines_too_few_samples = static_cast<int>(frame.lines.size());
    return st;
  }
  for (size_t i = 0; i < frame.lines.size(); ++i) {
    LineFeature& l = frame.lines[i];
    int n_valid = 0, n_in = 0;
    const LineFitResult fit =
        liftLine(frame.camera, depth, l.px1, l.px2, options, options.seed + i, &n_valid, &n_in);
    l.n_inliers = n_in;
    if (n_valid < std::max(3, options.min_line_samples)) {
      ++st.lines_too_few_samples;
    } else if (n_in < std::max(3, options.min_line_inliers)) {
      ++st.lines_too_few_inliers;
    } else if (!fit.ok()) {
      ++st.lines_fit_failed;
    } else {
      l.line = fit.line;
      l.has_3d = true;
      ++st.lines_lifted;
    }
  }
  return st;
}

}  // namespace pplvo::geometry
