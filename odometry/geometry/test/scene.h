#pragma once
// Small analytic scenes for the geometry tests: a box-shaped room rendered by ray casting with
// the pinhole model (signed focal lengths), optional depth noise from the sensor model.
#include <Eigen/Core>
#include <cmath>
#include <opencv2/core.hpp>
#include <random>
#include <vector>

#include "pplvo/core/camera.h"
#include "pplvo/core/geometry.h"
#include "pplvo/core/primitives.h"
#include "pplvo/core/rgbd_frame.h"

namespace pplvo::geometry::test {

inline PinholeCamera vgaCamera(bool mirrored_fy = true) {
  PinholeCamera c;
  c.width = 640;
  c.height = 480;
  c.fx = 481.2;
  c.fy = mirrored_fy ? -480.0 : 480.0;  // ICL-NUIM uses fy < 0
  c.cx = 319.5;
  c.cy = 239.5;
  return c;
}

/// Plane n.X + d = 0 in the world, normal pointing into the room.
struct WorldPlane {
  Eigen::Vector3d n;
  double d;
};

/// Room [x0,x1] x [y0,y1] x [z0,z1] (metres), planes with inward normals.
inline std::vector<WorldPlane> boxRoom(double x0, double x1, double y0, double y1, double z0,
                                       double z1) {
  return {{{1, 0, 0}, -x0}, {{-1, 0, 0}, x1}, {{0, 1, 0}, -y0},
          {{0, -1, 0}, y1}, {{0, 0, 1}, -z0}, {{0, 0, -1}, z1}};
}

/// The plane in the camera frame (PlaneWithCov convention: n.p + d = 0, d > 0 for a camera
/// inside the room).
inline Eigen::Vector4d planeInCamera(const WorldPlane& pw, const Pose3& T_w_c) {
  const Eigen::Vector3d n_c = T_w_c.linear().transpose() * pw.n;
  const double d_c = pw.n.dot(T_w_c.translation()) + pw.d;
  Eigen::Vector4d h;
  h << n_c, d_c;
  return h;
}

struct Rendered {
  DepthWithVariance depth;
  cv::Mat surface_id;  // CV_32S, -1 = none
};

/// Ray-casts the room; noise_seed >= 0 adds N(0, sigma_z(z)^2) depth noise with
/// sigma_z = coeff z^2 and stores the model variance in var_m2.
inline Rendered renderRoom(const PinholeCamera& cam, const Pose3& T_w_c,
                           const std::vector<WorldPlane>& room, int noise_seed,
                           double coeff = 1.425e-3, double max_depth_m = 10.0) {
  Rendered r;
  r.depth.depth_m = cv::Mat::zeros(cam.height, cam.width, CV_32F);
  r.depth.var_m2 = cv::Mat::zeros(cam.height, cam.width, CV_32F);
  r.surface_id = cv::Mat(cam.height, cam.width, CV_32S, cv::Scalar(-1));
  std::mt19937 rng(static_cast<unsigned>(std::max(0, noise_seed)));
  std::normal_distribution<double> nd(0.0, 1.0);
  const Eigen::Matrix3d R = T_w_c.linear();
  const Eigen::Vector3d t = T_w_c.translation();
  for (int v = 0; v < cam.height; ++v) {
    for (int u = 0; u < cam.width; ++u) {
      const Eigen::Vector3d rw = R * cam.ray(u, v);
      double best = 1e300;
      int id = -1;
      for (size_t k = 0; k < room.size(); ++k) {
        const double den = room[k].n.dot(rw);
        if (den >= -1e-12) continue;
        const double s = -(room[k].n.dot(t) + room[k].d) / den;
        if (s > 0 && s < best) {
          best = s;
          id = static_cast<int>(k);
        }
      }
      if (id < 0 || best > max_depth_m) continue;
      const double sigma = coeff * best * best;
      double z = best;
      if (noise_seed >= 0) z += sigma * nd(rng);
      r.depth.depth_m.at<float>(v, u) = static_cast<float>(z);
      r.depth.var_m2.at<float>(v, u) = static_cast<float>(sigma * sigma);
      r.surface_id.at<int>(v, u) = id;
    }
  }
  return r;
}

inline double angleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)) * 180.0 / M_PI;
}

/// Camera looking from inside the room towards a corner.
inline Pose3 cornerView(double yaw_deg = 35.0, double pitch_deg = 20.0,
                        Eigen::Vector3d t = {0.5, 0.6, 0.3}) {
  // Camera axes: z forward. Start looking along world +z, then yaw about world y and pitch down.
  const Eigen::Matrix3d R = (Eigen::AngleAxisd(yaw_deg * M_PI / 180.0, Eigen::Vector3d::UnitY()) *
                             Eigen::AngleAxisd(pitch_deg * M_PI / 180.0, Eigen::Vector3d::UnitX()))
                                .toRotationMatrix();
  Pose3 T = Pose3::Identity();
  T.linear() = R;
  T.translation() = t;
  return T;
}

}  // namespace pplvo::geometry::test
