// The pplvo-peer-odometry program on a synthetic TUM-layout folder: trajectory with verbatim
// stamps, accuracy, unreadable frames skipped and counted, exit codes on bad input.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <string>

#include "pplvo/core/trajectory.h"
#include "pplvo/dataset/dataset.h"
#include "pplvo/fixtures/synthetic_sequence.h"
#include "pplvo/peer/peer_odometry.h"

#ifndef PPLVO_PEER_BINARY
#error "PPLVO_PEER_BINARY must name the pplvo-peer-odometry program"
#endif

namespace pplvo {
namespace {

namespace fs = std::filesystem;

struct ProgramRun {
  int exit_code = -1;
  std::string out, err;
};

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

ProgramRun runProgram(const std::string& args, const fs::path& tmp) {
  const fs::path out = tmp / "stdout.txt", err = tmp / "stderr.txt";
  const std::string cmd = std::string(PPLVO_PEER_BINARY) + " " + args + " > '" + out.string() +
                          "' 2> '" + err.string() + "'";
  const int status = std::system(cmd.c_str());
  ProgramRun r;
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.out = slurp(out);
  r.err = slurp(err);
  return r;
}

class PeerProgram : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    tmp_ = new fs::path(fs::temp_directory_path() /
                        ("pplvo_test_peer_program_" + std::to_string(::getpid())));
    fs::remove_all(*tmp_);
    fs::create_directories(*tmp_);
    synth::SynthOptions o;
    o.frames = 12;
    o.seed = 5;
    seq_ = new synth::SyntheticSequence(o);
    synth::writeTumFolder(*seq_, (*tmp_ / "seq").string());
  }
  static void TearDownTestSuite() {
    fs::remove_all(*tmp_);
    delete seq_;
    delete tmp_;
  }
  static fs::path* tmp_;
  static synth::SyntheticSequence* seq_;
};
fs::path* PeerProgram::tmp_ = nullptr;
synth::SyntheticSequence* PeerProgram::seq_ = nullptr;

TEST_F(PeerProgram, WritesTheTrajectoryWithVerbatimStamps) {
  const fs::path traj = *tmp_ / "rgbd.txt";
  const ProgramRun r = runProgram("--dataset '" + (*tmp_ / "seq").string() + "' --output '" +
                                      traj.string() + "' --method rgbd --max-frames 10",
                                  *tmp_);
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("frames: 10 processed, 9 tracked, 0 failures"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("frames/s"), std::string::npos) << r.out;
  const TrajectoryReadResult t = readTumTrajectory(traj.string());
  EXPECT_EQ(t.skipped_lines, 0);
  ASSERT_EQ(t.poses.size(), 10u);
  const Pose3 T_c0_w = seq_->pose(0).inverse();
  for (int i = 0; i < 10; ++i) {
    EXPECT_EQ(t.poses[i].stamp_text, seq_->stamp(i));
    const Pose3 gt = T_c0_w * seq_->pose(i);
    // Loose: this checks the program's plumbing (world = first camera, T_w_c, stamps); the
    // accuracy itself is tested in test_peer_odometry. Measured: at most 0.048 m here.
    EXPECT_LT((t.poses[i].T_w_c.translation() - gt.translation()).norm(), 0.10) << i;
  }
  // The program's poses are the library's on the same frames (OpenCV's point sampling uses a
  // fixed seed, so runs repeat exactly; the file keeps 9 significant digits).
  const dataset::Dataset data = dataset::Dataset::open((*tmp_ / "seq").string());
  peer::PeerOdometry odo;
  for (size_t i = 0; i < 10; ++i) {
    const peer::PeerFrameResult res = odo.process(data.loadFrame(i));
    EXPECT_LT((res.T_w_c.translation() - t.poses[i].T_w_c.translation()).norm(), 1e-6) << i;
    EXPECT_LT(rotationAngle(res.T_w_c.linear().transpose() * t.poses[i].T_w_c.linear()), 1e-6) << i;
  }
}

