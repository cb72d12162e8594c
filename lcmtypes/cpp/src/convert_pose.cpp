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

void putMatrix(const Matrix6d& M, double* out) {
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < 6; ++c) out[6 * r + c] = M(r, c);
  }
}

Matrix6d getMatrix(const double* in, const char* what) {
  Matrix6d M;
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < 6; ++c) {
      if (!std::isfinite(in[6 * r + c])) throw MessageError(std::string("non-finite ") + what);
      M(r, c) = in[6 * r + c];
    }
  }
  return M;
}

Eigen::Vector3d getVector(const double* in, const char* what) {
  for (int k = 0; k < 3; ++k) {
    if (!std::isfinite(in[k])) throw MessageError(std::string("non-finite ") + what);
  }
  return {in[0], in[1], in[2]};
}

inline constexpr const char* kOdomFrame = "odom";
inline constexpr const char* kBaseFrame = "base_link";

}  // namespace

pplvo_msgs::pose_t toMsg(const FramePose& p) {
  pplvo_msgs::pose_t m;
  m.utime = p.utime;
  m.seq = p.seq;
  m.stamp = p.stamp;
  m.status = static_cast<int8_t>(p.status);
  putPose(p.T_w_c, m.position, m.orientation);
  putPose(p.T_prev_curr, m.rel_position, m.rel_orientation);
  putMatrix(p.rel_covariance, m.rel_covariance);
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
  p.rel_covariance = getMatrix(m.rel_covariance, "pose covariance");
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


pplvo_msgs::odometry_t toMsg(const BodyOdometry& o) {
  pplvo_msgs::odometry_t m;
  m.utime = o.utime;
  m.seq = o.seq;
  m.stamp = o.stamp;
  m.status = static_cast<int8_t>(o.status);
  m.frame_id = kOdomFrame;
  m.child_frame_id = kBaseFrame;
  putPose(o.T_odom_base, m.position, m.orientation);
  putMatrix(o.pose_covariance, m.pose_covariance);
  for (int k = 0; k < 3; ++k) {
    m.linear_velocity[k] = o.linear_velocity[k];
    m.angular_velocity[k] = o.angular_velocity[k];
  }
  putMatrix(o.twist_covariance, m.twist_covariance);
  m.dt = o.dt_s;
  return m;
}

BodyOdometry fromMsg(const pplvo_msgs::odometry_t& m) {
  BodyOdometry o;
  o.utime = m.utime;
  o.seq = m.seq;
  o.stamp = m.stamp;
  if (m.status < 0 || m.status > 4) {
    throw MessageError("unknown odometry status " + std::to_string(m.status));
  }
  o.status = static_cast<TrackingStatus>(m.status);
  o.T_odom_base = getPose(m.position, m.orientation, "odometry pose");
  o.pose_covariance = getMatrix(m.pose_covariance, "odometry pose covariance");
  o.linear_velocity = getVector(m.linear_velocity, "linear velocity");
  o.angular_velocity = getVector(m.angular_velocity, "angular velocity");
  o.twist_covariance = getMatrix(m.twist_covariance, "twist covariance");
  if (!std::isfinite(m.dt) || m.dt < 0) throw MessageError("bad odometry dt");
  o.dt_s = m.dt;
  return o;
}

}  // namespace pplvo::msgs
