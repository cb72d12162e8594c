#include "pplvo/tracking/keyframe_store.h"

#include <Eigen/Cholesky>
#include <algorithm>

#include "pplvo/estimator/pose_parameterisation.h"

namespace pplvo::tracking {

void KeyframeStore::insert(FrameFeatures landmarks, const Pose3& T_w_kf, bool at_stamp) {
  retireActive();
  active_ = Keyframe{std::move(landmarks), T_w_kf, std::nullopt, at_stamp};
  ++inserted_;
}

void KeyframeStore::clear() {
  retireActive();
  active_.reset();
}

void KeyframeStore::reset() {
  active_.reset();
  retired_.clear();
  inserted_ = 0;
}

void KeyframeStore::retireActive() {
  // Without a baseline no frame was ever tracked against it: nothing says it can serve.
  if (!active_ || !active_->baseline || max_retired_ <= 0) return;
  retired_.push_back(std::move(*active_));
  active_.reset();
  while (static_cast<int>(retired_.size()) > max_retired_) retired_.pop_front();
}

bool KeyframeStore::reactivate(int64_t seq) {
  const auto it = std::find_if(retired_.begin(), retired_.end(),
                               [seq](const Keyframe& k) { return k.seq() == seq; });
  if (it == retired_.end()) return false;
  Keyframe chosen = std::move(*it);
  retired_.erase(it);
  retireActive();
  active_ = std::move(chosen);
  return true;
}

std::optional<int64_t> KeyframeStore::activeSeq() const {
  if (!active_) return std::nullopt;
  return active_->seq();
}

void KeyframeStore::setBaseline(const KeyframeBaseline& baseline) {
  if (active_) active_->baseline = baseline;
}

int KeyframeStore::fuse(const KeyframeObservation& observation, const FrameFeatures& observed,
                        double gate_chi2) {
  if (!active_) return 0;
  std::vector<PointFeature>& landmarks = active_->landmarks.points;
  const Pose3& T = observation.T_kf_frame;
  const Eigen::Matrix3d R = T.linear();
  const Eigen::Vector3d q_xyz = poseToXi(T).tail<3>();
  int fused = 0;
  for (const auto& [i, j] : observation.points) {
    if (i < 0 || j < 0 || i >= static_cast<int>(landmarks.size()) ||
        j >= static_cast<int>(observed.points.size())) {
      continue;
    }
    PointFeature& landmark = landmarks[i];
    const PointFeature& seen = observed.points[j];
    if (!landmark.has_3d || !seen.has_3d) continue;
    // The observation in the keyframe, with the pose's uncertainty (first order in xi).
    const Eigen::Vector3d p = T * seen.point.p;
    const Eigen::Matrix3d C =
        transformedPointCovariance(R, q_xyz, observation.covariance, seen.point.p, seen.point.cov);
    const Eigen::Vector3d d = p - landmark.point.p;
    const Eigen::Matrix3d S = landmark.point.cov + C;
    const Eigen::LDLT<Eigen::Matrix3d> S_ldlt(S);
    if (S_ldlt.info() != Eigen::Success || !(S_ldlt.vectorD().minCoeff() > 0)) continue;
    const double chi2 = d.dot(S_ldlt.solve(d));
    if (!(chi2 < gate_chi2)) continue;
    // Information-weighted mean, in the update form that needs only S^-1:
    // p' = p_L + C_L S^-1 d, C' = C_L - C_L S^-1 C_L.
    const Eigen::Matrix3d K = S_ldlt.solve(landmark.point.cov).transpose();
    const Eigen::Vector3d fused_p = landmark.point.p + K * d;
    Eigen::Matrix3d fused_cov = landmark.point.cov - K * landmark.point.cov;
    fused_cov = 0.5 * (fused_cov + fused_cov.transpose());
    if (!fused_p.allFinite() || !fused_cov.allFinite()) continue;
    landmark.point.p = fused_p;
    landmark.point.cov = fused_cov;
    ++fused;
  }
  return fused;
}

}  // namespace pplvo::tracking
