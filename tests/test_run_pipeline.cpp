// pplvo-run: the processes on one memq:// LCM give exactly the trajectory of the LCM-free
// OdometryPipeline, with the dataset's stamps verbatim; bad input is a clear error or a
// counted skip.
#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>

#include "pplvo/dataset/dataset.h"
#include "pplvo/eval/nees.h"
#include "pplvo/eval/pose_records.h"
#include "pplvo/eval/relative_pose_file.h"
#include "pplvo/fixtures/synthetic_sequence.h"
#include "pplvo/msgs/frame_ledger.h"
#include "pplvo/node/process.h"
#include "pplvo/pipeline/odometry_pipeline.h"
#include "pplvo/run/run_args.h"
#include "pplvo/run/run_pipeline.h"

namespace fs = std::filesystem;

namespace pplvo::run {
namespace {

constexpr int kFrames = 24;

/// A synthetic TUM folder, written once per test program.
const std::string& sequenceDir() {
  static const std::string dir = [] {
    const fs::path d = fs::temp_directory_path() / ("pplvo_run_test_" + std::to_string(::getpid()));
    fs::remove_all(d);
    synth::SynthOptions o;
    o.frames = kFrames;
    o.seed = 11;
    synth::writeTumFolder(synth::SyntheticSequence(o), d.string());
    return d.string();
  }();
  return dir;
}

class RunPipelineTest : public ::testing::Test {
 protected:
  static void TearDownTestSuite() { fs::remove_all(sequenceDir()); }
};

TEST_F(RunPipelineTest, EqualsTheLcmFreePipelineWithVerbatimStamps) {
  RunOptions o;
  o.dataset_dir = sequenceDir();
  const RunResult r = runPipeline(o);
  ASSERT_FALSE(r.failed) << r.error;
  EXPECT_EQ(r.frames_published, kFrames);
  ASSERT_EQ(r.poses, kFrames);
  EXPECT_EQ(r.tracking, kFrames - 1);
  for (const NodeReport& n : r.nodes) {
    EXPECT_EQ(n.counters.frames_dropped, 0) << n.name;
    EXPECT_EQ(n.counters.frames_skipped, 0) << n.name;
    EXPECT_EQ(n.counters.errors, 0) << n.name;
    // Every node's every frame came out: the ledger holds nothing at the end.
    EXPECT_EQ(n.counters.frames_in, kFrames) << n.name;
    EXPECT_EQ(n.counters.frames_out, kFrames) << n.name;
    EXPECT_EQ(n.counters.frames_pending, 0) << n.name;
    EXPECT_EQ(n.counters.frames_lost + n.counters.messages_skipped, 0) << n.name;
  }

  const dataset::Dataset ds = dataset::Dataset::open(sequenceDir());
  pipeline::OdometryPipeline direct;
  ASSERT_EQ(ds.size(), static_cast<size_t>(kFrames));
  for (size_t i = 0; i < ds.size(); ++i) {
    const RgbdFrame f = ds.loadFrame(i);
    const pipeline::PipelineFrameResult d = direct.process(f);
    EXPECT_EQ(r.trajectory[i].stamp_text, f.stamp);
    // Messages carry doubles for poses and floats for feature geometry: equal up to that.
    EXPECT_LT((r.trajectory[i].T_w_c.matrix() - d.pose.T_w_c.matrix()).cwiseAbs().maxCoeff(), 1e-6)
        << "frame " << i;
  }
}

TEST_F(RunPipelineTest, CameraFileReplacesAMissingCalibration) {
  // The same frames in a folder without calib_params.xml (as from TUM's official download),
  // its camera given as a YAML file: the trajectory is the same, bit for bit.
  const fs::path bare = fs::path(sequenceDir()).string() + "_bare";
  fs::remove_all(bare);
  fs::create_directories(bare);
  for (const auto& entry : fs::directory_iterator(sequenceDir())) {
    if (entry.path().filename() == "calib_params.xml") continue;
    fs::create_symlink(entry.path(), bare / entry.path().filename());
  }
  const PinholeCamera c = dataset::Dataset::open(sequenceDir()).camera().camera;
  const fs::path yaml = bare.string() + ".yaml";
  std::ofstream(yaml) << std::setprecision(17) << "width: " << c.width << "\nheight: " << c.height
                      << "\nfx: " << c.fx << "\nfy: " << c.fy << "\ncx: " << c.cx
                      << "\ncy: " << c.cy << "\ndepth_scale: 5000\n";
  RunOptions with_calib;
  with_calib.dataset_dir = sequenceDir();
  with_calib.max_frames = 6;
  RunOptions with_camera = with_calib;
  with_camera.dataset_dir = bare.string();
  const RunResult without_file = runPipeline(with_camera);
  EXPECT_TRUE(without_file.failed);  // no calibration at all: a clear error
  EXPECT_NE(without_file.error.find("--camera"), std::string::npos) << without_file.error;
  with_camera.camera_file = yaml.string();
  const RunResult a = runPipeline(with_calib), b = runPipeline(with_camera);
  ASSERT_FALSE(b.failed) << b.error;
  ASSERT_EQ(a.trajectory.size(), b.trajectory.size());
  for (size_t i = 0; i < a.trajectory.size(); ++i) {
    EXPECT_EQ(a.trajectory[i].T_w_c.matrix(), b.trajectory[i].T_w_c.matrix()) << i;
  }
  EXPECT_EQ(parseRunArgs({"--dataset", "d", "--camera", "c.yaml"}).options.camera_file, "c.yaml");
  fs::remove_all(bare);
  fs::remove(yaml);
}

TEST_F(RunPipelineTest, FramesInFlightDoNotChangeTheTrajectory) {
  // Pipelined (frame k+1 extracted while k is fused) or one frame at a time: the same poses,
  // bit for bit, and nothing dropped. With 5 in flight up to 4 newer frames wait for their
  // pose in the depth filter, more than its load shedding allows: pplvo-run turns it off. The
  // frames decoded beforehand (--preload) give the same poses too.
  std::vector<RunResult> runs;
  const int in_flights[] = {1, 2, 3, 5, 2};
  for (const int in_flight : in_flights) {
    RunOptions o;
    o.dataset_dir = sequenceDir();
    o.in_flight = in_flight;
    o.preload = runs.size() == 4;
    runs.push_back(runPipeline(o));
    const RunResult& r = runs.back();
    ASSERT_FALSE(r.failed) << r.error;
    ASSERT_EQ(r.poses, kFrames) << "in flight " << in_flight;
    for (const NodeReport& n : r.nodes) EXPECT_EQ(n.counters.frames_dropped, 0) << n.name;
    for (const NodeReport& n : r.nodes) {
      EXPECT_EQ(n.timings.find("ogm_shortened"), nullptr) << "in flight " << in_flight;
    }
    EXPECT_EQ(r.preload_s > 0, o.preload);
    EXPECT_LT(r.preload_s, r.elapsed_s);
  }
  for (size_t k = 1; k < runs.size(); ++k) {
    for (int i = 0; i < kFrames; ++i) {
      EXPECT_EQ(runs[k].trajectory[i].stamp_text, runs[0].trajectory[i].stamp_text);
      EXPECT_TRUE(runs[k].trajectory[i].T_w_c.matrix() == runs[0].trajectory[i].T_w_c.matrix())
          << "run " << k << " (in flight " << in_flights[k] << "), frame " << i;
    }
  }
}

TEST_F(RunPipelineTest, TracksTheSyntheticSequenceWithBoundedDrift) {
  RunOptions o;
  o.dataset_dir = sequenceDir();
  const RunResult r = runPipeline(o);
  ASSERT_FALSE(r.failed) << r.error;
  synth::SynthOptions so;
  so.frames = kFrames;
  so.seed = 11;
  const synth::SyntheticSequence seq(so);
  double max_t = 0;
  for (int i = 0; i < kFrames; ++i) {
    const Pose3 truth = seq.pose(0).inverse() * seq.pose(i);
    max_t = std::max(max_t, (truth.translation() - r.trajectory[i].T_w_c.translation()).norm());
  }
  std::printf("pplvo-run synthetic %d frames: max drift %.2f mm\n%s", kFrames, 1e3 * max_t,
              r.text().c_str());
  EXPECT_LT(max_t, 0.03);  // observed < 1 cm
  // The summary names every node and is valid-looking YAML.
  const std::string y = r.yaml();
  for (const char* node :
       {"pplvo-player", "pplvo-depth-filter", "pplvo-frontend", "pplvo-estimator"}) {
    EXPECT_NE(y.find(node), std::string::npos) << node;
  }
  // The per-frame shared error, estimated online from the motions: rendered frames have none,
  // so what is read is the estimator's own roughness, well under a Kinect's ~2 mm.
  EXPECT_TRUE(r.frame_error_source.online());
  EXPECT_LT(r.frame_error_sigma_t_m, 1e-3);
  EXPECT_LT(r.frame_error_sigma_rot_deg, 0.05);
  EXPECT_NE(y.find("frame_error: {sigma_t_m: "), std::string::npos) << y;
  EXPECT_NE(r.text().find("shared frame error: "), std::string::npos);
  // Every estimate of the textured room constrains the pose and agrees with the prediction.
  EXPECT_EQ(r.weak_estimates_combined, 0);
  EXPECT_EQ(r.estimates_gated, 0);
  EXPECT_NE(y.find("estimates_gated: 0"), std::string::npos) << y;
}

TEST_F(RunPipelineTest, CorruptFrameIsACountedSkipWithSkipBad) {
  const fs::path copy = fs::path(sequenceDir() + "_corrupt");
  fs::remove_all(copy);
  fs::copy(sequenceDir(), copy, fs::copy_options::recursive);
  // Overwrite one colour image with garbage.
  std::vector<fs::path> rgb;
  for (const auto& e : fs::directory_iterator(copy / "rgb")) rgb.push_back(e.path());
  std::sort(rgb.begin(), rgb.end());
  ASSERT_GT(rgb.size(), 10u);
  std::ofstream(rgb[10], std::ios::binary | std::ios::trunc) << "not a png";

  RunOptions o;
  o.dataset_dir = copy.string();
  const RunResult stop = runPipeline(o);
  EXPECT_TRUE(stop.failed);
  EXPECT_NE(stop.error.find(rgb[10].filename().string()), std::string::npos) << stop.error;

  o.skip_bad = true;
  const RunResult skip = runPipeline(o);
  EXPECT_FALSE(skip.failed) << skip.error;
  EXPECT_EQ(skip.frames_skipped, 1);
  EXPECT_EQ(skip.poses, kFrames - 1);
  for (const NodeReport& n : skip.nodes) {
    EXPECT_TRUE(msgs::countsAddUp(n.counters)) << n.name;
    EXPECT_EQ(n.counters.frames_pending, 0) << n.name;
    // The player read the bad file (in, skipped); the nodes never saw that frame.
    if (n.name == "pplvo-player") {
      EXPECT_EQ(n.counters.frames_in, kFrames);
      EXPECT_EQ(n.counters.frames_skipped, 1);
    } else {
      EXPECT_EQ(n.counters.frames_in, kFrames - 1) << n.name;
    }
  }
  EXPECT_GE(skip.tracking, kFrames - 3);
  fs::remove_all(copy);
}

TEST_F(RunPipelineTest, MissingDatasetIsAClearError) {
  RunOptions o;
  o.dataset_dir = "/nonexistent/pplvo_dataset";
  const RunResult r = runPipeline(o);
  EXPECT_TRUE(r.failed);
  EXPECT_NE(r.error.find("/nonexistent/pplvo_dataset"), std::string::npos) << r.error;
  EXPECT_TRUE(r.trajectory.empty());
}

TEST_F(RunPipelineTest, CommandLineWritesTrajectoryAndSummary) {
  const std::string bin = std::string(std::getenv("PPLVO_BINARY_DIR")) + "/bin/pplvo-run";
  const fs::path out = fs::path(sequenceDir() + "_out");
  fs::create_directories(out);
  const std::string cmd = bin + " --dataset " + sequenceDir() +
                          " --max-frames 8 --features points,planes --output " +
                          (out / "traj.txt").string() + " --summary " +
                          (out / "summary.yaml").string() + " --quiet 2>/dev/null";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  const TrajectoryReadResult t = readTumTrajectory((out / "traj.txt").string());
  EXPECT_EQ(t.poses.size(), 8u);
  std::ifstream s(out / "summary.yaml");
  const std::string summary((std::istreambuf_iterator<char>(s)), {});
  EXPECT_NE(summary.find("poses: 8"), std::string::npos) << summary;
  // Bad options: exit status 2, nothing run.
  EXPECT_EQ(WEXITSTATUS(std::system((bin + " --dataset x --features surf 2>/dev/null").c_str())),
            2);
  EXPECT_EQ(WEXITSTATUS(std::system((bin + " --output y 2>/dev/null >/dev/null").c_str())), 2);
  fs::remove_all(out);
}

TEST_F(RunPipelineTest, IndexProblemsAreCountedInTheSummary) {
  // What pplvo-player prints at start-up: a listed file missing, garbage lines in the index.
  const fs::path copy = fs::path(sequenceDir() + "_index");
  fs::remove_all(copy);
  fs::copy(sequenceDir(), copy, fs::copy_options::recursive);
  fs::remove(copy / "associations.txt");  // rgb.txt + depth.txt
  std::vector<fs::path> rgb;
  for (const auto& e : fs::directory_iterator(copy / "rgb")) rgb.push_back(e.path());
  std::sort(rgb.begin(), rgb.end());
  ASSERT_GT(rgb.size(), 5u);
  fs::remove(rgb[5]);
  std::ofstream(copy / "rgb.txt", std::ios::app) << "garbage\n";
  std::ofstream(copy / "depth.txt", std::ios::app) << "1.0\n";

  RunOptions o;
  o.dataset_dir = copy.string();
  const RunResult r = runPipeline(o);
  ASSERT_FALSE(r.failed) << r.error;
  EXPECT_EQ(r.poses, kFrames - 1);
  EXPECT_EQ(r.index.missing_rgb_files, 1);
  EXPECT_EQ(r.index.malformed_lines, 2);
  EXPECT_NE(r.text().find("dataset: rgb.txt+depth.txt"), std::string::npos) << r.text();
  EXPECT_NE(r.text().find("dropped 1 missing colour"), std::string::npos) << r.text();
  EXPECT_NE(r.text().find("2 malformed lines"), std::string::npos) << r.text();
  EXPECT_NE(r.yaml().find("missing_rgb_files: 1, missing_depth_files: 0"), std::string::npos);
  EXPECT_NE(r.yaml().find("malformed_lines: 2"), std::string::npos) << r.yaml();
  fs::remove_all(copy);
}

TEST_F(RunPipelineTest, UnwritableOutputIsRefusedBeforeTheFirstFrame) {
  EXPECT_EQ(outputFileError("/nonexistent_pplvo_dir/traj.txt"), "No such file or directory");
  EXPECT_EQ(outputFileError(fs::temp_directory_path().string()), "is a directory");
  const fs::path fresh = fs::path(sequenceDir() + "_fresh.txt");
  EXPECT_EQ(outputFileError(fresh.string()), "");
  EXPECT_FALSE(fs::exists(fresh));  // nothing left behind

  const std::string bin = std::string(std::getenv("PPLVO_BINARY_DIR")) + "/bin/pplvo-run";
  const fs::path err = fs::path(sequenceDir() + "_err.txt");
  const fs::path out = fs::path(sequenceDir() + "_stdout.txt");
  for (const std::string option : {"--output", "--summary", "--log", "--covariance"}) {
    const std::string cmd = bin + " --dataset " + sequenceDir() + " " + option +
                            " /nonexistent_pplvo_dir/x >" + out.string() + " 2>" + err.string();
    EXPECT_EQ(WEXITSTATUS(std::system(cmd.c_str())), 1) << cmd;
    std::ifstream e(err), o(out);
    const std::string err_text((std::istreambuf_iterator<char>(e)), {});
    const std::string out_text((std::istreambuf_iterator<char>(o)), {});
    EXPECT_NE(err_text.find("cannot write /nonexistent_pplvo_dir/x: No such file or directory"),
              std::string::npos)
        << err_text;
    EXPECT_EQ(out_text.find("frames:"), std::string::npos) << out_text;  // no frame was run
  }
  fs::remove(err);
  fs::remove(out);
}

TEST_F(RunPipelineTest, CovarianceFileHoldsThePublishedRelativePoses) {
  // --covariance: one line per frame after the first, T_prev_curr and pose_t.rel_covariance
  // exactly (17 digits), stamps verbatim; the event log of the same run gives the same records.
  const std::string bin = std::string(std::getenv("PPLVO_BINARY_DIR")) + "/bin/pplvo-run";
  const fs::path out = fs::path(sequenceDir() + "_cov");
  fs::create_directories(out);
  const std::string cov = (out / "cov.txt").string(), log = (out / "run.lcmlog").string();
  const std::string cmd = bin + " --dataset " + sequenceDir() + " --max-frames 10 --covariance " +
                          cov + " --log " + log + " --quiet 2>/dev/null";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  const eval::RelativePoseReadResult file = eval::readRelativePoseFile(cov);
  ASSERT_TRUE(file.ok) << file.error;
  ASSERT_EQ(file.records.size(), 9u);

  RunOptions o;
  o.dataset_dir = sequenceDir();
  o.max_frames = 10;
  const RunResult r = runPipeline(o);
  ASSERT_FALSE(r.failed) << r.error;
  ASSERT_EQ(r.frame_poses.size(), 10u);
  for (size_t k = 0; k < file.records.size(); ++k) {
    const eval::RelativePoseRecord& rec = file.records[k];
    const FramePose& p = r.frame_poses[k + 1];
    EXPECT_EQ(rec.stamp_text, p.stamp);
    EXPECT_EQ(rec.prev_stamp_text, r.frame_poses[k].stamp);
    EXPECT_EQ(rec.status, static_cast<int>(p.status));
    EXPECT_EQ(rec.covariance, p.rel_covariance) << "frame " << k + 1;
    EXPECT_LT((rec.T_prev_curr.matrix() - p.T_prev_curr.matrix()).cwiseAbs().maxCoeff(), 1e-15);
    // A tracked frame's covariance is a proper one: symmetric, positive definite.
    if (p.status == TrackingStatus::kTracking) {
      EXPECT_EQ(Eigen::LLT<Matrix6d>(rec.covariance).info(), Eigen::Success);
      EXPECT_GT(rec.covariance(0, 0), 0.0);
    }
    // T_prev_curr is the motion between the two published T_w_c.
    const Pose3 rel = r.frame_poses[k].T_w_c.inverse() * p.T_w_c;
    EXPECT_LT((rel.matrix() - p.T_prev_curr.matrix()).cwiseAbs().maxCoeff(), 1e-6);
  }
  const eval::PoseLogReadResult from_log = eval::readPoseLog(log);
  ASSERT_TRUE(from_log.ok) << from_log.error;
  const auto log_records = eval::relativePoseRecords(from_log.poses);
  ASSERT_EQ(log_records.size(), file.records.size());
  for (size_t k = 0; k < log_records.size(); ++k) {
    EXPECT_EQ(log_records[k].covariance, file.records[k].covariance);
  }
  // And the evaluator takes it against the sequence's ground truth.
  eval::TumReadResult gt = eval::readTumFile(sequenceDir() + "/groundtruth.txt");
  ASSERT_TRUE(gt.ok) << gt.error;
  eval::NeesOptions no;
  no.gt = {0.0, 0.0, 0.0};
  const eval::NeesResult nees = eval::evaluateNees(gt.file, file.records, no);
  ASSERT_TRUE(nees.ok) << nees.error;
  EXPECT_EQ(nees.pairs.size(), 9u);
  fs::remove_all(out);
}

TEST(RunArgs, GoodBadAndHelp) {
  const RunArgs a =
      parseRunArgs({"--dataset", "d", "--output", "t.txt", "--max-frames", "5", "--in-flight", "1",
                    "--fps", "30", "--quiet", "--no-progress", "--features", "points", "--set",
                    "odometry.tracker.estimator.plane_scale_alpha=1"});
  EXPECT_TRUE(a.errors.empty()) << a.errors.front();
  EXPECT_EQ(a.options.dataset_dir, "d");
  EXPECT_EQ(a.options.output, "t.txt");
  EXPECT_EQ(a.options.max_frames, 5);
  EXPECT_EQ(a.options.in_flight, 1);
  EXPECT_EQ(a.options.fps, 30.0);
  EXPECT_TRUE(a.quiet);
  ASSERT_TRUE(a.progress.has_value());
  EXPECT_FALSE(*a.progress);
  EXPECT_FALSE(a.options.pipeline.frontend.families.lines);
  EXPECT_FALSE(a.options.pipeline.odometry.tracker.estimator.use_lines);
  EXPECT_EQ(a.options.pipeline.odometry.tracker.estimator.plane_scale_alpha, 1.0);
  EXPECT_FALSE(parseRunArgs({"--dataset", "d"}).progress.has_value());  // stderr decides

  const RunArgs bad = parseRunArgs({"--in-flight", "0", "--features", "surf"});
  ASSERT_EQ(bad.errors.size(), 3u);
  EXPECT_EQ(bad.errors[0], "--in-flight: expected an integer in [1, 1000], got '0'");
  EXPECT_NE(bad.errors[1].find("--features surf: features: invalid feature list 'surf'"),
            std::string::npos)
      << bad.errors[1];
  EXPECT_EQ(bad.errors[2], "--dataset is required");
  testing::internal::CaptureStdout();
  testing::internal::CaptureStderr();
  EXPECT_EQ(node::argsExitCode("pplvo-run", bad.help, bad.errors, runUsage()), 2);
  EXPECT_NE(testing::internal::GetCapturedStderr().find("pplvo-run: --dataset is required\n"),
            std::string::npos);
  testing::internal::GetCapturedStdout();
  EXPECT_TRUE(parseRunArgs({"--help"}).help);
  EXPECT_NE(runUsage().find("--depth-model MODEL"), std::string::npos) << runUsage();
}

}  // namespace
}  // namespace pplvo::run
