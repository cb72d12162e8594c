#pragma once
/// Point backprojection with first-order covariance (paper eqs. 9-10) and the depth noise model
/// used as a fallback when no per-pixel variance is available. Camera frame, metres.
#include <Eigen/Core>
#include <cmath>
#include <opencv2/core.hpp>

#include "pplvo/core/camera.h"
#include "pplvo/core/config_schema.h"
#include "pplvo/core/primitives.h"
#include "pplvo/core/rgbd_frame.h"

namespace pplvo::geometry {

/// Pixel quantisation variance: uniform error over one pixel, 1/12 px^2 (paper, sec. "Point
/// Backprojection").
constexpr double kPixelVariancePx2 = 1.0 / 12.0;

/// Structured-light depth noise sigma_z = c z^2 (paper eq. 1, Khoshelham & Elberink 2012):
/// c = 1.425e-6 mm^-1 = 1.425e-3 m^-1.
struct DepthNoiseModel {
  double sigma_z_coeff_per_m = 1.425e-3;
  /// Minimum standard deviation, metres (keeps weights finite for tiny depths / zero variance).
  double sigma_z_floor_m = 1e-4;
  double sigmaZ(double z_m) const {
    return std::max(sigma_z_floor_m, sigma_z_coeff_per_m * z_m * z_m);
  }
  double varianceZ(double z_m) const {
    const double s = sigmaZ(z_m);
    return s * s;
  }
};

/// Schema of DepthNoiseModel (pplvo/core/config_schema.h): names, docs and ranges, once.
template <class V>
void visit(V& v, DepthNoiseModel& o) {
  v.field("sigma_z_coeff_per_m", o.sigma_z_coeff_per_m,
          "fallback depth std sigma_z = coeff * z^2 where the depth map has no variance "
          "(paper eq. 1: 1.425e-3 per m; in the pipeline, depth_filter.sensor's)",
          config::positive());
  v.field("sigma_z_floor_m", o.sigma_z_floor_m, "smallest depth std used (m), keeps weights finite",
          config::positive());
}

/// Jacobian of eq. 9, P = Z [(u-cx)/fx, (v-cy)/fy, 1], with respect to (u, v, Z).
/// Uses the signed focal lengths (fy < 0 for ICL-NUIM).
inline Eigen::Matrix3d backprojectionJacobian(const PinholeCamera& cam, double u, double v,
                                              double z_m) {
  Eigen::Matrix3d J;
  J << z_m / cam.fx, 0.0, (u - cam.cx) / cam.fx,  //
      0.0, z_m / cam.fy, (v - cam.cy) / cam.fy,   //
      0.0, 0.0, 1.0;
  return J;
}

/// Eqs. 8-9: the point at depth z_m seen at undistorted pixel (u, v), with
/// Sigma_P = J diag(var_px2, var_px2, var_z_m2) J^T.
/// backprojectWithCov() of the pixel whose ray is (x, y, 1), x = (u - cx)/fx, y = (v - cy)/fy
/// (precomputed per column and row by callers that visit many pixels): the same result, bit
/// for bit.
inline Point3WithCov backprojectRayWithCov(const PinholeCamera& cam, double x, double y, double z_m,
                                           double var_z_m2, double var_px2 = kPixelVariancePx2) {
  Eigen::Matrix3d J;  // backprojectionJacobian()
  J << z_m / cam.fx, 0.0, x,  //
      0.0, z_m / cam.fy, y,   //
      0.0, 0.0, 1.0;
  const Eigen::Vector3d s(var_px2, var_px2, var_z_m2);
  Point3WithCov out;
  out.p = {x * z_m, y * z_m, z_m};  // PinholeCamera::backproject()
  out.cov = J * s.asDiagonal() * J.transpose();
  return out;
}

inline Point3WithCov backprojectWithCov(const PinholeCamera& cam, double u, double v, double z_m,
                                        double var_z_m2, double var_px2 = kPixelVariancePx2) {
  return backprojectRayWithCov(cam, (u - cam.cx) / cam.fx, (v - cam.cy) / cam.fy, z_m, var_z_m2,
                               var_px2);
}

/// Depth (metres) and its variance at integer pixel (u, v) of a depth map with variance.
/// Returns false when the pixel is outside, missing (0), non-finite or non-positive. When the
/// variance map is empty, or its value is not a positive finite number, the variance falls back
/// to `model` (documented in docs/geometry.md).
inline bool depthAt(const DepthWithVariance& dv, int u, int v, const DepthNoiseModel& model,
                    double* z_m, double* var_m2) {
  if (dv.depth_m.empty() || u < 0 || v < 0 || u >= dv.depth_m.cols || v >= dv.depth_m.rows)
    return false;
  const float z = dv.depth_m.at<float>(v, u);
  if (!(z > 0.0f) || !std::isfinite(z)) return false;
  double var = 0.0;
  if (!dv.var_m2.empty() && dv.var_m2.size() == dv.depth_m.size()) var = dv.var_m2.at<float>(v, u);
  if (!(var > 0.0) || !std::isfinite(var)) var = model.varianceZ(z);
  const double floor2 = model.sigma_z_floor_m * model.sigma_z_floor_m;
  *z_m = z;
  *var_m2 = std::max(var, floor2);
  return true;
}

}  // namespace pplvo::geometry
