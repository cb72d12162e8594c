#include "analytic_scene.h"

#include <cmath>
#include <limits>
#include <random>

namespace pplvo::depth_filter::test {

AnalyticScene::AnalyticScene(const SceneOptions& options) : options_(options) {}

PinholeCamera AnalyticScene::camera() const {
  PinholeCamera c;
  c.width = options_.width;
  c.height = options_.height;
  c.fx = options_.fx;
  c.fy = options_.fy;
  c.cx = options_.cx;
  c.cy = options_.cy;
  return c;
}

Pose3 AnalyticScene::pose(int i) const {
  const double a = 0.004 * i;  // rad about y
  const double b = 0.003 * std::sin(0.4 * i);
  const Eigen::Quaterniond q = Eigen::AngleAxisd(a, Eigen::Vector3d::UnitY()) *
                               Eigen::AngleAxisd(b, Eigen::Vector3d::UnitX()) *
                               Eigen::Quaterniond::Identity();
  const Eigen::Vector3d t(0.012 * i, 0.006 * std::sin(0.5 * i), 0.008 * i);
  return makePose(t, q);
}

namespace {

/// Ray-box intersection (slabs); returns the entry parameter or +inf.
double hitBox(const Eigen::Vector3d& o, const Eigen::Vector3d& d, const Eigen::Vector3d& lo,
              const Eigen::Vector3d& hi) {
  double t0 = 0.0, t1 = std::numeric_limits<double>::infinity();
  for (int k = 0; k < 3; ++k) {
    if (std::abs(d[k]) < 1e-12) {
      if (o[k] < lo[k] || o[k] > hi[k]) return std::numeric_limits<double>::infinity();
      continue;
    }
    double a = (lo[k] - o[k]) / d[k], b = (hi[k] - o[k]) / d[k];
    if (a > b) std::swap(a, b);
    t0 = std::max(t0, a);
    t1 = std::min(t1, b);
  }
  return (t0 <= t1 && t0 > 0.0) ? t0 : std::numeric_limits<double>::infinity();
}

}  // namespace

SceneFrame AnalyticScene::render(int i) const {
  SceneFrame f;
  f.T_w_c = pose(i);
  const int w = options_.width, h = options_.height;
  f.depth_m = cv::Mat::zeros(h, w, CV_32FC1);
  f.depth_true_m = cv::Mat::zeros(h, w, CV_32FC1);
  f.label = cv::Mat::zeros(h, w, CV_8UC1);
  const Eigen::Matrix3d R = f.T_w_c.linear();
  const Eigen::Vector3d o = f.T_w_c.translation();
  const Eigen::Vector3d box_lo(-0.6, -0.35, 2.0), box_hi(0.05, 0.3, 2.5);
  const double mz = 2.3 - options_.moving_speed_m_per_frame * i;
  const Eigen::Vector3d mov_lo(0.35, -0.25, mz), mov_hi(0.75, 0.15, mz + 0.3);
  std::mt19937_64 rng(options_.seed * 100003ULL + static_cast<uint64_t>(i));
  std::normal_distribution<double> normal(0.0, 1.0);
  const double fb = options_.fx * 0.075;
  const PinholeCamera cam = camera();
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      const Eigen::Vector3d d = R * cam.ray(u, v);  // unit depth: the parameter is the depth
      double t = d.z() > 1e-9 ? (3.0 - o.z()) / d.z() : std::numeric_limits<double>::infinity();
      uint8_t label = std::isfinite(t) ? kWall : kNone;
      const double tb = hitBox(o, d, box_lo, box_hi);
      if (tb < t) {
        t = tb;
        label = kBox;
      }
      if (options_.moving_object) {
        const double tm = hitBox(o, d, mov_lo, mov_hi);
        if (tm < t) {
          t = tm;
          label = kMoving;
        }
      }
      if (!std::isfinite(t)) continue;
      f.depth_true_m.at<float>(v, u) = static_cast<float>(t);
      f.label.at<uint8_t>(v, u) = label;
      double z = t;
      if (options_.noise) z += options_.sigma_z_coeff_per_m * t * t * normal(rng);
      if (options_.quantise_disparity) {
        const double disp = std::round(fb / z * 8.0) / 8.0;
        z = disp > 0 ? fb / disp : 0.0;
      }
      f.depth_m.at<float>(v, u) = static_cast<float>(z);
    }
  }
  if (options_.edge_dropout) {
    const cv::Mat& t = f.depth_true_m;
    for (int v = 0; v < h; ++v) {
      for (int u = 0; u < w; ++u) {
        const float z0 = t.at<float>(v, u);
        bool jump = false;
        for (int dv = -1; dv <= 1 && !jump; ++dv)
          for (int du = -1; du <= 1 && !jump; ++du) {
            const int vv = v + dv, uu = u + du;
            if (vv < 0 || uu < 0 || vv >= h || uu >= w) continue;
            jump = std::abs(t.at<float>(vv, uu) - z0) > 0.1f;
          }
        if (jump) f.depth_m.at<float>(v, u) = 0.f;
      }
    }
  }
  return f;
}

}  // namespace pplvo::depth_filter::test
