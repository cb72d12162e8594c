#include "pplvo/msgs/convert_pose.h"

#include <cmath>

namespace pplvo::msgs {
namespace {

void putPose(const Pose3& T, double* position, double* orientation_wxyz) {
  const Eigen::Quaterniond q(T.linear());
  for (int k = 0; k < 3; ++k) position[k] = T.translation()[k];
  orientation_wxyz[0] = q.w();
  orientation_wxyz[1] = q.x();
  orientation_wxyz[2] = q.y();
  orientation_wxyz[3] = q.z();
}

Pose3 getPose(const double* position, const double* q_wxyz, const char* what) {
  for (int k = 0; k < 3; ++k) {
    if (!std::isfinite(position[k])) throw MessageError(std::string("non-finite ") + what);
  }
  const Eigen::Quaterniond q(q_wxyz[0], q_wxyz[1], q_wxyz[2], q_wxyz[3]);
  const double n = q.norm();
  if (!std::isfinite(n) || std::abs(n - 1.0) > 1e-3) {
    throw MessageError(std::string("invalid quaternion in ") + what);
  }
  return makePose(Eigen::Vector3d(position[0], position[1], position[2]), q);
}

}  // namespace

pplvo_msgs::pose_t toMsg(const FramePose& p) {
  pplvo_msgs::pose_t m;
  m.utime = p.utime;
  m.seq = p.seq;
  m.stamp = p.stamp;
  m.status = static_cast<int8_t>(p.status);
  putPose(p.T_w_c, m.position, m.orientation);
  putPose(p.T_prev_curr, m.rel_position, m.rel_orientation);
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < 6; ++c) m.rel_covariance[6 * r + c] = p.rel_covariance(r, c);
  }
  m.max_translation_variance = p.max_translation_variance_m2;
  m.n_point_matches = p.n_point_matches;
  m.n_line_matches = p.n_line_matches;
  m.n_plane_matches = p.n_plane_matches;
  m.iterations = p.iterations;
  m.final_cost = p.final_cost;
  m.reference = static_cast<int8_t>(p.reference);
  m.n_window = static_cast<int32_t>(p.window.size());
  for (const auto& w : p.window) {
    m.window_seq.push_back(w.seq);
    m.window_max_translation_variance.push_back(w.max_translation_variance_m2);
  }
  return m;
}

FramePose fromMsg(const pplvo_msgs::pose_t& m) {
  FramePose p;
  p.utime = m.utime;
  p.seq = m.seq;
  p.stamp = m.stamp;
  if (m.status < 0 || m.status > 4) throw MessageError("unknown pose status " + std::to_string(m.status));
  p.status = static_cast<TrackingStatus>(m.status);
  p.T_w_c = getPose(m.position, m.orientation, "pose T_w_c");
  p.T_prev_curr = getPose(m.rel_position, m.rel_orientation, "relative pose");
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < 6; ++c) {
      const double v = m.rel_covariance[6 * r + c];
      if (!std::isfinite(v)) throw MessageError("non-finite pose covariance");
      p.rel_covariance(r, c) = v;
    }
  }
  p.max_translation_variance_m2 = m.max_translation_variance;
  p.n_point_matches = m.n_point_matches;
  p.n_line_matches = m.n_line_matches;
  p.n_plane_matches = m.n_plane_matches;
  p.iterations = m.iterations;
  p.final_cost = m.final_cost;
  if (m.reference < 0 || m.reference > 2) {
    throw MessageError("unknown pose reference role " + std::to_string(m.reference));
  }
  p.reference = static_cast<ReferenceRole>(m.reference);
  if (m.n_window < 0 || static_cast<size_t>(m.n_window) != m.window_seq.size() ||
      m.window_seq.size() != m.window_max_translation_variance.size()) {
    throw MessageError("pose window arrays disagree with n_window");
  }
  for (int i = 0; i < m.n_window; ++i) {
    if (!std::isfinite(m.window_max_translation_variance[i])) {
      throw MessageError("non-finite window uncertainty");
    }
    p.window.push_back({m.window_seq[i], m.window_max_translation_variance[i]});
  }
  return p;
}

}  // namespace pplvo::msgs
