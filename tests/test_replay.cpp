// Replay of each stage from a log recorded by pplvo-run: identical output with the recording's
// configuration, detected differences with another one, truncated and missing logs handled.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <set>
#include <string>
#include <vector>

#include "pplvo/fixtures/synthetic_sequence.h"
#include "pplvo/logging/event_log.h"
#include "pplvo/msgs/channels.h"
#include "pplvo/node/process.h"
#include "pplvo/replay/replay_args.h"
#include "pplvo/replay/replay_stage.h"
#include "pplvo/run/run_pipeline.h"

namespace fs = std::filesystem;

namespace pplvo::replay {
namespace {

struct Recording {
  fs::path dir, log;
};

const Recording& recording() {
  static const Recording r = [] {
    Recording rec;
    rec.dir = fs::temp_directory_path() / ("pplvo_replay_test_" + std::to_string(::getpid()));
    fs::remove_all(rec.dir);
    synth::SynthOptions o;
    o.frames = 8;
    o.seed = 2;
    synth::writeTumFolder(synth::SyntheticSequence(o), (rec.dir / "seq").string());
    rec.log = rec.dir / "run.lcmlog";
    run::RunOptions ro;
    ro.dataset_dir = (rec.dir / "seq").string();
    ro.log = rec.log.string();
    const run::RunResult rr = run::runPipeline(ro);
    EXPECT_FALSE(rr.failed) << rr.error;
    return rec;
  }();
  return r;
}

class ReplayTest : public ::testing::Test {
 protected:
  static void TearDownTestSuite() { fs::remove_all(recording().dir); }
};

TEST_F(ReplayTest, EveryStageReproducesTheRecordingExactly) {
  for (Stage s : {Stage::kDepthFilter, Stage::kFrontend, Stage::kEstimator}) {
    ReplayOptions o;
    o.log = recording().log.string();
    o.stage = s;
    const ReplayResult r = replayStage(o);
    std::printf("%s:\n%s", toString(s), r.text().c_str());
    EXPECT_TRUE(r.allIdentical()) << toString(s);
    for (const ChannelComparison& c : r.outputs) EXPECT_EQ(c.recorded, 8) << c.channel;
  }
}

TEST_F(ReplayTest, TheWholePipelineReproducesEveryRecordedChannelFromTheFramesAlone) {
  ReplayOptions o;
  o.log = recording().log.string();
  o.stage = Stage::kPipeline;
  const ReplayResult r = replayStage(o);
  std::printf("pipeline:\n%s", r.text().c_str());
  EXPECT_TRUE(r.allIdentical());
  EXPECT_EQ(r.inputs_fed, 8);
  EXPECT_EQ(r.outputs.size(), 5u);  // depth maps, features and poses: all in the full log
  for (const ChannelComparison& c : r.outputs) EXPECT_EQ(c.recorded, 8) << c.channel;
  o.pipeline.odometry.tracker.estimator.plane_scale_alpha = 1.0;  // recorded with the default
  EXPECT_FALSE(replayStage(o).allIdentical());
}

TEST_F(ReplayTest, ACompactRecordingKeepsFramesAndPosesAndReplaysThePosesExactly) {
  // --log-mode compact: JPEG colour and lossless zlib depth, which the run itself used, and no
  // derived channel. The frames alone give back the recorded poses byte for byte.
  const fs::path compact = recording().dir / "compact.lcmlog";
  run::RunOptions ro;
  ro.dataset_dir = (recording().dir / "seq").string();
  ro.log = compact.string();
  ro.compact_log = true;
  ro.log_channels = channels::kCompactLogChannels;
  const run::RunResult rr = run::runPipeline(ro);
  ASSERT_FALSE(rr.failed) << rr.error;
  ASSERT_EQ(rr.poses, 8);
  std::set<std::string> channels_in_log;
  {
    logging::EventLogReader reader(compact.string());
    while (auto ev = reader.next()) channels_in_log.insert(ev->channel);
  }
  EXPECT_EQ(channels_in_log,
            (std::set<std::string>{channels::kRgbd, channels::kPose, channels::kOdometry,
                                   channels::kStatus, channels::kStream}));
  // Far smaller than the full log (JPEG + zlib frames, no depth maps or features). The
  // synthetic frames are 640x480 with sharp texture: JPEG keeps a sixth of raw BGR here.
  const auto full_bytes = fs::file_size(recording().log);
  const auto compact_bytes = fs::file_size(compact);
  std::printf("full log %ju bytes, compact %ju bytes (%.1f %%)\n", full_bytes, compact_bytes,
              100.0 * static_cast<double>(compact_bytes) / static_cast<double>(full_bytes));
  EXPECT_LT(compact_bytes * 20, full_bytes);

  ReplayOptions o;
  o.log = compact.string();
  o.stage = Stage::kPipeline;
  const ReplayResult r = replayStage(o);
  std::printf("pipeline from the compact log:\n%s", r.text().c_str());
  EXPECT_TRUE(r.allIdentical());
  ASSERT_EQ(r.outputs.size(), 1u);  // only the poses were recorded
  EXPECT_EQ(r.outputs[0].channel, channels::kPose);
  EXPECT_EQ(r.outputs[0].identical, 8);
  // The depth filter alone replays from it too (its inputs: frames and poses).
  o.stage = Stage::kDepthFilter;
  const ReplayResult df = replayStage(o);
  EXPECT_FALSE(df.failed) << df.error;
  EXPECT_EQ(df.inputs_fed, 16);
}

TEST_F(ReplayTest, AnotherConfigurationShowsWhereTheOutputDiffers) {
  ReplayOptions o;
  o.log = recording().log.string();
  o.stage = Stage::kDepthFilter;
  o.pipeline.depth_filter.model = depth_filter::DepthModel::kCgm;  // recorded with O-GM
  const ReplayResult r = replayStage(o);
  EXPECT_FALSE(r.allIdentical());
  ASSERT_EQ(r.outputs.size(), 2u);
  EXPECT_TRUE(r.outputs[0].allIdentical());   // C-GM maps: unchanged
  EXPECT_FALSE(r.outputs[1].allIdentical());  // fused maps: differ
  EXPECT_EQ(r.outputs[1].first_mismatch, 0);

  o.stage = Stage::kEstimator;
  o.pipeline = {};
  o.pipeline.odometry.tracker.estimator.plane_scale_alpha = 1.0;
  EXPECT_FALSE(replayStage(o).allIdentical());
}

TEST_F(ReplayTest, TruncatedLogIsReplayedUpToTheCut) {
  const fs::path cut = recording().dir / "cut.lcmlog";
  fs::copy_file(recording().log, cut, fs::copy_options::overwrite_existing);
  fs::resize_file(cut, fs::file_size(cut) * 2 / 3);
  ReplayOptions o;
  o.log = cut.string();
  o.stage = Stage::kEstimator;
  const ReplayResult r = replayStage(o);
  EXPECT_FALSE(r.failed) << r.error;
  EXPECT_TRUE(r.log_truncated);
  // Everything replayed that was recorded before the cut matches.
  for (const ChannelComparison& c : r.outputs) {
    EXPECT_GT(c.recorded, 0);
    EXPECT_LT(c.recorded, 8);
    EXPECT_GE(c.identical, c.recorded - 1);
  }
}

TEST_F(ReplayTest, LogCutAnywhereIsIdenticalUpToTheCut) {
  // Cut positions chosen from the log's own event order (which depends on the recording
  // machine's thread timing): for each stage, right after each of its input messages (a log
  // that simply stops there, before the outputs that input triggers) and in the middle of the
  // event after it (a torn last event). Every output is logged after the input that triggered
  // it, so the first kind of cut always falls between an input and its output, on any machine.
  struct Event {
    std::string channel;
    int64_t end = 0;
  };
  std::vector<Event> events;
  {
    logging::EventLogReader reader(recording().log.string());
    while (auto ev = reader.next()) events.push_back({ev->channel, reader.validBytes()});
  }
  ASSERT_GT(events.size(), 30u);
  std::vector<int64_t> ends;
  for (const Event& e : events) ends.push_back(e.end);
  const fs::path cut = recording().dir / "cut_anywhere.lcmlog";
  for (Stage s : {Stage::kDepthFilter, Stage::kFrontend, Stage::kEstimator}) {
    const std::set<std::string> inputs = stageInputChannels(s);
    std::vector<int64_t> cuts;
    for (size_t k = 0; k + 1 < events.size(); ++k) {
      if (!inputs.count(events[k].channel)) continue;
      cuts.push_back(events[k].end);
      cuts.push_back((events[k].end + events[k + 1].end) / 2);
    }
    int replayed = 0, after_end = 0;
    for (const int64_t at : cuts) {
      fs::copy_file(recording().log, cut, fs::copy_options::overwrite_existing);
      fs::resize_file(cut, static_cast<uintmax_t>(at));
      ReplayOptions o;
      o.log = cut.string();
      o.stage = s;
      const ReplayResult r = replayStage(o);
      ASSERT_GT(r.inputs_fed, 0) << at;  // every cut is after one of the stage's inputs
      ++replayed;
      EXPECT_TRUE(r.allIdentical()) << toString(s) << " cut at byte " << at << ":\n" << r.text();
      EXPECT_EQ(r.log_truncated, std::find(ends.begin(), ends.end(), at) == ends.end()) << at;
      for (const ChannelComparison& c : r.outputs) after_end += c.afterEnd() > 0 ? 1 : 0;
    }
    EXPECT_GE(replayed, 16) << toString(s);  // 8 frames: at least one input each, two cuts
    EXPECT_GT(after_end, 0) << toString(s);  // some cuts fell between an input and its output
  }
}

TEST_F(ReplayTest, MissingLogIsAClearError) {
  ReplayOptions o;
  o.log = "/nonexistent/run.lcmlog";
  const ReplayResult r = replayStage(o);
  EXPECT_TRUE(r.failed);
  EXPECT_NE(r.error.find("/nonexistent/run.lcmlog"), std::string::npos) << r.error;
}

TEST(ReplayArgs, GoodBadAndHelp) {
  const ReplayArgs a =
      parseReplayArgs({"--log", "run.lcm", "--stage", "depth-filter", "--depth-model", "cgm",
                       "--set", "depth_filter.ogm.k_consistency=2"});
  EXPECT_TRUE(a.errors.empty()) << a.errors.front();
  EXPECT_EQ(a.options.log, "run.lcm");
  EXPECT_EQ(a.options.stage, Stage::kDepthFilter);
  EXPECT_EQ(a.options.pipeline.depth_filter.model, depth_filter::DepthModel::kCgm);
  EXPECT_EQ(a.options.pipeline.depth_filter.ogm.k_consistency, 2);

  const ReplayArgs bad = parseReplayArgs({"--stage", "player", "--set", "odometry.x=1"});
  ASSERT_EQ(bad.errors.size(), 3u);
  EXPECT_NE(bad.errors[0].find("odometry.x: unknown key"), std::string::npos) << bad.errors[0];
  EXPECT_EQ(bad.errors[1], "--stage: depth-filter, frontend, estimator or pipeline");
  EXPECT_EQ(bad.errors[2], "--log is required");
  testing::internal::CaptureStdout();
  testing::internal::CaptureStderr();
  EXPECT_EQ(node::argsExitCode("pplvo-replay", bad.help, bad.errors, replayUsage()), 2);
  EXPECT_NE(testing::internal::GetCapturedStderr().find("pplvo-replay: --log is required\n"),
            std::string::npos);
  testing::internal::GetCapturedStdout();
  EXPECT_TRUE(parseReplayArgs({"-h"}).help);
  EXPECT_NE(replayUsage().find("Exit 0 if identical"), std::string::npos);
}

}  // namespace
}  // namespace pplvo::replay
