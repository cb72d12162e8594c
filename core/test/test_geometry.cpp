#include <gtest/gtest.h>

#include "pplvo/core/geometry.h"
#include "pplvo/core/rgbd_frame.h"

namespace pplvo {
namespace {

TEST(Geometry, SymmetricPackRoundTrip) {
  Eigen::Matrix4d A = Eigen::Matrix4d::Random();
  A = (A * A.transpose()).eval();
  double upper[10];
  upperFromSymmetric<4>(A, upper);
  EXPECT_TRUE(symmetricFromUpper<4>(upper).isApprox(A));
  Eigen::Matrix3d B = Eigen::Matrix3d::Random();
  B = (B + B.transpose()).eval();
  float upper3[6];
  upperFromSymmetric<3>(B, upper3);
  EXPECT_TRUE(symmetricFromUpper<3>(upper3).isApprox(B, 1e-6));
}

TEST(Geometry, RotationAngleAndValidity) {
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitY()).toRotationMatrix();
  EXPECT_NEAR(rotationAngle(R), 0.3, 1e-12);
  EXPECT_NEAR(rotationAngle(Eigen::AngleAxisd(M_PI - 1e-9, Eigen::Vector3d::UnitX()).toRotationMatrix()),
              M_PI, 1e-6);
  Pose3 T = Pose3::Identity();
  EXPECT_TRUE(isValidPose(T));
  T.translation().x() = std::nan("");
  EXPECT_FALSE(isValidPose(T));
  EXPECT_EQ(skew(Eigen::Vector3d(1, 2, 3)) * Eigen::Vector3d(4, 5, 6),
            Eigen::Vector3d(1, 2, 3).cross(Eigen::Vector3d(4, 5, 6)));
}

TEST(RgbdFrame, DepthUnitConversionMarksInvalid) {
  cv::Mat u16 = (cv::Mat_<uint16_t>(1, 4) << 0, 5000, 65535, 12000);
  cv::Mat m = depthUnitsToMetres(u16, 5000.0, 10000);
  EXPECT_FLOAT_EQ(m.at<float>(0), 0.0f);
  EXPECT_FLOAT_EQ(m.at<float>(1), 1.0f);
  EXPECT_FLOAT_EQ(m.at<float>(2), 0.0f);  // invalid marker
  EXPECT_FLOAT_EQ(m.at<float>(3), 0.0f);  // beyond the configured maximum
  cv::Mat back = depthMetresToUnits(m, 5000.0);
  EXPECT_EQ(back.at<uint16_t>(1), 5000);
}

}  // namespace
}  // namespace pplvo
