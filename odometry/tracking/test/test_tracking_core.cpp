// The tracking core's data on their own: the keyframe store (insertion, baseline, landmark
// fusion by information weighting behind a chi-square gate) and the buffer of 3D stages
// (what is wanted, arrival in any order, pruning).
#include <gtest/gtest.h>

#include "pplvo/tracking/keyframe_store.h"
#include "pplvo/tracking/lifted_stage_buffer.h"

namespace pplvo::tracking {
namespace {

FrameFeatures withPoints(int64_t seq, const std::vector<Eigen::Vector3d>& points, double var) {
  FrameFeatures f;
  f.seq = seq;
  for (const Eigen::Vector3d& p : points) {
    PointFeature pf;
    pf.has_3d = true;
    pf.point.p = p;
    pf.point.cov = var * Eigen::Matrix3d::Identity();
    f.points.push_back(pf);
  }
  return f;
}

TEST(KeyframeStore, InsertReplacesTheActiveKeyframeAndCounts) {
  KeyframeStore store;
  EXPECT_EQ(store.active(), nullptr);
  EXPECT_FALSE(store.activeSeq());
  Pose3 T = Pose3::Identity();
  T.translation() = Eigen::Vector3d(1, 2, 3);
  store.insert(withPoints(4, {{0, 0, 2}}, 1e-4), T);
  ASSERT_NE(store.active(), nullptr);
  EXPECT_EQ(store.activeSeq(), 4);
  EXPECT_TRUE(store.active()->T_w_kf.isApprox(T));
  EXPECT_FALSE(store.active()->baseline);
  store.setBaseline({120, 1e-6, 2e-6});
  ASSERT_TRUE(store.active()->baseline);
  EXPECT_EQ(store.active()->baseline->rows, 120);
  store.insert(withPoints(9, {}, 1e-4), Pose3::Identity());
  EXPECT_EQ(store.activeSeq(), 9);
  EXPECT_FALSE(store.active()->baseline);  // a new keyframe has no baseline yet
  EXPECT_EQ(store.insertedCount(), 2);
  store.clear();
  EXPECT_EQ(store.active(), nullptr);
  EXPECT_EQ(store.insertedCount(), 2);
  store.reset();
  EXPECT_EQ(store.insertedCount(), 0);
}

TEST(KeyframeStore, RetiredKeyframesAreKeptBoundedAndReactivated) {
  KeyframeStore store(2);
  Pose3 T = Pose3::Identity();
  // A keyframe no frame was tracked against (no baseline) is not kept.
  store.insert(withPoints(1, {{0, 0, 2}}, 1e-4), T);
  store.insert(withPoints(2, {{0, 0, 2}}, 1e-4), T);
  EXPECT_TRUE(store.retired().empty());
  for (int64_t seq = 3; seq <= 5; ++seq) {
    store.setBaseline({100, 1e-6, 1e-6});  // keyframe seq - 1 served
    T.translation().x() = 0.1 * static_cast<double>(seq);
    store.insert(withPoints(seq, {{0, 0, 2}}, 1e-4), T, seq == 5);
  }
  // 2, 3 and 4 were retired; only the newest two are kept, oldest first.
  ASSERT_EQ(store.retired().size(), 2u);
  EXPECT_EQ(store.retired()[0].seq(), 3);
  EXPECT_EQ(store.retired()[1].seq(), 4);
  EXPECT_NEAR(store.retired()[0].T_w_kf.translation().x(), 0.3, 1e-12);
  EXPECT_TRUE(store.retired()[0].baseline);
  EXPECT_TRUE(store.active()->at_stamp);

  // Reactivation swaps: the chosen one is active with its baseline and pose, the active one
  // (it has a baseline) is retired in its place; the count of keyframes taken is unchanged.
  store.setBaseline({80, 2e-6, 2e-6});
  EXPECT_FALSE(store.reactivate(7));
  ASSERT_TRUE(store.reactivate(3));
  EXPECT_EQ(store.activeSeq(), 3);
  ASSERT_TRUE(store.active()->baseline);
  EXPECT_EQ(store.active()->baseline->rows, 100);
  EXPECT_FALSE(store.active()->at_stamp);
  ASSERT_EQ(store.retired().size(), 2u);
  EXPECT_EQ(store.retired()[0].seq(), 4);
  EXPECT_EQ(store.retired()[1].seq(), 5);
  EXPECT_EQ(store.retired()[1].baseline->rows, 80);
  EXPECT_EQ(store.insertedCount(), 5);

  // clear() retires as insert() does; forgetRetired() and reset() drop them.
  store.clear();
  EXPECT_EQ(store.active(), nullptr);
  EXPECT_EQ(store.retired().back().seq(), 3);
  store.forgetRetired();
  EXPECT_TRUE(store.retired().empty());
  EXPECT_EQ(store.insertedCount(), 5);

  // With none to keep (the default), nothing is retired.
  KeyframeStore none;
  none.insert(withPoints(1, {{0, 0, 2}}, 1e-4), T);
  none.setBaseline({100, 1e-6, 1e-6});
  none.insert(withPoints(2, {{0, 0, 2}}, 1e-4), T);
  EXPECT_TRUE(none.retired().empty());
}

TEST(KeyframeStore, FusionIsInformationWeightedAndGated) {
  KeyframeStore store;
  // Landmarks at z = 2 m (variance 4e-4 m^2 per axis); the observing frame sits 0.1 m to the
  // right of the keyframe (T_kf_frame), with an exactly known pose.
  store.insert(withPoints(0, {{0, 0, 2}, {0.5, 0, 2}, {-0.5, 0, 2}}, 4e-4), Pose3::Identity());
  KeyframeObservation obs;
  obs.seq = 3;
  obs.T_kf_frame = Pose3::Identity();
  obs.T_kf_frame.translation() = Eigen::Vector3d(0.1, 0, 0);
  // Observation 0: 1 cm deeper, equal variance -> the mean halfway, variance halved.
  // Observation 1: 1 m away -> outside the gate, untouched. Observation 2: no 3D.
  FrameFeatures seen = withPoints(3, {{-0.1, 0, 2.01}, {0.4, 0, 3}, {-0.6, 0, 2}}, 4e-4);
  seen.points[2].has_3d = false;
  obs.points = {{0, 0}, {1, 1}, {2, 2}, {7, 0}, {0, 9}};  // the last two out of range
  EXPECT_EQ(store.fuse(obs, seen, 7.81), 1);
  const std::vector<PointFeature>& L = store.active()->landmarks.points;
  EXPECT_NEAR(L[0].point.p.z(), 2.005, 1e-12);
  EXPECT_NEAR(L[0].point.p.x(), 0.0, 1e-12);
  EXPECT_TRUE(L[0].point.cov.isApprox(2e-4 * Eigen::Matrix3d::Identity(), 1e-12));
  EXPECT_EQ(L[1].point.p, Eigen::Vector3d(0.5, 0, 2));
  EXPECT_EQ(L[2].point.p, Eigen::Vector3d(-0.5, 0, 2));
  // The pose's uncertainty is added to the observation's: a looser observation moves less.
  KeyframeStore loose;
  loose.insert(withPoints(0, {{0, 0, 2}}, 4e-4), Pose3::Identity());
  obs.points = {{0, 0}};
  obs.covariance = Matrix6d::Zero();
  obs.covariance.topLeftCorner<3, 3>() = 4e-4 * Eigen::Matrix3d::Identity();
  EXPECT_EQ(loose.fuse(obs, seen, 7.81), 1);
  const double z = loose.active()->landmarks.points[0].point.p.z();
  EXPECT_NEAR(z, 2.0 + 0.01 / 3.0, 1e-9);  // weights 1/4e-4 against 1/8e-4
  // Nothing to fuse into without a keyframe.
  KeyframeStore empty;
  EXPECT_EQ(empty.fuse(obs, seen, 7.81), 0);
}

TEST(LiftedStageBuffer, KeepsWhatALaterFrameCanUse) {
  LiftedStageBuffer b;
  EXPECT_FALSE(b.wants(0));  // nothing posed yet
  b.setLastPosed(5);
  EXPECT_TRUE(b.wants(5));
  EXPECT_FALSE(b.wants(4));
  EXPECT_FALSE(b.wants(-1));
  EXPECT_FALSE(b.add(withPoints(4, {}, 1)));
  // Frame 5 was tracked against a keyframe: its observation waits for its 3D stage.
  KeyframeObservation o;
  o.seq = 5;
  b.addObservation(o);
  EXPECT_EQ(b.dueObservation(), nullptr);  // fusion runs one frame behind
  b.setLastPosed(6);
  ASSERT_NE(b.dueObservation(), nullptr);
  EXPECT_EQ(b.dueObservation()->seq, 5);
  EXPECT_TRUE(b.wants(5));
  EXPECT_TRUE(b.wants(6));
  // Arrival in any order; the same frame again replaces the first.
  EXPECT_TRUE(b.add(withPoints(6, {}, 1)));
  EXPECT_TRUE(b.add(withPoints(5, {{0, 0, 1}}, 1)));
  EXPECT_TRUE(b.add(withPoints(5, {{0, 0, 2}}, 1)));
  ASSERT_NE(b.find(5), nullptr);
  EXPECT_EQ(b.find(5)->points.at(0).point.p.z(), 2);
  b.popObservation();
  b.prune();
  EXPECT_EQ(b.find(5), nullptr);  // its fusion is done: no later frame needs it
  EXPECT_NE(b.find(6), nullptr);
  b.addObservation(o);
  b.dropObservations();
  EXPECT_FALSE(b.wants(5));
  b.clearStages();
  EXPECT_EQ(b.find(6), nullptr);
  EXPECT_EQ(b.lastPosed(), 6);
  b.clear();
  EXPECT_FALSE(b.lastPosed());
}

}  // namespace
}  // namespace pplvo::tracking
