// The paper's rig end to end (issue 23): pplvo-run on a synthetic sequence whose depth comes
// from a 58 deg depth camera of its own beside a 90 deg colour camera, written unregistered
// (calib_params.xml depth_registered 0), tracks as well as the same sequence with depth
// registered to the colour camera over its whole view, within a margin.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <unistd.h>

#include "pplvo/dataset/dataset.h"
#include "pplvo/fixtures/synthetic_sequence.h"
#include "pplvo/run/run_pipeline.h"

namespace fs = std::filesystem;

namespace pplvo::run {
namespace {

constexpr int kFrames = 40;

synth::SynthOptions options(bool rig) {
  synth::SynthOptions o;
  o.frames = kFrames;
  o.seed = 5;
  o.fx = o.fy = 320.0 / std::tan(45.0 * M_PI / 180.0);  // 90 deg over 640 px
  if (rig) {
    DepthCamera d;
    d.camera.width = 640;
    d.camera.height = 480;
    d.camera.cx = 319.5;
    d.camera.cy = 239.5;
    d.camera.fx = d.camera.fy = 320.0 / std::tan(29.0 * M_PI / 180.0);  // 58 deg
    d.T_c_d.linear() =
        Eigen::AngleAxisd(M_PI / 180.0, Eigen::Vector3d::UnitY()).toRotationMatrix();
    d.T_c_d.translation() = Eigen::Vector3d(0.025, 0.002, 0);
    o.depth_camera = d;
  }
  return o;
}

struct Outcome {
  double ate_rmse_m = 0;
  RunResult result;
};

Outcome runOn(bool rig) {
  const fs::path dir = fs::temp_directory_path() /
                       ("pplvo_rig_test_" + std::to_string(::getpid()) + (rig ? "_rig" : "_reg"));
  fs::remove_all(dir);
  const synth::SyntheticSequence seq(options(rig));
  synth::writeTumFolder(seq, dir.string());
  Outcome out;
  RunOptions o;
  o.dataset_dir = dir.string();
  out.result = runPipeline(o);
  fs::remove_all(dir);
  EXPECT_FALSE(out.result.failed) << out.result.error;
  EXPECT_EQ(out.result.poses, kFrames);
  if (out.result.trajectory.size() != static_cast<size_t>(kFrames)) return out;
  double sse = 0;
  for (int i = 0; i < kFrames; ++i) {
    const Pose3 truth = seq.pose(0).inverse() * seq.pose(i);
    sse += (truth.translation() - out.result.trajectory[i].T_w_c.translation()).squaredNorm();
  }
  out.ate_rmse_m = std::sqrt(sse / kFrames);
  return out;
}

TEST(RunRig, UnregisteredDepthFromANarrowerCameraTracksLikeRegisteredDepth) {
  const Outcome registered = runOn(false);
  const Outcome rig = runOn(true);
  std::printf("ATE (RMSE, first pose aligned): registered %.2f mm, rig %.2f mm\n%s",
              1e3 * registered.ate_rmse_m, 1e3 * rig.ate_rmse_m, rig.result.text().c_str());
  EXPECT_EQ(rig.result.tracking, kFrames - 1);
  EXPECT_LT(rig.ate_rmse_m, 0.03);
  EXPECT_LT(rig.ate_rmse_m, registered.ate_rmse_m + 0.005);
  // The depth filter registered every frame.
  for (const NodeReport& n : rig.result.nodes) {
    if (n.name != "pplvo-depth-filter") continue;
    const StageStats* reg = n.timings.find("register");
    ASSERT_NE(reg, nullptr);
    EXPECT_EQ(reg->count, kFrames);
    EXPECT_EQ(n.counters.frames_skipped, 0);
  }
}

}  // namespace
}  // namespace pplvo::run
