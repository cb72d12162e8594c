#pragma once
/// Stage 1 of the probabilistic depth filter (paper section 3.1): per-pixel depth uncertainty
/// from a sensor error model. Pluggable: derive from SensorModel (e.g. a ToF model later).
#include <memory>
#include <opencv2/core.hpp>

#include "pplvo/core/config_schema.h"
#include "pplvo/core/rgbd_frame.h"

namespace pplvo::depth_filter {

/// Depth error model of a sensor: variance of a depth measurement as a function of depth.
class SensorModel {
 public:
  virtual ~SensorModel() = default;
  /// Variance (m^2) of a depth measurement of z_m metres (z_m > 0).
  virtual float varianceM2(float z_m) const = 0;
  /// Row version (override for speed): var_m2[i] = varianceM2(z_m[i]) where z_m[i] > 0 and
  /// finite, else 0.
  virtual void varianceRow(const float* z_m, float* var_m2, int n) const;
};

/// Structured-light (Kinect) model of Khoshelham & Elberink, paper eq. (1):
/// sigma_z = 1.425e-6 z^2 with z, sigma in mm, i.e. sigma_z = 1.425e-3 z^2 with z in metres.
class QuadraticSensorModel final : public SensorModel {
 public:
  struct Options {
    /// sigma_z = coeff * z^2 (metres). Paper eq. (1): sigma_d = 0.5 px -> 1.425e-3 m^-1.
    double sigma_z_coeff_per_m = 1.425e-3;
  };
  QuadraticSensorModel() = default;
  explicit QuadraticSensorModel(const Options& options) : options_(options) {}
  float varianceM2(float z_m) const override;
  void varianceRow(const float* z_m, float* var_m2, int n) const override;
  const Options& options() const { return options_; }

 private:
  Options options_;
};

/// Schema of QuadraticSensorModel::Options (pplvo/core/config_schema.h).
template <class V>
void visit(V& v, QuadraticSensorModel::Options& o) {
  v.field("sigma_z_coeff_per_m", o.sigma_z_coeff_per_m,
          "sigma_z = coeff * z^2 (z, sigma in m). Paper eq. 1 (Khoshelham & Elberink, "
          "sigma_d = 0.5 px): 1.425e-6 in mm = 1.425e-3 per m",
          config::positive());
}

/// Stage 1 alone: depth unchanged (non-finite or <= 0 become 0 = missing) and the model's
/// variance per pixel. `depth_m` must be CV_32FC1 (throws std::invalid_argument otherwise).
DepthWithVariance applySensorModel(const SensorModel& model, const cv::Mat& depth_m);

}  // namespace pplvo::depth_filter
