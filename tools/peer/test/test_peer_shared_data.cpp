// The peer odometry (rgbd method) on the shared real sequences, evaluated with pplvo_eval
// against their ground truth. Skipped when PPLVO_SHARED_DATA is not set or the data is absent.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "pplvo/core/trajectory.h"
#include "pplvo/dataset/dataset.h"
#include "pplvo/eval/report.h"
#include "pplvo/peer/peer_odometry.h"

namespace pplvo {
namespace {

namespace fs = std::filesystem;

struct Figures {
  eval::EvalReport report;
  peer::PeerStats stats;
};

/// Runs the peer on every frame of `dir` and evaluates against its groundtruth.txt.
Figures runAndEvaluate(const fs::path& dir, double fps, peer::PeerMethod method) {
  const dataset::Dataset data = dataset::Dataset::open(dir.string());
  peer::PeerOdometryOptions o;
  o.method = method;
  peer::PeerOdometry odo(o);
  Trajectory traj;
  for (size_t i = 0; i < data.size(); ++i) {
    const RgbdFrame f = data.loadFrame(i);
    StampedPose p;
    p.stamp_text = f.stamp;
    p.T_w_c = odo.process(f).T_w_c;
    traj.push_back(p);
  }
  const fs::path est =
      fs::temp_directory_path() / ("pplvo_test_peer_" + std::to_string(::getpid()) + ".txt");
  writeTumTrajectory(est.string(), traj);
  eval::TumReadOptions ro;
  ro.fps = fps;
  const eval::TumReadResult gt = eval::readTumFile((dir / "groundtruth.txt").string(), ro);
  const eval::TumReadResult es = eval::readTumFile(est.string(), ro);
  fs::remove(est);
  EXPECT_TRUE(gt.ok) << gt.error;
  EXPECT_TRUE(es.ok) << es.error;
  eval::EvalOptions eo;
  eo.fps = fps;
  Figures f;
  f.report = eval::evaluateTrajectories(gt.file, es.file, eo);
  f.stats = odo.stats();
  std::printf(
      "%s [%s]: ATE rmse %.4f m (%d pairs), RPE %.4f m/s %.3f deg/s; %lld/%lld "
      "failures, mean %.1f ms/frame\n",
      dir.filename().c_str(), peer::methodName(method), f.report.ate.error_m.rmse,
      f.report.ate.error_m.count, f.report.rpe.trans_m.rmse / f.report.delta_s,
      f.report.rpe.rot_rad.rmse / f.report.delta_s * 180.0 / M_PI,
      static_cast<long long>(f.stats.failures), static_cast<long long>(f.stats.frames),
      f.stats.meanMs());
  return f;
}

fs::path sharedData(const char* name) {
  const char* root = std::getenv("PPLVO_SHARED_DATA");
  if (root == nullptr) return {};
  const fs::path p = fs::path(root) / name;
  return fs::exists(p / "groundtruth.txt") ? p : fs::path();
}

// Bounds: about twice the figures measured on this machine (docs/peer_odometry.md).
TEST(PeerSharedData, IclLivingRoomMirroredCamera) {
  const fs::path dir = sharedData("icl_living_room_kt0_short");
  if (dir.empty()) GTEST_SKIP() << "shared ICL data not available";
  const Figures f = runAndEvaluate(dir, 30.0, peer::PeerMethod::kRgbd);
  ASSERT_TRUE(f.report.ok());
  EXPECT_EQ(f.stats.failures, 0);
  EXPECT_GE(f.report.ate.error_m.count, 240);
  EXPECT_LT(f.report.ate.error_m.rmse, 0.08);                     // measured 0.037 m
  EXPECT_LT(f.report.rpe.trans_m.rmse / f.report.delta_s, 0.09);  // measured 0.042 m/s
}

TEST(PeerSharedData, TumSittingStatic) {
  const fs::path dir = sharedData("tum_fr3_sitting_static_short");
  if (dir.empty()) GTEST_SKIP() << "shared TUM data not available";
  const Figures f = runAndEvaluate(dir, 0.0, peer::PeerMethod::kRgbd);
  ASSERT_TRUE(f.report.ok());
  EXPECT_EQ(f.stats.failures, 0);
  EXPECT_GE(f.report.ate.error_m.count, 130);
  EXPECT_LT(f.report.ate.error_m.rmse, 0.04);                     // measured 0.014 m
  EXPECT_LT(f.report.rpe.trans_m.rmse / f.report.delta_s, 0.06);  // measured 0.026 m/s
}

}  // namespace
}  // namespace pplvo
