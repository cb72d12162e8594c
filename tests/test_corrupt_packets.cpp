// Corrupt packets on the bus next to the real ones: every node of the pipeline (player, depth
// filter, frontend, estimator) on one memq:// LCM, as pplvo-run wires them, with a corrupted
// copy of every message on their input channels published right after the real one. Each copy
// must be a counted skip of the node that receives it (never an exception, an exit or a hang),
// and the poses must be byte-identical to those of a clean run.
#include <gtest/gtest.h>

#include <filesystem>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "pplvo/depth_filter_node/depth_filter_node.h"
#include "pplvo/fixtures/synthetic_sequence.h"
#include "pplvo/msgs/channels.h"
#include "pplvo_msgs/camera_info_t.hpp"
#include "pplvo/odometry_nodes/estimator_node.h"
#include "pplvo/odometry_nodes/frontend_node.h"
#include "pplvo/player/player_node.h"

namespace fs = std::filesystem;

namespace pplvo {
namespace {

constexpr int kFrames = 12;

/// The synthetic sequence, written once and removed when the test program ends.
const std::string& sequenceDir() {
  struct Folder {
    std::string path;
    ~Folder() { fs::remove_all(path); }
  };
  static const Folder dir = [] {
    const fs::path d =
        fs::temp_directory_path() / ("pplvo_corrupt_test_" + std::to_string(::getpid()));
    fs::remove_all(d);
    synth::SynthOptions o;
    o.frames = kFrames;
    o.seed = 5;
    synth::writeTumFolder(synth::SyntheticSequence(o), d.string());
    return Folder{d.string()};
  }();
  return dir.path;
}

void putInt32(std::vector<uint8_t>& bytes, size_t at, uint32_t value) {
  for (int i = 0; i < 4; ++i) bytes.at(at + i) = static_cast<uint8_t>(value >> (24 - 8 * i));
}

/// Publishes, after each message on a pipeline channel, a corrupted copy of it: the frame's
/// `stamp` length (offset 24 after hash, utime and seq; 32 in rgbd_frame_t, which carries
/// depth_utime too) made negative, zero or
/// huge, a features_t's n_points made negative or huge, or the packet cut in half. Records the
/// real poses' bytes.
class Corrupter {
 public:
  Corrupter(lcm::LCM& lcm, bool corrupt) : lcm_(lcm), corrupt_(corrupt) {
    sub_ = lcm_.subscribe(".*", &Corrupter::onMessage, this);
  }
  ~Corrupter() { lcm_.unsubscribe(sub_); }

  void onMessage(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
    const auto* p = static_cast<const uint8_t*>(rbuf->data);
    std::vector<uint8_t> bytes(p, p + rbuf->data_size);
    auto own = sent_.find(bytes);
    if (own != sent_.end()) {  // a copy this corrupter published
      sent_.erase(own);
      return;
    }
    if (channel == channels::kPose) poses.push_back(bytes);
    if (!corrupt_ || !kCorrupted.count(channel)) return;
    std::vector<uint8_t> bad = bytes;
    // rgbd_frame_t carries depth_utime between utime and seq.
    const size_t stamp_at = channel == channels::kRgbd ? 32 : 24;
    const int kind = static_cast<int>(published_[channel]++ % 5);
    switch (kind) {
      case 0:
        putInt32(bad, stamp_at, 0xffffffffu);
        break;
      case 1:
        putInt32(bad, stamp_at, 0u);
        break;
      case 2:
        putInt32(bad, stamp_at, 0x7fffffffu);
        break;
      case 3:
        bad.resize(bad.size() / 2);
        break;
      default: {
        if (channel == channels::kFeatures || channel == channels::kFeatures3d) {
          // n_points follows stamp, stage (1 byte) and camera_info (88 bytes: size from the type).
          const uint32_t stamp_length = (uint32_t{bad[24]} << 24) | (uint32_t{bad[25]} << 16) |
                                        (uint32_t{bad[26]} << 8) | bad[27];
          const uint32_t camera_bytes =
              static_cast<uint32_t>(pplvo_msgs::camera_info_t()._getEncodedSizeNoHash());
          putInt32(bad, 28 + stamp_length + 1 + camera_bytes,
                   published_[channel] % 2 ? 0x80000000u : 0x7ffffff0u);
        } else {
          // One byte too long.
          putInt32(bad, stamp_at, static_cast<uint32_t>(bad.size() - (stamp_at + 4) + 1));
        }
        break;
      }
    }
    sent_.insert(bad);
    ++corrupted[channel];
    lcm_.publish(channel, bad.data(), static_cast<unsigned>(bad.size()));
  }

