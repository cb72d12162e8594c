#include "pplvo/eval/nees.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cstdio>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>

namespace pplvo {
namespace eval {

// ---------------------------------------------------------------------------------------------
// Chi-square distribution.

double regularisedGammaP(double a, double x) {
  if (!(a > 0) || !(x >= 0)) return std::numeric_limits<double>::quiet_NaN();
  if (x == 0) return 0.0;
  const double log_prefix = a * std::log(x) - x - std::lgamma(a);
  if (x < a + 1) {
    // Series: P = x^a e^-x / Gamma(a + 1) * sum_n x^n / ((a + 1) ... (a + n)).
    double term = 1.0 / a, sum = term;
    for (int n = 1; n < 1000; ++n) {
      term *= x / (a + n);
      sum += term;
      if (std::abs(term) < 1e-16 * std::abs(sum)) break;
    }
    return std::min(1.0, sum * std::exp(log_prefix));
  }
  // Continued fraction for Q = 1 - P (modified Lentz).
  const double tiny = 1e-300;
  double b = x + 1 - a, c = 1 / tiny, d = 1 / b, h = d;
  for (int i = 1; i < 1000; ++i) {
    const double an = -i * (i - a);
    b += 2;
    d = an * d + b;
    if (std::abs(d) < tiny) d = tiny;
    c = b + an / c;
    if (std::abs(c) < tiny) c = tiny;
    d = 1 / d;
    const double delta = d * c;
    h *= delta;
    if (std::abs(delta - 1) < 1e-16) break;
  }
  return std::max(0.0, 1.0 - std::exp(log_prefix) * h);
}

double chiSquareCdf(double x, double dof) {
  if (x <= 0) return 0.0;
  return regularisedGammaP(0.5 * dof, 0.5 * x);
}

double chiSquareQuantile(double p, double dof) {
  double lo = 0.0, hi = std::max(1.0, dof);
  while (chiSquareCdf(hi, dof) < p) hi *= 2;
  for (int i = 0; i < 200 && hi - lo > 1e-12 * hi; ++i) {
    const double mid = 0.5 * (lo + hi);
    (chiSquareCdf(mid, dof) < p ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

namespace {

// ---------------------------------------------------------------------------------------------
// Ground truth as a function of time.

class GroundTruth {
 public:
  explicit GroundTruth(const TumFile& file) {
    std::map<double, TumRow> by_stamp;  // last line of a stamp wins (TUM dict semantics)
    for (const TumRow& r : file.rows) {
      bool finite = std::isfinite(r.stamp_s);
      for (double v : r.values) finite = finite && std::isfinite(v);
      const double qq = r.values[3] * r.values[3] + r.values[4] * r.values[4] +
                        r.values[5] * r.values[5] + r.values[6] * r.values[6];
      if (finite && qq > 1e-12) by_stamp[r.stamp_s] = r;
    }
    for (const auto& [s, r] : by_stamp) {
      t_.push_back(s);
      p_.emplace_back(r.values[0], r.values[1], r.values[2]);
      q_.push_back(
          Eigen::Quaterniond(r.values[6], r.values[3], r.values[4], r.values[5]).normalized());
    }
    std::vector<double> dt;
    for (size_t i = 1; i < t_.size(); ++i) dt.push_back(t_[i] - t_[i - 1]);
    if (!dt.empty()) {
      std::nth_element(dt.begin(), dt.begin() + dt.size() / 2, dt.end());
      median_interval_s_ = dt[dt.size() / 2];
    }
  }
  size_t size() const { return t_.size(); }
  double medianInterval() const { return median_interval_s_; }

  /// T_w_c at time s: linear in position, slerp in rotation between the two samples around s,
  /// which must be at most max_interval apart. False outside the ground truth or in a gap.
  /// `noise_factor`: std of the interpolated pose's white noise relative to one sample's,
  /// sqrt((1 - a)^2 + a^2) at fraction a between the samples (1 on a sample).
  bool at(double s, double max_interval, Eigen::Isometry3d* T,
          double* noise_factor = nullptr) const {
    if (noise_factor) *noise_factor = 1.0;
    if (t_.empty() || s < t_.front() || s > t_.back()) return false;
    const size_t j = std::lower_bound(t_.begin(), t_.end(), s) - t_.begin();
    Eigen::Vector3d p;
    Eigen::Quaterniond q;
    if (t_[j] == s) {
      p = p_[j];
      q = q_[j];
    } else {
      const size_t i = j - 1;  // t_[i] < s < t_[j], j >= 1 since s >= t_.front()
      const double span = t_[j] - t_[i];
      if (span > max_interval) return false;
      const double a = (s - t_[i]) / span;
      p = (1 - a) * p_[i] + a * p_[j];
      q = q_[i].slerp(a, q_[j]);
      if (noise_factor) *noise_factor = std::sqrt((1 - a) * (1 - a) + a * a);
    }
    *T = Eigen::Isometry3d::Identity();
    T->linear() = q.normalized().toRotationMatrix();
    T->translation() = p;
    return true;
  }

 private:
  std::vector<double> t_;
  std::vector<Eigen::Vector3d> p_;
  std::vector<Eigen::Quaterniond> q_;
  double median_interval_s_ = 0.0;
};

Eigen::Isometry3d perturbed(const Eigen::Isometry3d& T, const Vector6d& d) {
  // Right perturbation in the body frame: T * Exp([dt; dtheta]) to first order.
  Eigen::Isometry3d out = T;
  out.translation() += T.linear() * d.head<3>();
  const double angle = d.tail<3>().norm();
  if (angle > 0) {
    out.linear() = T.linear() * Eigen::AngleAxisd(angle, d.tail<3>() / angle).toRotationMatrix();
  }
  return out;
}

/// Covariance of xi(G0^-1 G1) caused by independent white noise on G0 and G1 (body frame,
/// per axis sigma_t and sigma_rot, times factor0 / factor1), by central differences.
Matrix6d poseNoiseCovariance(const Eigen::Isometry3d& G0, const Eigen::Isometry3d& G1,
                             const GtNoiseOptions& o, double factor0, double factor1) {
  Vector6d sigma;
  sigma << Eigen::Vector3d::Constant(o.sigma_t_m), Eigen::Vector3d::Constant(o.sigma_rot_rad);
  Matrix6d C = Matrix6d::Zero();
  if (sigma.isZero()) return C;
  const double h = 1e-6;
  for (int end = 0; end < 2; ++end) {
    Matrix6d J;
    for (int k = 0; k < 6; ++k) {
      const Vector6d d = h * Vector6d::Unit(k);
      const Eigen::Isometry3d a0 = end == 0 ? perturbed(G0, d) : G0;
      const Eigen::Isometry3d a1 = end == 1 ? perturbed(G1, d) : G1;
      const Eigen::Isometry3d b0 = end == 0 ? perturbed(G0, -d) : G0;
      const Eigen::Isometry3d b1 = end == 1 ? perturbed(G1, -d) : G1;
      J.col(k) = (poseToXi(a0.inverse() * a1) - poseToXi(b0.inverse() * b1)) / (2 * h);
    }
    const double f = end == 0 ? factor0 : factor1;
    C += f * f * J * sigma.cwiseAbs2().asDiagonal() * J.transpose();
  }
  return C;
}

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

NeesBlockStats blockStats(const std::vector<double>& values, double bound) {
  NeesBlockStats s;
  s.bound = bound;
  if (values.empty()) return s;
  double sum = 0;
  int inside = 0;
  for (double v : values) {
    sum += v;
    if (v <= bound) ++inside;
  }
  s.mean = sum / values.size();
  s.median = median(values);
  s.share_inside = static_cast<double>(inside) / values.size();
  return s;
}

double quadratic(const Eigen::VectorXd& e, const Eigen::MatrixXd& C, bool* ok) {
  Eigen::LLT<Eigen::MatrixXd> llt(C);
  if (llt.info() != Eigen::Success) {
    *ok = false;
    return 0.0;
  }
  return e.dot(llt.solve(e));
}

/// 2 Q of a relative pose whose two frames each carry an independent pose error of per-axis
/// std sigma_t (m) and sigma_rot (rad, as angle; q_xyz is half of it).
Matrix6d frameErrorCovariance(double sigma_t_m, double sigma_rot_rad) {
  Matrix6d C = Matrix6d::Zero();
  C.topLeftCorner<3, 3>().diagonal().setConstant(2 * sigma_t_m * sigma_t_m);
  C.bottomRightCorner<3, 3>().diagonal().setConstant(2 * 0.25 * sigma_rot_rad * sigma_rot_rad);
  return C;
}

}  // namespace

GtJitter estimateGtJitter(const TumFile& file) {
  GtJitter j;
  std::map<double, TumRow> by_stamp;
  for (const TumRow& r : file.rows) {
    bool finite = std::isfinite(r.stamp_s);
    for (double v : r.values) finite = finite && std::isfinite(v);
    if (finite) by_stamp[r.stamp_s] = r;
  }
  std::vector<Eigen::Vector3d> p;
  std::vector<Eigen::Quaterniond> q;
  for (const auto& [s, r] : by_stamp) {
    const Eigen::Quaterniond qi(r.values[6], r.values[3], r.values[4], r.values[5]);
    if (!(qi.norm() > 1e-6)) continue;
    p.emplace_back(r.values[0], r.values[1], r.values[2]);
    q.push_back(qi.normalized());
  }
  if (p.size() < 20) return j;
  // Rotation: body-frame increments w_i = log(R_i^T R_i+1); their second difference is the
  // third difference of the orientation noise (for small steps).
  std::vector<Eigen::Vector3d> w;
  for (size_t i = 0; i + 1 < q.size(); ++i) {
    const Eigen::AngleAxisd aa(q[i].conjugate() * q[i + 1]);
    double angle = aa.angle();
    if (angle > M_PI) angle -= 2 * M_PI;
    w.push_back(angle * aa.axis());
  }
  double sum_t = 0, sum_r = 0;
  for (int k = 0; k < 3; ++k) {
    std::vector<double> d3, d2w;
    for (size_t i = 0; i + 3 < p.size(); ++i) {
      d3.push_back(std::abs(p[i + 3][k] - 3 * p[i + 2][k] + 3 * p[i + 1][k] - p[i][k]));
    }
    for (size_t i = 0; i + 2 < w.size(); ++i) {
      d2w.push_back(std::abs(w[i + 2][k] - 2 * w[i + 1][k] + w[i][k]));
    }
    j.per_axis_t_m[k] = 1.4826 * median(d3) / std::sqrt(20.0);
    j.per_axis_rot_rad[k] = 1.4826 * median(d2w) / std::sqrt(20.0);
    sum_t += j.per_axis_t_m[k] * j.per_axis_t_m[k];
    sum_r += j.per_axis_rot_rad[k] * j.per_axis_rot_rad[k];
  }
  j.sigma_t_m = std::sqrt(sum_t / 3);
  j.sigma_rot_rad = std::sqrt(sum_r / 3);
  j.ok = true;
  return j;
}

NeesResult evaluateNees(const TumFile& gt_file, const std::vector<RelativePoseRecord>& records,
                        const NeesOptions& options) {
  NeesOptions o = options;
  if (o.gt_jitter_from_data) {
    const GtJitter j = estimateGtJitter(gt_file);
    if (j.ok) {
      o.gt.sigma_t_m = j.sigma_t_m;
      o.gt.sigma_rot_rad = j.sigma_rot_rad;
    }
  }
  NeesResult res;
  res.gt_used = o.gt;
  res.gt_time_offset_s = o.gt_time_offset_s;
  res.added_frame_sigma_t_m = o.added_frame_sigma_t_m;
  res.added_frame_sigma_rot_rad = o.added_frame_sigma_rot_rad;
  res.records = static_cast<int>(records.size());
  const GroundTruth gt(gt_file);
  if (gt.size() < 2) {
    res.error = "ground truth " + gt_file.name + " has fewer than 2 valid poses";
    return res;
  }
  const double max_gap = o.max_gt_interval_s > 0 ? o.max_gt_interval_s : 2.5 * gt.medianInterval();
  res.max_gt_interval_s = max_gap;
  const double h = gt.medianInterval();  // velocity by central differences over 2 intervals
  std::vector<double> n6, nt, nr;
  double sum_est_only = 0, s_var_t = 0, s_err_t = 0, s_var_q = 0, s_err_q = 0, s_gt_t = 0,
         s_gt_q = 0;
  for (const RelativePoseRecord& r : records) {
    const auto status = static_cast<RelativePoseStatus>(r.status);
    if (status == RelativePoseStatus::kFirstFrame || status == RelativePoseStatus::kLost ||
        (status == RelativePoseStatus::kVelocityModel && !o.include_velocity_model)) {
      ++res.skipped_status;
      continue;
    }
    Eigen::Isometry3d G0, G1;
    double f0 = 1.0, f1 = 1.0;
    const double off = o.gt_time_offset_s;
    if (!gt.at(r.prev_stamp_s + off, max_gap, &G0, &f0) ||
        !gt.at(r.stamp_s + off, max_gap, &G1, &f1)) {
      ++res.skipped_no_gt;
      continue;
    }
    const Eigen::Isometry3d T_gt = G0.inverse() * G1;
    NeesPair pair;
    pair.stamp_s = r.stamp_s;
    pair.prev_stamp_s = r.prev_stamp_s;
    pair.status = r.status;
    const Vector6d xi_gt = poseToXi(T_gt);
    pair.error = poseToXi(r.T_prev_curr) - xi_gt;
    pair.cov_est = 0.5 * (r.covariance + r.covariance.transpose());
    pair.cov_gt = poseNoiseCovariance(G0, G1, o.gt, f0, f1);
    if (o.gt.sigma_stamp_s > 0) {
      // d xi_gt / d stamp of each end, central differences on the interpolated ground truth
      // (one-sided at its ends).
      for (int end = 0; end < 2; ++end) {
        const double s = (end == 0 ? r.prev_stamp_s : r.stamp_s) + off;
        Eigen::Isometry3d Ga, Gb;
        double sa = s - h, sb = s + h;
        if (!gt.at(sa, max_gap, &Ga)) {
          sa = s;
          Ga = end == 0 ? G0 : G1;
        }
        if (!gt.at(sb, max_gap, &Gb)) {
          sb = s;
          Gb = end == 0 ? G0 : G1;
        }
        if (sb <= sa) continue;
        const Vector6d xa = end == 0 ? poseToXi(Ga.inverse() * G1) : poseToXi(G0.inverse() * Ga);
        const Vector6d xb = end == 0 ? poseToXi(Gb.inverse() * G1) : poseToXi(G0.inverse() * Gb);
        const Vector6d v = (xb - xa) / (sb - sa);
        pair.cov_gt += o.gt.sigma_stamp_s * o.gt.sigma_stamp_s * v * v.transpose();
      }
    }
    pair.cov_frame = frameErrorCovariance(o.added_frame_sigma_t_m, o.added_frame_sigma_rot_rad);
    const Matrix6d C = pair.cov_est + pair.cov_gt + pair.cov_frame;
    bool ok = true;
    pair.nees = quadratic(pair.error, C, &ok);
    pair.nees_t = quadratic(pair.error.head<3>(), C.topLeftCorner<3, 3>(), &ok);
    pair.nees_r = quadratic(pair.error.tail<3>(), C.bottomRightCorner<3, 3>(), &ok);
    bool ok_est = true;
    pair.nees_est_only = quadratic(pair.error, pair.cov_est, &ok_est);
    if (!ok || !std::isfinite(pair.nees)) {
      ++res.skipped_singular;
      continue;
    }
    if (!ok_est) pair.nees_est_only = std::numeric_limits<double>::infinity();
    n6.push_back(pair.nees);
    nt.push_back(pair.nees_t);
    nr.push_back(pair.nees_r);
    sum_est_only += pair.nees_est_only;
    s_var_t += pair.cov_est.topLeftCorner<3, 3>().trace() / 3;
    s_var_q += pair.cov_est.bottomRightCorner<3, 3>().trace() / 3;
    s_gt_t += pair.cov_gt.topLeftCorner<3, 3>().trace() / 3;
    s_gt_q += pair.cov_gt.bottomRightCorner<3, 3>().trace() / 3;
    s_err_t += pair.error.head<3>().squaredNorm() / 3;
    s_err_q += pair.error.tail<3>().squaredNorm() / 3;
    res.pairs.push_back(pair);
  }
  const size_t n = res.pairs.size();
  if (n < 1) {
    res.error = "no frame pair could be evaluated (" + std::to_string(res.records) + " records, " +
                std::to_string(res.skipped_no_gt) + " without ground truth, " +
                std::to_string(res.skipped_status) + " first/lost): same clock and --fps?";
    return res;
  }
  res.all = blockStats(n6, chiSquareQuantile(o.confidence, 6));
  res.translation = blockStats(nt, chiSquareQuantile(o.confidence, 3));
  res.rotation = blockStats(nr, chiSquareQuantile(o.confidence, 3));
  res.mean_est_only = sum_est_only / n;
  const double N = static_cast<double>(n);
  res.mean_interval_lo = chiSquareQuantile(0.5 * (1 - o.confidence), 6 * N) / N;
  res.mean_interval_hi = chiSquareQuantile(0.5 * (1 + o.confidence), 6 * N) / N;
  res.rms_sigma_t_m = std::sqrt(s_var_t / N);
  res.rms_sigma_q = std::sqrt(s_var_q / N);
  res.rms_sigma_gt_t_m = std::sqrt(s_gt_t / N);
  res.rms_sigma_gt_q = std::sqrt(s_gt_q / N);
  res.rms_error_t_m = std::sqrt(s_err_t / N);
  res.rms_error_q = std::sqrt(s_err_q / N);
  res.ok = true;
  return res;
}

GtTimeOffsetEstimate estimateGtTimeOffset(const TumFile& gt,
                                          const std::vector<RelativePoseRecord>& records,
                                          const NeesOptions& options, double max_abs_s,
                                          double step_s) {
  GtTimeOffsetEstimate best;
  if (!(step_s > 0) || !(max_abs_s >= 0)) return best;
  NeesOptions o = options;
  const int steps = static_cast<int>(std::floor(max_abs_s / step_s + 1e-9));
  double best_ms = std::numeric_limits<double>::infinity();
  for (int k = -steps; k <= steps; ++k) {
    o.gt_time_offset_s = k * step_s;
    const NeesResult r = evaluateNees(gt, records, o);
    if (!r.ok) return GtTimeOffsetEstimate{};  // a pair set that changes with the offset
    double sum = 0;
    for (const NeesPair& p : r.pairs) sum += 4 * p.error.tail<3>().squaredNorm() / 3;
    const double ms = sum / r.pairs.size();
    if (k == 0) best.rms_rot_zero_rad = std::sqrt(ms);
    if (ms < best_ms) {
      best_ms = ms;
      best.offset_s = o.gt_time_offset_s;
    }
  }
  best.rms_rot_rad = std::sqrt(best_ms);
  best.ok = true;
  return best;
}

namespace {

/// Mean over `pairs` of e_b^T (C_b + 2 s^2 scale I)^-1 e_b for the 3x3 block b (0: t, 3: q).
double meanBlockNees(const std::vector<const NeesPair*>& pairs, int block, double added_var) {
  double sum = 0;
  for (const NeesPair* p : pairs) {
    const Eigen::Matrix3d C = (p->cov_est + p->cov_gt).block<3, 3>(block, block) +
                              added_var * Eigen::Matrix3d::Identity();
    const Eigen::Vector3d e = p->error.segment<3>(block);
    sum += e.dot(C.ldlt().solve(e));
  }
  return sum / pairs.size();
}

/// Smallest per-frame std s >= 0 (in the block's units) with mean block NEES <= 3, where a
/// pair gains 2 s^2 `unit_factor` on its block's diagonal; bisection on a monotone function.
double fitBlock(const std::vector<const NeesPair*>& pairs, int block, double unit_factor) {
  auto meanAt = [&](double s) { return meanBlockNees(pairs, block, 2 * unit_factor * s * s); };
  if (meanAt(0.0) <= 3.0) return 0.0;
  double lo = 0.0, hi = 1e-4;
  while (meanAt(hi) > 3.0 && hi < 10.0) hi *= 2;
  for (int i = 0; i < 100 && hi - lo > 1e-12; ++i) {
    const double mid = 0.5 * (lo + hi);
    (meanAt(mid) > 3.0 ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

}  // namespace

FrameErrorFit fitFrameError(const std::vector<const NeesResult*>& results) {
  FrameErrorFit fit;
  std::vector<const NeesPair*> pairs;
  for (const NeesResult* r : results) {
    if (r == nullptr || !r->ok) continue;
    for (const NeesPair& p : r->pairs) pairs.push_back(&p);
  }
  fit.pairs = static_cast<int>(pairs.size());
  if (pairs.empty()) return fit;
  fit.sigma_t_m = fitBlock(pairs, 0, 1.0);
  // q_xyz is half the rotation vector: its variance is a quarter of the angle's.
  fit.sigma_rot_rad = fitBlock(pairs, 3, 0.25);
  fit.ok = true;
  return fit;
}

namespace {

void line(std::ostringstream& out, const char* key, double v) {
  char buf[128];
  std::snprintf(buf, sizeof buf, "%s %.6g\n", key, v);
  out << buf;
}

}  // namespace

std::string formatNeesText(const NeesResult& r) {
  std::ostringstream out;
  if (!r.ok) {
    out << "nees.error " << r.error << "\n";
    return out.str();
  }
  out << "nees.pairs " << r.pairs.size() << "\n";
  line(out, "nees.gt_sigma_t_m", r.gt_used.sigma_t_m);
  line(out, "nees.gt_sigma_rot_deg", r.gt_used.sigma_rot_rad * 180 / M_PI);
  line(out, "nees.stamp_sigma_s", r.gt_used.sigma_stamp_s);
  line(out, "nees.gt_time_offset_s", r.gt_time_offset_s);
  line(out, "nees.added_frame_sigma_t_m", r.added_frame_sigma_t_m);
  line(out, "nees.added_frame_sigma_rot_deg", r.added_frame_sigma_rot_rad * 180 / M_PI);
  line(out, "nees.mean", r.all.mean);
  line(out, "nees.median", r.all.median);
  line(out, "nees.share_inside_95", r.all.share_inside);
  line(out, "nees.bound_6dof", r.all.bound);
  line(out, "nees.t_mean", r.translation.mean);
  line(out, "nees.t_median", r.translation.median);
  line(out, "nees.t_share_inside_95", r.translation.share_inside);
  line(out, "nees.r_mean", r.rotation.mean);
  line(out, "nees.r_median", r.rotation.median);
  line(out, "nees.r_share_inside_95", r.rotation.share_inside);
  line(out, "nees.bound_3dof", r.translation.bound);
  line(out, "nees.mean_without_gt_noise", r.mean_est_only);
  line(out, "nees.mean_interval_lo", r.mean_interval_lo);
  line(out, "nees.mean_interval_hi", r.mean_interval_hi);
  line(out, "nees.rms_sigma_t_m", r.rms_sigma_t_m);
  line(out, "nees.rms_error_t_m", r.rms_error_t_m);
  line(out, "nees.rms_sigma_gt_t_m", r.rms_sigma_gt_t_m);
  line(out, "nees.rms_sigma_rot_deg", 2 * r.rms_sigma_q * 180 / M_PI);
  line(out, "nees.rms_error_rot_deg", 2 * r.rms_error_q * 180 / M_PI);
  line(out, "nees.rms_sigma_gt_rot_deg", 2 * r.rms_sigma_gt_q * 180 / M_PI);
  out << "nees.skipped_status " << r.skipped_status << "\n"
      << "nees.skipped_no_gt " << r.skipped_no_gt << "\n"
      << "nees.skipped_singular " << r.skipped_singular << "\n";
  out << "# NEES of N consistent pairs averages 6 (blocks 3); 95 % of the 6-dof values lie below "
         "bound_6dof; mean_interval: where the mean of N independent consistent pairs lies with "
         "95 %; rot = 2 |q_xyz| (rad -> deg)\n";
  return out.str();
}

std::string formatNeesJson(const NeesResult& r) {
  std::ostringstream out;
  char buf[64];
  auto num = [&](double v) {
    std::snprintf(buf, sizeof buf, "%.17g", v);
    return std::string(std::isfinite(v) ? buf : "null");
  };
  out << "{\"ok\": " << (r.ok ? "true" : "false");
  if (!r.ok) {
    out << ", \"error\": \"" << r.error << "\"}\n";
    return out.str();
  }
  out << ", \"pairs\": " << r.pairs.size() << ", \"mean\": " << num(r.all.mean)
      << ", \"median\": " << num(r.all.median)
      << ", \"share_inside_95\": " << num(r.all.share_inside)
      << ", \"t_mean\": " << num(r.translation.mean)
      << ", \"t_median\": " << num(r.translation.median)
      << ", \"t_share_inside_95\": " << num(r.translation.share_inside)
      << ", \"r_mean\": " << num(r.rotation.mean) << ", \"r_median\": " << num(r.rotation.median)
      << ", \"r_share_inside_95\": " << num(r.rotation.share_inside)
      << ", \"gt_time_offset_s\": " << num(r.gt_time_offset_s)
      << ", \"added_frame_sigma_t_m\": " << num(r.added_frame_sigma_t_m)
      << ", \"added_frame_sigma_rot_deg\": " << num(r.added_frame_sigma_rot_rad * 180 / M_PI)
      << ", \"mean_without_gt_noise\": " << num(r.mean_est_only)
      << ", \"rms_sigma_t_m\": " << num(r.rms_sigma_t_m)
      << ", \"rms_error_t_m\": " << num(r.rms_error_t_m)
      << ", \"rms_sigma_rot_deg\": " << num(2 * r.rms_sigma_q * 180 / M_PI)
      << ", \"rms_error_rot_deg\": " << num(2 * r.rms_error_q * 180 / M_PI)
      << ", \"skipped_no_gt\": " << r.skipped_no_gt << ", \"skipped_status\": " << r.skipped_status
      << "}\n";
  return out.str();
}

std::string formatNeesData(const NeesResult& r) {
  std::ostringstream out;
  char buf[64];
  out << "# pplvo-eval --nees per-pair data\n";
  std::snprintf(buf, sizeof buf, "# bound_6dof %.6f bound_3dof %.6f\n", r.all.bound,
                r.translation.bound);
  out << buf;
  out << "# stamp_s prev_stamp_s status nees nees_t nees_r nees_est_only e_tx e_ty e_tz e_qx e_qy "
         "e_qz sd_tx sd_ty sd_tz sd_qx sd_qy sd_qz (sd: sqrt of the diagonal of C_est + C_gt)\n";
  for (const NeesPair& p : r.pairs) {
    std::snprintf(buf, sizeof buf, "%.6f %.6f %d", p.stamp_s, p.prev_stamp_s, p.status);
    out << buf;
    for (double v : {p.nees, p.nees_t, p.nees_r, p.nees_est_only}) {
      std::snprintf(buf, sizeof buf, " %.6g", v);
      out << buf;
    }
    const Matrix6d C = p.cov_est + p.cov_gt;
    for (int k = 0; k < 6; ++k) {
      std::snprintf(buf, sizeof buf, " %.6g", p.error(k));
      out << buf;
    }
    for (int k = 0; k < 6; ++k) {
      std::snprintf(buf, sizeof buf, " %.6g", std::sqrt(std::max(0.0, C(k, k))));
      out << buf;
    }
    out << '\n';
  }
  return out.str();
}

NeesDataReadResult readNeesData(const std::string& path) {
  NeesDataReadResult res;
  std::ifstream in(path);
  if (!in) {
    res.error = "cannot open " + path;
    return res;
  }
  std::string text;
  int line_no = 0;
  while (std::getline(in, text)) {
    ++line_no;
    const size_t first = text.find_first_not_of(" \t\r");
    if (first == std::string::npos || text[first] == '#') continue;
    std::istringstream fields(text);
    double stamp, prev, status;
    NeesDataRow row;
    if (!(fields >> stamp >> prev >> status >> row.nees >> row.nees_t >> row.nees_r)) {
      res.error = path + ":" + std::to_string(line_no) + ": expected NEES data";
      res.rows.clear();
      return res;
    }
    row.stamp_s = stamp;
    res.rows.push_back(row);
  }
  res.ok = true;
  return res;
}

}  // namespace eval
}  // namespace pplvo
