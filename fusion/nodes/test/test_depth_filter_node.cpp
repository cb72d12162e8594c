// pplvo-depth-filter: message conversions round trip, in-process memq:// run, bad input, and
// bit-identical replay from a file:// log.
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <lcm/lcm-cpp.hpp>
#include <limits>
#include <string>
#include <thread>
#include <vector>

#include "pplvo/depth_filter_node/depth_filter_args.h"
#include "pplvo/depth_filter_node/depth_filter_convert.h"
#include "pplvo/depth_filter_node/depth_filter_node.h"
#include "pplvo/fixtures/analytic_scene.h"
#include "pplvo/msgs/convert.h"
#include "pplvo/msgs/convert_pose.h"
#include "pplvo/node/process.h"

namespace pplvo::nodes {
namespace {

using fixtures::AnalyticScene;
using fixtures::SceneOptions;

SceneOptions smallScene() {
  SceneOptions o;
  o.width = 160;
  o.height = 120;
  o.fx = o.fy = 131.25;
  o.cx = 79.5;
  o.cy = 59.5;
  o.quantise_disparity = false;  // 1/8 px steps are ~11 cm at 3 m with fx = 131
  return o;
}

pplvo_msgs::rgbd_frame_t frameMsg(const AnalyticScene& scene, int i) {
  RgbdFrame f;
  f.utime = 1000000 + 33333 * i;
  f.seq = i;
  f.stamp = std::to_string(i);
  f.camera = scene.camera();
  f.bgr = cv::Mat(f.camera.height, f.camera.width, CV_8UC1, cv::Scalar(128));
  f.depth_m = scene.render(i).depth_m;
  return msgs::toMsg(f, 5000.0, pplvo_msgs::image_t::ENCODING_RAW_GRAY8,
                     pplvo_msgs::image_t::ENCODING_RAW_U16);
}

pplvo_msgs::pose_t poseMsg(const AnalyticScene& scene, int i,
                           const std::vector<std::pair<int64_t, double>>& w = {}) {
  FramePose p;
  p.utime = 1000000 + 33333 * i;
  p.seq = i;
  p.stamp = std::to_string(i);
  p.status = TrackingStatus::kTracking;
  p.T_w_c = scene.pose(i);
  for (const auto& [seq, var_m2] : w) p.window.push_back({seq, var_m2});
  return msgs::toMsg(p);
}

/// Collects depth maps (decoded and as encoded bytes).
struct Collector {
  std::vector<pplvo_msgs::depth_map_t> cgm, fused;
  std::vector<std::vector<uint8_t>> bytes;
  void onDepth(const lcm::ReceiveBuffer* rbuf, const std::string& channel,
               const pplvo_msgs::depth_map_t* msg) {
    (channel == channels::kDepthCgm ? cgm : fused).push_back(*msg);
    const auto* b = static_cast<const uint8_t*>(rbuf->data);
    bytes.emplace_back(b, b + rbuf->data_size);
  }
};

void drain(lcm::LCM& lcm) {
  while (lcm.handleTimeout(0) > 0) {
  }
}

TEST(DepthFilterConvert, PoseWindowAndDepthRoundTrip) {
  // The node decodes pose_t with msgs::fromMsg; the fields it uses survive the round trip.
  FramePose p;
  p.utime = 123;
  p.seq = 7;
  p.stamp = "7.000";
  p.status = TrackingStatus::kVelocityModel;
  p.T_w_c =
      makePose(Eigen::Vector3d(1, -2, 3),
               Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized())));
  p.window = {{5, 1e-5}, {6, 2e-4}};
  const FramePose q = msgs::fromMsg(msgs::toMsg(p));
  EXPECT_EQ(q.utime, 123);
  EXPECT_EQ(q.seq, 7);
  EXPECT_EQ(q.stamp, "7.000");
  EXPECT_EQ(q.status, p.status);
  EXPECT_TRUE(q.T_w_c.isApprox(p.T_w_c, 1e-12));
  ASSERT_EQ(q.window.size(), 2u);
  for (size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(q.window[i].seq, p.window[i].seq);
    EXPECT_EQ(q.window[i].max_translation_variance_m2, p.window[i].max_translation_variance_m2);
  }
  pplvo_msgs::pose_t bad = msgs::toMsg(p);
  bad.n_window = 3;
  EXPECT_THROW(msgs::fromMsg(bad), msgs::MessageError);

