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

/// A point's two residuals or a line end's one, their derivatives in the pose (translation,
/// rotation) and the readout.
template <int D>
struct ReadoutRows {
  Eigen::Matrix<double, D, 1> residual;
  Eigen::Matrix<double, D, 7> jacobian;
};

/// One family's reading: the readout fitted with the 6 pose parameters to its rows, gated (twice)
/// at three times the median residual (1 px at least: mismatches and moving objects out). nullopt
/// with fewer than `min_groups` inside the gate or without information on the readout (a camera at
/// rest).
template <int D>
std::optional<ReadoutReading> readFamily(const std::vector<ReadoutRows<D>>& groups,
                                         int min_groups) {
  if (static_cast<int>(groups.size()) < min_groups) return std::nullopt;
  // Gated twice: on the residuals at the pose given, which still hold the shear (largest
  // where it is: a fast roll's corners), then on the fit's own residuals, so that what the
  // readout explains is not cut as if it were a mismatch.
  std::vector<double> norms;
  norms.reserve(groups.size());
  for (const ReadoutRows<D>& g : groups) norms.push_back(g.residual.norm());
  double gate = 0;
  int used = 0;
  Eigen::Matrix<double, 7, 1> x = Eigen::Matrix<double, 7, 1>::Zero();
  Eigen::LDLT<Eigen::Matrix<double, 7, 7>> ldlt;
  for (int pass = 0; pass < 2; ++pass) {
    if (pass > 0) {
      for (size_t k = 0; k < groups.size(); ++k) {
        norms[k] = (groups[k].residual - groups[k].jacobian * x).norm();
      }
    }
    std::vector<double> sorted = norms;
    std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
    gate = std::max(3.0 * sorted[sorted.size() / 2], 1.0);
    Eigen::Matrix<double, 7, 7> H = Eigen::Matrix<double, 7, 7>::Zero();
    Eigen::Matrix<double, 7, 1> b = Eigen::Matrix<double, 7, 1>::Zero();
    used = 0;
    for (size_t k = 0; k < groups.size(); ++k) {
      if (norms[k] > gate) continue;
      H += groups[k].jacobian.transpose() * groups[k].jacobian;
      b += groups[k].jacobian.transpose() * groups[k].residual;
      ++used;
    }
    if (used < min_groups || !(H(6, 6) > 0)) return std::nullopt;  // at rest: nothing sheared
    ldlt.compute(H);
    if (ldlt.info() != Eigen::Success) return std::nullopt;
    x = ldlt.solve(b);
  }
  const Eigen::Matrix<double, 7, 7> H_inv = ldlt.solve(Eigen::Matrix<double, 7, 7>::Identity());
  double squared = 0;
  for (size_t k = 0; k < groups.size(); ++k) {
    if (norms[k] <= gate) squared += (groups[k].residual - groups[k].jacobian * x).squaredNorm();
  }
  // Not below a keypoint's quantisation (1/12 px^2, the estimator's point_sigma_px): a frame
  // matched against its own image (a repeated frame) fits exactly and would outweigh the rest.
  constexpr double kPixelNoiseFloorPx2 = 1.0 / 12.0;
  const double noise_px2 = std::max(kPixelNoiseFloorPx2, squared / std::max(1, D * used - 7));
  ReadoutReading reading;
  reading.readout_s = x(6);
  reading.variance_s2 = noise_px2 * H_inv(6, 6);
  if (!std::isfinite(reading.readout_s) || !(reading.variance_s2 > 0) ||
      !std::isfinite(reading.variance_s2)) {
    return std::nullopt;
  }
  (D == 2 ? reading.points : reading.lines) = used;
  return reading;
}

}  // namespace

