#include "pplvo/depth_filter/depth_time_alignment.h"

#include "forward_warp.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

namespace pplvo::depth_filter {

cv::Mat warpDepth(const PinholeCamera& camera, const cv::Mat& depth_m, const Pose3& T_target_source) {
  if (depth_m.type() != CV_32FC1 || depth_m.rows != camera.height || depth_m.cols != camera.width) {
    throw std::invalid_argument("warpDepth: depth must be CV_32FC1 of the camera's size");
  }
  const double fx = camera.fx, fy = camera.fy, cx = camera.cx, cy = camera.cy;
  std::vector<double> ray_x(static_cast<size_t>(camera.width));
  std::vector<double> ray_y(static_cast<size_t>(camera.height));
  for (int u = 0; u < camera.width; ++u) ray_x[static_cast<size_t>(u)] = (u - cx) / fx;
  for (int v = 0; v < camera.height; ++v) ray_y[static_cast<size_t>(v)] = (v - cy) / fy;
  cv::Mat out;
  detail::forwardWarpPinholeNearest(depth_m, ray_x, ray_y, camera, T_target_source, &out);
  return out;
}

void DepthTimeAligner::observePose(int64_t seq, int64_t colour_utime, const Pose3& T_w_c,
                                   bool tracked) {
  if (!isValidPose(T_w_c)) tracked = false;
  for (KnownPose& p : poses_) {
    if (p.seq == seq) {  // a repeated pose replaces the old one
      p = {seq, colour_utime, T_w_c, tracked};
      return;
    }
  }
  poses_.push_back({seq, colour_utime, T_w_c, tracked});
  std::sort(poses_.begin(), poses_.end(),
            [](const KnownPose& a, const KnownPose& b) { return a.seq < b.seq; });
  constexpr size_t kKept = 8;
  if (poses_.size() > kKept) poses_.erase(poses_.begin(), poses_.end() - kKept);
}

bool DepthTimeAligner::hasPose(int64_t seq) const {
  return std::any_of(poses_.begin(), poses_.end(),
                     [seq](const KnownPose& p) { return p.seq == seq; });
}

std::optional<AlignmentMotion> DepthTimeAligner::colourFromDepth(int64_t seq, int64_t colour_utime,
                                                                 int64_t depth_utime) const {
  // The newest pair of consecutive tracked poses at least kPoseLag frames before this one.
  for (size_t i = poses_.size(); i-- > 1;) {
    const KnownPose& b = poses_[i];
    const KnownPose& a = poses_[i - 1];
    if (b.seq > seq - kPoseLag) continue;
    if (b.seq != a.seq + 1 || !a.tracked || !b.tracked) return std::nullopt;
    const double dt = (b.utime - a.utime) * 1e-6;
    if (!(dt > 0) || dt > 0.5) return std::nullopt;
    const Pose3 T_a_b = a.T_w_c.inverse() * b.T_w_c;
    const Eigen::AngleAxisd aa(T_a_b.linear());
    // T_w(t + s) = T_w(t) * exp(s * velocity), to first order: the depth camera seen from the
    // colour camera.
    const double s = (depth_utime - colour_utime) * 1e-6 / dt;
    AlignmentMotion m;
    m.T_colour_depth.linear() = Eigen::AngleAxisd(aa.angle() * s, aa.axis()).toRotationMatrix();
    m.T_colour_depth.translation() = T_a_b.translation() * s;
    m.alignment = DepthTimeAlignment{s, b.seq};
    return m;
  }
  return std::nullopt;
}

std::optional<AlignmentMotion> DepthTimeAligner::motion(int64_t seq, int64_t colour_utime,
                                                        int64_t depth_utime) {
  if (!needed(colour_utime, depth_utime)) return std::nullopt;
  const double offset_s = (depth_utime - colour_utime) * 1e-6;
  stats_.last_offset_ms = offset_s * 1e3;
  if (std::abs(offset_s) > max_offset_s_) return std::nullopt;
  std::optional<AlignmentMotion> m = colourFromDepth(seq, colour_utime, depth_utime);
  if (!m) {
    ++stats_.frames_without_velocity;
    return std::nullopt;
  }
  ++stats_.frames_aligned;
  return m;
}

cv::Mat DepthTimeAligner::apply(const PinholeCamera& camera, const cv::Mat& depth_m, int64_t seq,
                                int64_t colour_utime, int64_t depth_utime,
                                DepthTimeAlignment* alignment) {
  const std::optional<AlignmentMotion> m = motion(seq, colour_utime, depth_utime);
  if (alignment) *alignment = m ? m->alignment : DepthTimeAlignment{};
  return m ? warpDepth(camera, depth_m, m->T_colour_depth) : depth_m;
}

}  // namespace pplvo::depth_filter