  DepthWithVariance d;
  d.depth_m = cv::Mat(4, 6, CV_32FC1, cv::Scalar(2.5f));
  d.var_m2 = cv::Mat(4, 6, CV_32FC1, cv::Scalar(1e-4f));
  d.depth_m.at<float>(1, 2) = 0.f;
  d.var_m2.at<float>(1, 2) = 0.f;
  d.window_length = 4;
  PinholeCamera cam;
  cam.width = 6;
  cam.height = 4;
  cam.fx = cam.fy = 5;
  cam.cx = 2.5;
  cam.cy = 1.5;
  for (bool compress : {false, true}) {
    const DepthWithVariance e =
        depthFromMsg(depthToMsg(d, cam, 1, 2, "s", pplvo_msgs::depth_map_t::STAGE_OGM, compress));
    EXPECT_EQ(cv::norm(e.depth_m, d.depth_m, cv::NORM_INF), 0.0);
    EXPECT_EQ(cv::norm(e.var_m2, d.var_m2, cv::NORM_INF), 0.0);
    EXPECT_EQ(e.window_length, 4);
  }
  // The packet the node publishes uncompressed: the same map and fields, the pose's reference.
  std::vector<uint8_t> packet;
  encodeDepthPacket(d, cam, 1, 2, "s", pplvo_msgs::depth_map_t::STAGE_OGM, 2, &packet);
  pplvo_msgs::depth_map_t m;
  ASSERT_EQ(m.decode(packet.data(), 0, static_cast<int>(packet.size())),
            static_cast<int>(packet.size()));
  EXPECT_EQ(m.seq, 2);
  EXPECT_EQ(m.stamp, "s");
  EXPECT_EQ(m.reference, 2);
  EXPECT_EQ(m.depth.encoding, pplvo_msgs::image_t::ENCODING_RAW_F32);
  const DepthWithVariance e = depthFromMsg(m);
  EXPECT_EQ(cv::norm(e.depth_m, d.depth_m, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(e.var_m2, d.var_m2, cv::NORM_INF), 0.0);
  EXPECT_EQ(e.window_length, 4);
}

TEST(DepthFilterNode, MemqFramesAndPosesGiveCgmAndFusedMaps) {
  AnalyticScene scene(smallScene());
  lcm::LCM lcm("memq://");
  ASSERT_TRUE(lcm.good());
  DepthFilterNodeOptions o;
  o.filter.ogm.max_window = 5;
  DepthFilterNode node(o, lcm);
  Collector c;
  lcm.subscribe(channels::kDepthCgm, &Collector::onDepth, &c);
  lcm.subscribe(channels::kDepthFused, &Collector::onDepth, &c);
  const int n = 8;
  for (int i = 0; i < n; ++i) {
    pplvo_msgs::rgbd_frame_t f = frameMsg(scene, i);
    lcm.publish(channels::kRgbd, &f);
    drain(lcm);
    ASSERT_EQ(static_cast<int>(c.cgm.size()), i + 1);  // C-GM at once, before the pose
    pplvo_msgs::pose_t p = poseMsg(scene, i);
    // What the estimator says of the frame reaches the frontend with its fused depth.
    p.reference = i % 3 == 0 ? pplvo_msgs::pose_t::REFERENCE_YES
                             : pplvo_msgs::pose_t::REFERENCE_FALLBACK_ONLY;
    lcm.publish(channels::kPose, &p);
    drain(lcm);
    ASSERT_EQ(static_cast<int>(c.fused.size()), i + 1);
    EXPECT_EQ(c.fused.back().seq, i);
    EXPECT_EQ(c.fused.back().reference, p.reference);
    EXPECT_EQ(c.cgm.back().reference, pplvo_msgs::pose_t::REFERENCE_UNKNOWN);
    EXPECT_EQ(c.fused.back().stage, pplvo_msgs::depth_map_t::STAGE_OGM);
    EXPECT_EQ(c.fused.back().window_length, std::min(i + 1, 5));
    EXPECT_EQ(c.cgm.back().stage, pplvo_msgs::depth_map_t::STAGE_CGM);
  }
  // The fused map is close to the truth on the wall centre.
  const DepthWithVariance fused = depthFromMsg(c.fused.back());
  const cv::Mat truth = scene.render(n - 1).depth_true_m;
  EXPECT_NEAR(fused.depth_m.at<float>(10, 150), truth.at<float>(10, 150), 0.02);
  EXPECT_GT(fused.var_m2.at<float>(10, 150), 0.f);
  EXPECT_EQ(node.counters().frames_in, n);
  EXPECT_EQ(node.counters().frames_out, n);
  EXPECT_EQ(node.counters().errors, 0);
  node.publishStatus(1);
  drain(lcm);
}

TEST(DepthFilterNode, FusingOnAWorkerPublishesTheSameMapsInFrameOrder) {
  // All frames and their poses at once (a loop that posed ahead of the fusion): the worker
  // fuses them in order; the fused maps come when published, byte for byte the handler's.
  AnalyticScene scene(smallScene());
  std::vector<std::vector<uint8_t>> fused_bytes[2];
  for (const bool worker : {false, true}) {
    lcm::LCM lcm("memq://");
    ASSERT_TRUE(lcm.good());
    DepthFilterNodeOptions o;
    o.filter.ogm.max_window = 5;
    o.fuse_on_worker = worker;
    DepthFilterNode node(o, lcm);
    Collector c;
    lcm.subscribe(channels::kDepthFused, &Collector::onDepth, &c);
    const int n = 6;
    for (int i = 0; i < n; ++i) {
      pplvo_msgs::rgbd_frame_t f = frameMsg(scene, i);
      lcm.publish(channels::kRgbd, &f);
      pplvo_msgs::pose_t p = poseMsg(scene, i);
      lcm.publish(channels::kPose, &p);
    }
    drain(lcm);
    while (node.publishFusions(true)) drain(lcm);
    EXPECT_FALSE(node.fusing());
    EXPECT_FALSE(node.publishFusions(true));  // nothing left: no wait
    ASSERT_EQ(static_cast<int>(c.fused.size()), n);
    for (int i = 0; i < n; ++i) {
      EXPECT_EQ(c.fused[static_cast<size_t>(i)].seq, i);
      EXPECT_EQ(c.fused[static_cast<size_t>(i)].stage, pplvo_msgs::depth_map_t::STAGE_OGM);
    }
    EXPECT_EQ(node.counters().frames_out, n);
    EXPECT_EQ(node.counters().errors, 0);
    fused_bytes[worker ? 1 : 0] = c.bytes;
  }
  EXPECT_TRUE(fused_bytes[0] == fused_bytes[1]);
}

// Depth 15 ms older than colour: frame j's depth is moved with the velocity of frames j-3 and
// j-2. A frame that comes before the pose of frame j-2 (another channel, another port in a
// launch) waits for it, so the motion is the same in every layout; a pose that never comes
// costs only max_alignment_wait_ms.
TEST(DepthFilterNode, FrameWaitsForThePoseItsTimeAlignmentNeeds) {
  AnalyticScene scene(smallScene());
  lcm::LCM lcm("memq://");
  DepthFilterNodeOptions o;
  o.max_alignment_wait_ms = 50;
  DepthFilterNode node(o, lcm);
  Collector c;
  lcm.subscribe(channels::kDepthCgm, &Collector::onDepth, &c);
  const auto frame = [&](int i) {
    pplvo_msgs::rgbd_frame_t f = frameMsg(scene, i);
    f.depth_utime = f.utime - 15000;
    lcm.publish(channels::kRgbd, &f);
    drain(lcm);
  };
  const auto pose = [&](int i) {
    pplvo_msgs::pose_t p = poseMsg(scene, i);
    lcm.publish(channels::kPose, &p);
    drain(lcm);
  };
  frame(0);  // frames 0 and 1 need poses of frames that never were
  frame(1);
  pose(0);
  frame(2);  // the pose of frame 0 is there
  EXPECT_EQ(c.cgm.size(), 3u);
  frame(3);  // needs the pose of frame 1, which frame 1 still waits for
  EXPECT_EQ(c.cgm.size(), 3u);
  EXPECT_EQ(node.deferred(), 1);
  frame(4);  // behind frame 3, in order
  EXPECT_EQ(node.deferred(), 2);
  pose(1);  // frame 3 can go; frame 4 needs the pose of frame 2
  ASSERT_EQ(c.cgm.size(), 4u);
  EXPECT_EQ(c.cgm.back().seq, 3);
  // What the map says of its alignment: frame 2 had no motion yet (one pose), frame 3 was
  // moved by the motion into frame 1 scaled by -15 ms over the frame interval.
  EXPECT_EQ(c.cgm[2].time_alignment_motion_seq, -1);
  EXPECT_EQ(c.cgm[3].time_alignment_motion_seq, 1);
  const double interval_us =
      static_cast<double>(frameMsg(scene, 1).utime - frameMsg(scene, 0).utime);
  EXPECT_NEAR(c.cgm[3].time_alignment_scale, -15000.0 / interval_us, 1e-9);
  pose(2);
  ASSERT_EQ(c.cgm.size(), 5u);
  EXPECT_EQ(c.cgm.back().seq, 4);
  EXPECT_EQ(node.alignmentWaitsTimedOut(), 0);
  // The pose of frame 3 never comes: frame 5 goes on after the wait, counted.
  frame(5);
  EXPECT_EQ(node.deferred(), 1);
  node.poll();
  EXPECT_EQ(node.deferred(), 1);  // not yet 50 ms
  std::this_thread::sleep_for(std::chrono::milliseconds(60));
  node.poll();
  drain(lcm);
  EXPECT_EQ(node.deferred(), 0);
  ASSERT_EQ(c.cgm.size(), 6u);
  EXPECT_EQ(node.alignmentWaitsTimedOut(), 1);
  EXPECT_NE(node.counters().last_warning.find("older velocity"), std::string::npos);
}

TEST(DepthFilterNode, OverloadWindowRule) {
  DepthFilterNodeOptions o;  // window 10; more than 2 newer frames waiting: 2 shorter per frame
  ASSERT_EQ(o.filter.ogm.max_window, 10);
  ASSERT_EQ(o.filter.overload.backlog, 2);
  EXPECT_EQ(overloadWindow(0, o), 0);
  EXPECT_EQ(overloadWindow(2, o), 0);
  EXPECT_EQ(overloadWindow(3, o), 8);
  EXPECT_EQ(overloadWindow(4, o), 6);
  EXPECT_EQ(overloadWindow(6, o), 2);
  EXPECT_EQ(overloadWindow(1000000, o), 2);  // never below the frame and one past frame
  o.filter.overload.window_step = 5;
  EXPECT_EQ(overloadWindow(3, o), 5);
  o.filter.ogm.max_window = 2;  // nothing to shorten
  EXPECT_EQ(overloadWindow(1000, o), 0);
  o.filter.ogm.max_window = 10;
  o.filter.overload.backlog = 0;  // never
  EXPECT_EQ(overloadWindow(1000, o), 0);
}

/// Poses that come while newer frames wait (a live loop slower than the sensor) fuse fewer
/// frames until the backlog is gone; the frames left out still serve later fusions.
TEST(DepthFilterNode, BacklogOfFramesShortensTheWindowUntilCaughtUp) {
  AnalyticScene scene(smallScene());
  DepthFilterNodeOptions o;
  o.filter.ogm.max_window = 10;
  o.filter.overload.backlog = 2;
  o.filter.overload.window_step = 4;
  // Frames 0-5 each with its pose at once, then frames 6-10 before the pose of frame 6.
  auto run = [&](const DepthFilterNodeOptions& options, int64_t* shortened) {
    lcm::LCM lcm("memq://");
    EXPECT_TRUE(lcm.good());
    DepthFilterNode node(options, lcm);
    Collector c;
    lcm.subscribe(channels::kDepthFused, &Collector::onDepth, &c);
    std::vector<int> windows;
    auto frame = [&](int i) {
      pplvo_msgs::rgbd_frame_t f = frameMsg(scene, i);
      lcm.publish(channels::kRgbd, &f);
      drain(lcm);
    };
    auto pose = [&](int i) {
      pplvo_msgs::pose_t p = poseMsg(scene, i);
      lcm.publish(channels::kPose, &p);
      drain(lcm);
      windows.push_back(c.fused.back().window_length);
    };
    for (int i = 0; i < 6; ++i) {
      frame(i);
      pose(i);
    }
    for (int i = 6; i < 11; ++i) frame(i);
    for (int i = 6; i < 11; ++i) pose(i);
    EXPECT_EQ(node.counters().frames_out, 11);
    EXPECT_EQ(node.counters().frames_dropped, 0);
    *shortened = node.overloadFusions();
    const StageStats* st = node.timings().find("ogm_shortened");  // in node_status_t too
    EXPECT_EQ(st ? st->count : 0, *shortened);
    return windows;
  };
  int64_t shortened = 0;
  // Pose 6 with 4 newer frames waiting: 10 - 2 * 4 = 2 frames; pose 7 with 3: 10 - 4 = 6; then
  // caught up: frames 0-8, 0-9, 1-10.
  EXPECT_EQ(run(o, &shortened), (std::vector<int>{1, 2, 3, 4, 5, 6, 2, 6, 9, 10, 10}));
  EXPECT_EQ(shortened, 2);
  o.filter.overload.backlog = 0;  // off: the same backlog fuses the whole window
  EXPECT_EQ(run(o, &shortened), (std::vector<int>{1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 10}));
  EXPECT_EQ(shortened, 0);
}

TEST(DepthFilterNode, CgmModelPublishesCgmAsFused) {
  AnalyticScene scene(smallScene());
  lcm::LCM lcm("memq://");
  DepthFilterNodeOptions o;
  ASSERT_TRUE(parseDepthModel("cgm", &o.filter.model));
  DepthFilterNode node(o, lcm);
  Collector c;
  lcm.subscribe(channels::kDepthCgm, &Collector::onDepth, &c);
  lcm.subscribe(channels::kDepthFused, &Collector::onDepth, &c);
  for (int i = 0; i < 3; ++i) {
    pplvo_msgs::rgbd_frame_t f = frameMsg(scene, i);
    lcm.publish(channels::kRgbd, &f);
    pplvo_msgs::pose_t p = poseMsg(scene, i);
    lcm.publish(channels::kPose, &p);
    drain(lcm);
  }
  ASSERT_EQ(c.fused.size(), 3u);
  EXPECT_EQ(c.fused[2].stage, pplvo_msgs::depth_map_t::STAGE_CGM);
  EXPECT_EQ(c.fused[2].depth.data, c.cgm[2].depth.data);
  EXPECT_EQ(c.fused[2].variance.data, c.cgm[2].variance.data);
  DepthModel m;
  EXPECT_FALSE(parseDepthModel("bilateral", &m));
}

TEST(DepthFilterNode, RoutedFramesAndMapsNeverTouchTheMainInstance) {
  // pplvo-launch's layout: frames and depth maps on their own instances, poses and statuses
  // on the main one. Every message must travel where its route says.
  AnalyticScene scene(smallScene());
  lcm::LCM main_lcm("memq://"), frames("memq://"), maps("memq://");
  msgs::Bus bus(main_lcm);
  bus.route(channels::kRgbd, frames);
  bus.route(channels::kDepthCgm, maps);
  bus.route(channels::kDepthFused, maps);
  DepthFilterNodeOptions o;
  DepthFilterNode node(o, bus);
  Collector c;
  maps.subscribe(channels::kDepthCgm, &Collector::onDepth, &c);
  maps.subscribe(channels::kDepthFused, &Collector::onDepth, &c);
  Collector wrong;
  main_lcm.subscribe("PPLVO_DEPTH_.*", &Collector::onDepth, &wrong);
  for (int i = 0; i < 3; ++i) {
    pplvo_msgs::rgbd_frame_t f = frameMsg(scene, i);
    frames.publish(channels::kRgbd, &f);
    pplvo_msgs::pose_t p = poseMsg(scene, i);
    main_lcm.publish(channels::kPose, &p);
    while (bus.handleTimeout(0) > 0) {
    }
    drain(maps);
    drain(main_lcm);
  }
  EXPECT_EQ(c.cgm.size(), 3u);
  EXPECT_EQ(c.fused.size(), 3u);
  EXPECT_TRUE(wrong.cgm.empty());
  EXPECT_TRUE(wrong.fused.empty());
  EXPECT_EQ(node.counters().frames_out, 3);
}

TEST(DepthFilterNode, BadInputIsCountedNeverFatal) {
  AnalyticScene scene(smallScene());
  lcm::LCM lcm("memq://");
  DepthFilterNodeOptions o;
  o.max_pending = 3;
  DepthFilterNode node(o, lcm);
  Collector c;
  lcm.subscribe(channels::kDepthFused, &Collector::onDepth, &c);
  // Pose for a frame never seen.
  pplvo_msgs::pose_t p = poseMsg(scene, 42);
  lcm.publish(channels::kPose, &p);
  drain(lcm);
  EXPECT_EQ(node.unknownPoses(), 1);
  // Corrupt frame: depth payload size disagrees.
  pplvo_msgs::rgbd_frame_t f = frameMsg(scene, 0);
  f.depth.data.resize(10);
  f.depth.size = 10;
  lcm.publish(channels::kRgbd, &f);
  drain(lcm);
  EXPECT_EQ(node.counters().messages_skipped, 1);  // the pose: no frame of this node
  EXPECT_EQ(node.counters().frames_skipped, 1);    // the frame
  EXPECT_TRUE(msgs::countsAddUp(node.counters()));
  // All-zero depth frame: C-GM and fusion run, empty map out.
  RgbdFrame z;
  z.seq = 1;
  z.camera = scene.camera();
  z.bgr = cv::Mat(z.camera.height, z.camera.width, CV_8UC1, cv::Scalar(0));
  z.depth_m = cv::Mat::zeros(z.camera.height, z.camera.width, CV_32FC1);
  f = msgs::toMsg(z, 5000.0, pplvo_msgs::image_t::ENCODING_RAW_GRAY8,
                  pplvo_msgs::image_t::ENCODING_RAW_U16);
  lcm.publish(channels::kRgbd, &f);
  p = poseMsg(scene, 1);
  lcm.publish(channels::kPose, &p);
  drain(lcm);
  ASSERT_EQ(c.fused.size(), 1u);
  EXPECT_EQ(cv::countNonZero(depthFromMsg(c.fused[0]).depth_m), 0);
  // NaN pose: rejected by msgs::fromMsg (never reaches the fusion), counted as a skipped
  // message; the frame's C-GM is still published as fused.
  f = frameMsg(scene, 2);
  lcm.publish(channels::kRgbd, &f);
  p = poseMsg(scene, 2);
  p.position[0] = std::numeric_limits<double>::quiet_NaN();
  lcm.publish(channels::kPose, &p);
  drain(lcm);
  ASSERT_EQ(c.fused.size(), 2u);
  EXPECT_EQ(c.fused[1].stage, pplvo_msgs::depth_map_t::STAGE_CGM);
  EXPECT_EQ(node.ogmStats().invalid_poses, 0);
  EXPECT_EQ(node.counters().messages_skipped, 2);
  EXPECT_EQ(node.counters().frames_skipped, 1);
  EXPECT_EQ(node.counters().frames_out, 2);  // frame 2 went out despite its bad pose
  EXPECT_EQ(node.counters().errors, 0);
  // Frames whose pose never comes: bounded queue drops the oldest.
  for (int i = 3; i < 9; ++i) {
    f = frameMsg(scene, i);
    lcm.publish(channels::kRgbd, &f);
    drain(lcm);
  }
  EXPECT_EQ(node.pending(), 3);
  EXPECT_EQ(node.counters().frames_dropped, 3);
  EXPECT_EQ(node.counters().frames_pending, 3);
  EXPECT_TRUE(msgs::countsAddUp(node.counters()));
  // Pose of frame 8 drops the stale 6 and 7.
  p = poseMsg(scene, 8);
  lcm.publish(channels::kPose, &p);
  drain(lcm);
  EXPECT_EQ(node.counters().frames_dropped, 5);
  EXPECT_EQ(node.counters().frames_pending, 0);
  EXPECT_EQ(c.fused.back().seq, 8);
  // A frame of another size resets the window with a counted warning.
  SceneOptions so = smallScene();
  so.width = 80;
  so.height = 60;
  so.fx = so.fy = 65.6;
  so.cx = 39.5;
  so.cy = 29.5;
  AnalyticScene small(so);
  f = frameMsg(small, 9);
  lcm.publish(channels::kRgbd, &f);
  p = poseMsg(small, 9);
  lcm.publish(channels::kPose, &p);
  drain(lcm);
  EXPECT_EQ(node.ogmStats().size_changes, 1);
  EXPECT_EQ(c.fused.back().window_length, 1);
  EXPECT_EQ(node.counters().errors, 0);
  // Every frame accounted for: 10 in = 4 out (1, 2, 8, 9) + 5 dropped + 1 skipped.
  EXPECT_EQ(node.counters().frames_in, 10);
  EXPECT_EQ(node.counters().frames_out, 4);
  EXPECT_TRUE(msgs::countsAddUp(node.counters()));
}

TEST(DepthFilterNode, NonFinitePosesAreCountedSkips) {
  // Every kind of pose msgs::fromMsg rejects is one counted skip (not an error), releases the
  // frame's C-GM as fused output, and leaves the node working for the next frame.
  AnalyticScene scene(smallScene());
  lcm::LCM lcm("memq://");
  DepthFilterNode node(DepthFilterNodeOptions{}, lcm);
  Collector c;
  lcm.subscribe(channels::kDepthFused, &Collector::onDepth, &c);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<std::function<void(pplvo_msgs::pose_t&)>> spoil = {
      [&](pplvo_msgs::pose_t& m) { m.position[2] = nan; },
      [&](pplvo_msgs::pose_t& m) { m.orientation[0] = nan; },
      [&](pplvo_msgs::pose_t& m) { m.window_max_translation_variance[0] = nan; },
      [&](pplvo_msgs::pose_t& m) { m.rel_covariance[7] = std::numeric_limits<double>::infinity(); },
  };
  int seq = 0;
  for (size_t k = 0; k < spoil.size(); ++k, ++seq) {
    pplvo_msgs::rgbd_frame_t f = frameMsg(scene, seq);
    lcm.publish(channels::kRgbd, &f);
    pplvo_msgs::pose_t p = poseMsg(scene, seq, {{seq - 1, 1e-5}});
    spoil[k](p);
    lcm.publish(channels::kPose, &p);
    drain(lcm);
    EXPECT_EQ(node.counters().messages_skipped, static_cast<int64_t>(k + 1)) << "case " << k;
    EXPECT_EQ(node.counters().frames_out, static_cast<int64_t>(k + 1)) << "case " << k;
    EXPECT_NE(node.counters().last_warning.find("skipped bad message"), std::string::npos)
        << node.counters().last_warning;
    ASSERT_EQ(c.fused.size(), k + 1);
    EXPECT_EQ(c.fused.back().seq, seq);
    EXPECT_EQ(c.fused.back().stage, pplvo_msgs::depth_map_t::STAGE_CGM);
  }
  EXPECT_EQ(node.pending(), 0);
  EXPECT_EQ(node.ogmStats().invalid_poses, 0);
  // A NaN pose for a frame that is not pending is still one counted skip, nothing published.
  pplvo_msgs::pose_t orphan = poseMsg(scene, 100);
  orphan.position[0] = nan;
  lcm.publish(channels::kPose, &orphan);
  drain(lcm);
  EXPECT_EQ(node.counters().messages_skipped, static_cast<int64_t>(spoil.size() + 1));
  EXPECT_EQ(node.counters().frames_skipped, 0);
  EXPECT_EQ(c.fused.size(), spoil.size());
  // A good pose afterwards is fused normally.
  pplvo_msgs::rgbd_frame_t f = frameMsg(scene, 101);
  lcm.publish(channels::kRgbd, &f);
  pplvo_msgs::pose_t good = poseMsg(scene, 101);
  lcm.publish(channels::kPose, &good);
  drain(lcm);
  ASSERT_EQ(c.fused.size(), spoil.size() + 1);
  EXPECT_EQ(c.fused.back().stage, pplvo_msgs::depth_map_t::STAGE_OGM);
  EXPECT_EQ(node.counters().errors, 0);
}

/// Replays a log onto a fresh node on a fresh memq:// instance; returns the output bytes.
std::vector<std::vector<uint8_t>> replay(const std::string& path) {
  lcm::LCM lcm("memq://");
  DepthFilterNodeOptions o;
  DepthFilterNode node(o, lcm);
  Collector c;
  lcm.subscribe(channels::kDepthCgm, &Collector::onDepth, &c);
  lcm.subscribe(channels::kDepthFused, &Collector::onDepth, &c);
  lcm::LogFile log(path, "r");
  EXPECT_TRUE(log.good());
  while (const lcm::LogEvent* e = log.readNextEvent()) {
    lcm.publish(e->channel, e->data, static_cast<unsigned int>(e->datalen));
    drain(lcm);
  }
  return c.bytes;
}

TEST(DepthFilterNode, ReplayFromLogIsBitIdentical) {
  AnalyticScene scene(smallScene());
  const std::string path = "/tmp/pplvo_depth_filter_replay_" + std::to_string(getpid()) + ".lcmlog";
  {
    lcm::LogFile log(path, "w");
    ASSERT_TRUE(log.good());
    auto write = [&](const std::string& channel, const auto& msg, int64_t t) {
      std::vector<uint8_t> buf(msg.getEncodedSize());
      msg.encode(buf.data(), 0, static_cast<int>(buf.size()));
      lcm::LogEvent e;
      e.eventnum = 0;
      e.timestamp = t;
      e.channel = channel;
      e.datalen = static_cast<int32_t>(buf.size());
      e.data = buf.data();
      ASSERT_EQ(log.writeEvent(&e), 0);
    };
    for (int i = 0; i < 12; ++i) {
      write(channels::kRgbd, frameMsg(scene, i), 2 * i);
      // Window frames older than 3 get an uncertainty above the default threshold.
      std::vector<std::pair<int64_t, double>> w;
      for (int j = std::max(0, i - 9); j < i; ++j) w.emplace_back(j, (i - j) > 6 ? 2e-4 : 1e-5);
      write(channels::kPose, poseMsg(scene, i, w), 2 * i + 1);
    }
  }
  const auto a = replay(path);
  const auto b = replay(path);
  std::remove(path.c_str());
  ASSERT_EQ(a.size(), 24u);
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) EXPECT_TRUE(a[i] == b[i]) << "message " << i;
  // The uncertainty threshold kept the window at 7 frames (current + 6 within 1e-4 m^2).
  pplvo_msgs::depth_map_t last;
  ASSERT_EQ(last.decode(a.back().data(), 0, static_cast<int>(a.back().size())),
            static_cast<int>(a.back().size()));
  EXPECT_EQ(last.window_length, 7);
}

