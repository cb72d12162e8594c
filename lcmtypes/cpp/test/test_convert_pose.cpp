#include <gtest/gtest.h>

#include "pplvo/msgs/convert_pose.h"

namespace pplvo::msgs {
namespace {

FramePose makePose() {
  FramePose p;
  p.utime = 99;
  p.seq = 12;
  p.stamp = "1341845688.593654";
  p.status = TrackingStatus::kVelocityModel;
  p.T_w_c = pplvo::makePose({1, 2, 3}, Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ())));
  p.T_prev_curr = pplvo::makePose({0.01, 0, 0.02}, Eigen::Quaterniond(Eigen::AngleAxisd(0.01, Eigen::Vector3d::UnitX())));
  p.rel_covariance = Matrix6d::Identity() * 1e-6;
  p.rel_covariance(0, 5) = p.rel_covariance(5, 0) = 1e-8;
  p.n_point_matches = 200;
  p.reference = ReferenceRole::kFallbackOnly;
  p.window = {{10, 1e-5}, {11, 2e-6}};
  return p;
}

TEST(PoseConvert, RoundTrip) {
  const FramePose p = makePose();
  const auto m = toMsg(p);
  std::vector<uint8_t> buf(m.getEncodedSize());
  m.encode(buf.data(), 0, static_cast<int>(buf.size()));
  pplvo_msgs::pose_t d;
  d.decode(buf.data(), 0, static_cast<int>(buf.size()));
  const FramePose b = fromMsg(d);
  EXPECT_EQ(b.status, TrackingStatus::kVelocityModel);
  EXPECT_EQ(b.stamp, p.stamp);
  EXPECT_TRUE(b.T_w_c.isApprox(p.T_w_c, 1e-12));
  EXPECT_TRUE(b.T_prev_curr.isApprox(p.T_prev_curr, 1e-12));
  EXPECT_TRUE(b.rel_covariance.isApprox(p.rel_covariance));
  ASSERT_EQ(b.window.size(), 2u);
  EXPECT_EQ(b.window[1].seq, 11);
  EXPECT_EQ(b.reference, ReferenceRole::kFallbackOnly);
}

TEST(OdometryConvert, RoundTripAndBadValuesRejected) {
  BodyOdometry o;
  o.utime = 5;
  o.seq = 7;
  o.stamp = "0.233";
  o.status = TrackingStatus::kTracking;
  o.T_odom_base = pplvo::makePose({1, -2, 0.5}, Eigen::Quaterniond(Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitZ())));
  o.pose_covariance = Matrix6d::Identity() * 1e-4;
  o.pose_covariance(0, 5) = o.pose_covariance(5, 0) = 2e-6;
  o.linear_velocity = {0.5, 0.01, 0};
  o.angular_velocity = {0, 0, 0.3};
  o.twist_covariance = Matrix6d::Identity() * 3e-3;
  o.dt_s = 1.0 / 30;
  const pplvo_msgs::odometry_t m = toMsg(o);
  EXPECT_EQ(m.frame_id, "odom");
  EXPECT_EQ(m.child_frame_id, "base_link");
  std::vector<uint8_t> buf(m.getEncodedSize());
  m.encode(buf.data(), 0, static_cast<int>(buf.size()));
  pplvo_msgs::odometry_t d;
  d.decode(buf.data(), 0, static_cast<int>(buf.size()));
  const BodyOdometry b = fromMsg(d);
  EXPECT_EQ(b.seq, 7);
  EXPECT_EQ(b.stamp, "0.233");
  EXPECT_TRUE(b.T_odom_base.isApprox(o.T_odom_base, 1e-12));
  EXPECT_EQ(b.pose_covariance, o.pose_covariance);
  EXPECT_EQ(b.twist_covariance, o.twist_covariance);
  EXPECT_EQ(b.linear_velocity, o.linear_velocity);
  EXPECT_EQ(b.angular_velocity, o.angular_velocity);
  EXPECT_EQ(b.dt_s, o.dt_s);
  pplvo_msgs::odometry_t bad = m;
  bad.twist_covariance[3] = std::nan("");
  EXPECT_THROW(fromMsg(bad), MessageError);
  bad = m;
  bad.orientation[0] = 3;
  EXPECT_THROW(fromMsg(bad), MessageError);
  bad = m;
  bad.dt = -1;
  EXPECT_THROW(fromMsg(bad), MessageError);
}

TEST(PoseConvert, NaNAndBadQuaternionsAreRejected) {
  auto m = toMsg(makePose());
  m.position[1] = std::nan("");
  EXPECT_THROW(fromMsg(m), MessageError);
  m = toMsg(makePose());
  m.orientation[0] = 2.0;
  EXPECT_THROW(fromMsg(m), MessageError);
  m = toMsg(makePose());
  m.rel_covariance[7] = std::numeric_limits<double>::infinity();
  EXPECT_THROW(fromMsg(m), MessageError);
  m = toMsg(makePose());
  m.n_window = 5;
  EXPECT_THROW(fromMsg(m), MessageError);
  m = toMsg(makePose());
  m.status = 17;
  EXPECT_THROW(fromMsg(m), MessageError);
  m = toMsg(makePose());
  m.reference = 3;
  EXPECT_THROW(fromMsg(m), MessageError);
}

}  // namespace
}  // namespace pplvo::msgs
