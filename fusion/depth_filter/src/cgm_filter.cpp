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
  const size_t n = static_cast<size_t>(cols);
  z_.assign(n, 0.f);
  var_.assign(n, 0.f);
  // Padded row (cols + 2) of y, z, z^2 + sigma^2; three ring rows of horizontal sums.
  pad_y_.assign(n + 2, 0.0);
  pad_z_.assign(n + 2, 0.0);
  pad_q_.assign(n + 2, 0.0);
  h_s_.assign(3 * n, 0.0);
  h_z_.assign(3 * n, 0.0);
  h_q_.assign(3 * n, 0.0);
  zero_.assign(n, 0.0);
  centre_.assign(3 * n, 0.f);
  ++stats_.resizes;
}

void CgmFilter::horizontalRow(const cv::Mat& depth_m, int r, int64_t* invalid, int64_t* valid) {
  const int cols = cols_;
  const size_t slot = static_cast<size_t>(r % 3) * cols;
  const float* in = depth_m.ptr<float>(r);
  float* z = z_.data();
  int64_t bad = 0, good = 0;
  for (int c = 0; c < cols; ++c) {
    const float v = in[c];
    const bool ok = v > 0.f && v < 1e6f;  // false for NaN, +-inf, <= 0
    bad += (!ok && v != 0.f) ? 1 : 0;
    good += ok ? 1 : 0;
    z[c] = ok ? v : 0.f;
  }
  *invalid += bad;
  *valid += good;
  model_->varianceRow(z, var_.data(), cols);
  double* py = pad_y_.data() + 1;
  double* pz = pad_z_.data() + 1;
  double* pq = pad_q_.data() + 1;
  const float* var = var_.data();
  for (int c = 0; c < cols; ++c) {
    const double zz = z[c];
    py[c] = z[c] > 0.f ? 1.0 : 0.0;
    pz[c] = zz;
    pq[c] = zz * zz + static_cast<double>(var[c]);
  }
  double* hs = &h_s_[slot];
  double* hz = &h_z_[slot];
  double* hq = &h_q_[slot];
  const double* ys = pad_y_.data();
  const double* zs = pad_z_.data();
  const double* qs = pad_q_.data();
  for (int c = 0; c < cols; ++c) hs[c] = ys[c] + 2.0 * ys[c + 1] + ys[c + 2];
  for (int c = 0; c < cols; ++c) hz[c] = zs[c] + 2.0 * zs[c + 1] + zs[c + 2];
  for (int c = 0; c < cols; ++c) hq[c] = qs[c] + 2.0 * qs[c + 1] + qs[c + 2];
  std::copy(z, z + cols, centre_.begin() + static_cast<std::ptrdiff_t>(slot));
}

DepthWithVariance CgmFilter::apply(const cv::Mat& depth_m) {
  DepthWithVariance out;
  apply(depth_m, &out);
  return out;
}

void CgmFilter::apply(const cv::Mat& depth_m, DepthWithVariance* out_ptr) {
  if (depth_m.empty() || depth_m.type() != CV_32FC1) {
    throw std::invalid_argument("CgmFilter::apply: depth must be a non-empty CV_32FC1 matrix");
  }
  const int rows = depth_m.rows, cols = depth_m.cols;
  if (rows != rows_ || cols != cols_) resize(rows, cols);
  ++stats_.frames;

  DepthWithVariance& out = *out_ptr;
  out.depth_m.create(rows, cols, CV_32FC1);
  out.var_m2.create(rows, cols, CV_32FC1);
  out.window_length = 1;
  int64_t invalid = 0, valid_in = 0, valid_out = 0;
  const bool keep_holes = options_.missing_centre_stays_missing;
  // Stage 1 and the horizontal [1 2 1] sums of y, y z, y (z^2 + sigma^2) row by row (missing
  // pixels carry z = sigma^2 = 0, so y multiplies out), kept in a ring of three rows; then the
  // vertical [1 2 1] sums give S, S z_bar, and the second moment (eqs. 4, 5).
  horizontalRow(depth_m, 0, &invalid, &valid_in);
  for (int r = 0; r < rows; ++r) {
    if (r + 1 < rows) horizontalRow(depth_m, r + 1, &invalid, &valid_in);
    const size_t mid = static_cast<size_t>(r % 3) * cols;
    const bool has_up = r > 0, has_dn = r + 1 < rows;
    const size_t up = static_cast<size_t>((r + 2) % 3) * cols;
    const size_t dn = static_cast<size_t>((r + 1) % 3) * cols;
    const double* su = has_up ? &h_s_[up] : zero_.data();
    const double* sd = has_dn ? &h_s_[dn] : zero_.data();
    const double* zu = has_up ? &h_z_[up] : zero_.data();
    const double* zd = has_dn ? &h_z_[dn] : zero_.data();
    const double* qu = has_up ? &h_q_[up] : zero_.data();
    const double* qd = has_dn ? &h_q_[dn] : zero_.data();
    const double* sm = &h_s_[mid];
    const double* zm = &h_z_[mid];
    const double* qm = &h_q_[mid];
    const float* zc = &centre_[mid];
    float* oz = out.depth_m.ptr<float>(r);
    float* ov = out.var_m2.ptr<float>(r);
    int64_t n = 0;
    for (int c = 0; c < cols; ++c) {
      const double s = su[c] + 2.0 * sm[c] + sd[c];
      const double sz = zu[c] + 2.0 * zm[c] + zd[c];
      const double sq = qu[c] + 2.0 * qm[c] + qd[c];
      const bool ok = s > 0.0 && (!keep_holes || zc[c] > 0.f);
      const double inv = ok ? 1.0 / s : 0.0;
      const double mean = sz * inv;
      const double var = std::max(sq * inv - mean * mean, 0.0);
      oz[c] = static_cast<float>(mean);
      ov[c] = static_cast<float>(var);
      n += ok ? 1 : 0;
    }
    valid_out += n;
  }
  stats_.invalid_inputs += invalid;
  stats_.last_valid_in = valid_in;
  stats_.last_valid_out = valid_out;
}

}  // namespace pplvo::depth_filter
