#pragma once
// Synthetic 3D-to-2D / 3D-to-3D correspondences with known pose and noise drawn from the
// stated covariances (for tests and the benchmark). Header-only, deterministic given the seed.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>
#include <random>

#include "pplvo/core/camera.h"
#include "pplvo/estimator/pose_estimator.h"

namespace pplvo::testing {

using estimator::Correspondences;
using estimator::LineMatch3D2D;
using estimator::PlaneMatch3D3D;
using estimator::PointMatch3D2D;

struct SceneConfig {
  int n_points = 300;
  int n_lines = 50;
  int n_planes = 4;  ///< taken from a fixed list of non-parallel room planes (max 5)
  double min_depth_m = 1.0, max_depth_m = 4.0;
  double sigma_px = std::sqrt(1.0 / 12.0);       ///< keypoint pixel noise
  double line_sigma_px = std::sqrt(1.0 / 12.0);  ///< 2D line endpoint noise
  double depth_sigma_coeff = 1.425e-3;           ///< sigma_z = coeff * z^2 (paper eq. 1)
  double plane_sigma_normal_rad = 0.003;
  double plane_sigma_d_m = 0.002;
  double outlier_fraction = 0.0;  ///< point matches replaced by random pixels
};

inline PinholeCamera testCamera(double fy = 525.0) {
  PinholeCamera c;
  c.width = 640;
  c.height = 480;
  c.fx = 525.0;
  c.fy = fy;
  c.cx = 319.5;
  c.cy = 239.5;
  return c;
}

/// A typical frame-to-frame motion (3.7 cm, 2.3 deg).
inline Pose3 typicalMotion() {
  const Eigen::Vector3d axis = Eigen::Vector3d(0.3, 1.0, -0.2).normalized();
  return makePose(Eigen::Vector3d(0.03, -0.01, 0.02),
                  Eigen::Quaterniond(Eigen::AngleAxisd(2.3 * M_PI / 180.0, axis)));
}

class SceneGenerator {
 public:
  SceneGenerator(const PinholeCamera& cam, const SceneConfig& cfg, unsigned seed)
      : cam_(cam), cfg_(cfg), rng_(seed) {}

  std::mt19937& rng() { return rng_; }

  Eigen::Vector3d gauss3() { return {n_(rng_), n_(rng_), n_(rng_)}; }

  /// Backprojection covariance (paper eq. 11) of pixel (u, v) at depth z.
  Eigen::Matrix3d backprojectionCov(double u, double v, double z) const {
    Eigen::Matrix3d J;  // d(X, Y, Z) / d(u, v, z)
    J << z / cam_.fx, 0, (u - cam_.cx) / cam_.fx, 0, z / cam_.fy, (v - cam_.cy) / cam_.fy, 0, 0, 1;
    const double sz = cfg_.depth_sigma_coeff * z * z;
    const Eigen::Vector3d var(cfg_.sigma_px * cfg_.sigma_px, cfg_.sigma_px * cfg_.sigma_px,
                              sz * sz);
    return J * var.asDiagonal() * J.transpose();
  }

  Eigen::Vector3d sampleWithCov(const Eigen::Vector3d& mean, const Eigen::Matrix3d& cov) {
    Eigen::LLT<Eigen::Matrix3d> llt(cov);
    return mean + llt.matrixL() * gauss3();
  }

  /// A visible 3D point of the previous frame (true value) and its covariance.
  bool samplePoint(const Pose3& T_curr_prev, Eigen::Vector3d& P, Eigen::Matrix3d& cov) {
    std::uniform_real_distribution<double> U(0.0, cam_.width - 1.0), V(0.0, cam_.height - 1.0),
        Z(cfg_.min_depth_m, cfg_.max_depth_m);
    for (int tries = 0; tries < 1000; ++tries) {
      const double u = U(rng_), v = V(rng_), z = Z(rng_);
      P = cam_.backproject(u, v, z);
      const Eigen::Vector3d Pc = T_curr_prev * P;
      if (Pc.z() < 0.2 || !cam_.inImage(cam_.project(Pc), 2.0)) continue;
      cov = backprojectionCov(u, v, z);
      return true;
    }
    return false;
  }

