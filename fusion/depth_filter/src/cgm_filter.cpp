#include "pplvo/depth_filter/cgm_filter.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace pplvo::depth_filter {

CgmFilter::CgmFilter(const Options& options, std::shared_ptr<const SensorModel> model)
    : options_(options), model_(std::move(model)) {
  if (!model_) model_ = std::make_shared<QuadraticSensorModel>();
}

void CgmFilter::resize(int rows, int cols) {
  rows_ = rows;
  cols_ = cols;
  const size_t n = static_cast<size_t>(rows) * static_cast<size_t>(cols);
  z_.assign(n, 0.f);
  var_.assign(n, 0.f);
  h_s_.assign(n, 0.0);
  h_z_.assign(n, 0.0);
  h_q_.assign(n, 0.0);
  ++stats_.resizes;
}

DepthWithVariance CgmFilter::apply(const cv::Mat& depth_m) {
  if (depth_m.empty() || depth_m.type() != CV_32FC1) {
    throw std::invalid_argument("CgmFilter::apply: depth must be a non-empty CV_32FC1 matrix");
  }
  const int rows = depth_m.rows, cols = depth_m.cols;
  if (rows != rows_ || cols != cols_) resize(rows, cols);
  ++stats_.frames;

  // Stage 1: clean depth (y_i = z_i > 0) and sensor variance; then horizontal [1 2 1] sums of
  // y, y z and y (z^2 + sigma^2). Missing pixels carry z = sigma^2 = 0, so y multiplies out.
  int64_t invalid = 0, valid_in = 0;
  for (int r = 0; r < rows; ++r) {
    const float* in = depth_m.ptr<float>(r);
    float* z = &z_[static_cast<size_t>(r) * cols];
    float* var = &var_[static_cast<size_t>(r) * cols];
    for (int c = 0; c < cols; ++c) {
      const float v = in[c];
      const bool ok = v > 0.f && std::isfinite(v);
      invalid += (!ok && v != 0.f) ? 1 : 0;
      valid_in += ok ? 1 : 0;
      z[c] = ok ? v : 0.f;
    }
    model_->varianceRow(z, var, cols);
    double* hs = &h_s_[static_cast<size_t>(r) * cols];
    double* hz = &h_z_[static_cast<size_t>(r) * cols];
    double* hq = &h_q_[static_cast<size_t>(r) * cols];
    auto yv = [&](int c) { return z[c] > 0.f ? 1.0 : 0.0; };
    auto zv = [&](int c) { return static_cast<double>(z[c]); };
    auto qv = [&](int c) {
      const double zz = z[c];
      return zz * zz + static_cast<double>(var[c]);
    };
    if (cols == 1) {
      hs[0] = 2 * yv(0);
      hz[0] = 2 * zv(0);
      hq[0] = 2 * qv(0);
      continue;
    }
    hs[0] = 2 * yv(0) + yv(1);
    hz[0] = 2 * zv(0) + zv(1);
    hq[0] = 2 * qv(0) + qv(1);
    for (int c = 1; c < cols - 1; ++c) {
      hs[c] = yv(c - 1) + 2 * yv(c) + yv(c + 1);
      hz[c] = zv(c - 1) + 2 * zv(c) + zv(c + 1);
      hq[c] = qv(c - 1) + 2 * qv(c) + qv(c + 1);
    }
    const int e = cols - 1;
    hs[e] = yv(e - 1) + 2 * yv(e);
    hz[e] = zv(e - 1) + 2 * zv(e);
    hq[e] = qv(e - 1) + 2 * qv(e);
  }
  stats_.invalid_inputs += invalid;
  stats_.last_valid_in = valid_in;

  // Vertical [1 2 1] pass and eqs. (4), (5).
  DepthWithVariance out;
  out.depth_m.create(rows, cols, CV_32FC1);
  out.var_m2.create(rows, cols, CV_32FC1);
  out.window_length = 1;
  int64_t valid_out = 0;
  const bool keep_holes = options_.missing_centre_stays_missing;
  for (int r = 0; r < rows; ++r) {
    const size_t o = static_cast<size_t>(r) * cols;
    const size_t up = r > 0 ? o - cols : o;
    const size_t dn = r + 1 < rows ? o + cols : o;
    const double wu = r > 0 ? 1.0 : 0.0;
    const double wd = r + 1 < rows ? 1.0 : 0.0;
    const float* zc = &z_[o];
    float* oz = out.depth_m.ptr<float>(r);
    float* ov = out.var_m2.ptr<float>(r);
    for (int c = 0; c < cols; ++c) {
      const double s = wu * h_s_[up + c] + 2.0 * h_s_[o + c] + wd * h_s_[dn + c];
      if (s <= 0.0 || (keep_holes && !(zc[c] > 0.f))) {
        oz[c] = 0.f;
        ov[c] = 0.f;
        continue;
      }
      const double sz = wu * h_z_[up + c] + 2.0 * h_z_[o + c] + wd * h_z_[dn + c];
      const double sq = wu * h_q_[up + c] + 2.0 * h_q_[o + c] + wd * h_q_[dn + c];
      const double mean = sz / s;
      const double var = std::max(sq / s - mean * mean, 0.0);
      oz[c] = static_cast<float>(mean);
      ov[c] = static_cast<float>(var);
      ++valid_out;
    }
  }
  stats_.last_valid_out = valid_out;
  return out;
}

}  // namespace pplvo::depth_filter
