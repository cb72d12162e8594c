#include <gtest/gtest.h>

#include "pplvo/fixtures/box_room.h"
#include "pplvo/geometry/plane_extraction.h"
#include "pplvo/geometry/plane_matching.h"

namespace pplvo::geometry {
namespace {

// True surface id of an extracted plane: the majority surface under its label.
int trueId(const FrameFeatures& f, int i, const fixtures::Rendered& r) {
  std::vector<int> votes(6, 0);
  for (int v = 0; v < f.plane_labels.rows; ++v)
    for (int u = 0; u < f.plane_labels.cols; ++u)
      if (f.plane_labels.at<uint8_t>(v, u) == f.planes[i].label && r.surface_id.at<int>(v, u) >= 0)
        ++votes[r.surface_id.at<int>(v, u)];
  return static_cast<int>(std::max_element(votes.begin(), votes.end()) - votes.begin());
}

TEST(PlaneMatching, TwoViewsWithKnownMotion) {
  const PinholeCamera cam = fixtures::iclVgaCamera(true);
  const auto room = fixtures::boxRoom(-2, 2, -1.2, 1.5, -2, 3);
  const Pose3 T_w_prev = fixtures::cornerView(35, 20, {0.5, 0.6, 0.3});
  // Small motion: 4 cm and 3 deg.
  const Pose3 T_w_curr = fixtures::cornerView(38, 19, {0.53, 0.58, 0.33});
  const fixtures::Rendered rp = fixtures::renderRoom(cam, T_w_prev, room, 21);
  const fixtures::Rendered rc = fixtures::renderRoom(cam, T_w_curr, room, 22);
  FrameFeatures prev, curr;
  prev.camera = curr.camera = cam;
  PlaneExtractor ex(cam);
  auto a = ex.extract(rp.depth);
  prev.planes = a.planes;
  prev.plane_labels = a.labels;
  auto b = ex.extract(rc.depth);
  curr.planes = b.planes;
  curr.plane_labels = b.labels;
  ASSERT_GE(prev.planes.size(), 2u);
  ASSERT_GE(curr.planes.size(), 2u);
  // Every true surface seen in both frames should be matched, correctly.
  std::vector<int> id_p(prev.planes.size()), id_c(curr.planes.size());
  for (size_t i = 0; i < prev.planes.size(); ++i) id_p[i] = trueId(prev, static_cast<int>(i), rp);
  for (size_t i = 0; i < curr.planes.size(); ++i) id_c[i] = trueId(curr, static_cast<int>(i), rc);
  int expected = 0;
  for (int x : id_p) expected += std::count(id_c.begin(), id_c.end(), x) > 0;
  for (const bool with_pose : {false, true}) {
    const std::optional<Pose3> T_curr_prev =
        with_pose ? std::optional<Pose3>(T_w_curr.inverse() * T_w_prev) : std::nullopt;
    const PlaneMatchResult m = matchPlanesWithStats(prev, curr, {}, T_curr_prev);
    EXPECT_EQ(static_cast<int>(m.matches.size()), expected);
    for (const auto& [i, j] : m.matches) EXPECT_EQ(id_p[i], id_c[j]);
    std::vector<int> seen_p(prev.planes.size(), 0), seen_c(curr.planes.size(), 0);
    for (const auto& [i, j] : m.matches) {
      EXPECT_EQ(seen_p[i]++, 0);
      EXPECT_EQ(seen_c[j]++, 0);
    }
    if (with_pose) {
      for (double dist : m.distances_m) EXPECT_LT(dist, 0.03);
    }
  }
  EXPECT_EQ(matchPlanes(prev, curr).size(), static_cast<size_t>(expected));
}

TEST(PlaneMatching, GatesRejectLargeMotionWithoutPrediction) {
  const PinholeCamera cam = fixtures::iclVgaCamera(true);
  const auto room = fixtures::boxRoom(-2, 2, -1.2, 1.5, -2, 3);
  const Pose3 T_w_prev = fixtures::cornerView(35, 20, {0.5, 0.6, 0.3});
  const Pose3 T_w_curr = fixtures::cornerView(35, 20, {0.5, 0.6, 0.6});  // 30 cm forward-ish
  const fixtures::Rendered rp = fixtures::renderRoom(cam, T_w_prev, room, -1);
  const fixtures::Rendered rc = fixtures::renderRoom(cam, T_w_curr, room, -1);
  FrameFeatures prev, curr;
  prev.camera = curr.camera = cam;
  extractPlanes(prev, rp.depth);
  extractPlanes(curr, rc.depth);
  // The plane facing the motion changes d by > 10 cm: without prediction it cannot match.
  const PlaneMatchResult no_pred = matchPlanesWithStats(prev, curr);
  const PlaneMatchResult pred = matchPlanesWithStats(prev, curr, {}, T_w_curr.inverse() * T_w_prev);
  EXPECT_LT(no_pred.matches.size(), pred.matches.size());
  EXPECT_GE(pred.matches.size(), 2u);
}

TEST(PlaneMatching, EmptyAndInconsistentInputs) {
  FrameFeatures a, b;
  EXPECT_TRUE(matchPlanes(a, b).empty());
  a.planes.resize(1);
  a.planes[0].label = 1;
  b.planes.resize(1);
  b.planes[0].label = 1;
  a.plane_labels = cv::Mat::ones(10, 10, CV_8U);
  b.plane_labels = cv::Mat::ones(12, 10, CV_8U);
  const PlaneMatchResult r = matchPlanesWithStats(a, b);
  EXPECT_FALSE(r.stats.error.empty());
  EXPECT_TRUE(r.matches.empty());
  b.plane_labels = cv::Mat::ones(10, 10, CV_8U);
  EXPECT_EQ(matchPlanes(a, b).size(), 1u);  // identical planes, full overlap
}

}  // namespace
}  // namespace pplvo::geometry