TEST_F(PeerProgram, KeyframeModeWritesTheLibrarysPosesAndCountsKeyframes) {
  // Thresholds of 1 cm: the 12 frames (about 3 mm apart) make a few keyframes.
  const fs::path traj = *tmp_ / "keyframes.txt";
  const ProgramRun r =
      runProgram("--dataset '" + (*tmp_ / "seq").string() + "' --output '" + traj.string() +
                     "' --keyframes --keyframe-translation 0.01 "
                     "--keyframe-rotation 5",
                 *tmp_);
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("reference: keyframe (new keyframe beyond 0.01 m or 5 deg"),
            std::string::npos)
      << r.out;
  const TrajectoryReadResult t = readTumTrajectory(traj.string());
  ASSERT_EQ(t.poses.size(), 12u);
  const dataset::Dataset data = dataset::Dataset::open((*tmp_ / "seq").string());
  peer::PeerOdometryOptions o;
  o.reference_mode = peer::ReferenceMode::kKeyframe;
  o.keyframe_translation_m = 0.01;
  o.keyframe_rotation_deg = 5.0;
  peer::PeerOdometry odo(o);
  for (size_t i = 0; i < 12; ++i) {
    const peer::PeerFrameResult res = odo.process(data.loadFrame(i));
    EXPECT_LT((res.T_w_c.translation() - t.poses[i].T_w_c.translation()).norm(), 1e-6) << i;
    EXPECT_LT(rotationAngle(res.T_w_c.linear().transpose() * t.poses[i].T_w_c.linear()), 1e-6) << i;
  }
  const peer::PeerStats& s = odo.stats();
  EXPECT_GE(s.keyframes, 2);
  char line[160];
  std::snprintf(line, sizeof line, "keyframes: %lld (%lld by motion, %lld after a fallback",
                static_cast<long long>(s.keyframes), static_cast<long long>(s.keyframes_by_motion),
                static_cast<long long>(s.keyframe_fallbacks));
  EXPECT_NE(r.out.find(line), std::string::npos) << r.out;

  // Frame to frame (the default) says so and prints no keyframe count.
  const ProgramRun d = runProgram("--dataset '" + (*tmp_ / "seq").string() + "' --output '" +
                                      (*tmp_ / "f2f.txt").string() + "' --max-frames 3",
                                  *tmp_);
  ASSERT_EQ(d.exit_code, 0) << d.out << d.err;
  EXPECT_NE(d.out.find("reference: previous frame"), std::string::npos) << d.out;
  EXPECT_EQ(d.out.find("keyframes:"), std::string::npos) << d.out;
}

TEST_F(PeerProgram, UnreadableFrameIsSkippedAndCounted) {
  // A copy of the folder with one corrupt depth PNG.
  const fs::path dir = *tmp_ / "corrupt";
  fs::remove_all(dir);
  fs::copy(*tmp_ / "seq", dir, fs::copy_options::recursive);
  std::string depth_file;
  {
    std::ifstream assoc(dir / "associations.txt");
    std::string line;
    int data_line = 0;
    while (std::getline(assoc, line)) {
      if (line.empty() || line[0] == '#') continue;
      if (data_line++ == 4) {  // depth first: "stamp depth/x.png stamp rgb/x.png"
        std::istringstream ss(line);
        std::string stamp;
        ss >> stamp >> depth_file;
      }
    }
  }
  ASSERT_FALSE(depth_file.empty());
  std::ofstream(dir / depth_file, std::ios::trunc) << "not a png";
  const fs::path traj = *tmp_ / "corrupt.txt";
  const ProgramRun r =
      runProgram("--dataset '" + dir.string() + "' --output '" + traj.string() + "'", *tmp_);
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("1 unreadable frames skipped"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("0 failures"), std::string::npos) << r.out;
  EXPECT_EQ(readTumTrajectory(traj.string()).poses.size(), 11u);
}

