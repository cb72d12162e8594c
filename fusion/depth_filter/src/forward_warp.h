#pragma once
// Forward warping of a depth map into another (or the same) pinhole camera: the nearest-pixel
// warp of warpDepth (time alignment) and the footprint warp of DepthRegistration, sharing the
// crack closing. Internal header.
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <opencv2/core.hpp>

#include "pplvo/core/camera.h"
#include "pplvo/core/geometry.h"

namespace pplvo::depth_filter::detail {

/// How source points land in the target image of forwardWarp.
struct ForwardWarpOptions {
  /// |fx|, |fy| of the source (pixels per unit ray), for the footprint: each point covers every
  /// target pixel whose centre lies in its source pixel's angular size seen from the target at
  /// the point's depth (fronto-parallel), so that a lower-resolution source leaves no sieve of
  /// holes and a higher-resolution one gives each target pixel one point per surface.
  double source_fx = 1, source_fy = 1;
};

/// The last step of a forward warp: closes one-pixel cracks of a stretched surface in `out`
/// (infinity = nothing landed) where both neighbours on a line are present and within 1 % of
/// each other (a depth step is left open), the variance `var` (may be null) alike, and writes
/// the result with 0 for missing depth.
inline void closeCracks(const cv::Mat& out, const cv::Mat* var_in, cv::Mat* out_depth,
                        cv::Mat* out_var) {
  const int w = out.cols, h = out.rows;
  const float kInf = std::numeric_limits<float>::infinity();
  const bool with_var = var_in != nullptr;
  const cv::Mat var = with_var ? *var_in : cv::Mat();
  cv::Mat closed = out.clone();
  cv::Mat closed_var = with_var ? var.clone() : cv::Mat();
  const auto near = [](float a, float b) {
    return std::isfinite(a) && std::isfinite(b) && std::abs(a - b) <= 0.01f * std::min(a, b);
  };
  for (int v = 1; v + 1 < h; ++v) {
    for (int u = 1; u + 1 < w; ++u) {
      if (std::isfinite(out.at<float>(v, u))) continue;
      const float l = out.at<float>(v, u - 1), r = out.at<float>(v, u + 1);
      const float a = out.at<float>(v - 1, u), b = out.at<float>(v + 1, u);
      if (near(l, r)) {
        closed.at<float>(v, u) = 0.5f * (l + r);
        if (with_var) closed_var.at<float>(v, u) = 0.5f * (var.at<float>(v, u - 1) + var.at<float>(v, u + 1));
      } else if (near(a, b)) {
        closed.at<float>(v, u) = 0.5f * (a + b);
        if (with_var) closed_var.at<float>(v, u) = 0.5f * (var.at<float>(v - 1, u) + var.at<float>(v + 1, u));
      }
    }
  }
  closed.setTo(0.0f, closed == kInf);
  *out_depth = closed;
  if (out_var) *out_var = closed_var;
}

/// Moves every valid point of `depth_m` (CV_32FC1, 0 = none) of an undistorted pinhole source,
/// whose ray through (u, v) is (ray_x[u], ray_y[v], 1), by `T_target_source` onto its nearest
/// pixel of `target`, the nearest surface winning (ties: the first in row-major order), then
/// closes cracks (closeCracks). Each row's transform and projection runs in a vectorised pass
/// with the per-point double arithmetic p = R (x z, y z, z) + t, u = fx p_x / p_z + cx.
void forwardWarpPinholeNearest(const cv::Mat& depth_m, const std::vector<double>& ray_x,
                               const std::vector<double>& ray_y, const PinholeCamera& target,
                               const Pose3& T_target_source, cv::Mat* out_depth);

/// Moves every valid point of `depth_m` (CV_32FC1, 0 = none; point = z * (ray_x, ray_y, 1) with
/// `ray(u, v, &x, &y)` the source pixel's ray) by `T_target_source` into `target`'s pixel grid
/// (undistorted pinhole), each over its footprint (options) in two passes: the nearest surface
/// over each point's footprint, then each pixel takes the point of that surface whose
/// footprint holds its centre, if any. Then
/// one-pixel cracks of a stretched surface are closed (both neighbours on a line present and
/// within 1 % of each other; a depth step is left open). With `var_m2` (CV_32FC1 of the
/// source's size) the variance travels with its depth, scaled by (dz_t/dz_s)^2 = (R ray)_z^2
/// (z_t = (R ray)_z z_s + t_z is linear in z_s), into `out_var`. Missing output is 0.
template <class RayFn>
void forwardWarp(const cv::Mat& depth_m, const cv::Mat* var_m2, RayFn ray,
                 const PinholeCamera& target, const Pose3& T_target_source,
                 const ForwardWarpOptions& options, cv::Mat* out_depth, cv::Mat* out_var) {
  const int w = target.width, h = target.height;
  const float kInf = std::numeric_limits<float>::infinity();
  cv::Mat out(h, w, CV_32FC1, cv::Scalar(kInf));
  cv::Mat var;
  if (var_m2) var = cv::Mat(h, w, CV_32FC1, cv::Scalar(0.0f));
  const Eigen::Matrix3d R = T_target_source.linear();
  const Eigen::Vector3d t = T_target_source.translation();
  const double fx_ratio = std::abs(target.fx) / options.source_fx;
  const double fy_ratio = std::abs(target.fy) / options.source_fy;
  /// One source point in the target: pixel position, depth, variance, footprint (pixels).
  struct Landed {
    Eigen::Vector2d px;
    float z, var;
    double su, sv;
  };
  const auto moved = [&](int u, int v, Landed* l) {
    const double z = depth_m.ptr<float>(v)[u];
    if (!(z > 0) || !std::isfinite(z)) return false;
    double rx, ry;
    if (!ray(u, v, &rx, &ry)) return false;
    const Eigen::Vector3d p = R * Eigen::Vector3d(rx * z, ry * z, z) + t;
    if (!(p.z() > 0)) return false;
    l->px = target.project(p);
    l->z = static_cast<float>(p.z());
    l->var = 0.0f;
    if (var_m2) {
      const double a = R(2, 0) * rx + R(2, 1) * ry + R(2, 2);  // dz_t / dz_s
      l->var = static_cast<float>(a * a * var_m2->ptr<float>(v)[u]);
    }
    l->su = fx_ratio * z / p.z();
    l->sv = fy_ratio * z / p.z();
    return true;
  };
  /// Calls f(ut, vt) for the pixel centres in [px - s/2, px + s/2) on each axis.
  const auto forCentres = [&](const Eigen::Vector2d& px, double su, double sv, auto&& f) {
    const double hu = 0.5 * su, hv = 0.5 * sv;
    const long u0 = std::max<long>(0, static_cast<long>(std::ceil(px.x() - hu)));
    const long u1 = std::min<long>(w - 1, static_cast<long>(std::ceil(px.x() + hu)) - 1);
    const long v0 = std::max<long>(0, static_cast<long>(std::ceil(px.y() - hv)));
    const long v1 = std::min<long>(h - 1, static_cast<long>(std::ceil(px.y() + hv)) - 1);
    for (long vr = v0; vr <= v1; ++vr) {
      for (long ut = u0; ut <= u1; ++ut) f(static_cast<int>(ut), static_cast<int>(vr));
    }
  };
  Landed pt;
  // Pass 1, occlusion: every point covers its footprint, at least its nearest pixel; the
  // nearest surface's depth per pixel.
  for (int v = 0; v < depth_m.rows; ++v) {
    for (int u = 0; u < depth_m.cols; ++u) {
      if (!moved(u, v, &pt)) continue;
      forCentres(pt.px, std::max(pt.su, 1.0), std::max(pt.sv, 1.0), [&](int ut, int vr) {
        float& d = out.at<float>(vr, ut);
        if (pt.z < d) {
          d = pt.z;
          if (var_m2) var.at<float>(vr, ut) = pt.var;
        }
      });
    }
  }
  // Pass 2, value: a pixel whose centre lies in the footprint of a point of that nearest
  // surface (within 1 %) takes that point (the nearest of them), not the nearest of all the
  // surface's points that rounded to it: a surface sampled more densely than the target
  // grid would otherwise come out biased towards the camera (the minimum of several noisy
  // samples). Pixels no footprint centre-covers keep pass 1's depth.
  cv::Mat value(h, w, CV_32FC1, cv::Scalar(kInf));
  cv::Mat value_var;
  if (var_m2) value_var = cv::Mat(h, w, CV_32FC1, cv::Scalar(0.0f));
  for (int v = 0; v < depth_m.rows; ++v) {
    for (int u = 0; u < depth_m.cols; ++u) {
      if (!moved(u, v, &pt)) continue;
      if (pt.su >= 1.0 && pt.sv >= 1.0) continue;  // pass 1 already wrote its footprint
      forCentres(pt.px, pt.su, pt.sv, [&](int ut, int vr) {
        if (pt.z > out.at<float>(vr, ut) * 1.01f) return;  // behind the nearest surface
        float& d = value.at<float>(vr, ut);
        if (pt.z < d) {
          d = pt.z;
          if (var_m2) value_var.at<float>(vr, ut) = pt.var;
        }
      });
    }
  }
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      if (!std::isfinite(value.at<float>(v, u))) continue;
      out.at<float>(v, u) = value.at<float>(v, u);
      if (var_m2) var.at<float>(v, u) = value_var.at<float>(v, u);
    }
  }
  closeCracks(out, var_m2 ? &var : nullptr, out_depth, out_var);
}

}  // namespace pplvo::depth_filter::detail