TEST(DepthFilterArgs, ConfigSetAndShortcutsOnTheDepthFilterSchema) {
  const std::string config = std::string(std::getenv("PPLVO_SOURCE_DIR")) + "/config/pplvo.yaml";
  // The same command line as a launch gives it: keys of other sections are the other processes'.
  const DepthFilterArgs a = parseDepthFilterArgs({"--config",
                                                  config,
                                                  "--set",
                                                  "depth_filter.ogm.k_consistency=2",
                                                  "--set",
                                                  "frontend.points.max_points=500",
                                                  "--window",
                                                  "7",
                                                  "--depth-model=cgm",
                                                  "--max-translation-variance",
                                                  "2e-4",
                                                  "--overload-backlog",
                                                  "0",
                                                  "--overload-step",
                                                  "3",
                                                  "--features",
                                                  "points,planes",
                                                  "--lcm-url",
                                                  "memq://",
                                                  "--route",
                                                  "PPLVO_RGBD=memq://",
                                                  "--max-pending",
                                                  "9",
                                                  "--compress",
                                                  "--fuse-on-worker",
                                                  "--prefault-mb",
                                                  "0"});
  EXPECT_TRUE(a.errors.empty()) << a.errors.front();
  EXPECT_FALSE(a.help);
  const depth_filter::DepthFilterOptions& f = a.options.filter;
  EXPECT_EQ(f.ogm.k_consistency, 2);
  EXPECT_EQ(f.ogm.max_window, 7);
  EXPECT_EQ(f.model, depth_filter::DepthModel::kCgm);
  EXPECT_EQ(f.ogm.max_translation_variance_m2, 2e-4);
  EXPECT_EQ(f.overload.backlog, 0);
  EXPECT_EQ(f.overload.window_step, 3);
  EXPECT_EQ(a.options.lcm_url, "memq://");
  EXPECT_EQ(a.options.routes.size(), 1u);
  EXPECT_EQ(a.options.max_pending, 9);
  EXPECT_TRUE(a.options.compress);
  EXPECT_TRUE(a.options.fuse_on_worker);
  EXPECT_EQ(a.prefault_mb, 0);
  // Defaults: the depth filter schema's.
  const DepthFilterArgs d = parseDepthFilterArgs({});
  EXPECT_TRUE(d.errors.empty());
  EXPECT_EQ(d.options.filter.ogm.max_window, 10);
  EXPECT_EQ(d.options.filter.overload.backlog, 2);
  EXPECT_FALSE(d.options.fuse_on_worker);
  EXPECT_EQ(d.prefault_mb, 64);
}

