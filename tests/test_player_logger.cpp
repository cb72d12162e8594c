// Player -> logger on one memq:// instance: what the player publishes is what the log holds.
#include <gtest/gtest.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <cstdlib>
#include <filesystem>
#include <pplvo_msgs/rgbd_frame_t.hpp>

#include "pplvo/logging/event_log.h"
#include "pplvo/logging/logger_node.h"
#include "pplvo/player/player_node.h"

namespace fs = std::filesystem;
using namespace pplvo;

TEST(PlayerToLogger, AllFramesLoggedInOrderWithVerbatimStamps) {
  const char* env = std::getenv("PPLVO_SHARED_DATA");
  const std::string dir =
      std::string(env ? env : "../shared/data") + "/tum_fr3_sitting_static_short";
  const std::string base =
      (fs::temp_directory_path() / ("pplvo_test_pl_" + std::to_string(::getpid()))).string();
  const std::string log_path = base + ".lcmlog", sum_path = base + ".yaml";

  lcm::LCM lcm("memq://");
  logging::LoggerOptions lo;
  lo.output = log_path;
  lo.summary = sum_path;
  lo.until_end = true;
  lo.drain_s = 0.1;
  lo.timeout_s = 60;
  logging::LoggerNode logger(lo, lcm);

  player::PlayerOptions po;
  po.dataset_dir = dir;
  po.rate = 0;
  po.rgb_encoding = pplvo_msgs::image_t::ENCODING_JPEG;  // keep the log small
  po.depth_encoding = pplvo_msgs::image_t::ENCODING_PNG_U16;
  player::PlayerNode player(po, lcm);
  const auto pr = player.run();  // the logger's handlers run inside the player's drain
  ASSERT_FALSE(pr.failed) << pr.error;
  const auto lr = logger.run();
  EXPECT_EQ(lr.exit_code, logging::kExitOk) << lr.summary.error;
  EXPECT_EQ(lr.summary.stop_reason, "end of stream");

  const auto log = logging::readEventLog(log_path);
  EXPECT_FALSE(log.truncated);
  int64_t seq = 0;
  for (const auto& ev : log.events) {
    if (ev.channel != "PPLVO_RGBD") continue;
    pplvo_msgs::rgbd_frame_t m;
    ASSERT_GT(m.decode(ev.data.data(), 0, static_cast<int>(ev.data.size())), 0);
    EXPECT_EQ(m.seq, seq);
    EXPECT_EQ(m.stamp, player.dataset().entry(static_cast<size_t>(seq)).stamp_text);
    ++seq;
  }
  EXPECT_EQ(seq, static_cast<int64_t>(player.dataset().size()));
  EXPECT_EQ(seq, pr.published);
  const YAML::Node s = YAML::LoadFile(sum_path);
  EXPECT_EQ(s["channels"]["PPLVO_RGBD"]["messages"].as<int64_t>(), pr.published);
  EXPECT_EQ(s["channels"]["PPLVO_RGBD"]["gaps"].as<int>(), 0);
  EXPECT_EQ(s["nodes"]["pplvo-player"]["frames_out"].as<int64_t>(), pr.published);
  EXPECT_EQ(s["stream"]["frames_published"].as<int64_t>(), pr.published);
  fs::remove(log_path);
  fs::remove(sum_path);
}
