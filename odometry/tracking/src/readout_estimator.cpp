#include "pplvo/tracking/readout_estimator.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>

#include "pplvo/estimator/residuals.h"

namespace pplvo::tracking {

namespace {

/// The pinhole projection's Jacobian at X (camera frame; z > 0), the estimator's.
Eigen::Matrix<double, 2, 3> projectionJacobian(const PinholeCamera& camera,
                                               const Eigen::Vector3d& X) {
  const estimator::Projector projector{camera.fx, camera.fy, camera.cx, camera.cy, 0.0};
  Eigen::Vector2d px;
  estimator::Matrix23 J = estimator::Matrix23::Zero();
  projector.project(X, px, J);
  return J;
}

/// Row fraction of image row v: -1/2 at the top, 1/2 at the bottom (the middle at the stamp).
double rowFraction(const PinholeCamera& camera, double v) {
  return camera.height < 2 ? 0.0 : (v - 0.5 * (camera.height - 1)) / (camera.height - 1);
}

/// The image velocity (px/s) of the point X (camera frame) under the camera's velocity.
Eigen::Vector2d imageVelocity(const Eigen::Matrix<double, 2, 3>& J, const Eigen::Vector3d& X,
                              const CameraVelocity& velocity) {
  return J * (-velocity.angular.cross(X) - velocity.linear);
}

}  // namespace

std::optional<ReadoutReading> readReadout(const FrameFeatures& reference,
                                          const FrameFeatures& current,
                                          const std::vector<std::pair<int, int>>& point_matches,
                                          const Pose3& T_curr_ref,
                                          const CameraVelocity& reference_velocity,
                                          const CameraVelocity& current_velocity) {
  constexpr int kMinPoints = 12;
  const PinholeCamera& camera = current.camera;
  if (!camera.valid() || camera.height < 2) return std::nullopt;
  struct Row {
    Eigen::Vector2d residual;
    Eigen::Matrix<double, 2, 7> jacobian;  // pose (translation, rotation), readout
  };
  std::vector<Row> rows;
  rows.reserve(point_matches.size());
  const Eigen::Matrix3d R_curr_ref = T_curr_ref.linear();
  for (const auto& [i, j] : point_matches) {
    if (i < 0 || j < 0 || i >= static_cast<int>(reference.points.size()) ||
        j >= static_cast<int>(current.points.size())) {
      continue;
    }
    const PointFeature& ref = reference.points[i];
    const PointFeature& cur = current.points[j];
    if (!ref.has_3d || !ref.px.allFinite() || !cur.px.allFinite()) continue;
    const Eigen::Vector3d X_ref = ref.point.p;
    const Eigen::Vector3d X_curr = T_curr_ref * X_ref;
    if (!(X_ref.z() > 1e-3) || !(X_curr.z() > 1e-3) || !X_curr.allFinite()) continue;
    const Eigen::Matrix<double, 2, 3> J_curr = projectionJacobian(camera, X_curr);
    const Eigen::Matrix<double, 2, 3> J_ref = projectionJacobian(camera, X_ref);
    // The reference point was lifted at its depth on the ray of its displaced pixel: it is
    // displaced sideways by its depth times that pixel shift.
    const Eigen::Vector2d ref_shift =
        rowFraction(camera, ref.px.y()) * imageVelocity(J_ref, X_ref, reference_velocity);
    const Eigen::Vector3d ref_displacement(X_ref.z() * ref_shift.x() / camera.fx,
                                           X_ref.z() * ref_shift.y() / camera.fy, 0.0);
    Row row;
    row.residual = cur.px - camera.project(X_curr);
    row.jacobian.block<2, 3>(0, 0) = J_curr;
    row.jacobian.block<2, 3>(0, 3) = -J_curr * skew(X_curr);
    row.jacobian.col(6) =
        rowFraction(camera, cur.px.y()) * imageVelocity(J_curr, X_curr, current_velocity) -
        J_curr * (R_curr_ref * ref_displacement);
    if (row.residual.allFinite() && row.jacobian.allFinite()) rows.push_back(row);
  }
  if (static_cast<int>(rows.size()) < kMinPoints) return std::nullopt;
  // Gate at three times the median residual (1 px at least): mismatches and moving objects out.
  std::vector<double> norms;
  norms.reserve(rows.size());
  for (const Row& row : rows) norms.push_back(row.residual.norm());
  std::vector<double> sorted = norms;
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
  const double gate = std::max(3.0 * sorted[sorted.size() / 2], 1.0);
  Eigen::Matrix<double, 7, 7> H = Eigen::Matrix<double, 7, 7>::Zero();
  Eigen::Matrix<double, 7, 1> b = Eigen::Matrix<double, 7, 1>::Zero();
  int used = 0;
  for (size_t k = 0; k < rows.size(); ++k) {
    if (norms[k] > gate) continue;
    H += rows[k].jacobian.transpose() * rows[k].jacobian;
    b += rows[k].jacobian.transpose() * rows[k].residual;
    ++used;
  }
  if (used < kMinPoints || !(H(6, 6) > 0)) return std::nullopt;  // at rest: nothing sheared
  const Eigen::LDLT<Eigen::Matrix<double, 7, 7>> ldlt(H);
  if (ldlt.info() != Eigen::Success) return std::nullopt;
  const Eigen::Matrix<double, 7, 1> x = ldlt.solve(b);
  const Eigen::Matrix<double, 7, 7> H_inv = ldlt.solve(Eigen::Matrix<double, 7, 7>::Identity());
  double squared = 0;
  for (size_t k = 0; k < rows.size(); ++k) {
    if (norms[k] <= gate) squared += (rows[k].residual - rows[k].jacobian * x).squaredNorm();
  }
  // Not below a keypoint's quantisation (1/12 px^2, the estimator's point_sigma_px): a frame
  // matched against its own image (a repeated frame) fits exactly and would outweigh the rest.
  constexpr double kPixelNoiseFloorPx2 = 1.0 / 12.0;
  const double noise_px2 = std::max(kPixelNoiseFloorPx2, squared / std::max(1, 2 * used - 7));
  ReadoutReading reading{x(6), noise_px2 * H_inv(6, 6), used};
  if (!std::isfinite(reading.readout_s) || !(reading.variance_s2 > 0) ||
      !std::isfinite(reading.variance_s2)) {
    return std::nullopt;
  }
  return reading;
}

double ReadoutEstimator::referenceStandardError() const {
  // Each reference's information and mean; the variance of the weighted mean from their
  // scatter (a cluster-robust sandwich, G / (G - 1) for the few references).
  std::vector<std::pair<double, double>> groups;  // (information, information x mean)
  int64_t current = -1;
  for (const Entry& e : readings_) {
    if (groups.empty() || e.reference_seq != current) groups.emplace_back(0.0, 0.0);
    current = e.reference_seq;
    groups.back().first += 1.0 / e.reading.variance_s2;
    groups.back().second += e.reading.readout_s / e.reading.variance_s2;
  }
  const double G = static_cast<double>(groups.size());
  if (groups.size() < static_cast<size_t>(kMinReferences)) return 0.0;
  double information = 0, sandwich = 0;
  for (const auto& [w, wm] : groups) information += w;
  for (const auto& [w, wm] : groups) sandwich += (wm - w * mean_s_) * (wm - w * mean_s_);
  return std::sqrt(G / (G - 1) * sandwich) / information;
}

void ReadoutEstimator::add(int64_t seq, int64_t reference_seq, const ReadoutReading& reading) {
  if (!std::isfinite(reading.readout_s) || !(reading.variance_s2 > 0)) return;
  readings_.push_back({seq, reference_seq, reading});
  while (readings_.size() > kWindow) readings_.pop_front();
  double information = 0, weighted = 0;
  for (const Entry& e : readings_) {
    const ReadoutReading& r = e.reading;
    information += 1.0 / r.variance_s2;
    weighted += r.readout_s / r.variance_s2;
  }
  mean_s_ = weighted / information;
  // The readings scatter more than their own variances say (the shared error of a frame, a
  // pose off by more than its points): widen the standard error by the excess.
  double chi2 = 0;
  for (const Entry& e : readings_) {
    const ReadoutReading& r = e.reading;
    chi2 += (r.readout_s - mean_s_) * (r.readout_s - mean_s_) / r.variance_s2;
  }
  const double n = static_cast<double>(readings_.size());
  const double dispersion = n > 1 ? std::max(1.0, chi2 / (n - 1)) : 1.0;
  const double reference_error = referenceStandardError();
  standard_error_s_ = std::max(std::sqrt(dispersion / information), reference_error);
  const bool clear_of_zero = readings() >= kMinReadings && reference_error > 0 &&
                             mean_s_ > kSignificance * standard_error_s_;
  // Once used, kept (a compensation switched on and off would start a keyframe each time).
  if (adopted_ || clear_of_zero) adopted_ = std::clamp(mean_s_, 0.0, kMaxReadoutS);
}

int ReadoutEstimator::references() const {
  int n = 0;
  for (size_t i = 0; i < readings_.size(); ++i) {
    n += i == 0 || readings_[i].reference_seq != readings_[i - 1].reference_seq;
  }
  return n;
}

void ReadoutEstimator::reset() {
  readings_.clear();
  mean_s_ = standard_error_s_ = 0;
  adopted_.reset();
}

}  // namespace pplvo::tracking
