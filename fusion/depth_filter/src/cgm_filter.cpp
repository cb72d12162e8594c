#include "pplvo/depth_filter/cgm_filter.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "pplvo/core/parallel.h"

namespace pplvo::depth_filter {

CgmFilter::CgmFilter(const Options& options, std::shared_ptr<const SensorModel> model)
    : options_(options), model_(std::move(model)) {
  if (!model_) model_ = std::make_shared<QuadraticSensorModel>();
}

namespace {
constexpr int kBands = 4;  // fixed, so that the per-band work does not depend on the threads
}  // namespace

void CgmFilter::resize(int rows, int cols) {
  rows_ = rows;
  cols_ = cols;
  const size_t n = static_cast<size_t>(cols);
  bands_.assign(kBands, RowBuffers());
  for (RowBuffers& b : bands_) {
    b.z.assign(n, 0.f);
    b.var.assign(n, 0.f);
    b.pad_y.assign(n + 2, 0.0);
    b.pad_z.assign(n + 2, 0.0);
    b.pad_q.assign(n + 2, 0.0);
    b.h_s.assign(3 * n, 0.0);
    b.h_z.assign(3 * n, 0.0);
    b.h_q.assign(3 * n, 0.0);
    b.centre.assign(3 * n, 0.f);
  }
  zero_.assign(n, 0.0);
  ++stats_.resizes;
}

void CgmFilter::horizontalRow(const cv::Mat& depth_m, const cv::Mat* var_m2, int r,
                              RowBuffers& b, int64_t* invalid, int64_t* valid) const {
  const int cols = cols_;
  const size_t slot = static_cast<size_t>(r % 3) * cols;
  const float* in = depth_m.ptr<float>(r);
  float* z = b.z.data();
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
  if (var_m2 != nullptr) {  // measured variances (registered depth): 0 where depth is missing
    const float* vin = var_m2->ptr<float>(r);
    for (int c = 0; c < cols; ++c) b.var[c] = z[c] > 0.f && vin[c] >= 0.f ? vin[c] : 0.f;
  } else {
    model_->varianceRow(z, b.var.data(), cols);
  }
  double* py = b.pad_y.data() + 1;
  double* pz = b.pad_z.data() + 1;
  double* pq = b.pad_q.data() + 1;
  const float* var = b.var.data();
  for (int c = 0; c < cols; ++c) {
    const double zz = z[c];
    py[c] = z[c] > 0.f ? 1.0 : 0.0;
    pz[c] = zz;
    pq[c] = zz * zz + static_cast<double>(var[c]);
  }
  double* hs = &b.h_s[slot];
  double* hz = &b.h_z[slot];
  double* hq = &b.h_q[slot];
  const double* ys = b.pad_y.data();
  const double* zs = b.pad_z.data();
  const double* qs = b.pad_q.data();
  for (int c = 0; c < cols; ++c) hs[c] = ys[c] + 2.0 * ys[c + 1] + ys[c + 2];
  for (int c = 0; c < cols; ++c) hz[c] = zs[c] + 2.0 * zs[c + 1] + zs[c + 2];
  for (int c = 0; c < cols; ++c) hq[c] = qs[c] + 2.0 * qs[c + 1] + qs[c + 2];
  std::copy(z, z + cols, b.centre.begin() + static_cast<std::ptrdiff_t>(slot));
}

DepthWithVariance CgmFilter::apply(const cv::Mat& depth_m) {
  DepthWithVariance out;
  apply(depth_m, &out);
  return out;
}

void CgmFilter::applyRows(const cv::Mat& depth_m, const cv::Mat* var_m2, int r0, int r1,
                          RowBuffers& b, DepthWithVariance& out, BandCounts* counts) const {
  const int rows = rows_, cols = cols_;
  const bool keep_holes = options_.missing_centre_stays_missing;
  int64_t not_counted = 0;
  // Stage 1 and the horizontal [1 2 1] sums of y, y z, y (z^2 + sigma^2) row by row (missing
  // pixels carry z = sigma^2 = 0, so y multiplies out), kept in a ring of three rows; then the
  // vertical [1 2 1] sums give S, S z_bar, and the second moment (eqs. 4, 5). The rows just
  // outside the band are computed here too but counted by their own band.
  if (r0 > 0) horizontalRow(depth_m, var_m2, r0 - 1, b, &not_counted, &not_counted);
  horizontalRow(depth_m, var_m2, r0, b, &counts->invalid, &counts->valid_in);
  for (int r = r0; r < r1; ++r) {
    if (r + 1 < rows) {
      const bool own = r + 1 < r1;
      horizontalRow(depth_m, var_m2, r + 1, b, own ? &counts->invalid : &not_counted,
                    own ? &counts->valid_in : &not_counted);
    }
    const size_t mid = static_cast<size_t>(r % 3) * cols;
    const bool has_up = r > 0, has_dn = r + 1 < rows;
    const size_t up = static_cast<size_t>((r + 2) % 3) * cols;
    const size_t dn = static_cast<size_t>((r + 1) % 3) * cols;
    const double* su = has_up ? &b.h_s[up] : zero_.data();
    const double* sd = has_dn ? &b.h_s[dn] : zero_.data();
    const double* zu = has_up ? &b.h_z[up] : zero_.data();
    const double* zd = has_dn ? &b.h_z[dn] : zero_.data();
    const double* qu = has_up ? &b.h_q[up] : zero_.data();
    const double* qd = has_dn ? &b.h_q[dn] : zero_.data();
    const double* sm = &b.h_s[mid];
    const double* zm = &b.h_z[mid];
    const double* qm = &b.h_q[mid];
    const float* zc = &b.centre[mid];
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
    counts->valid_out += n;
  }
}

DepthWithVariance CgmFilter::apply(const DepthWithVariance& measured) {
  if (measured.var_m2.type() != CV_32FC1 || measured.var_m2.size() != measured.depth_m.size()) {
    throw std::invalid_argument("CgmFilter::apply: variance must be CV_32FC1 of the depth's size");
  }
  DepthWithVariance out;
  run(measured.depth_m, &measured.var_m2, &out);
  return out;
}

void CgmFilter::apply(const cv::Mat& depth_m, DepthWithVariance* out_ptr) {
  run(depth_m, nullptr, out_ptr);
}

void CgmFilter::run(const cv::Mat& depth_m, const cv::Mat* var_m2, DepthWithVariance* out_ptr) {
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
  BandCounts counts[kBands];
  auto band = [&](int k) {
    const int r0 = k * rows / kBands, r1 = (k + 1) * rows / kBands;
    if (r1 > r0) applyRows(depth_m, var_m2, r0, r1, bands_[k], out, &counts[k]);
  };
  forEachTask(kBands, options_.threads, band);
  int64_t invalid = 0, valid_in = 0, valid_out = 0;
  for (const BandCounts& c : counts) {
    invalid += c.invalid;
    valid_in += c.valid_in;
    valid_out += c.valid_out;
  }
  stats_.invalid_inputs += invalid;
  stats_.last_valid_in = valid_in;
  stats_.last_valid_out = valid_out;
}

}  // namespace pplvo::depth_filter
