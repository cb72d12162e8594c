#include <gtest/gtest.h>

#include "pplvo/core/camera.h"

namespace pplvo {
namespace {

PinholeCamera tumFr1() {
  PinholeCamera c;
  c.width = 640;
  c.height = 480;
  c.fx = 517.3;
  c.fy = 516.5;
  c.cx = 318.6;
  c.cy = 255.3;
  c.distortion = {0.2624, -0.9531, -0.0054, 0.0026, 1.1633};
  return c;
}

TEST(PinholeCamera, BackprojectThenProjectIsIdentity) {
  PinholeCamera c = tumFr1();
  for (double u : {0.0, 100.5, 639.0}) {
    for (double v : {0.0, 240.25, 479.0}) {
      const Eigen::Vector3d p = c.backproject(u, v, 2.5);
      EXPECT_DOUBLE_EQ(p.z(), 2.5);
      const Eigen::Vector2d px = c.project(p);
      EXPECT_NEAR(px.x(), u, 1e-9);
      EXPECT_NEAR(px.y(), v, 1e-9);
    }
  }
}

TEST(PinholeCamera, MirroredModelKeepsSignConsistent) {
  PinholeCamera c;
  c.width = 640;
  c.height = 480;
  c.fx = 481.2;
  c.fy = -480.0;
  c.cx = 319.5;
  c.cy = 239.5;
  ASSERT_TRUE(c.valid());
  const Eigen::Vector3d p = c.backproject(100, 50, 1.0);
  EXPECT_GT(p.y(), 0.0);  // above the principal point in the image means +y with fy < 0
  EXPECT_NEAR(c.project(p).y(), 50.0, 1e-9);
}

TEST(PinholeCamera, UndistortInvertsDistort) {
  PinholeCamera c = tumFr1();
  for (double u = 20; u < 640; u += 77) {
    for (double v = 15; v < 480; v += 61) {
      const Eigen::Vector2d und(u, v);
      const Eigen::Vector2d dist = c.distortPixel(und);
      const Eigen::Vector2d back = c.undistortPixel(dist);
      EXPECT_NEAR(back.x(), u, 1e-3) << u << "," << v;
      EXPECT_NEAR(back.y(), v, 1e-3) << u << "," << v;
    }
  }
}

TEST(PinholeCamera, NoDistortionIsIdentity) {
  PinholeCamera c = tumFr1();
  c.distortion = {0, 0, 0, 0, 0};
  EXPECT_FALSE(c.hasDistortion());
  const Eigen::Vector2d p(12.25, 400.5);
  EXPECT_EQ(c.undistortPixel(p), p);
}

TEST(PinholeCamera, ScaledHalvesFocalAndKeepsPixelCentres) {
  PinholeCamera c = tumFr1();
  const PinholeCamera h = c.scaled(0.5);
  EXPECT_EQ(h.width, 320);
  EXPECT_EQ(h.height, 240);
  // A 3D point projects to half the (centre-aligned) full-resolution pixel.
  const Eigen::Vector3d p(0.3, -0.2, 2.0);
  const Eigen::Vector2d full = c.project(p), half = h.project(p);
  EXPECT_NEAR(half.x(), (full.x() + 0.5) * 0.5 - 0.5, 1e-9);
  EXPECT_NEAR(half.y(), (full.y() + 0.5) * 0.5 - 0.5, 1e-9);
}

TEST(PinholeCamera, InvalidWhenFocalZeroOrNaN) {
  PinholeCamera c = tumFr1();
  c.fx = 0;
  EXPECT_FALSE(c.valid());
  c = tumFr1();
  c.cy = std::nan("");
  EXPECT_FALSE(c.valid());
}

}  // namespace
}  // namespace pplvo
