// The generated decoders with their length fields bounded (cmake/HardenLcmDecoders.cmake):
// every packet with any 4-byte window overwritten by a negative, zero or huge length, and every
// truncation, decodes to a value or fails with -1; none throws, none allocates beyond the packet.
#include <gtest/gtest.h>

#include <cstdint>
#include <pplvo_msgs/depth_map_t.hpp>
#include <pplvo_msgs/features_t.hpp>
#include <pplvo_msgs/node_status_t.hpp>
#include <pplvo_msgs/pose_t.hpp>
#include <pplvo_msgs/rgbd_frame_t.hpp>
#include <pplvo_msgs/stream_event_t.hpp>
#include <vector>

#include "pplvo/msgs/decode.h"

namespace pplvo::msgs {
namespace {

pplvo_msgs::image_t image(int width, int height, int bytes_per_pixel) {
  pplvo_msgs::image_t m;
  m.width = width;
  m.height = height;
  m.encoding = pplvo_msgs::image_t::ENCODING_RAW_U8;
  m.size = width * height * bytes_per_pixel;
  m.data.assign(static_cast<size_t>(m.size), 7);
  return m;
}

pplvo_msgs::features_t features() {
  pplvo_msgs::features_t m{};
  m.seq = 3;
  m.stamp = "1.25";
  m.n_points = 2;
  m.points.resize(2);
  m.point_descriptor_bytes = 4;
  m.point_descriptors.assign(2, std::vector<uint8_t>(4, 1));
  m.n_lines = 1;
  m.lines.resize(1);
  m.line_descriptor_bytes = 3;
  m.line_descriptors.assign(1, std::vector<uint8_t>(3, 2));
  m.n_planes = 1;
  m.planes.resize(1);
  m.plane_labels = image(4, 3, 1);
  return m;
}

pplvo_msgs::pose_t pose() {
  pplvo_msgs::pose_t m{};
  m.stamp = "12.5";
  m.n_window = 3;
  m.window_seq = {1, 2, 3};
  m.window_max_translation_variance = {0.1, 0.2, 0.3};
  return m;
}

pplvo_msgs::node_status_t status() {
  pplvo_msgs::node_status_t m{};
  m.node = "pplvo-test";
  m.n_stages = 2;
  m.stages.resize(2);
  m.stages[0].name = "decode";
  m.stages[1].name = "encode";
  m.last_warning = "none";
  return m;
}

pplvo_msgs::rgbd_frame_t frame() {
  pplvo_msgs::rgbd_frame_t m{};
  m.stamp = "0.5";
  m.source = "test";
  m.rgb = image(4, 3, 3);
  m.depth = image(4, 3, 2);
  return m;
}

pplvo_msgs::depth_map_t depth() {
  pplvo_msgs::depth_map_t m{};
  m.stamp = "0.5";
  m.depth = image(4, 3, 4);
  m.variance = image(4, 3, 4);
  return m;
}

template <class M>
std::vector<uint8_t> encode(const M& m) {
  std::vector<uint8_t> bytes(static_cast<size_t>(m.getEncodedSize()));
  EXPECT_EQ(m.encode(bytes.data(), 0, static_cast<int>(bytes.size())),
            static_cast<int>(bytes.size()));
  return bytes;
}

/// Total elements of every variable-length field, which a decoder sized from the packet.
size_t elements(const pplvo_msgs::image_t& m) { return m.data.size(); }
size_t elements(const pplvo_msgs::features_t& m) {
  size_t n = m.points.size() + m.point_descriptors.size() + m.lines.size() +
             m.line_descriptors.size() + m.planes.size() + m.stamp.size() +
             elements(m.plane_labels);
  for (const auto& d : m.point_descriptors) n += d.size();
  for (const auto& d : m.line_descriptors) n += d.size();
  return n;
}
size_t elements(const pplvo_msgs::pose_t& m) {
  return m.stamp.size() + m.window_seq.size() + m.window_max_translation_variance.size();
}
size_t elements(const pplvo_msgs::node_status_t& m) {
  size_t n = m.node.size() + m.stages.size() + m.last_warning.size();
  for (const auto& s : m.stages) n += s.name.size();
  return n;
}
size_t elements(const pplvo_msgs::rgbd_frame_t& m) {
  return m.stamp.size() + m.source.size() + elements(m.rgb) + elements(m.depth);
}
size_t elements(const pplvo_msgs::stream_event_t& m) { return m.source.size(); }
size_t elements(const pplvo_msgs::depth_map_t& m) {
  return m.stamp.size() + elements(m.depth) + elements(m.variance);
}

template <class M>
void expectEveryCorruptionDecodesOrFails(const M& original) {
  const std::vector<uint8_t> good = encode(original);
  {
    M m;
    ASSERT_EQ(decodeMessage(good.data(), good.size(), &m), "");
    EXPECT_EQ(encode(m), good);
  }
  int failed = 0;
  for (size_t at = 8; at + 4 <= good.size(); ++at) {
    for (const uint32_t v : {0xffffffffu, 0x80000000u, 0x7fffffffu, 0u, 0x00010000u}) {
      std::vector<uint8_t> bad = good;
      for (int i = 0; i < 4; ++i) bad[at + i] = static_cast<uint8_t>(v >> (24 - 8 * i));
      M m;
      int rc = 0;
      // The generated decoder itself: before the bounds, std::length_error / bad_alloc.
      ASSERT_NO_THROW(rc = m.decode(bad.data(), 0, static_cast<int>(bad.size())))
          << M::getTypeName() << " offset " << at << " value " << v;
      if (rc < 0) {
        ++failed;
      } else {
        EXPECT_LE(elements(m), bad.size()) << M::getTypeName() << " offset " << at;
      }
    }
  }
  EXPECT_GT(failed, 0) << M::getTypeName();
  for (size_t n = 0; n < good.size(); ++n) {
    M m;
    int rc = 0;
    ASSERT_NO_THROW(rc = m.decode(good.data(), 0, static_cast<int>(n))) << n;
    EXPECT_LT(rc, 0) << M::getTypeName() << " cut at " << n;
    EXPECT_NE(decodeMessage(good.data(), n, &m), "");
  }
}

TEST(HardenedDecoders, FeaturesT) { expectEveryCorruptionDecodesOrFails(features()); }
TEST(HardenedDecoders, PoseT) { expectEveryCorruptionDecodesOrFails(pose()); }
TEST(HardenedDecoders, NodeStatusT) { expectEveryCorruptionDecodesOrFails(status()); }
TEST(HardenedDecoders, RgbdFrameT) { expectEveryCorruptionDecodesOrFails(frame()); }
TEST(HardenedDecoders, DepthMapT) { expectEveryCorruptionDecodesOrFails(depth()); }
TEST(HardenedDecoders, StreamEventT) {
  pplvo_msgs::stream_event_t m{};
  m.source = "dataset";
  expectEveryCorruptionDecodesOrFails(m);
}

TEST(HardenedDecoders, EmptyArraysAndEmptyDescriptorRowsStillDecode) {
  pplvo_msgs::features_t m = features();
  m.point_descriptor_bytes = 0;  // rows of zero bytes: the outer dimension is bounded by the packet
  m.point_descriptors.assign(2, {});
  m.n_lines = 0;
  m.lines.clear();
  m.line_descriptors.clear();
  const std::vector<uint8_t> bytes = encode(m);
  pplvo_msgs::features_t out;
  ASSERT_EQ(decodeMessage(bytes.data(), bytes.size(), &out), "");
  EXPECT_EQ(out.point_descriptors.size(), 2u);
  EXPECT_EQ(encode(out), bytes);
}

TEST(DecodeMessage, ReportsTheTypeAndNeverThrows) {
  const std::vector<uint8_t> bytes = encode(pose());
  pplvo_msgs::features_t wrong_type;
  const std::string error = decodeMessage(bytes.data(), bytes.size(), &wrong_type);
  EXPECT_NE(error.find("features_t"), std::string::npos) << error;
  EXPECT_NE(error.find("fingerprint differs"), std::string::npos) << error;
}

// A frame written before rgbd_frame_t had depth_utime: its body is today's minus that field,
// and its fingerprint the one lcm-gen gave the old layout.
TEST(DecodeMessage, NamesAnOlderLogVersion) {
  std::vector<uint8_t> bytes = encode(frame());
  ASSERT_GE(bytes.size(), 24u);
  bytes.erase(bytes.begin() + 16, bytes.begin() + 24);  // fingerprint, utime, [depth_utime]
  const uint64_t old_fingerprint = 0x91c3a57269ce5245ULL;
  for (int i = 0; i < 8; ++i) bytes[i] = static_cast<uint8_t>(old_fingerprint >> (56 - 8 * i));
  pplvo_msgs::rgbd_frame_t out;
  const std::string error = decodeMessage(bytes.data(), bytes.size(), &out);
  EXPECT_NE(error.find("older log version"), std::string::npos) << error;
  EXPECT_NE(error.find("depth_utime"), std::string::npos) << error;

  // The layout before depth_frame / depth_camera / R_c_d / t_c_d_m (1 + 80 + 72 + 24 bytes at
  // the end).
  std::vector<uint8_t> before_rig = encode(frame());
  ASSERT_GT(before_rig.size(), 177u);
  before_rig.resize(before_rig.size() - 177);
  const uint64_t rig_fingerprint = 0xfb99a9fa90b73068ULL;
  for (int i = 0; i < 8; ++i) before_rig[i] = static_cast<uint8_t>(rig_fingerprint >> (56 - 8 * i));
  const std::string rig_error = decodeMessage(before_rig.data(), before_rig.size(), &out);
  EXPECT_NE(rig_error.find("older log version"), std::string::npos) << rig_error;
  EXPECT_NE(rig_error.find("depth_camera"), std::string::npos) << rig_error;

  // pose_t and depth_map_t before the reference role (one int8_t more today).
  auto withFingerprint = [](std::vector<uint8_t> packet, uint64_t fingerprint) {
    for (int i = 0; i < 8; ++i) packet[i] = static_cast<uint8_t>(fingerprint >> (56 - 8 * i));
    return packet;
  };
  const std::vector<uint8_t> old_pose = withFingerprint(encode(pose()), 0xefc8a0c530381bb2ULL);
  pplvo_msgs::pose_t pose_out;
  const std::string pose_error = decodeMessage(old_pose.data(), old_pose.size(), &pose_out);
  EXPECT_NE(pose_error.find("older log version: pose_t without reference"), std::string::npos)
      << pose_error;
  const std::vector<uint8_t> old_depth = withFingerprint(encode(depth()), 0x1ecd5069eeeacec5ULL);
  pplvo_msgs::depth_map_t depth_out;
  const std::string depth_error = decodeMessage(old_depth.data(), old_depth.size(), &depth_out);
  EXPECT_NE(depth_error.find("older log version: depth_map_t without reference"),
            std::string::npos)
      << depth_error;

  // depth_map_t before the time alignment was passed on (a double and an int64 fewer).
  std::vector<uint8_t> before_alignment = withFingerprint(encode(depth()), 0x3d3b45f8e04d8252ULL);
  before_alignment.resize(before_alignment.size() - 16);
  const std::string alignment_error =
      decodeMessage(before_alignment.data(), before_alignment.size(), &depth_out);
  EXPECT_NE(alignment_error.find("older log version: depth_map_t without time_alignment"),
            std::string::npos)
      << alignment_error;

  // Every message holding a camera_info_t before its readout_s.
  const std::vector<uint8_t> old_camera = withFingerprint(encode(frame()), 0xf83ee6370c017a62ULL);
  const std::string camera_error = decodeMessage(old_camera.data(), old_camera.size(), &out);
  EXPECT_NE(camera_error.find("older log version: rgbd_frame_t with a camera_info_t without "
                              "readout_s"),
            std::string::npos)
      << camera_error;

  // Today's layout still decodes, and carries the depth instant.
  pplvo_msgs::rgbd_frame_t now = frame();
  now.depth_utime = now.utime - 13000;
  const std::vector<uint8_t> current = encode(now);
  EXPECT_EQ(decodeMessage(current.data(), current.size(), &out), "");
  EXPECT_EQ(out.depth_utime, now.utime - 13000);
}

}  // namespace
}  // namespace pplvo::msgs
