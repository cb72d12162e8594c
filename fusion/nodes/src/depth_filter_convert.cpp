#include "pplvo/nodes/depth_filter_convert.h"

#include <cmath>

#include "pplvo/msgs/convert.h"

namespace pplvo::nodes {

PoseInput poseFromMsg(const pplvo_msgs::pose_t& msg) {
  if (msg.n_window < 0 || static_cast<size_t>(msg.n_window) != msg.window_seq.size() ||
      msg.window_seq.size() != msg.window_max_translation_variance.size()) {
    throw msgs::MessageError("pose_t: n_window disagrees with its arrays");
  }
  PoseInput p;
  p.utime = msg.utime;
  p.seq = msg.seq;
  p.stamp = msg.stamp;
  p.status = msg.status;
  Eigen::Quaterniond q(msg.orientation[0], msg.orientation[1], msg.orientation[2],
                       msg.orientation[3]);
  const double norm = q.norm();
  if (norm > 0 && std::isfinite(norm)) q.coeffs() /= norm;  // else NaN flows to the check
  p.T_w_c = Pose3::Identity();
  p.T_w_c.linear() = q.toRotationMatrix();
  p.T_w_c.translation() = Eigen::Vector3d(msg.position[0], msg.position[1], msg.position[2]);
  p.window_uncertainty.reserve(msg.window_seq.size());
  for (size_t i = 0; i < msg.window_seq.size(); ++i) {
    p.window_uncertainty.emplace_back(msg.window_seq[i], msg.window_max_translation_variance[i]);
  }
  return p;
}

pplvo_msgs::pose_t poseToMsg(const PoseInput& pose) {
  pplvo_msgs::pose_t m{};
  m.utime = pose.utime;
  m.seq = pose.seq;
  m.stamp = pose.stamp;
  m.status = pose.status;
  const Eigen::Quaterniond q(pose.T_w_c.linear());
  const Eigen::Vector3d t = pose.T_w_c.translation();
  for (int i = 0; i < 3; ++i) m.position[i] = t[i];
  m.orientation[0] = q.w();
  m.orientation[1] = q.x();
  m.orientation[2] = q.y();
  m.orientation[3] = q.z();
  m.rel_orientation[0] = 1.0;
  m.n_window = static_cast<int32_t>(pose.window_uncertainty.size());
  for (const auto& w : pose.window_uncertainty) {
    m.window_seq.push_back(w.first);
    m.window_max_translation_variance.push_back(w.second);
  }
  return m;
}

pplvo_msgs::depth_map_t depthToMsg(const DepthWithVariance& depth, const PinholeCamera& camera,
                                   int64_t utime, int64_t seq, const std::string& stamp,
                                   int8_t stage, bool compress) {
  return msgs::toMsg(depth, camera, utime, seq, stamp, stage, compress);
}

DepthWithVariance depthFromMsg(const pplvo_msgs::depth_map_t& msg) { return msgs::fromMsg(msg); }

}  // namespace pplvo::nodes