// A folder without calib_params.xml (TUM's official download) runs with --camera, the same
// poses as with the calibration file.
TEST_F(PeerProgram, CameraFileReplacesAMissingCalibration) {
  const fs::path bare = *tmp_ / "bare";
  fs::create_directories(bare);
  for (const auto& entry : fs::directory_iterator(*tmp_ / "seq")) {
    if (entry.path().filename() == "calib_params.xml") continue;
    fs::create_symlink(entry.path(), bare / entry.path().filename());
  }
  const PinholeCamera c = dataset::Dataset::open((*tmp_ / "seq").string()).camera().camera;
  const fs::path yaml = *tmp_ / "camera.yaml";
  std::ofstream(yaml) << std::setprecision(17) << "width: " << c.width << "\nheight: " << c.height
                      << "\nfx: " << c.fx << "\nfy: " << c.fy << "\ncx: " << c.cx
                      << "\ncy: " << c.cy << "\ndepth_scale: 5000\n";
  const std::string common = " --max-frames 4 --output '";
  EXPECT_EQ(runProgram("--dataset '" + bare.string() + "'" + common +
                           (*tmp_ / "none.txt").string() + "'",
                       *tmp_)
                .exit_code,
            1);  // no calibration at all: an error
  const ProgramRun with_file = runProgram("--dataset '" + (*tmp_ / "seq").string() + "'" + common +
                                              (*tmp_ / "calib.txt").string() + "'",
                                          *tmp_);
  const ProgramRun with_camera =
      runProgram("--dataset '" + bare.string() + "' --camera '" + yaml.string() + "'" + common +
                     (*tmp_ / "camera.txt").string() + "'",
                 *tmp_);
  ASSERT_EQ(with_file.exit_code, 0) << with_file.err;
  ASSERT_EQ(with_camera.exit_code, 0) << with_camera.err;
  const auto a = readTumTrajectory((*tmp_ / "calib.txt").string());
  const auto b = readTumTrajectory((*tmp_ / "camera.txt").string());
  ASSERT_EQ(a.poses.size(), b.poses.size());
  for (size_t i = 0; i < a.poses.size(); ++i) {
    EXPECT_EQ(a.poses[i].T_w_c.matrix(), b.poses[i].T_w_c.matrix()) << i;
  }
}

TEST_F(PeerProgram, BadDatasetExitsWithOne) {
  const ProgramRun r = runProgram("--dataset '" + (*tmp_ / "missing").string() + "' --output '" +
                                      (*tmp_ / "x.txt").string() + "'",
                                  *tmp_);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("bad dataset"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(*tmp_ / "x.txt"));

  // A folder that exists but holds no index.
  fs::create_directories(*tmp_ / "empty");
  EXPECT_EQ(
      runProgram("--dataset '" + (*tmp_ / "empty").string() + "' --output x.txt", *tmp_).exit_code,
      1);

  // An output that cannot be written.
  const ProgramRun w = runProgram(
      "--dataset '" + (*tmp_ / "seq").string() + "' --max-frames 2 --output /nonexistent_dir/x.txt",
      *tmp_);
  EXPECT_EQ(w.exit_code, 1);
  EXPECT_FALSE(w.err.empty());
}

TEST_F(PeerProgram, BadArgumentsExitWithTwo) {
  const std::string ds = "--dataset '" + (*tmp_ / "seq").string() + "' ";
  EXPECT_EQ(runProgram(ds + "--output x.txt --method fast", *tmp_).exit_code, 2);
  EXPECT_EQ(runProgram(ds, *tmp_).exit_code, 2);
  EXPECT_EQ(runProgram(ds + "--output x.txt --max-frames ten", *tmp_).exit_code, 2);
  EXPECT_EQ(runProgram(ds + "--output x.txt --max-frames 0", *tmp_).exit_code, 2);
  EXPECT_EQ(runProgram(ds + "--output x.txt --bogus", *tmp_).exit_code, 2);
  EXPECT_EQ(runProgram(ds + "--output", *tmp_).exit_code, 2);
  EXPECT_EQ(runProgram(ds + "--output x.txt --max-points-part 1.5", *tmp_).exit_code, 2);
  EXPECT_EQ(runProgram(ds + "--output x.txt --max-depth -1", *tmp_).exit_code, 2);
  EXPECT_EQ(runProgram(ds + "--output x.txt --failure sometimes", *tmp_).exit_code, 2);
  EXPECT_EQ(
      runProgram(ds + "--output x.txt --keyframes --keyframe-translation -0.1", *tmp_).exit_code,
      2);
  EXPECT_EQ(runProgram(ds + "--output x.txt --keyframes --keyframe-rotation ten", *tmp_).exit_code,
            2);
  EXPECT_EQ(runProgram(ds + "--output x.txt --keyframes --keyframe-rotation", *tmp_).exit_code, 2);
  const ProgramRun k = runProgram(ds + "--output x.txt --keyframe-translation 0.2", *tmp_);
  EXPECT_EQ(k.exit_code, 2);
  EXPECT_NE(k.err.find("need --keyframes"), std::string::npos) << k.err;
  const ProgramRun r = runProgram(ds + "--output x.txt --method fast", *tmp_);
  EXPECT_NE(r.err.find("unknown --method"), std::string::npos) << r.err;
  EXPECT_EQ(runProgram("--help", *tmp_).exit_code, 0);
}

}  // namespace
}  // namespace pplvo
