#pragma once
/// Stage 2 of the probabilistic depth filter (paper section 3.2, eqs. 2-6): convolution of
/// Gaussian mixtures (C-GM, after Dryanovski et al. 2013) over a 3x3 neighbourhood.
#include <cstdint>
#include <memory>
#include <opencv2/core.hpp>
#include <vector>

#include "pplvo/core/config_schema.h"
#include "pplvo/core/rgbd_frame.h"
#include "pplvo/depth_filter/sensor_model.h"

namespace pplvo::depth_filter {

struct CgmStats {
  int64_t frames = 0;
  int64_t resizes = 0;         ///< buffer re-allocations (image size changed)
  int64_t invalid_inputs = 0;  ///< non-finite or negative depth values treated as missing
  int64_t last_valid_in = 0;   ///< valid pixels of the last input
  int64_t last_valid_out = 0;  ///< valid pixels of the last output
};

struct CgmOptions {
  /// When the centre pixel has no depth, output missing (true, the default) rather than the
  /// mixture of its neighbours: C-GM then never invents depth in holes (the authors' code
  /// behaves the same). Filling holes is left to the temporal stage (O-GM).
  bool missing_centre_stays_missing = true;
  /// Threads over horizontal bands of rows (each band computes its own border rows); the
  /// output does not depend on this number.
  int threads = 2;
};

/// Schema of CgmOptions (pplvo/core/config_schema.h).
template <class V>
void visit(V& v, CgmOptions& o) {
  v.field("missing_centre_stays_missing", o.missing_centre_stays_missing,
          "a pixel without depth stays missing instead of taking the mixture of its 3x3 "
          "neighbours (eqs. 2-6); holes are left to O-GM");
  v.field("threads", o.threads, "threads over bands of rows (the output does not depend on it)",
          config::atLeast(1));
}

/// C-GM filter. For pixel p with neighbours i (3x3, weights W = [1 2 1; 2 4 2; 1 2 1], eq. 3),
/// y_i = 1 where depth is present, S = sum w_i y_i (eq. 5),
///   z = (1/S) sum w_i y_i z_i                                   (eq. 4)
///   var = (1/S) sum w_i y_i (z_i^2 + sigma_i^2) - z^2           (eq. 5, variance of eq. 2)
/// with sigma_i^2 from the sensor model (stage 1). Pixels outside the image count as missing.
/// Sums are accumulated in double precision (z^2 ~ 10 m^2 against variances ~ 1e-6 m^2).
/// Buffers are sized once per image size; no per-pixel allocation.
class CgmFilter {
 public:
  using Options = CgmOptions;

  /// Uses the paper's Kinect model (QuadraticSensorModel defaults) when `model` is null.
  explicit CgmFilter(const Options& options = Options(),
                     std::shared_ptr<const SensorModel> model = nullptr);

  /// Filters a CV_32FC1 depth map in metres (0 = missing; NaN/negative counted and treated as
  /// missing). Returns depth and variance (CV_32FC1, 0 where missing), window_length = 1.
  /// Throws std::invalid_argument if depth_m is not a non-empty CV_32FC1 matrix.
  DepthWithVariance apply(const cv::Mat& depth_m);
  /// Same, writing into `out`, whose matrices are reused when they already have the size and
  /// type (no allocation in steady state). They must not share data with anything still in use.
  void apply(const cv::Mat& depth_m, DepthWithVariance* out);
  /// Same on depth whose stage-1 variance is already known (registered depth,
  /// depth_registration.h): sigma_i^2 = measured.var_m2 instead of the sensor model's.
  DepthWithVariance apply(const DepthWithVariance& measured);

  const CgmStats& stats() const { return stats_; }
  const Options& options() const { return options_; }
  const SensorModel& sensorModel() const { return *model_; }

 private:
  // Per band: one row of clean depth and sensor variance; padded rows of y, z, z^2 + sigma^2;
  // a ring of three rows of horizontal [1 2 1] sums and of the centre depth.
  struct RowBuffers {
    std::vector<float> z, var, centre;
    std::vector<double> pad_y, pad_z, pad_q, h_s, h_z, h_q;
  };
  struct BandCounts {
    int64_t invalid = 0, valid_in = 0, valid_out = 0;
  };

  void resize(int rows, int cols);
  /// Stage 1 and horizontal sums of row r; variances from `var_m2` when given, else the model.
  void horizontalRow(const cv::Mat& depth_m, const cv::Mat* var_m2, int r, RowBuffers& b,
                     int64_t* invalid, int64_t* valid) const;
  /// Output rows [r0, r1) (inputs r0 - 1 .. r1 read, counted only within the band).
  void applyRows(const cv::Mat& depth_m, const cv::Mat* var_m2, int r0, int r1, RowBuffers& b,
                 DepthWithVariance& out, BandCounts* counts) const;
  void run(const cv::Mat& depth_m, const cv::Mat* var_m2, DepthWithVariance* out);

  Options options_;
  std::shared_ptr<const SensorModel> model_;
  CgmStats stats_;
  int rows_ = 0, cols_ = 0;
  std::vector<RowBuffers> bands_;  ///< sized once per image size
  std::vector<double> zero_;
};

}  // namespace pplvo::depth_filter