TEST(DepthFilterArgs, BadValuesAreExitCodeTwoWithTheKeysRange) {
  const DepthFilterArgs a =
      parseDepthFilterArgs({"--window", "0", "--set", "depth_filter.ogm.gate_sigma=-1",
                            "--overload-step", "x", "--bogus", "--max-translation-variance", "0"});
  ASSERT_EQ(a.errors.size(), 5u);
  EXPECT_EQ(a.errors[0], "unknown option '--bogus'");
  EXPECT_NE(a.errors[1].find("overrides: configuration has 1 error(s):\n  "
                             "depth_filter.ogm.gate_sigma: -1.0 is out of range (must be > 0.0)"),
            std::string::npos)
      << a.errors[1];
  // --window has the range of depth_filter.ogm.max_window (one place: the schema).
  EXPECT_EQ(a.errors[2],
            "--window 0: depth_filter.ogm.max_window: 0 is out of range (must be >= 1)");
  EXPECT_EQ(a.errors[3],
            "--overload-step x: depth_filter.overload.window_step: cannot read 'x' as an integer");
  EXPECT_EQ(a.errors[4],
            "--max-translation-variance 0: depth_filter.ogm.max_translation_variance_m2: 0.0 is "
            "out of range (must be > 0.0)");
  testing::internal::CaptureStdout();
  testing::internal::CaptureStderr();
  EXPECT_EQ(node::argsExitCode(DepthFilterNode::kName, a.help, a.errors, depthFilterUsage()), 2);
  const std::string err = testing::internal::GetCapturedStderr();
  testing::internal::GetCapturedStdout();
  EXPECT_NE(err.find("pplvo-depth-filter: --window 0: depth_filter.ogm.max_window: 0 is out of "
                     "range (must be >= 1)\n"),
            std::string::npos)
      << err;
  // Keys of the depth filter's own section are still checked strictly.
  const DepthFilterArgs typo = parseDepthFilterArgs({"--set", "depth_filter.ogm.max_windw=3"});
  ASSERT_EQ(typo.errors.size(), 1u);
  EXPECT_NE(typo.errors[0].find("depth_filter.ogm.max_windw: unknown key"), std::string::npos);
}

TEST(DepthFilterArgs, Help) {
  const DepthFilterArgs a = parseDepthFilterArgs({"--window", "3", "--help"});
  EXPECT_TRUE(a.help);
  testing::internal::CaptureStdout();
  EXPECT_EQ(node::argsExitCode(DepthFilterNode::kName, a.help, a.errors, depthFilterUsage()), 0);
  const std::string out = testing::internal::GetCapturedStdout();
  for (const char* flag : {"--window N", "--depth-model MODEL", "--config FILE", "--set KEY=VALUE",
                           "--overload-backlog N", "--route CHANNEL=URL", "--compress"})
    EXPECT_NE(out.find(flag), std::string::npos) << flag << " in\n" << out;
  EXPECT_NE(out.find("(= --set depth_filter.ogm.max_window)"), std::string::npos) << out;
}

}  // namespace
}  // namespace pplvo::nodes