  std::vector<std::vector<uint8_t>> poses;
  std::map<std::string, int64_t> corrupted;

 private:
  inline static const std::set<std::string> kCorrupted = {
      channels::kRgbd,       channels::kPose,     channels::kDepthCgm,
      channels::kDepthFused, channels::kFeatures, channels::kFeatures3d};
  lcm::LCM& lcm_;
  bool corrupt_;
  lcm::Subscription* sub_ = nullptr;
  std::multiset<std::vector<uint8_t>> sent_;
  std::map<std::string, int64_t> published_;
};

/// A stray publisher on PPLVO_RGBD (issue 39): a second player of the same folder started with
/// the first (every frame again, right after the real one), and once one well-formed frame
/// whose seq is 10^12. Both are to be counted and skipped by the nodes that read frames.
class StrayPublisher {
 public:
  explicit StrayPublisher(lcm::LCM& lcm) : lcm_(lcm) {
    sub_ = lcm_.subscribe(channels::kRgbd, &StrayPublisher::onFrame, this);
  }
  ~StrayPublisher() { lcm_.unsubscribe(sub_); }
  void onFrame(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
    const auto* p = static_cast<const uint8_t*>(rbuf->data);
    std::vector<uint8_t> bytes(p, p + rbuf->data_size);
    auto own = sent_.find(bytes);
    if (own != sent_.end()) {
      sent_.erase(own);
      return;
    }
    publish(channel, bytes);  // the second player
    if (++real_ == 4) {
      // seq (int64, big-endian) follows hash, utime and depth_utime.
      for (int i = 0; i < 8; ++i) bytes.at(24 + i) = 0;
      const uint64_t forged = 1'000'000'000'000ull;
      for (int i = 0; i < 8; ++i) bytes.at(24 + i) = static_cast<uint8_t>(forged >> (56 - 8 * i));
      publish(channel, bytes);
    }
  }
  int64_t published = 0;

