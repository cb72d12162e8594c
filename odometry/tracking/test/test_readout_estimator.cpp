// The colour readout read from the frames (readout_estimator.h): one frame's reading against
// its reference under a known rolling shutter, and the estimate's rule (clear of zero, over
// enough readings and references).
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <random>
#include <string>

#include "landmark_world.h"
#include "pplvo/features/line_extractor.h"
#include "pplvo/tracking/readout_estimator.h"

namespace pplvo::tracking {
namespace {

using testing::poseOf;

/// Matches of two observations of a landmark world by their (exact, per landmark) descriptors.
std::vector<std::pair<int, int>> sameLandmarks(const FrameFeatures& a, const FrameFeatures& b) {
  std::map<std::string, int> in_a;
  for (int i = 0; i < a.point_descriptors.rows; ++i) {
    const cv::Mat row = a.point_descriptors.row(i);
    in_a[std::string(row.ptr<char>(), 32)] = i;
  }
  std::vector<std::pair<int, int>> matches;
  for (int j = 0; j < b.point_descriptors.rows; ++j) {
    const cv::Mat row = b.point_descriptors.row(j);
    const auto it = in_a.find(std::string(row.ptr<char>(), 32));
    if (it != in_a.end()) matches.emplace_back(it->second, j);
  }
  return matches;
}

struct TwoViews {
  FrameFeatures reference;  ///< 3D stage, as read
  FrameFeatures current;    ///< 2D stage, as read
  FeatureMatches matches;
  Pose3 T_curr_ref;
  CameraVelocity reference_velocity, current_velocity;
};

/// A reference stepping sideways and a frame a third of a second later turning and stepping
/// the other way (a hand reversing), both read by a rolling shutter of `readout_s`.
TwoViews twoViews(double readout_s, double speed_scale, uint64_t seed) {
  testing::LandmarkWorld world(seed);
  TwoViews v;
  const Pose3 T_w_ref = poseOf({0, 0, 0}, 0.0);
  const Pose3 T_w_curr = poseOf({0.05, 0.01, 0.02}, 0.04);
  v.reference_velocity = {Eigen::Vector3d(0, 0.2, 0) * speed_scale,
                          Eigen::Vector3d(0.4, 0.05, 0) * speed_scale};
  v.current_velocity = {Eigen::Vector3d(0.05, -0.8, 0) * speed_scale,
                        Eigen::Vector3d(-0.5, 0, 0.1) * speed_scale};
  v.reference = world.observe(0, T_w_ref, 1, readout_s, v.reference_velocity).second;
  v.current = world.observe(10, T_w_curr, 1, readout_s, v.current_velocity).first;
  v.matches.points = sameLandmarks(v.reference, v.current);
  v.T_curr_ref = T_w_curr.inverse() * T_w_ref;
  return v;
}

TEST(ReadoutFromFrames, AFrameAndItsReferenceReadTheReadout) {
  for (const double readout_s : {0.015, 0.030}) {
    const TwoViews v = twoViews(readout_s, 1.0, 11);
    ASSERT_GT(v.matches.points.size(), 100u);
    const std::optional<ReadoutReading> r = readReadout(
        v.reference, v.current, v.matches, v.T_curr_ref, v.reference_velocity, v.current_velocity);
    ASSERT_TRUE(r.has_value());
    std::printf("readout %.1f ms read as %.2f ms (standard error %.2f ms, %d points)\n",
                1e3 * readout_s, 1e3 * r->readout_s, 1e3 * std::sqrt(r->variance_s2), r->points);
    // Measured 15.2 / 30.1 ms with a standard error of 0.6 ms: within 3 of them.
    EXPECT_NEAR(r->readout_s, readout_s, 3 * std::sqrt(r->variance_s2) + 0.001);
    EXPECT_LT(std::sqrt(r->variance_s2), 0.003);
  }
}

/// Segments between pairs of the views' landmarks (from the `first`-th pair on, every other
/// pair): the reference's 3D ends lifted as its points and moved by `T_lines_ref` (a family
/// whose 3D is off by a rigid motion, as a line's depth at an edge can put it), the current
/// frame's line through where its rolling shutter read the two ends. Replaces the views' lines.
FeatureMatches linesBetweenLandmarks(TwoViews& v, size_t first, const Pose3& T_lines_ref) {
  v.reference.lines.clear();
  v.current.lines.clear();
  FeatureMatches lines;
  for (size_t k = 2 * first; k + 1 < v.matches.points.size(); k += 4) {
    const auto [i1, j1] = v.matches.points[k];
    const auto [i2, j2] = v.matches.points[k + 1];
    LineFeature ref;
    ref.px1 = v.reference.points[i1].px;
    ref.px2 = v.reference.points[i2].px;
    ref.has_3d = true;
    ref.line.p1 = T_lines_ref * v.reference.points[i1].point.p;
    ref.line.p2 = T_lines_ref * v.reference.points[i2].point.p;
    LineFeature cur;
    cur.px1 = v.current.points[j1].px;
    cur.px2 = v.current.points[j2].px;
    cur.eq = features::lineEquation(cur.px1, cur.px2);
    if ((cur.px1 - cur.px2).norm() < 20) continue;  // too short to say where it points
    lines.lines.emplace_back(static_cast<int>(v.reference.lines.size()),
                             static_cast<int>(v.current.lines.size()));
    v.reference.lines.push_back(ref);
    v.current.lines.push_back(cur);
  }
  return lines;
}

TEST(ReadoutFromFrames, LinesAloneReadTheReadout) {
  TwoViews v = twoViews(0.030, 1.0, 15);
  FeatureMatches lines_only = linesBetweenLandmarks(v, 0, Pose3::Identity());
  ASSERT_GT(lines_only.lines.size(), 25u);
  const std::optional<ReadoutReading> r = readReadout(
      v.reference, v.current, lines_only, v.T_curr_ref, v.reference_velocity, v.current_velocity);
  ASSERT_TRUE(r.has_value());
  std::printf("lines alone: readout 30 ms read as %.2f ms (standard error %.2f ms, %d line ends)\n",
              1e3 * r->readout_s, 1e3 * std::sqrt(r->variance_s2), r->lines);
  EXPECT_EQ(r->points, 0);
  EXPECT_NEAR(r->readout_s, 0.030, 3 * std::sqrt(r->variance_s2) + 0.001);
  EXPECT_LT(std::sqrt(r->variance_s2), 0.005);
}

TEST(ReadoutFromFrames, FamiliesWhosePosesDisagreeEachReadTheirOwnShear) {
  // The lines' 3D is off by about a centimetre and half a degree against the points' (each family
  // is consistent in itself): read with one pose for both, the readout absorbs part of that
  // disagreement (measured: 30 ms read as 22.0 +- 0.8 ms); each family with its own pose
  // reads the shear.
  TwoViews v = twoViews(0.030, 1.0, 16);
  Pose3 offset = poseOf({0.01, -0.006, 0.004}, 0.0);
  offset.linear() = Eigen::AngleAxisd(0.009, Eigen::Vector3d(0.3, 1, 0.2).normalized()).matrix();
  FeatureMatches both = linesBetweenLandmarks(v, 1, offset);
  for (size_t k = 0; k + 1 < v.matches.points.size(); k += 4) {
    both.points.push_back(v.matches.points[k]);
    both.points.push_back(v.matches.points[k + 1]);
  }
  ASSERT_GT(both.lines.size(), 25u);
  ASSERT_GT(both.points.size(), 50u);
  const std::optional<ReadoutReading> r = readReadout(v.reference, v.current, both, v.T_curr_ref,
                                                      v.reference_velocity, v.current_velocity);
  ASSERT_TRUE(r.has_value());
  std::printf(
      "points and offset lines: readout 30 ms read as %.2f ms (standard error %.2f ms, "
      "%d points, %d line ends)\n",
      1e3 * r->readout_s, 1e3 * std::sqrt(r->variance_s2), r->points, r->lines);
  EXPECT_GT(r->points, 0);
  EXPECT_GT(r->lines, 0);
  EXPECT_NEAR(r->readout_s, 0.030, 3 * std::sqrt(r->variance_s2) + 0.001);
}

TEST(ReadoutFromFrames, AFastRollsCornersAreNotGatedAway) {
  // A roll's shear grows towards the image's corners, and at the pose given (which holds no
  // readout) the corners' residuals are the largest. Gated on those alone (measured: 22 and 26
  // of 585 points cut, 28.2 +- 0.7 and 29.4 +- 0.4 ms read) the reading falls short; gated
  // again on the fit's own residuals every point stays.
  for (const double roll_rate : {1.0, 2.0}) {
    testing::LandmarkWorld world(18);
    TwoViews v;
    const Pose3 T_w_ref = poseOf({0, 0, 0}, 0.0);
    const Pose3 T_w_curr = poseOf({0.05, 0.01, 0.02}, 0.04);
    v.reference_velocity = {Eigen::Vector3d(0, 0.05, 0), Eigen::Vector3d(0.05, 0, 0)};
    v.current_velocity = {Eigen::Vector3d(0, 0, roll_rate), Eigen::Vector3d(0, 0.02, 0)};
    v.reference = world.observe(0, T_w_ref, 1, 0.030, v.reference_velocity).second;
    v.current = world.observe(10, T_w_curr, 1, 0.030, v.current_velocity).first;
    v.matches.points = sameLandmarks(v.reference, v.current);
    v.T_curr_ref = T_w_curr.inverse() * T_w_ref;
    const std::optional<ReadoutReading> r = readReadout(
        v.reference, v.current, v.matches, v.T_curr_ref, v.reference_velocity, v.current_velocity);
    ASSERT_TRUE(r.has_value());
    std::printf(
        "roll at %.0f rad/s: readout 30 ms read as %.2f ms (standard error %.2f ms, %d of "
        "%zu points)\n",
        roll_rate, 1e3 * r->readout_s, 1e3 * std::sqrt(r->variance_s2), r->points,
        v.matches.points.size());
    EXPECT_EQ(r->points, static_cast<int>(v.matches.points.size()));
    EXPECT_NEAR(r->readout_s, 0.030, 2 * std::sqrt(r->variance_s2));
  }
}

TEST(ReadoutFromFrames, AGlobalShutterReadsZeroAndACameraAtRestNothing) {
  const TwoViews global = twoViews(0.0, 1.0, 12);
  const std::optional<ReadoutReading> r =
      readReadout(global.reference, global.current, global.matches, global.T_curr_ref,
                  global.reference_velocity, global.current_velocity);
  ASSERT_TRUE(r.has_value());
  EXPECT_NEAR(r->readout_s, 0.0, 3 * std::sqrt(r->variance_s2) + 0.001);
  // At rest nothing is sheared and nothing can be read.
  const TwoViews still = twoViews(0.030, 0.0, 13);
  EXPECT_FALSE(readReadout(still.reference, still.current, still.matches, still.T_curr_ref,
                           still.reference_velocity, still.current_velocity)
                   .has_value());
}

TEST(ReadoutFromFrames, WithoutEnoughMatchesNothingIsRead) {
  TwoViews v = twoViews(0.030, 1.0, 14);
  v.matches.points.resize(11);
  EXPECT_FALSE(readReadout(v.reference, v.current, v.matches, v.T_curr_ref, v.reference_velocity,
                           v.current_velocity)
                   .has_value());
  // Indices outside the frames are skipped, not read.
  v.matches.points = {{-1, 0}, {0, 100000}};
  EXPECT_FALSE(readReadout(v.reference, v.current, v.matches, v.T_curr_ref, v.reference_velocity,
                           v.current_velocity)
                   .has_value());
}

/// Adds `frames` readings of mean `mean_s` (each with its own standard error `sigma_s` and
/// that scatter) against references that change every `per_reference` frames, each reference
/// shifting its frames' readings by a normal offset of `reference_sigma_s`.
void feed(ReadoutEstimator& estimator, int frames, int per_reference, double mean_s, double sigma_s,
          double reference_sigma_s, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n01(0.0, 1.0);
  double offset = 0;
  for (int k = 0; k < frames; ++k) {
    if (k % per_reference == 0) offset = reference_sigma_s * n01(rng);
    estimator.add(k, k / per_reference,
                  {mean_s + offset + sigma_s * n01(rng), sigma_s * sigma_s, 50});
  }
}

TEST(ReadoutEstimator, UsedOnceClearOfZeroOverEnoughReadingsAndReferences) {
  ReadoutEstimator e;
  feed(e, 29, 5, 0.025, 0.004, 0.0, 1);
  EXPECT_FALSE(e.readout_s().has_value()) << "fewer than kMinReadings";
  ReadoutEstimator one_reference;
  feed(one_reference, 200, 1000, 0.025, 0.004, 0.0, 2);
  EXPECT_FALSE(one_reference.readout_s().has_value()) << "a single reference";
  ReadoutEstimator enough;
  feed(enough, 60, 10, 0.025, 0.004, 0.0, 3);
  ASSERT_TRUE(enough.readout_s().has_value());
  EXPECT_NEAR(*enough.readout_s(), 0.025, 0.002);
}

TEST(ReadoutEstimator, AGlobalShutterIsNeverUsed) {
  // Zero-mean readings whose references scatter more than the frames say (the frames of one
  // reference share its errors): the standard error counts the references.
  for (uint64_t seed = 1; seed <= 20; ++seed) {
    ReadoutEstimator e;
    feed(e, 600, 12, 0.0, 0.002, 0.004, seed);
    EXPECT_FALSE(e.readout_s().has_value()) << "seed " << seed << ", mean " << e.mean_s();
    EXPECT_LT(std::abs(e.mean_s()), 3 * e.standardError_s() + 1e-9) << "seed " << seed;
  }
}

TEST(ReadoutEstimator, KeepsAnUsedReadoutAndClampsIt) {
  ReadoutEstimator e;
  feed(e, 60, 10, 0.2, 0.004, 0.0, 4);
  ASSERT_TRUE(e.readout_s().has_value());
  EXPECT_DOUBLE_EQ(*e.readout_s(), ReadoutEstimator::kMaxReadoutS);
  e.reset();
  EXPECT_FALSE(e.readout_s().has_value());
  EXPECT_EQ(e.readings(), 0);
  // Readings without information are ignored.
  e.add(1, 1, {0.02, 0.0, 50});
  e.add(2, 1, {std::nan(""), 1e-6, 50});
  EXPECT_EQ(e.readings(), 0);
}

}  // namespace
}  // namespace pplvo::tracking
