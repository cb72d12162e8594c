#include <gtest/gtest.h>

#include <limits>
#include <random>

#include "pplvo/msgs/convert_features.h"

namespace pplvo::msgs {
namespace {

FrameFeatures makeFeatures(bool float_descriptors) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  FrameFeatures f;
  f.utime = 123;
  f.seq = 4;
  f.depth_time_alignment = DepthTimeAlignment{-0.47, 1};
  f.stamp = "4";
  f.camera.width = 32;
  f.camera.height = 24;
  f.camera.fx = 30;
  f.camera.fy = -30;
  f.camera.cx = 15.5;
  f.camera.cy = 11.5;
  for (int i = 0; i < 7; ++i) {
    PointFeature p;
    p.px = {U(rng) * 31, U(rng) * 23};
    p.response = static_cast<float>(U(rng));
    p.octave = i % 3;
    p.has_3d = i % 2 == 0;
    if (p.has_3d) {
      p.point.p = {U(rng), U(rng), 1 + U(rng)};
      p.point.cov = Eigen::Vector3d(1e-4, 2e-4, 3e-3).asDiagonal();
      p.point.cov(0, 2) = p.point.cov(2, 0) = 1e-5;
    }
    f.points.push_back(p);
  }
  f.point_descriptors = float_descriptors ? cv::Mat(7, 128, CV_32F) : cv::Mat(7, 32, CV_8U);
  cv::randu(f.point_descriptors, 0, 255);
  for (int i = 0; i < 3; ++i) {
    LineFeature l;
    l.px1 = {1.0 + i, 2.0};
    l.px2 = {20.0, 10.0 + i};
    l.eq = Eigen::Vector3d(0.6, 0.8, -3.0 - i);
    l.has_3d = i != 1;
    l.line.p1 = {0.1, 0.2, 2.0};
    l.line.p2 = {0.4, 0.2, 2.1};
    l.line.cov1 = Eigen::Matrix3d::Identity() * 1e-4;
    l.line.cov2 = Eigen::Matrix3d::Identity() * 2e-4;
    l.n_inliers = 40 + i;
    f.lines.push_back(l);
  }
  f.line_descriptors = cv::Mat(3, 32, CV_8U);
  cv::randu(f.line_descriptors, 0, 255);
  PlaneFeature pl;
  pl.plane.hessian << 0, 0, -1, 2.5;
  pl.plane.cov = Eigen::Matrix4d::Identity() * 1e-5;
  pl.n_points = 300;
  pl.centroid = {0.1, 0.1, 2.5};
  pl.label = 1;
  f.planes.push_back(pl);
  f.plane_labels = cv::Mat(24, 32, CV_8UC1, cv::Scalar(0));
  f.plane_labels(cv::Rect(4, 4, 10, 10)).setTo(1);
  return f;
}

pplvo_msgs::features_t viaBytes(const pplvo_msgs::features_t& m) {
  std::vector<uint8_t> buf(m.getEncodedSize());
  m.encode(buf.data(), 0, static_cast<int>(buf.size()));
  pplvo_msgs::features_t out;
  EXPECT_EQ(out.decode(buf.data(), 0, static_cast<int>(buf.size())), static_cast<int>(buf.size()));
  return out;
}

class FeaturesRoundTrip : public ::testing::TestWithParam<bool> {};

TEST_P(FeaturesRoundTrip, EverythingSurvives) {
  const FrameFeatures f = makeFeatures(GetParam());
  const FrameFeatures b = fromMsg(viaBytes(toMsg(f, pplvo_msgs::features_t::STAGE_3D)));
  EXPECT_EQ(b.seq, f.seq);
  EXPECT_EQ(b.camera, f.camera);
  EXPECT_EQ(b.depth_time_alignment.scale, f.depth_time_alignment.scale);
  EXPECT_EQ(b.depth_time_alignment.motion_seq, f.depth_time_alignment.motion_seq);
  ASSERT_EQ(b.points.size(), f.points.size());
  for (size_t i = 0; i < f.points.size(); ++i) {
    EXPECT_NEAR((b.points[i].px - f.points[i].px).norm(), 0.0, 1e-4);
    EXPECT_EQ(b.points[i].has_3d, f.points[i].has_3d);
    EXPECT_EQ(b.points[i].octave, f.points[i].octave);
    if (f.points[i].has_3d) {
      EXPECT_TRUE(b.points[i].point.p.isApprox(f.points[i].point.p));
      EXPECT_TRUE(b.points[i].point.cov.isApprox(f.points[i].point.cov));
    }
  }
  EXPECT_EQ(b.point_descriptors.type(), f.point_descriptors.type());
  EXPECT_EQ(cv::norm(b.point_descriptors, f.point_descriptors, cv::NORM_INF), 0.0);
  ASSERT_EQ(b.lines.size(), 3u);
  EXPECT_EQ(b.lines[1].has_3d, false);
  EXPECT_TRUE(b.lines[2].line.cov2.isApprox(f.lines[2].line.cov2));
  EXPECT_EQ(b.lines[2].n_inliers, 42);
  EXPECT_EQ(cv::norm(b.line_descriptors, f.line_descriptors, cv::NORM_INF), 0.0);
  ASSERT_EQ(b.planes.size(), 1u);
  EXPECT_TRUE(b.planes[0].plane.hessian.isApprox(f.planes[0].plane.hessian));
  EXPECT_TRUE(b.planes[0].plane.cov.isApprox(f.planes[0].plane.cov));
  ASSERT_EQ(b.plane_labels.type(), CV_8UC1);
  EXPECT_EQ(cv::norm(b.plane_labels, f.plane_labels, cv::NORM_INF), 0.0);
}

INSTANTIATE_TEST_SUITE_P(DescriptorTypes, FeaturesRoundTrip, ::testing::Values(false, true));

TEST(FeaturesConvert, LabelsAreZlibAndPngLabelsOfOlderLogsStillDecode) {
  const FrameFeatures f = makeFeatures(false);
  pplvo_msgs::features_t m = toMsg(f, pplvo_msgs::features_t::STAGE_3D);
  EXPECT_EQ(m.plane_labels.encoding, pplvo_msgs::image_t::ENCODING_ZLIB_U8);
  m.plane_labels = encodeImage(f.plane_labels, pplvo_msgs::image_t::ENCODING_PNG);
  const FrameFeatures b = fromMsg(viaBytes(m));
  EXPECT_EQ(cv::norm(b.plane_labels, f.plane_labels, cv::NORM_INF), 0.0);
}

TEST(FeaturesConvert, PreEncodedLabelsGiveTheSameMessage) {
  const FrameFeatures f = makeFeatures(false);
  const pplvo_msgs::features_t two_d = toMsg(f, pplvo_msgs::features_t::STAGE_2D);
  const pplvo_msgs::features_t fresh = toMsg(f, pplvo_msgs::features_t::STAGE_3D);
  const pplvo_msgs::features_t reused =
      toMsg(f, pplvo_msgs::features_t::STAGE_3D, &two_d.plane_labels);
  std::vector<uint8_t> a(fresh.getEncodedSize()), b(reused.getEncodedSize());
  ASSERT_EQ(a.size(), b.size());
  fresh.encode(a.data(), 0, static_cast<int>(a.size()));
  reused.encode(b.data(), 0, static_cast<int>(b.size()));
  EXPECT_EQ(a, b);  // byte for byte
}

TEST(FeaturesConvert, InconsistentMessagesThrow) {
  auto m = toMsg(makeFeatures(false), pplvo_msgs::features_t::STAGE_2D);
  auto bad = m;
  bad.n_points = 3;  // disagrees with the array
  EXPECT_THROW(fromMsg(bad), MessageError);
  bad = m;
  bad.point_descriptors[2].resize(5);
  EXPECT_THROW(fromMsg(bad), MessageError);
  bad = m;
  bad.points[0].has_3d = true;
  bad.points[0].p_c[1] = std::nan("");
  EXPECT_THROW(fromMsg(bad), MessageError);
  bad = m;
  bad.plane_labels = encodeImage(cv::Mat(5, 5, CV_8UC1, cv::Scalar(0)), pplvo_msgs::image_t::ENCODING_PNG);
  EXPECT_THROW(fromMsg(bad), MessageError);
  bad = m;
  bad.depth_alignment_scale = std::numeric_limits<double>::infinity();
  EXPECT_THROW(fromMsg(bad), MessageError);
  bad = m;
  bad.depth_alignment_motion_seq = m.seq + 1;  // a motion after the frame
  EXPECT_THROW(fromMsg(bad), MessageError);
}

TEST(FeaturesConvert, EmptyFrameRoundTrips) {
  FrameFeatures f;
  f.camera = makeFeatures(false).camera;
  const FrameFeatures b = fromMsg(viaBytes(toMsg(f, pplvo_msgs::features_t::STAGE_2D)));
  EXPECT_TRUE(b.points.empty());
  EXPECT_TRUE(b.point_descriptors.empty());
  EXPECT_TRUE(b.plane_labels.empty());
}

}  // namespace
}  // namespace pplvo::msgs