 private:
  void publish(const std::string& channel, const std::vector<uint8_t>& bytes) {
    sent_.insert(bytes);
    ++published;
    lcm_.publish(channel, bytes.data(), static_cast<unsigned>(bytes.size()));
  }
  lcm::LCM& lcm_;
  lcm::Subscription* sub_ = nullptr;
  std::multiset<std::vector<uint8_t>> sent_;
  int real_ = 0;
};

struct PipelineRun {
  std::vector<std::vector<uint8_t>> poses;
  std::map<std::string, int64_t> corrupted;
  std::map<std::string, msgs::NodeCounters> counters;
  player::PlayerResult player;
};

PipelineRun runPipeline(bool corrupt, bool stray = false) {
  lcm::LCM lcm("memq://");
  EXPECT_TRUE(lcm.good());
  nodes::DepthFilterNodeOptions df;
  df.filter.overload.backlog = 0;
  nodes::DepthFilterNode depth_filter(df, lcm);
  nodes::FrontendNode frontend(nodes::FrontendNodeOptions{}, lcm);
  nodes::EstimatorNode estimator(nodes::EstimatorNodeOptions{}, lcm);
  Corrupter corrupter(lcm, corrupt);
  std::optional<StrayPublisher> strays;
  if (stray) strays.emplace(lcm);
  player::PlayerOptions po;
  po.dataset_dir = sequenceDir();
  po.rate = 0.0;
  po.lockstep = true;
  po.in_process = true;
  po.status_period_s = 1e9;
  player::PlayerNode player(po, lcm);
  PipelineRun run;
  run.player = player.run();
  run.poses = corrupter.poses;
  run.corrupted = corrupter.corrupted;
  if (strays) run.corrupted["stray frames"] = strays->published;
  run.counters[player::PlayerOptions{}.node_name] = player.counters();
  run.counters[nodes::DepthFilterNode::kName] = depth_filter.counters();
  run.counters[nodes::FrontendNode::kName] = frontend.counters();
  run.counters[nodes::EstimatorNode::kName] = estimator.counters();
  return run;
}

TEST(CorruptPackets, AreCountedSkipsAndThePosesStayByteIdentical) {
  const PipelineRun clean = runPipeline(false);
  ASSERT_FALSE(clean.player.failed) << clean.player.error;
  ASSERT_EQ(clean.poses.size(), static_cast<size_t>(kFrames));
  for (const auto& [name, c] : clean.counters) {
    EXPECT_EQ(c.frames_skipped + c.messages_skipped, 0) << name;
    EXPECT_EQ(c.errors, 0) << name;
    EXPECT_TRUE(msgs::countsAddUp(c)) << name;
  }

  const PipelineRun bad = runPipeline(true);
  ASSERT_FALSE(bad.player.failed) << bad.player.error;
  EXPECT_EQ(bad.poses, clean.poses);  // every frame posed, byte for byte

  const auto corrupted = [&](std::initializer_list<const char*> inputs) {
    int64_t n = 0;
    for (const char* c : inputs) n += bad.corrupted.count(c) ? bad.corrupted.at(c) : 0;
    return n;
  };
  EXPECT_EQ(bad.corrupted.at(channels::kFeatures), kFrames);
  const std::map<std::string, int64_t> expected = {
      {"pplvo-player", corrupted({channels::kPose})},
      {nodes::DepthFilterNode::kName, corrupted({channels::kRgbd, channels::kPose})},
      {nodes::FrontendNode::kName,
       corrupted({channels::kRgbd, channels::kDepthCgm, channels::kDepthFused})},
      {nodes::EstimatorNode::kName, corrupted({channels::kFeatures, channels::kFeatures3d})}};
  for (const auto& [name, n] : expected) {
    const msgs::NodeCounters& c = bad.counters.at(name);
    // Undecodable packets have no seq: they are skipped messages, not frames of the ledger.
    EXPECT_EQ(c.frames_skipped + c.messages_skipped, n) << name << ": " << c.last_warning;
    EXPECT_EQ(c.errors, 0) << name << ": " << c.last_warning;
    EXPECT_EQ(c.frames_out, clean.counters.at(name).frames_out) << name;
    EXPECT_EQ(c.frames_in, clean.counters.at(name).frames_in) << name;
    EXPECT_TRUE(msgs::countsAddUp(c)) << name;
  }
}

TEST(StrayPublisher, FramesOfASecondSourceOrAForgedSeqAreSkippedAndThePosesStayByteIdentical) {
  const PipelineRun clean = runPipeline(false);
  ASSERT_EQ(clean.poses.size(), static_cast<size_t>(kFrames));
  const PipelineRun stray = runPipeline(false, true);
  ASSERT_FALSE(stray.player.failed) << stray.player.error;
  EXPECT_EQ(stray.corrupted.at("stray frames"), kFrames + 1);
  EXPECT_EQ(stray.poses, clean.poses);  // every frame posed, byte for byte
  for (const char* node : {nodes::DepthFilterNode::kName, nodes::FrontendNode::kName}) {
    const msgs::NodeCounters& c = stray.counters.at(node);
    EXPECT_EQ(c.frames_skipped, kFrames + 1) << node << ": " << c.last_warning;
    EXPECT_EQ(c.frames_dropped, 0) << node << ": " << c.last_warning;  // no "lost" frames
    EXPECT_EQ(c.frames_in, 2 * kFrames + 1) << node;
    EXPECT_EQ(c.frames_lost, 0) << node;
    EXPECT_TRUE(msgs::countsAddUp(c)) << node;
    EXPECT_NE(c.last_warning.find("stray frame"), std::string::npos) << c.last_warning;
  }
}

}  // namespace
}  // namespace pplvo
