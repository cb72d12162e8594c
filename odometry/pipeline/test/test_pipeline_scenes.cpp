// The paper's headline case (issue 41): scenes where points fail and lines and planes carry the
// odometry. Each scene of pplvo-synth is run for 2 s (60 frames, QVGA, the scene's own path)
// through the whole pipeline: with all features every frame is tracked and the trajectory
// stays within a bound (twice the error measured here); where there is no texture, points
// alone lose frames or drift far beyond it; on a textured wall without structure, lines and
// planes do not make it worse than points alone. With the hand-held effects of a Kinect v1
// (fr1 lens, rolling shutter, blur, colour/depth offsets) as well, for the zig-zag. On the clean
// zig-zag the published covariance is consistent with the rendered truth (NEES in band).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <string>

#include "pplvo/estimator/pose_parameterisation.h"
#include "pplvo/fixtures/cameras.h"
#include "pplvo/fixtures/synthetic_sequence.h"
#include "pplvo/pipeline/odometry_pipeline.h"

namespace pplvo::pipeline {
namespace {

struct SceneRun {
  int frames = 0;
  int tracked = 0;             ///< frames after the first with status kTracking
  double max_error_mm = 0.0;   ///< largest position error against the truth (first frame aligned)
};

SceneRun runScene(const std::string& scene, const std::string& features, bool hand_held) {
  synth::SynthOptions o;
  o.scene = scene;
  o.frames = 60;
  o.seed = 3;
  o.setCamera(fixtures::kinectQvgaCamera());
  if (hand_held) {
    o.distortion = {0.2624, -0.9531, -0.0054, 0.0026, 1.1633};  // TUM fr1's lens
    o.colour_readout_s = 0.025;
    o.colour_exposure_s = 0.008;
    o.colour_exposure_samples = 4;
    o.depth_offsets_s = {-0.015, -0.013, 0.016, -0.016, -0.012};
  }
  const synth::SyntheticSequence seq(o);
  PipelineOptions options;
  FeatureFamilies families;
  EXPECT_TRUE(parseFeatureFamilies(features, &families));
  options.setFamilies(families);
  OdometryPipeline pipe{options};
  SceneRun run;
  const Pose3 T_0_w = seq.pose(0).inverse();
  for (int i = 0; i < seq.size(); ++i) {
    const PipelineFrameResult r = pipe.process(seq.render(i).frame);
    ++run.frames;
    if (i == 0) continue;
    if (r.pose.status == TrackingStatus::kTracking) ++run.tracked;
    const Eigen::Vector3d truth = (T_0_w * seq.pose(i)).translation();
    run.max_error_mm =
        std::max(run.max_error_mm, 1e3 * (r.pose.T_w_c.translation() - truth).norm());
  }
  std::printf("%-15s %-20s %s: %d of %d frames tracked, largest position error %.1f mm\n",
              scene.c_str(), features.c_str(), hand_held ? "hand-held" : "clean", run.tracked,
              run.frames - 1, run.max_error_mm);
  return run;
}

struct SceneCase {
  const char* scene;
  bool hand_held;
  double bound_mm;  ///< all features: twice the largest error measured (test output)
};

class StructuredScenes : public ::testing::TestWithParam<SceneCase> {};

TEST_P(StructuredScenes, AllFeaturesTrackEveryFrameAndPointsAloneFailOrDrift) {
  const SceneCase c = GetParam();
  const SceneRun all = runScene(c.scene, "points,lines,planes", c.hand_held);
  EXPECT_EQ(all.tracked, all.frames - 1);
  EXPECT_LT(all.max_error_mm, c.bound_mm);
  const SceneRun points = runScene(c.scene, "points", c.hand_held);
  // Without texture points lose frames (velocity model, lost) or drift by far more.
  EXPECT_TRUE(points.tracked < points.frames - 1 || points.max_error_mm > 5.0 * all.max_error_mm)
      << points.tracked << " tracked, " << points.max_error_mm << " mm";
}

INSTANTIATE_TEST_SUITE_P(
    Scenes, StructuredScenes,
    // Bounds: twice the largest error measured (2.5, 3.8, 8.6, 18.0, 33.2 mm at QVGA; the
    // cabinet is circled at 0.17 m/s, the textureless room walked and turned).
    ::testing::Values(SceneCase{"structure_near", false, 5.0},
                      SceneCase{"structure_far", false, 7.6},
                      SceneCase{"structure_near", true, 17.2}, SceneCase{"cabinet", false, 36.0},
                      SceneCase{"textureless", false, 66.4}),
    [](const ::testing::TestParamInfo<SceneCase>& i) {
      return std::string(i.param.scene) + (i.param.hand_held ? "_hand_held" : "");
    });

/// Mean NEES (6 dof) of the published relative poses of the clean near zig-zag, against the
/// rendered truth, from frame `from` on (before it the shared error's start value holds).
double meanNeesOfCleanZigZag(bool publish_measured_spread, int from) {
  synth::SynthOptions o;
  o.scene = "structure_near";
  o.frames = 90;
  o.seed = 3;
  o.setCamera(fixtures::kinectVgaCamera());
  const synth::SyntheticSequence seq(o);
  PipelineOptions options;
  options.odometry.tracker.publish_measured_spread = publish_measured_spread;
  OdometryPipeline pipe{options};
  double sum = 0.0;
  int pairs = 0;
  for (int i = 0; i < seq.size(); ++i) {
    const PipelineFrameResult r = pipe.process(seq.render(i).frame);
    if (i < from || r.pose.status != TrackingStatus::kTracking) continue;
    const Pose3 truth = seq.pose(i - 1).inverse() * seq.pose(i);  // T_prev_curr
    const Vector6d err = poseToXi(r.pose.T_prev_curr) - poseToXi(truth);
    sum += err.dot(r.pose.rel_covariance.ldlt().solve(err));
    ++pairs;
  }
  return pairs > 0 ? sum / pairs : 0.0;
}

// Exact rendered images fit better than a real camera's noise model: the covariance published
// at the residuals' measured spread is consistent (decision record 0023), the model's floor
// alone is pessimistic (90 frames at VGA: 6.46 against 2.30).
TEST(CleanZigZag, PublishedCovarianceFollowsTheResidualsBelowTheModel) {
  const double with = meanNeesOfCleanZigZag(true, 20);
  const double floor_only = meanNeesOfCleanZigZag(false, 20);
  std::printf(
      "clean near zig-zag, mean NEES of the published motions: %.2f (model's floor "
      "alone: %.2f)\n",
      with, floor_only);
  EXPECT_GT(with, 3.0);
  EXPECT_LT(with, 12.0);
  EXPECT_LT(floor_only, 0.8 * with);
}

TEST(TexturedWall, LinesAndPlanesDoNotMakeItWorseThanPointsAlone) {
  // One plane in view: the planes constrain three degrees of freedom, points the rest.
  const SceneRun all = runScene("texture_wall", "points,lines,planes", false);
  const SceneRun points = runScene("texture_wall", "points", false);
  EXPECT_EQ(all.tracked, all.frames - 1);
  EXPECT_EQ(points.tracked, points.frames - 1);
  EXPECT_LE(all.max_error_mm, 1.5 * points.max_error_mm + 1.0);
}

}  // namespace
}  // namespace pplvo::pipeline
