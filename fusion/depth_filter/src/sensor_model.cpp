#include "pplvo/depth_filter/sensor_model.h"

#include <cmath>
#include <stdexcept>

namespace pplvo::depth_filter {

void SensorModel::varianceRow(const float* z_m, float* var_m2, int n) const {
  for (int i = 0; i < n; ++i) {
    const float z = z_m[i];
    var_m2[i] = (z > 0.f && std::isfinite(z)) ? varianceM2(z) : 0.f;
  }
}

float QuadraticSensorModel::varianceM2(float z_m) const {
  const float sigma = static_cast<float>(options_.sigma_z_coeff_per_m) * z_m * z_m;
  return sigma * sigma;
}

void QuadraticSensorModel::varianceRow(const float* z_m, float* var_m2, int n) const {
  const float k = static_cast<float>(options_.sigma_z_coeff_per_m);
  const float k2 = k * k;
  for (int i = 0; i < n; ++i) {
    const float z = z_m[i];
    const float z2 = z * z;
    // Missing (0) gives 0; callers pass cleaned depth (NaN / negative already set to 0).
    var_m2[i] = (z > 0.f && z < 1e6f) ? k2 * z2 * z2 : 0.f;
  }
}

DepthWithVariance applySensorModel(const SensorModel& model, const cv::Mat& depth_m) {
  if (depth_m.empty() || depth_m.type() != CV_32FC1) {
    throw std::invalid_argument("applySensorModel: depth must be a non-empty CV_32FC1 matrix");
  }
  DepthWithVariance out;
  out.depth_m.create(depth_m.rows, depth_m.cols, CV_32FC1);
  out.var_m2.create(depth_m.rows, depth_m.cols, CV_32FC1);
  out.window_length = 1;
  for (int r = 0; r < depth_m.rows; ++r) {
    const float* in = depth_m.ptr<float>(r);
    float* z = out.depth_m.ptr<float>(r);
    for (int c = 0; c < depth_m.cols; ++c) {
      const float v = in[c];
      z[c] = (v > 0.f && std::isfinite(v)) ? v : 0.f;
    }
    model.varianceRow(z, out.var_m2.ptr<float>(r), depth_m.cols);
  }
  return out;
}

}  // namespace pplvo::depth_filter