  Correspondences generate(const Pose3& T_curr_prev) {
    Correspondences c;
    std::uniform_real_distribution<double> U01(0.0, 1.0);
    for (int i = 0; i < cfg_.n_points; ++i) {
      Eigen::Vector3d P;
      Eigen::Matrix3d cov;
      if (!samplePoint(T_curr_prev, P, cov)) continue;
      PointMatch3D2D m;
      m.P_prev.p = sampleWithCov(P, cov);
      m.P_prev.cov = cov;
      m.sigma_px = cfg_.sigma_px;
      if (U01(rng_) < cfg_.outlier_fraction) {
        m.px_curr = {U01(rng_) * (cam_.width - 1), U01(rng_) * (cam_.height - 1)};
      } else {
        m.px_curr =
            cam_.project(T_curr_prev * P) + cfg_.sigma_px * Eigen::Vector2d(n_(rng_), n_(rng_));
      }
      c.points.push_back(m);
    }
    for (int i = 0; i < cfg_.n_lines; ++i) {
      Eigen::Vector3d P1, P2;
      Eigen::Matrix3d cov1, cov2;
      bool ok = false;
      for (int tries = 0; tries < 100 && !ok; ++tries) {
        if (!samplePoint(T_curr_prev, P1, cov1) || !samplePoint(T_curr_prev, P2, cov2)) break;
        const Eigen::Vector2d q1 = cam_.project(T_curr_prev * P1),
                              q2 = cam_.project(T_curr_prev * P2);
        const double len = (q1 - q2).norm();
        ok = len > 40.0 && len < 300.0;
      }
      if (!ok) continue;
      c.lines.push_back(lineMatch(P1, cov1, P2, cov2, T_curr_prev));
    }
    const std::vector<Eigen::Vector4d> room = roomPlanes();
    for (int i = 0; i < std::min<int>(cfg_.n_planes, static_cast<int>(room.size())); ++i) {
      c.planes.push_back(planeMatch(room[i], T_curr_prev));
    }
    return c;
  }

  /// The segment P1-P2 of the previous frame (true endpoints, their covariances): its 3D
  /// endpoints sampled with those, its current image line through the projected endpoints
  /// with line_sigma_px of pixel noise.
  LineMatch3D2D lineMatch(const Eigen::Vector3d& P1, const Eigen::Matrix3d& cov1,
                          const Eigen::Vector3d& P2, const Eigen::Matrix3d& cov2,
                          const Pose3& T_curr_prev) {
    LineMatch3D2D m;
    m.L_prev.p1 = sampleWithCov(P1, cov1);
    m.L_prev.p2 = sampleWithCov(P2, cov2);
    m.L_prev.cov1 = cov1;
    m.L_prev.cov2 = cov2;
    const Eigen::Vector2d q1 =
        cam_.project(T_curr_prev * P1) + cfg_.line_sigma_px * Eigen::Vector2d(n_(rng_), n_(rng_));
    const Eigen::Vector2d q2 =
        cam_.project(T_curr_prev * P2) + cfg_.line_sigma_px * Eigen::Vector2d(n_(rng_), n_(rng_));
    Eigen::Vector3d l =
        Eigen::Vector3d(q1.x(), q1.y(), 1.0).cross(Eigen::Vector3d(q2.x(), q2.y(), 1.0));
    l /= l.head<2>().norm();
    m.l_curr = l;
    m.sigma_px = cfg_.line_sigma_px;
    return m;
  }

  /// Non-parallel planes of a room around the previous camera ([n; d], d > 0).
  static std::vector<Eigen::Vector4d> roomPlanes() {
    auto mk = [](Eigen::Vector3d n, double d) {
      n.normalize();
      return Eigen::Vector4d(n.x(), n.y(), n.z(), d);
    };
    return {mk({0, -1, 0}, 1.4),       // floor (y down)
            mk({0, 0, -1}, 3.5),       // back wall
            mk({1, 0, -0.2}, 2.0),     // left wall
            mk({-1, 0.1, -0.3}, 2.2),  // right wall
            mk({0, 1, -0.1}, 1.3)};    // ceiling
  }

  PlaneWithCov noisyPlane(const Eigen::Vector4d& h) {
    const Eigen::Vector3d n = h.head<3>();
    Eigen::Vector3d b1 = n.unitOrthogonal(), b2 = n.cross(b1);
    Eigen::Matrix<double, 3, 2> B;
    B << b1, b2;
    PlaneWithCov p;
    p.cov.setZero();
    p.cov.topLeftCorner<3, 3>() =
        cfg_.plane_sigma_normal_rad * cfg_.plane_sigma_normal_rad * B * B.transpose();
    p.cov(3, 3) = cfg_.plane_sigma_d_m * cfg_.plane_sigma_d_m;
    const Eigen::Vector3d nn =
        (n + cfg_.plane_sigma_normal_rad * (B * Eigen::Vector2d(n_(rng_), n_(rng_)))).normalized();
    p.hessian << nn, h(3) + cfg_.plane_sigma_d_m * n_(rng_);
    return p;
  }

  PlaneMatch3D3D planeMatch(const Eigen::Vector4d& h_prev, const Pose3& T_curr_prev) {
    PlaneWithCov truth;
    truth.hessian = h_prev;
    const Eigen::Vector4d h_curr = truth.transformed(T_curr_prev).hessian;
    return {noisyPlane(h_prev), noisyPlane(h_curr)};
  }

 private:
  PinholeCamera cam_;
  SceneConfig cfg_;
  std::mt19937 rng_;
  std::normal_distribution<double> n_{0.0, 1.0};
};

}  // namespace pplvo::testing
