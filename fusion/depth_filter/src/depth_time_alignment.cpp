#include "pplvo/depth_filter/depth_time_alignment.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace pplvo::depth_filter {

cv::Mat warpDepth(const PinholeCamera& camera, const cv::Mat& depth_m, const Pose3& T_target_source) {
  if (depth_m.type() != CV_32FC1 || depth_m.rows != camera.height || depth_m.cols != camera.width) {
    throw std::invalid_argument("warpDepth: depth must be CV_32FC1 of the camera's size");
  }
  const int w = camera.width, h = camera.height;
  cv::Mat out(h, w, CV_32FC1, cv::Scalar(std::numeric_limits<float>::infinity()));
  const Eigen::Matrix3d R = T_target_source.linear();
  const Eigen::Vector3d t = T_target_source.translation();
  for (int v = 0; v < h; ++v) {
    const float* src = depth_m.ptr<float>(v);
    for (int u = 0; u < w; ++u) {
      const double z = src[u];
      if (!(z > 0) || !std::isfinite(z)) continue;
      const Eigen::Vector3d p = R * camera.backproject(u, v, z) + t;
      if (!(p.z() > 0)) continue;
      const Eigen::Vector2d px = camera.project(p);
      const long ut = std::lround(px.x()), vt = std::lround(px.y());
      if (ut < 0 || vt < 0 || ut >= w || vt >= h) continue;
      float& d = out.at<float>(static_cast<int>(vt), static_cast<int>(ut));
      d = std::min(d, static_cast<float>(p.z()));  // the nearest surface wins
    }
  }
  // Close one-pixel cracks of a stretched surface: both neighbours on a line present and
  // within 1 % of each other (a depth step is left open).
  cv::Mat closed = out.clone();
  const auto near = [](float a, float b) {
    return std::isfinite(a) && std::isfinite(b) && std::abs(a - b) <= 0.01f * std::min(a, b);
  };
  for (int v = 1; v + 1 < h; ++v) {
    for (int u = 1; u + 1 < w; ++u) {
      if (std::isfinite(out.at<float>(v, u))) continue;
      const float l = out.at<float>(v, u - 1), r = out.at<float>(v, u + 1);
      const float a = out.at<float>(v - 1, u), b = out.at<float>(v + 1, u);
      if (near(l, r)) {
        closed.at<float>(v, u) = 0.5f * (l + r);
      } else if (near(a, b)) {
        closed.at<float>(v, u) = 0.5f * (a + b);
      }
    }
  }
  closed.setTo(0.0f, closed == std::numeric_limits<float>::infinity());
  return closed;
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

std::optional<Pose3> DepthTimeAligner::colourFromDepth(int64_t seq, int64_t colour_utime,
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
    Pose3 T = Pose3::Identity();
    T.linear() = Eigen::AngleAxisd(aa.angle() * s, aa.axis()).toRotationMatrix();
    T.translation() = T_a_b.translation() * s;
    return T;
  }
  return std::nullopt;
}

cv::Mat DepthTimeAligner::apply(const PinholeCamera& camera, const cv::Mat& depth_m, int64_t seq,
                                int64_t colour_utime, int64_t depth_utime) {
  if (!needed(colour_utime, depth_utime)) return depth_m;
  const double offset_s = (depth_utime - colour_utime) * 1e-6;
  stats_.last_offset_ms = offset_s * 1e3;
  if (std::abs(offset_s) > max_offset_s_) return depth_m;
  const std::optional<Pose3> T = colourFromDepth(seq, colour_utime, depth_utime);
  if (!T) {
    ++stats_.frames_without_velocity;
    return depth_m;
  }
  ++stats_.frames_aligned;
  return warpDepth(camera, depth_m, *T);
}

}  // namespace pplvo::depth_filter
