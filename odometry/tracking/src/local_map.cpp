#include "pplvo/tracking/local_map.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <utility>

namespace pplvo::tracking {

void LocalMap::addKeyframe(int64_t seq, const Pose3& T_w_kf,
                           const std::optional<MapRelativePose>& from_previous,
                           const std::optional<MapRelativePose>& tracked) {
  keyframes_.push_back(MapKeyframe{seq, T_w_kf, {}, from_previous, tracked});
}

MapKeyframe* LocalMap::keyframe(int64_t seq) {
  return const_cast<MapKeyframe*>(std::as_const(*this).keyframe(seq));
}

const MapKeyframe* LocalMap::keyframe(int64_t seq) const {
  const auto it = std::lower_bound(keyframes_.begin(), keyframes_.end(), seq,
                                   [](const MapKeyframe& k, int64_t s) { return k.seq < s; });
  return it != keyframes_.end() && it->seq == seq ? &*it : nullptr;
}

MapPoint* LocalMap::point(int64_t id) {
  const auto it = points_.find(id);
  return it == points_.end() ? nullptr : &it->second;
}

int64_t LocalMap::addPoint(const MapObservation& observation, const cv::Mat& descriptor) {
  const int64_t seq = observation.keyframe_seq;
  MapKeyframe* kf = keyframe(seq);
  if (kf == nullptr) return -1;
  const int64_t id = next_point_id_++;
  MapPoint& p = points_[id];
  const Eigen::Matrix3d R = kf->T_w_kf.linear();
  p.p_w = kf->T_w_kf * observation.p_kf;
  p.cov_w = R * observation.cov_kf * R.transpose();
  p.descriptor = descriptor.clone();
  p.observations.push_back(observation);
  kf->point_ids.push_back(id);
  return id;
}

bool LocalMap::addObservation(int64_t id, const MapObservation& observation,
                              const cv::Mat& descriptor) {
  const int64_t seq = observation.keyframe_seq;
  MapKeyframe* kf = keyframe(seq);
  MapPoint* p = point(id);
  if (kf == nullptr || p == nullptr) return false;
  for (const MapObservation& o : p->observations) {
    if (o.keyframe_seq == seq) return false;
  }
  p->observations.push_back(observation);
  std::sort(p->observations.begin(), p->observations.end(),
            [](const MapObservation& a, const MapObservation& b) {
              return a.keyframe_seq < b.keyframe_seq;
            });
  if (p->observations.back().keyframe_seq == seq) p->descriptor = descriptor.clone();
  kf->point_ids.push_back(id);
  return true;
}

void LocalMap::removeObservation(int64_t id, int64_t seq) {
  MapPoint* p = point(id);
  if (p == nullptr) return;
  auto& obs = p->observations;
  obs.erase(std::remove_if(obs.begin(), obs.end(),
                           [&](const MapObservation& o) { return o.keyframe_seq == seq; }),
            obs.end());
  if (MapKeyframe* kf = keyframe(seq)) {
    auto& ids = kf->point_ids;
    ids.erase(std::remove(ids.begin(), ids.end(), id), ids.end());
  }
  if (obs.empty()) points_.erase(id);
}

void LocalMap::eraseOldestKeyframe() {
  if (keyframes_.empty()) return;
  const MapKeyframe oldest = keyframes_.front();
  for (const int64_t id : oldest.point_ids) {
    MapPoint* p = point(id);
    if (p == nullptr) continue;
    auto& obs = p->observations;
    obs.erase(std::remove_if(obs.begin(), obs.end(),
                             [&](const MapObservation& o) { return o.keyframe_seq == oldest.seq; }),
              obs.end());
    if (obs.empty()) points_.erase(id);
  }
  keyframes_.pop_front();
}

void LocalMap::reset() {
  keyframes_.clear();
  points_.clear();
}

void LocalMap::updatePointCovariance(int64_t id) {
  MapPoint* p = point(id);
  if (p == nullptr) return;
  Eigen::Matrix3d information = Eigen::Matrix3d::Zero();
  for (const MapObservation& o : p->observations) {
    const MapKeyframe* kf = keyframe(o.keyframe_seq);
    if (kf == nullptr) continue;
    const Eigen::LDLT<Eigen::Matrix3d> ldlt(o.cov_kf);
    if (ldlt.info() != Eigen::Success) continue;
    const Eigen::Matrix3d R = kf->T_w_kf.linear();
    information += R * ldlt.solve(Eigen::Matrix3d::Identity()) * R.transpose();
  }
  const Eigen::LDLT<Eigen::Matrix3d> ldlt(information);
  if (ldlt.info() != Eigen::Success || !(ldlt.vectorD().minCoeff() > 0)) return;
  Eigen::Matrix3d cov = ldlt.solve(Eigen::Matrix3d::Identity());
  cov = 0.5 * (cov + cov.transpose());
  if (cov.allFinite()) p->cov_w = cov;
}

}  // namespace pplvo::tracking