std::optional<ReadoutReading> readReadout(const FrameFeatures& reference,
                                          const FrameFeatures& current,
                                          const FeatureMatches& matches, const Pose3& T_curr_ref,
                                          const CameraVelocity& reference_velocity,
                                          const CameraVelocity& current_velocity) {
  const PinholeCamera& camera = current.camera;
  if (!camera.valid() || camera.height < 2) return std::nullopt;
  const Eigen::Matrix3d R_curr_ref = T_curr_ref.linear();
  // A reference point X_ref was lifted at its depth on the ray of its pixel px_ref as read,
  // displaced by that row's shift: it is displaced sideways by its depth times the shift. Its
  // shear per second of readout, seen in the current image (J_curr at T_curr_ref X_ref).
  auto referenceShear = [&](const Eigen::Vector3d& X_ref, const Eigen::Vector2d& px_ref,
                            const Eigen::Matrix<double, 2, 3>& J_curr) -> Eigen::Vector2d {
    const Eigen::Vector2d shift =
        rowFraction(camera, px_ref.y()) *
        imageVelocity(projectionJacobian(camera, X_ref), X_ref, reference_velocity);
    const Eigen::Vector3d displacement(X_ref.z() * shift.x() / camera.fx,
                                       X_ref.z() * shift.y() / camera.fy, 0.0);
    return J_curr * (R_curr_ref * displacement);
  };
  // The current image's shear at px_curr of the point X_curr, per second of readout.
  auto currentShear = [&](const Eigen::Vector3d& X_curr, const Eigen::Vector2d& px_curr,
                          const Eigen::Matrix<double, 2, 3>& J_curr) -> Eigen::Vector2d {
    return rowFraction(camera, px_curr.y()) * imageVelocity(J_curr, X_curr, current_velocity);
  };
  auto poseJacobian = [](const Eigen::Matrix<double, 2, 3>& J, const Eigen::Vector3d& X) {
    Eigen::Matrix<double, 2, 6> A;
    A.leftCols<3>() = J;
    A.rightCols<3>() = -J * skew(X);
    return A;
  };
  auto inFront = [](const Eigen::Vector3d& X) { return X.z() > 1e-3 && X.allFinite(); };

  std::vector<ReadoutRows<2>> points;
  points.reserve(matches.points.size());
  for (const auto& [i, j] : matches.points) {
    if (i < 0 || j < 0 || i >= static_cast<int>(reference.points.size()) ||
        j >= static_cast<int>(current.points.size())) {
      continue;
    }
    const PointFeature& ref = reference.points[i];
    const PointFeature& cur = current.points[j];
    if (!ref.has_3d || !ref.px.allFinite() || !cur.px.allFinite()) continue;
    const Eigen::Vector3d X_ref = ref.point.p;
    const Eigen::Vector3d X_curr = T_curr_ref * X_ref;
    if (!inFront(X_ref) || !inFront(X_curr)) continue;
    const Eigen::Matrix<double, 2, 3> J = projectionJacobian(camera, X_curr);
    ReadoutRows<2> row;
    row.residual = cur.px - camera.project(X_curr);
    row.jacobian.leftCols<6>() = poseJacobian(J, X_curr);
    row.jacobian.col(6) = currentShear(X_curr, cur.px, J) - referenceShear(X_ref, ref.px, J);
    if (row.residual.allFinite() && row.jacobian.allFinite()) points.push_back(row);
  }

  // A line by its ends' distances to the observed line (the estimator's line residual). The
  // observed line runs through the current image's sheared edge, so an end's distance moves by
  // minus the current shear along the line's normal at the end's row, and by the reference
  // end's own shear (at the row it was lifted from, where the reference saw it).
  std::vector<ReadoutRows<1>> line_ends;
  line_ends.reserve(2 * matches.lines.size());
  for (const auto& [i, j] : matches.lines) {
    if (i < 0 || j < 0 || i >= static_cast<int>(reference.lines.size()) ||
        j >= static_cast<int>(current.lines.size())) {
      continue;
    }
    const LineFeature& ref = reference.lines[i];
    const Eigen::Vector3d& l = current.lines[j].eq;
    const double norm = l.head<2>().norm();
    if (!ref.has_3d || !(norm > 0) || !l.allFinite()) continue;
    const Eigen::Vector2d n = l.head<2>() / norm;
    for (const Eigen::Vector3d& X_ref : {ref.line.p1, ref.line.p2}) {
      const Eigen::Vector3d X_curr = T_curr_ref * X_ref;
      if (!inFront(X_ref) || !inFront(X_curr)) continue;
      const Eigen::Matrix<double, 2, 3> J = projectionJacobian(camera, X_curr);
      const Eigen::Vector2d q = camera.project(X_curr);
      ReadoutRows<1> row;
      row.residual(0) = n.dot(q) + l.z() / norm;
      row.jacobian.leftCols<6>() = n.transpose() * poseJacobian(J, X_curr);
      row.jacobian(0, 6) =
          -n.dot(currentShear(X_curr, q, J) - referenceShear(X_ref, camera.project(X_ref), J));
      if (row.residual.allFinite() && row.jacobian.allFinite()) line_ends.push_back(row);
    }
  }

  // Each family read with its own pose: the families' poses can disagree by more than their
  // noise (a line's depth at an edge, a point's on a textured plane), and a pose shared between
  // them would push that disagreement into the readout (measured on TUM fr3: points alone 22.5,
  // lines alone 25.4, together 12.6 ms). Combined by information.
  constexpr int kMinPoints = 12;
  constexpr int kMinLineEnds = 24;
  const std::optional<ReadoutReading> from_points = readFamily(points, kMinPoints);
  const std::optional<ReadoutReading> from_lines = readFamily(line_ends, kMinLineEnds);
  if (!from_points || !from_lines) return from_points ? from_points : from_lines;
  const double w_points = 1.0 / from_points->variance_s2;
  const double w_lines = 1.0 / from_lines->variance_s2;
  ReadoutReading reading;
  reading.readout_s =
      (w_points * from_points->readout_s + w_lines * from_lines->readout_s) / (w_points + w_lines);
  reading.variance_s2 = 1.0 / (w_points + w_lines);
  reading.points = from_points->points;
  reading.lines = from_lines->lines;
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
