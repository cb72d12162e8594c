#include <gtest/gtest.h>

#include <cstdio>
#include <sstream>

#include "pplvo/core/trajectory.h"

namespace pplvo {
namespace {

TEST(Trajectory, ParsesCommentsAndSkipsBadLines) {
  std::istringstream in(
      "# ground truth\n"
      "1341845688.7021 -0.7041 -2.9302 1.4567 -0.7895 0.0312 -0.0138 0.6128\n"
      "\n"
      "12 1 2 3\n"
      "2 0 0 -2.25 0 0 0 1\n");
  const auto r = parseTumTrajectory(in);
  ASSERT_EQ(r.poses.size(), 2u);
  EXPECT_EQ(r.skipped_lines, 1);
  EXPECT_NE(r.first_error.find("line 4"), std::string::npos);
  EXPECT_EQ(r.poses[0].stamp_text, "1341845688.7021");
  EXPECT_NEAR(r.poses[0].stamp, 1341845688.7021, 1e-6);
  EXPECT_NEAR(r.poses[1].T_w_c.translation().z(), -2.25, 1e-12);
}

TEST(Trajectory, WriteReadRoundTripKeepsStampsVerbatim) {
  Trajectory t;
  for (int i = 0; i < 5; ++i) {
    StampedPose p;
    p.stamp_text = i == 0 ? "1341845688.561749" : std::to_string(i);
    p.stamp = std::stod(p.stamp_text);
    p.T_w_c = makePose(Eigen::Vector3d(0.1 * i, -0.2 * i, 1.0),
                       Eigen::Quaterniond(Eigen::AngleAxisd(0.1 * i, Eigen::Vector3d(1, 2, 3).normalized())));
    t.push_back(p);
  }
  const std::string path = ::testing::TempDir() + "/traj_roundtrip.txt";
  writeTumTrajectory(path, t);
  const auto r = readTumTrajectory(path);
  ASSERT_EQ(r.poses.size(), t.size());
  EXPECT_EQ(r.skipped_lines, 0);
  for (size_t i = 0; i < t.size(); ++i) {
    EXPECT_EQ(r.poses[i].stamp_text, t[i].stamp_text);
    EXPECT_TRUE(r.poses[i].T_w_c.isApprox(t[i].T_w_c, 1e-8));
  }
  std::remove(path.c_str());
}

TEST(Trajectory, MissingFileThrowsNamingIt) {
  try {
    readTumTrajectory("/nonexistent/traj.txt");
    FAIL() << "expected an exception";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/traj.txt"), std::string::npos);
  }
}

}  // namespace
}  // namespace pplvo
