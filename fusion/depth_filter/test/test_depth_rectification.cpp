// DepthRectifier: registered depth indexed by distorted pixels resampled to the undistorted
// pinhole model that lifting, plane extraction and O-GM use.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "pplvo/depth_filter/depth_rectification.h"
#include "pplvo/fixtures/cameras.h"

namespace pplvo::depth_filter {
namespace {

// Depth a distorted camera measures of the plane n.X = d: each raw pixel's ray is its
// undistorted pixel's pinhole ray.
cv::Mat rawDepthOfPlane(const PinholeCamera& c, const Eigen::Vector3d& n, double d) {
  cv::Mat depth(c.height, c.width, CV_32FC1);
  for (int v = 0; v < c.height; ++v) {
    for (int u = 0; u < c.width; ++u) {
      const Eigen::Vector2d p = c.undistortPixel(Eigen::Vector2d(u, v));
      const Eigen::Vector3d ray = c.ray(p.x(), p.y());
      depth.at<float>(v, u) = static_cast<float>(d / n.dot(ray));
    }
  }
  return depth;
}

// RMS distance to the plane of every pixel back-projected with the pinhole model.
double rmsPlaneDistance(const PinholeCamera& c, const cv::Mat& depth, const Eigen::Vector3d& n,
                        double d, int* n_valid) {
  double sum = 0;
  *n_valid = 0;
  for (int v = 0; v < c.height; ++v) {
    for (int u = 0; u < c.width; ++u) {
      const float z = depth.at<float>(v, u);
      if (!(z > 0)) continue;
      const double e = n.dot(c.backproject(u, v, z)) - d;
      sum += e * e;
      ++*n_valid;
    }
  }
  return std::sqrt(sum / std::max(1, *n_valid));
}

TEST(DepthRectifier, WithoutDistortionReturnsTheInputItself) {
  PinholeCamera c = fixtures::tumFr1Camera();
  c.distortion = {0, 0, 0, 0, 0};
  const cv::Mat depth(c.height, c.width, CV_32FC1, cv::Scalar(1.5f));
  DepthRectifier r;
  const cv::Mat out = r.apply(c, depth);
  EXPECT_EQ(out.data, depth.data);
  EXPECT_TRUE(r.sourceIndex().empty());
}

TEST(DepthRectifier, EachPixelReadsTheRawPixelTheLensMapsItTo) {
  const PinholeCamera c = fixtures::tumFr1Camera();
  cv::Mat index(c.height, c.width, CV_32FC1);
  for (int v = 0; v < c.height; ++v)
    for (int u = 0; u < c.width; ++u) index.at<float>(v, u) = float(v * c.width + u + 1);
  DepthRectifier r;
  const cv::Mat out = r.apply(c, index);
  int outside = 0;
  for (const Eigen::Vector2i& p : {Eigen::Vector2i(319, 255), Eigen::Vector2i(100, 80),
                                  Eigen::Vector2i(600, 400), Eigen::Vector2i(0, 0),
                                  Eigen::Vector2i(639, 479), Eigen::Vector2i(320, 5)}) {
    const Eigen::Vector2d raw = c.distortPixel(p.cast<double>());
    const long ur = std::lround(raw.x()), vr = std::lround(raw.y());
    const float got = out.at<float>(p.y(), p.x());
    if (ur < 0 || vr < 0 || ur >= c.width || vr >= c.height) {
      EXPECT_EQ(got, 0.0f) << p.transpose();
      ++outside;
    } else {
      EXPECT_EQ(got, float(vr * c.width + ur + 1)) << p.transpose();
    }
  }
  EXPECT_GE(outside, 1);  // fr1's lens maps the corners of the pinhole grid off the raw image
  // Mid-image the lens moves pixels by several pixels: the resampling is not the identity.
  const Eigen::Vector2d raw = c.distortPixel(Eigen::Vector2d(100, 80));
  EXPECT_GT((raw - Eigen::Vector2d(100, 80)).norm(), 5.0);
}

TEST(DepthRectifier, PlaneSeenThroughTheLensBackProjectsOntoThePlane) {
  const PinholeCamera c = fixtures::tumFr1Camera();
  const Eigen::Vector3d n = Eigen::Vector3d(0.3, -0.2, -1.0).normalized();
  const double d = n.dot(Eigen::Vector3d(0, 0, 2.0));  // through (0, 0, 2 m)
  const cv::Mat raw = rawDepthOfPlane(c, n, d);
  DepthRectifier r;
  const cv::Mat rectified = r.apply(c, raw);
  int valid_raw = 0, valid_rect = 0;
  const double before = rmsPlaneDistance(c, raw, n, d, &valid_raw);
  const double after = rmsPlaneDistance(c, rectified, n, d, &valid_rect);
  // Nearest-neighbour resampling leaves at most half a pixel of lateral error: ~1 mm on this
  // slanted plane at 2 m, against centimetres when raw depth is read at pinhole pixels.
  EXPECT_LT(after, 0.002) << "before " << before;
  std::printf("plane RMS distance: raw depth at pinhole pixels %.2f mm, rectified %.2f mm\n", before * 1e3, after * 1e3);
  EXPECT_GT(before, 5 * after);
  // fr1's lens maps ~6 % of the pinhole grid (its corners) off the raw image.
  EXPECT_GT(valid_rect, 0.9 * valid_raw);
  // The same map again (cached) gives the same result.
  EXPECT_EQ(cv::norm(r.apply(c, raw), rectified, cv::NORM_INF), 0.0);
}

TEST(DepthRectifier, RejectsDepthOfAnotherSize) {
  const PinholeCamera c = fixtures::tumFr1Camera();
  DepthRectifier r;
  EXPECT_THROW(r.apply(c, cv::Mat(10, 10, CV_32FC1, cv::Scalar(1.0f))), std::invalid_argument);
}

}  // namespace
}  // namespace pplvo::depth_filter
