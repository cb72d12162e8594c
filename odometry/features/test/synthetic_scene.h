#pragma once
// Small analytic test scenes (used until the shared synthetic sequence generator is merged):
// a textured plane rendered by ray casting from known poses, with its exact depth.
#include <cmath>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "pplvo/core/camera.h"
#include "pplvo/core/geometry.h"

namespace pplvo::features::test {

/// Procedural texture: rectangles and polygons of random grey levels (corners and straight
/// edges), discs, and low-amplitude smoothed noise. Deterministic for a seed.
inline cv::Mat makeTexture(int size, uint64_t seed) {
  cv::RNG rng(seed);
  cv::Mat tex(size, size, CV_8UC1, cv::Scalar(128));
  for (int k = 0; k < 160; ++k) {
    const int w = rng.uniform(size / 40, size / 8), h = rng.uniform(size / 40, size / 8);
    const int x = rng.uniform(0, size - w), y = rng.uniform(0, size - h);
    cv::rectangle(tex, cv::Rect(x, y, w, h), cv::Scalar(rng.uniform(0, 256)), cv::FILLED);
  }
  for (int k = 0; k < 40; ++k) {
    std::vector<cv::Point> poly;
    const cv::Point c(rng.uniform(0, size), rng.uniform(0, size));
    for (int v = 0; v < 4; ++v)
      poly.emplace_back(c.x + rng.uniform(-size / 12, size / 12),
                        c.y + rng.uniform(-size / 12, size / 12));
    cv::fillConvexPoly(tex, poly, cv::Scalar(rng.uniform(0, 256)));
  }
  for (int k = 0; k < 120; ++k) {
    cv::circle(tex, cv::Point(rng.uniform(0, size), rng.uniform(0, size)),
               rng.uniform(2, size / 60), cv::Scalar(rng.uniform(0, 256)), cv::FILLED);
  }
  cv::Mat noise(size, size, CV_32F);
  rng.fill(noise, cv::RNG::NORMAL, 0, 25);
  cv::GaussianBlur(noise, noise, cv::Size(0, 0), 2.0);
  cv::Mat t32;
  tex.convertTo(t32, CV_32F);
  t32 += noise;
  t32.convertTo(tex, CV_8U);
  cv::GaussianBlur(tex, tex, cv::Size(0, 0), 0.7);
  return tex;
}

/// A textured plane through O = (0, 0, z0) in the world (= first camera) frame, spanned by
/// e1 = (cos a, 0, sin a) and e2 = (0, 1, 0); texture covers [-side/2, side/2]^2 metres.
struct PlaneScene {
  cv::Mat texture;
  double side_m = 4.0;
  double z0_m = 2.0;
  double tilt_rad = 0.35;

  Eigen::Vector3d origin() const { return {0, 0, z0_m}; }
  Eigen::Vector3d e1() const { return {std::cos(tilt_rad), 0, std::sin(tilt_rad)}; }
  Eigen::Vector3d e2() const { return {0, 1, 0}; }
  Eigen::Vector3d normal() const { return e1().cross(e2()).normalized(); }

  /// Depth (z in the camera frame) seen through undistorted pixel (u, v); 0 if no hit.
  double depthAt(const PinholeCamera& cam, const Pose3& T_w_c, double u, double v) const {
    const Eigen::Vector3d d = T_w_c.linear() * cam.ray(u, v);
    const Eigen::Vector3d c = T_w_c.translation();
    const double den = normal().dot(d);
    if (std::abs(den) < 1e-9) return 0;
    const double lambda = normal().dot(origin() - c) / den;
    return lambda > 0 ? lambda : 0;
  }

  /// Renders grey image (with the camera's distortion) and the depth map on the undistorted
  /// pixel grid (depth_m(v, u) = depth seen through undistorted pixel (u, v)).
  void render(const PinholeCamera& cam, const Pose3& T_w_c, double noise_sigma, uint64_t seed,
              cv::Mat* gray, cv::Mat* depth_m) const {
    cv::Mat map_x(cam.height, cam.width, CV_32F), map_y(cam.height, cam.width, CV_32F);
    if (depth_m) *depth_m = cv::Mat::zeros(cam.height, cam.width, CV_32F);
    const double texel_per_m = texture.cols / side_m;
    for (int v = 0; v < cam.height; ++v) {
      for (int u = 0; u < cam.width; ++u) {
        for (int pass = 0; pass < 2; ++pass) {
          // pass 0: image pixel (distorted) -> texture; pass 1: undistorted grid -> depth.
          if (pass == 1 && !depth_m) break;
          const Eigen::Vector2d und =
              pass == 0 ? cam.undistortPixel(Eigen::Vector2d(u, v)) : Eigen::Vector2d(u, v);
          const double z = depthAt(cam, T_w_c, und.x(), und.y());
          if (pass == 1) {
            depth_m->at<float>(v, u) = static_cast<float>(z);
            continue;
          }
          if (z <= 0) {
            map_x.at<float>(v, u) = map_y.at<float>(v, u) = -1;
            continue;
          }
          const Eigen::Vector3d p = T_w_c * cam.backproject(und.x(), und.y(), z);
          const double s = e1().dot(p - origin()), t = e2().dot(p - origin());
          map_x.at<float>(v, u) = static_cast<float>((s + side_m / 2) * texel_per_m - 0.5);
          map_y.at<float>(v, u) = static_cast<float>((t + side_m / 2) * texel_per_m - 0.5);
        }
      }
    }
    cv::Mat img;
    cv::remap(texture, img, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_CONSTANT,
              cv::Scalar(0));
    cv::Mat noise(img.size(), CV_32F);
    cv::RNG rng(seed);
    rng.fill(noise, cv::RNG::NORMAL, 0, noise_sigma);
    cv::Mat f;
    img.convertTo(f, CV_32F);
    f += noise;
    f.convertTo(*gray, CV_8U);
  }
};

inline PinholeCamera vgaCamera(double fy_sign = 1.0) {
  PinholeCamera c;
  c.width = 640;
  c.height = 480;
  c.fx = 525;
  c.fy = 525 * fy_sign;
  c.cx = 319.5;
  c.cy = 239.5;
  return c;
}

/// The textured plane (texture seed 7) seen by vgaCamera() from the first pose of the feature
/// tests, with image noise sigma 2 (seed 11): a grey VGA image rich in corners and edges.
inline cv::Mat texturedPlaneView() {
  PlaneScene scene;
  scene.texture = makeTexture(1024, 7);
  cv::Mat gray;
  scene.render(vgaCamera(),
               makePose(Eigen::Vector3d(0.05, -0.03, 0.0), Eigen::Quaterniond::Identity()), 2.0,
               11, &gray, nullptr);
  return gray;
}

}  // namespace pplvo::features::test
