// pplvo-frontend and pplvo-estimator nodes on one memq:// LCM: message pairing in any order,
// bounded queues, the reference hand-over between the two stages, restarts when a reference
// never comes, counted skips for bad messages; and the pipeline's command-line options.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <lcm/lcm-cpp.hpp>
#include <limits>
#include <pplvo_msgs/features_t.hpp>
#include <pplvo_msgs/odometry_t.hpp>
#include <pplvo_msgs/pose_t.hpp>
#include <thread>

#include "pplvo/core/args.h"
#include "pplvo/depth_filter/cgm_filter.h"
#include "pplvo/fixtures/synthetic_sequence.h"
#include "pplvo/msgs/convert_features.h"
#include "pplvo/msgs/convert_pose.h"
#include "pplvo/node/process.h"
#include "pplvo/odometry_nodes/estimator_node.h"
#include "pplvo/odometry_nodes/frontend_node.h"
#include "pplvo/odometry_nodes/odometry_args.h"
#include "pplvo/pipeline/pipeline_args.h"

namespace pplvo::nodes {
namespace {

const std::vector<synth::SynthFrame>& frames() {
  static const std::vector<synth::SynthFrame> f = [] {
    synth::SynthOptions o;
    o.frames = 6;
    o.seed = 5;
    synth::SyntheticSequence seq(o);
    std::vector<synth::SynthFrame> out;
    for (int i = 0; i < seq.size(); ++i) out.push_back(seq.render(i));
    return out;
  }();
  return f;
}

void drain(lcm::LCM& lcm) {
  while (lcm.handleTimeout(0) > 0) {
  }
}

/// Records every message of one type on one channel.
template <typename Msg>
struct Recorder {
  Recorder(lcm::LCM& lcm, const std::string& channel) : lcm_(lcm) {
    sub_ = lcm_.subscribe(channel, &Recorder::on, this);
  }
  ~Recorder() { lcm_.unsubscribe(sub_); }
  void on(const lcm::ReceiveBuffer*, const std::string&, const Msg* m) { msgs.push_back(*m); }
  lcm::LCM& lcm_;
  lcm::Subscription* sub_;
  std::vector<Msg> msgs;
};

pplvo_msgs::rgbd_frame_t frameMsg(int i) {
  return msgs::toMsg(frames()[i].frame, 5000.0, pplvo_msgs::image_t::ENCODING_RAW_BGR8,
                     pplvo_msgs::image_t::ENCODING_RAW_U16);
}

pplvo_msgs::depth_map_t cgmMsg(int i, int8_t stage = pplvo_msgs::depth_map_t::STAGE_CGM) {
  const RgbdFrame& f = frames()[i].frame;
  depth_filter::CgmFilter cgm;
  return msgs::toMsg(cgm.apply(f.depth_m), f.camera, f.utime, f.seq, f.stamp, stage);
}

TEST(FrontendNode, PairsColourAndDepthInAnyOrderAndLiftsOnFusedDepth) {
  for (const bool ahead : {false, true}) {
    SCOPED_TRACE(ahead ? "extract ahead" : "extract in the handler");
    lcm::LCM lcm("memq://");
    FrontendNodeOptions options;
    options.extract_ahead = ahead;
    FrontendNode node(options, lcm);
    Recorder<pplvo_msgs::features_t> f2d(lcm, channels::kFeatures), f3d(lcm, channels::kFeatures3d);
    // Frame 0: depth first; frame 1: colour first, and its depth after the next colour.
    auto m0 = frameMsg(0), m1 = frameMsg(1), m2 = frameMsg(2);
    auto d0 = cgmMsg(0), d1 = cgmMsg(1);
    // Frame 1's depth was moved to its colour instant: the features say by what.
    d1.time_alignment_scale = -0.4;
    d1.time_alignment_motion_seq = d1.seq - 1;
    lcm.publish(channels::kDepthCgm, &d0);
    lcm.publish(channels::kRgbd, &m0);
    lcm.publish(channels::kRgbd, &m1);
    lcm.publish(channels::kRgbd, &m2);
    lcm.publish(channels::kDepthCgm, &d1);
    drain(lcm);
    if (ahead) {
      // Frame 1 went to the worker while frame 0 waits for its fused depth; with nothing else
      // coming, the idle-loop poll publishes it once it is done.
      ASSERT_EQ(f2d.msgs.size(), 1u);
      for (int i = 0; i < 2000 && f2d.msgs.size() < 2; ++i) {
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
        node.poll();
        drain(lcm);
      }
    }
    ASSERT_EQ(f2d.msgs.size(), 2u);
    EXPECT_EQ(f2d.msgs[0].seq, m0.seq);
    EXPECT_EQ(f2d.msgs[1].seq, m1.seq);
    EXPECT_FALSE(msgs::fromMsg(f2d.msgs[0]).depth_time_alignment.moved());
    EXPECT_EQ(f2d.msgs[1].depth_alignment_scale, -0.4);
    EXPECT_EQ(f2d.msgs[1].depth_alignment_motion_seq, m1.seq - 1);
    for (const auto& m : f2d.msgs) {
      EXPECT_EQ(m.stage, pplvo_msgs::features_t::STAGE_2D);
      EXPECT_GT(m.n_points, 200);
      EXPECT_GT(m.n_lines, 10);
      EXPECT_GE(m.n_planes, 2);
    }
    EXPECT_TRUE(f3d.msgs.empty());
    // Fused depth of frame 1 arrives: frame 0 never gets one and is dropped (counted).
    auto fused1 = cgmMsg(1, pplvo_msgs::depth_map_t::STAGE_OGM);
    lcm.publish(channels::kDepthFused, &fused1);
    drain(lcm);
    ASSERT_EQ(f3d.msgs.size(), 1u);
    EXPECT_EQ(f3d.msgs[0].seq, m1.seq);
    const FrameFeatures lifted = msgs::fromMsg(f3d.msgs[0]);
    int with_3d = 0;
    for (const auto& p : lifted.points) with_3d += p.has_3d;
    EXPECT_GT(with_3d, 200);
    EXPECT_EQ(node.counters().frames_dropped, 1);
    EXPECT_EQ(node.counters().frames_out, 1);
  }
}

TEST(FrontendNode, ExtractsAheadWhileLiftingAndPublishesInFrameOrder) {
  // The pipelined order of pplvo-run: frame 1 is paired while frame 0 waits for its fused
  // depth; frame 1's stage 2D must come out after frame 0's stage 3D, equal to a serial run.
  auto run = [](bool ahead, std::vector<pplvo_msgs::features_t>* out) {
    lcm::LCM lcm("memq://");
    FrontendNodeOptions options;
    options.extract_ahead = ahead;
    FrontendNode node(options, lcm);
    struct Both {
      std::vector<pplvo_msgs::features_t>* out;
      void on(const lcm::ReceiveBuffer*, const std::string&, const pplvo_msgs::features_t* m) {
        out->push_back(*m);
      }
    } both{out};
    lcm.subscribe(channels::kFeatures, &Both::on, &both);
    lcm.subscribe(channels::kFeatures3d, &Both::on, &both);
    auto m0 = frameMsg(0), m1 = frameMsg(1);
    auto d0 = cgmMsg(0), d1 = cgmMsg(1);
    auto f0 = cgmMsg(0, pplvo_msgs::depth_map_t::STAGE_OGM);
    auto f1 = cgmMsg(1, pplvo_msgs::depth_map_t::STAGE_OGM);
    lcm.publish(channels::kRgbd, &m0);
    lcm.publish(channels::kDepthCgm, &d0);
    lcm.publish(channels::kRgbd, &m1);
    lcm.publish(channels::kDepthCgm, &d1);
    lcm.publish(channels::kDepthFused, &f0);
    drain(lcm);
    lcm.publish(channels::kDepthFused, &f1);
    drain(lcm);
    EXPECT_EQ(node.counters().frames_out, 2);
    EXPECT_EQ(node.counters().frames_dropped, 0);
  };
  std::vector<pplvo_msgs::features_t> serial, ahead;
  run(false, &serial);
  run(true, &ahead);
  ASSERT_EQ(ahead.size(), 4u);
  const std::vector<std::pair<int8_t, int64_t>> order = {{pplvo_msgs::features_t::STAGE_2D, 0},
                                                         {pplvo_msgs::features_t::STAGE_3D, 0},
                                                         {pplvo_msgs::features_t::STAGE_2D, 1},
                                                         {pplvo_msgs::features_t::STAGE_3D, 1}};
  ASSERT_EQ(serial.size(), 4u);
  auto encoded = [](const pplvo_msgs::features_t& m) {
    std::vector<uint8_t> bytes(m.getEncodedSize());
    m.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
    return bytes;
  };
  for (size_t i = 0; i < order.size(); ++i) {
    EXPECT_EQ(std::make_pair(ahead[i].stage, ahead[i].seq), order[i]) << i;
    // Same features as the serial run (which publishes frame 1's stage 2D at once).
    const auto same = std::find_if(serial.begin(), serial.end(), [&](const auto& m) {
      return std::make_pair(m.stage, m.seq) == order[i];
    });
    ASSERT_NE(same, serial.end()) << i;
    EXPECT_EQ(encoded(ahead[i]), encoded(*same)) << i;
  }
}

TEST(FrontendNode, DropsNewFramesBeforeExtractionWhileTheLoopIsBehind) {
  // Five frames, no fused depth ever: with max_unlifted 3 the fourth and fifth are dropped
  // before their (expensive, wasted) extraction; with 0 every frame is extracted.
  for (const int max_unlifted : {3, 0}) {
    SCOPED_TRACE("max_unlifted " + std::to_string(max_unlifted));
    lcm::LCM lcm("memq://");
    FrontendNodeOptions options;
    options.max_unlifted = max_unlifted;
    FrontendNode node(options, lcm);
    Recorder<pplvo_msgs::features_t> f2d(lcm, channels::kFeatures);
    for (int i = 0; i < 5; ++i) {
      auto m = frameMsg(i);
      auto d = cgmMsg(i);
      lcm.publish(channels::kRgbd, &m);
      lcm.publish(channels::kDepthCgm, &d);
      drain(lcm);
    }
    // Frame 0 went out at once; each later one waits on the worker until the next pairs.
    if (max_unlifted == 3) {
      EXPECT_EQ(node.counters().frames_dropped, 2);
      EXPECT_EQ(node.droppedLoopBehind(), 2);
      EXPECT_EQ(f2d.msgs.size(), 2u);  // frames 0 and 1; frame 2 still on the worker
      EXPECT_NE(node.counters().last_warning.find("dropped before extraction"), std::string::npos);
    } else {
      EXPECT_EQ(node.counters().frames_dropped, 0);
      EXPECT_EQ(node.droppedLoopBehind(), 0);
      EXPECT_EQ(f2d.msgs.size(), 4u);  // frames 0-3; frame 4 still on the worker
    }
  }
}

TEST(FrontendNode, ALoopThatDeliversNoFusedDepthForTheTimeBoundIsDropped) {
  // No fused depth ever (the loop lost it: a paused estimator). With max_unlifted 3 frames 3
  // and 4 are dropped before extraction; a frame 2 s later (stream time) finds no fused depth
  // came for more than max_unlifted_wait_ms: the queue is dropped and the frame extracted.
  // Without the time bound it stays full for good.
  for (const int wait_ms : {1000, 0}) {
    SCOPED_TRACE("max_unlifted_wait_ms " + std::to_string(wait_ms));
    lcm::LCM lcm("memq://");
    FrontendNodeOptions options;
    options.max_unlifted = 3;
    options.max_unlifted_wait_ms = wait_ms;
    FrontendNode node(options, lcm);
    Recorder<pplvo_msgs::features_t> f2d(lcm, channels::kFeatures);
    for (int i = 0; i < 6; ++i) {
      auto m = frameMsg(i);
      auto d = cgmMsg(i);
      if (i == 5) {
        m.utime += 2000000;
        d.utime = m.utime;
      }
      lcm.publish(channels::kRgbd, &m);
      lcm.publish(channels::kDepthCgm, &d);
      drain(lcm);
    }
    if (wait_ms > 0) {
      EXPECT_EQ(node.droppedLoopBehind(), 2);
      EXPECT_EQ(node.droppedUnliftedTimeout(), 2);  // frames 0 and 1 (2 was on the worker)
      EXPECT_EQ(node.counters().frames_dropped, 4);
      EXPECT_NE(node.counters().last_warning.find("no fused depth for"), std::string::npos)
          << node.counters().last_warning;
      node.poll();
      for (int k = 0; k < 500 && f2d.msgs.size() < 4; ++k) {
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
        node.poll();
        drain(lcm);
      }
      ASSERT_EQ(f2d.msgs.size(), 4u);  // frames 0, 1, 2 and then 5
      EXPECT_EQ(f2d.msgs.back().seq, frames()[5].frame.seq);
    } else {
      EXPECT_EQ(node.droppedLoopBehind(), 3);  // frames 3, 4 and 5
      EXPECT_EQ(node.droppedUnliftedTimeout(), 0);
    }
  }
}

TEST(FrontendNode, BadMessagesAreCountedAndQueuesStayBounded) {
  lcm::LCM lcm("memq://");
  FrontendNodeOptions o;
  o.max_pending = 3;
  FrontendNode node(o, lcm);
  Recorder<pplvo_msgs::features_t> f2d(lcm, channels::kFeatures);
  // Colour whose size disagrees with its camera: counted skip, not a crash.
  auto bad = frameMsg(0);
  bad.camera.width = 320;
  lcm.publish(channels::kRgbd, &bad);
  // A depth map whose byte count disagrees with its size.
  auto bad_depth = cgmMsg(0);
  bad_depth.depth.data.resize(10);
  bad_depth.depth.size = 10;
  lcm.publish(channels::kDepthCgm, &bad_depth);
  drain(lcm);
  EXPECT_EQ(node.counters().frames_skipped, 1);    // the frame
  EXPECT_EQ(node.counters().messages_skipped, 1);  // the depth map: not one of its frames
  // Colour without its depth: the queue never holds more than max_pending.
  for (int i = 0; i < 6; ++i) {
    auto m = frameMsg(i);
    lcm.publish(channels::kRgbd, &m);
  }
  drain(lcm);
  EXPECT_TRUE(f2d.msgs.empty());
  EXPECT_EQ(node.counters().frames_dropped, 3);
  EXPECT_EQ(node.counters().frames_pending, 3);
  // 7 in = 0 out + 3 dropped + 1 skipped + 3 pending.
  EXPECT_EQ(node.counters().frames_in, 7);
  EXPECT_TRUE(msgs::countsAddUp(node.counters()));
}

TEST(FrontendNode, CountsFramesLostBeforeReachingIt) {
  lcm::LCM lcm("memq://");
  FrontendNode node({}, lcm);
  for (int i : {0, 1, 4}) {  // frames 2 and 3 never arrive (e.g. a full socket buffer)
    auto m = frameMsg(i);
    auto d = cgmMsg(i);
    lcm.publish(channels::kRgbd, &m);
    lcm.publish(channels::kDepthCgm, &d);
    drain(lcm);
  }
  // Lost on the way, so not in: in = out + dropped + skipped + pending holds without them.
  EXPECT_EQ(node.counters().frames_lost, 2);
  EXPECT_EQ(node.counters().frames_in, 3);
  EXPECT_EQ(node.counters().frames_dropped, 0);
  EXPECT_TRUE(msgs::countsAddUp(node.counters()));
  EXPECT_NE(node.counters().last_warning.find("lost"), std::string::npos)
      << node.counters().last_warning;
  // A restarted source (seq back to 0) is not a loss.
  auto m0 = frameMsg(0);
  lcm.publish(channels::kRgbd, &m0);
  drain(lcm);
  EXPECT_EQ(node.counters().frames_lost, 2);
  EXPECT_TRUE(msgs::countsAddUp(node.counters()));
}

/// Stage-2D and stage-3D features of the synthetic frames, computed once by a frontend.
struct FeatureSet {
  std::vector<pplvo_msgs::features_t> f2d, f3d;
};
const FeatureSet& featureSet() {
  static const FeatureSet s = [] {
    lcm::LCM lcm("memq://");
    FrontendNode node({}, lcm);
    Recorder<pplvo_msgs::features_t> a(lcm, channels::kFeatures), b(lcm, channels::kFeatures3d);
    for (int i = 0; i < static_cast<int>(frames().size()); ++i) {
      auto m = frameMsg(i);
      auto d = cgmMsg(i);
      auto f = cgmMsg(i, pplvo_msgs::depth_map_t::STAGE_OGM);
      lcm.publish(channels::kRgbd, &m);
      lcm.publish(channels::kDepthCgm, &d);
      lcm.publish(channels::kDepthFused, &f);
      drain(lcm);
    }
    return FeatureSet{a.msgs, b.msgs};
  }();
  return s;
}

TEST(FrontendNode, FitsPlanesToTheFusedDepthOnlyForFramesTrackedAgainst) {
  // The fused depth 2 cm behind the C-GM one: planes fitted to it have other offsets.
  struct Case {
    int8_t reference;
    bool refitted;
  };
  for (const Case c : {Case{pplvo_msgs::pose_t::REFERENCE_UNKNOWN, true},
                       Case{pplvo_msgs::pose_t::REFERENCE_YES, true},
                       Case{pplvo_msgs::pose_t::REFERENCE_FALLBACK_ONLY, false}}) {
    SCOPED_TRACE(static_cast<int>(c.reference));
    lcm::LCM lcm("memq://");
    FrontendNodeOptions options;
    options.extract_ahead = false;
    FrontendNode node(options, lcm);
    Recorder<pplvo_msgs::features_t> f2d(lcm, channels::kFeatures), f3d(lcm, channels::kFeatures3d);
    auto m0 = frameMsg(0);
    auto d0 = cgmMsg(0);
    lcm.publish(channels::kRgbd, &m0);
    lcm.publish(channels::kDepthCgm, &d0);
    drain(lcm);
    ASSERT_EQ(f2d.msgs.size(), 1u);
    const RgbdFrame& f = frames()[0].frame;
    DepthWithVariance behind = depth_filter::CgmFilter().apply(f.depth_m);
    behind.depth_m.setTo(0, behind.depth_m <= 0);
    cv::Mat valid = behind.depth_m > 0;
    cv::add(behind.depth_m, 0.02, behind.depth_m, valid);
    pplvo_msgs::depth_map_t fused =
        msgs::toMsg(behind, f.camera, f.utime, f.seq, f.stamp, pplvo_msgs::depth_map_t::STAGE_OGM);
    fused.reference = c.reference;
    lcm.publish(channels::kDepthFused, &fused);
    drain(lcm);
    ASSERT_EQ(f3d.msgs.size(), 1u);
    const FrameFeatures cgm_planes = msgs::fromMsg(f2d.msgs[0]);
    const FrameFeatures lifted = msgs::fromMsg(f3d.msgs[0]);
    ASSERT_GE(cgm_planes.planes.size(), 2u);
    bool same = lifted.planes.size() == cgm_planes.planes.size();
    for (size_t i = 0; same && i < lifted.planes.size(); ++i) {
      same = lifted.planes[i].plane.hessian == cgm_planes.planes[i].plane.hessian;
    }
    EXPECT_EQ(same, !c.refitted);
    int with_3d = 0;
    for (const auto& p : lifted.points) with_3d += p.has_3d;
    EXPECT_GT(with_3d, 200);  // points are lifted either way
  }
}

TEST(EstimatorNode, TracksEachFrameOnceItsReferenceArrives) {
  const FeatureSet& fs = featureSet();
  ASSERT_EQ(fs.f2d.size(), frames().size());
  lcm::LCM lcm("memq://");
  EstimatorNode node({}, lcm);
  Recorder<pplvo_msgs::pose_t> poses(lcm, channels::kPose);
  Recorder<pplvo_msgs::odometry_t> odometry(lcm, channels::kOdometry);
  lcm.publish(channels::kFeatures, &fs.f2d[0]);
  drain(lcm);
  ASSERT_EQ(poses.msgs.size(), 1u);
  EXPECT_EQ(poses.msgs[0].status, pplvo_msgs::pose_t::STATUS_FIRST_FRAME);
  // Frame 1 waits for frame 0's 3D features.
  lcm.publish(channels::kFeatures, &fs.f2d[1]);
  drain(lcm);
  EXPECT_EQ(poses.msgs.size(), 1u);
  // The 3D features of a frame that is not the reference are ignored (counted).
  lcm.publish(channels::kFeatures3d, &fs.f3d[2]);
  drain(lcm);
  EXPECT_EQ(poses.msgs.size(), 1u);
  EXPECT_EQ(node.counters().messages_skipped, 1);
  EXPECT_EQ(node.counters().frames_skipped, 0);
  lcm.publish(channels::kFeatures3d, &fs.f3d[0]);
  drain(lcm);
  ASSERT_EQ(poses.msgs.size(), 2u);
  for (int i = 2; i < static_cast<int>(fs.f2d.size()); ++i) {
    lcm.publish(channels::kFeatures3d, &fs.f3d[i - 1]);
    lcm.publish(channels::kFeatures, &fs.f2d[i]);
    drain(lcm);
  }
  ASSERT_EQ(poses.msgs.size(), fs.f2d.size());
  for (size_t i = 1; i < poses.msgs.size(); ++i) {
    const FramePose p = msgs::fromMsg(poses.msgs[i]);
    EXPECT_EQ(p.seq, frames()[i].frame.seq);
    EXPECT_EQ(p.stamp, frames()[i].frame.stamp);
    EXPECT_EQ(p.status, TrackingStatus::kTracking) << i;
    const Pose3 truth = frames()[0].T_w_c.inverse() * frames()[i].T_w_c;
    EXPECT_LT((truth.translation() - p.T_w_c.translation()).norm(), 0.01) << i;
    EXPECT_FALSE(p.window.empty());
  }
  EXPECT_EQ(node.counts().tracking, static_cast<int64_t>(fs.f2d.size()) - 1);
  EXPECT_EQ(node.counters().frames_out, static_cast<int64_t>(fs.f2d.size()));
  EXPECT_EQ(node.counters().frames_pending, 0);
  EXPECT_TRUE(msgs::countsAddUp(node.counters()));
  // Body-frame odometry beside each pose: the camera's pose in REP-103 axes (identity mount),
  // a twist with its covariance from the second frame on.
  ASSERT_EQ(odometry.msgs.size(), poses.msgs.size());
  Pose3 A = Pose3::Identity();
  A.linear() = opticalToCameraBody();
  for (size_t i = 0; i < odometry.msgs.size(); ++i) {
    const BodyOdometry o = msgs::fromMsg(odometry.msgs[i]);
    const FramePose p = msgs::fromMsg(poses.msgs[i]);
    EXPECT_EQ(o.seq, p.seq);
    EXPECT_EQ(o.stamp, p.stamp);
    EXPECT_TRUE(o.T_odom_base.isApprox(A * p.T_w_c * A.inverse(), 1e-6)) << i;
    if (i == 0) continue;
    EXPECT_GT(o.dt_s, 0.0);
    EXPECT_GT(o.twist_covariance.trace(), 0.0);
    EXPECT_LT(o.twist_covariance.trace(), 1.0);
    EXPECT_GE(o.pose_covariance.trace(), msgs::fromMsg(odometry.msgs[i - 1]).pose_covariance.trace());
  }
  // Against keyframes (the default) the first frame is the first keyframe; the frames that
  // are not new keyframes are said to be needed only for a fallback.
  EXPECT_EQ(poses.msgs[0].reference, pplvo_msgs::pose_t::REFERENCE_YES);
  int fallback_only = 0;
  for (const auto& m : poses.msgs) {
    EXPECT_TRUE(m.reference == pplvo_msgs::pose_t::REFERENCE_YES ||
                m.reference == pplvo_msgs::pose_t::REFERENCE_FALLBACK_ONLY);
    fallback_only += m.reference == pplvo_msgs::pose_t::REFERENCE_FALLBACK_ONLY;
  }
  EXPECT_GT(fallback_only, 0);
}

TEST(EstimatorNode, RestartsHoldingThePoseWhenTheReferenceNeverComes) {
  const FeatureSet& fs = featureSet();
  lcm::LCM lcm("memq://");
  EstimatorNodeOptions o;
  o.max_waiting = 1;
  o.max_drops_without_reference = 1;
  // Frame to frame: every frame needs the previous one's 3D features (with keyframes a
  // frame is posed against the keyframe without them: KeyframesPoseWithoutThePreviousFrame).
  o.odometry.reference = tracking::TrackingReference::kFrame;
  EstimatorNode node(o, lcm);
  Recorder<pplvo_msgs::pose_t> poses(lcm, channels::kPose);
  lcm.publish(channels::kFeatures, &fs.f2d[0]);
  lcm.publish(channels::kFeatures3d, &fs.f3d[0]);
  lcm.publish(channels::kFeatures, &fs.f2d[1]);
  drain(lcm);
  ASSERT_EQ(poses.msgs.size(), 2u);
  // Frame 1's 3D features are lost: frames 2, 3, 4 arrive without a reference.
  for (int i = 2; i <= 4; ++i) {
    lcm.publish(channels::kFeatures, &fs.f2d[i]);
    drain(lcm);
  }
  ASSERT_EQ(poses.msgs.size(), 3u);
  const FramePose restart = msgs::fromMsg(poses.msgs[2]);
  EXPECT_EQ(restart.status, TrackingStatus::kReinitialised);
  EXPECT_EQ(restart.seq, frames()[4].frame.seq);
  // The last pose is held, not reset to the origin.
  const FramePose before = msgs::fromMsg(poses.msgs[1]);
  EXPECT_TRUE(restart.T_w_c.isApprox(before.T_w_c, 1e-12));
  EXPECT_EQ(node.counts().restarts_missing_reference, 1);
  EXPECT_GE(node.counters().frames_dropped, 2);
  // Tracking continues from the restart frame.
  lcm.publish(channels::kFeatures3d, &fs.f3d[4]);
  lcm.publish(channels::kFeatures, &fs.f2d[5]);
  drain(lcm);
  ASSERT_EQ(poses.msgs.size(), 4u);
  EXPECT_EQ(poses.msgs[3].status, pplvo_msgs::pose_t::STATUS_TRACKING);
}

TEST(EstimatorNode, RestartsWhenNoPoseCouldBeMadeForTheTimeBound) {
  // Frame 1's 3D features are lost and only two more frames come (a frontend that lost its
  // loop sends few): no drop, but they are 2 s of stream time past the last pose: tracking
  // restarts at the newest. Without the time bound they wait for good.
  const FeatureSet& fs = featureSet();
  for (const int wait_ms : {1000, 0}) {
    SCOPED_TRACE("max_reference_wait_ms " + std::to_string(wait_ms));
    lcm::LCM lcm("memq://");
    EstimatorNodeOptions o;
    o.max_reference_wait_ms = wait_ms;
    // Frame to frame: every frame needs the previous one's 3D features (with keyframes a
    // frame is posed against the keyframe without them: KeyframesPoseWithoutThePreviousFrame).
    o.odometry.reference = tracking::TrackingReference::kFrame;
    EstimatorNode node(o, lcm);
    Recorder<pplvo_msgs::pose_t> poses(lcm, channels::kPose);
    lcm.publish(channels::kFeatures, &fs.f2d[0]);
    lcm.publish(channels::kFeatures3d, &fs.f3d[0]);
    lcm.publish(channels::kFeatures, &fs.f2d[1]);
    drain(lcm);
    ASSERT_EQ(poses.msgs.size(), 2u);
    for (int i = 2; i <= 3; ++i) {
      auto late = fs.f2d[i];
      late.utime += 2000000;
      lcm.publish(channels::kFeatures, &late);
      drain(lcm);
    }
    if (wait_ms > 0) {
      ASSERT_EQ(poses.msgs.size(), 3u);
      EXPECT_EQ(poses.msgs[2].status, pplvo_msgs::pose_t::STATUS_REINITIALISED);
      EXPECT_EQ(poses.msgs[2].seq, frames()[3].frame.seq);
      EXPECT_EQ(node.counts().restarts_missing_reference, 1);
    } else {
      EXPECT_EQ(poses.msgs.size(), 2u);
    }
  }
}

TEST(EstimatorNode, KeyframesPoseWithoutThePreviousFrame) {
  // Against the keyframe, frame k+1 needs neither frame k's 3D features nor, until frame k+2,
  // its landmark fusion: the pose loop does not wait for frame k's fused depth.
  const FeatureSet& fs = featureSet();
  lcm::LCM lcm("memq://");
  EstimatorNode node({}, lcm);
  Recorder<pplvo_msgs::pose_t> poses(lcm, channels::kPose);
  Recorder<pplvo_msgs::odometry_t> odometry(lcm, channels::kOdometry);
  lcm.publish(channels::kFeatures, &fs.f2d[0]);
  lcm.publish(channels::kFeatures3d, &fs.f3d[0]);  // the first keyframe
  lcm.publish(channels::kFeatures, &fs.f2d[1]);
  lcm.publish(channels::kFeatures3d, &fs.f3d[1]);
  lcm.publish(channels::kFeatures, &fs.f2d[2]);  // against the keyframe
  drain(lcm);
  ASSERT_EQ(poses.msgs.size(), 3u);
  lcm.publish(channels::kFeatures, &fs.f2d[3]);  // without frame 2's 3D features
  drain(lcm);
  ASSERT_EQ(poses.msgs.size(), 4u);
  EXPECT_EQ(poses.msgs[3].status, pplvo_msgs::pose_t::STATUS_TRACKING);
  lcm.publish(channels::kFeatures, &fs.f2d[4]);  // frame 2's landmark fusion is due
  drain(lcm);
  EXPECT_EQ(poses.msgs.size(), 4u);
  lcm.publish(channels::kFeatures3d, &fs.f3d[2]);
  drain(lcm);
  ASSERT_EQ(poses.msgs.size(), 5u);
  EXPECT_EQ(poses.msgs[4].seq, frames()[4].frame.seq);
  EXPECT_EQ(node.counters().frames_skipped, 0);
  EXPECT_EQ(node.counters().frames_dropped, 0);
}

TEST(EstimatorNode, InconsistentMessagesAreCountedNotFatal) {
  const FeatureSet& fs = featureSet();
  lcm::LCM lcm("memq://");
  EstimatorNode node({}, lcm);
  Recorder<pplvo_msgs::pose_t> poses(lcm, channels::kPose);
  pplvo_msgs::features_t bad = fs.f2d[0];
  bad.points[3].u = std::numeric_limits<float>::quiet_NaN();  // decodes, but is garbage
  lcm.publish(channels::kFeatures, &bad);
  pplvo_msgs::features_t wrong_stage = fs.f2d[0];
  wrong_stage.stage = pplvo_msgs::features_t::STAGE_3D;
  lcm.publish(channels::kFeatures, &wrong_stage);
  drain(lcm);
  EXPECT_TRUE(poses.msgs.empty());
  EXPECT_EQ(node.counters().frames_skipped, 2);
  lcm.publish(channels::kFeatures, &fs.f2d[0]);
  drain(lcm);
  EXPECT_EQ(poses.msgs.size(), 1u);
}

TEST(PipelineArgs, ConfigSetFeaturesAndDepthModel) {
  pipeline::PipelineArgs pa;
  ArgParser p;
  pipeline::addPipelineOptions(p, &pa);
  const std::string config = std::string(std::getenv("PPLVO_SOURCE_DIR")) + "/config/pplvo.yaml";
  ASSERT_TRUE(
      p.parse({"--config", config, "--set", "features=[points, lines]",
               "--set=odometry.tracker.estimator.plane_scale_alpha=1", "--depth-model", "cgm"}));
  pipeline::PipelineOptions o;
  pipeline::applyPipelineArgs(pa, &o, &p);
  EXPECT_TRUE(p.ok());
  EXPECT_TRUE(o.frontend.families.points);
  EXPECT_TRUE(o.frontend.families.lines);
  EXPECT_FALSE(o.frontend.families.planes);
  EXPECT_FALSE(o.odometry.tracker.estimator.use_planes);
  EXPECT_DOUBLE_EQ(o.odometry.tracker.estimator.plane_scale_alpha, 1.0);
  EXPECT_EQ(o.depth_filter.model, depth_filter::DepthModel::kCgm);
}

TEST(PipelineArgs, ReportsEveryProblem) {
  pipeline::PipelineArgs pa;
  ArgParser p;
  pipeline::addPipelineOptions(p, &pa);
  p.parse({"--features", "points,surf", "--depth-model", "bilateral", "--config",
           "/nonexistent/pplvo.yaml"});
  pipeline::PipelineOptions o;
  pipeline::applyPipelineArgs(pa, &o, &p);
  ASSERT_EQ(p.errors().size(), 3u);
  EXPECT_NE(p.errors()[0].find("/nonexistent/pplvo.yaml"), std::string::npos);
  // The defaults are untouched.
  EXPECT_TRUE(o.frontend.families.lines);
  EXPECT_EQ(o.depth_filter.model, depth_filter::DepthModel::kOgm);
}

TEST(FrontendArgs, GoodBadAndHelp) {
  const FrontendArgs a = parseFrontendArgs(
      {"--lcm-url", "memq://", "--max-unlifted", "2", "--no-extract-ahead", "--features",
       "points,planes", "--set", "frontend.points.max_points=321", "--prefault-mb", "8"});
  EXPECT_TRUE(a.errors.empty()) << a.errors.front();
  EXPECT_EQ(a.options.lcm_url, "memq://");
  EXPECT_EQ(a.options.max_unlifted, 2);
  EXPECT_FALSE(a.options.extract_ahead);
  EXPECT_FALSE(a.options.frontend.families.lines);
  EXPECT_EQ(a.options.frontend.points.max_points, 321);
  EXPECT_EQ(a.prefault_mb, 8);
  EXPECT_EQ(parseFrontendArgs({}).prefault_mb, 64);

  const FrontendArgs bad = parseFrontendArgs({"--max-unlifted", "-1", "--depth-model", "gm"});
  ASSERT_EQ(bad.errors.size(), 2u);
  EXPECT_EQ(bad.errors[0], "--max-unlifted: expected an integer in [0, 1000], got '-1'");
  EXPECT_EQ(bad.errors[1],
            "--depth-model gm: depth_filter.model: invalid value 'gm' (choose one of: sensor, "
            "cgm, ogm)");
  testing::internal::CaptureStdout();
  testing::internal::CaptureStderr();
  EXPECT_EQ(node::argsExitCode(FrontendNode::kName, bad.help, bad.errors, frontendUsage()), 2);
  EXPECT_NE(testing::internal::GetCapturedStderr().find("pplvo-frontend: --max-unlifted: expected"),
            std::string::npos);
  testing::internal::GetCapturedStdout();

  const FrontendArgs help = parseFrontendArgs({"-h", "--bogus"});
  EXPECT_TRUE(help.help);
  EXPECT_NE(frontendUsage().find("--max-unlifted-wait-ms MS"), std::string::npos);
  EXPECT_NE(frontendUsage().find("--set KEY=VALUE"), std::string::npos);
}

TEST(EstimatorArgs, GoodBadAndHelp) {
  const EstimatorArgs a =
      parseEstimatorArgs({"--max-waiting", "3", "--set", "odometry.tracker.window_length=12",
                          "--pose-channel", "P", "--route", "PPLVO_FEATURES=memq://"});
  EXPECT_TRUE(a.errors.empty()) << a.errors.front();
  EXPECT_EQ(a.options.max_waiting, 3);
  EXPECT_EQ(a.options.odometry.tracker.window_length, 12);
  EXPECT_EQ(a.options.pose_channel, "P");
  EXPECT_EQ(a.options.routes.size(), 1u);
  EXPECT_EQ(a.prefault_mb, 16);

  // The cross-module rule runs after every override: the tracker window must cover the fusion
  // window set by --set, and a --depth-model without O-GM lifts it.
  const EstimatorArgs bad =
      parseEstimatorArgs({"--set", "depth_filter.ogm.max_window=12", "--max-waiting", "0"});
  ASSERT_EQ(bad.errors.size(), 2u);  // reported together: the option and the broken rule
  EXPECT_EQ(bad.errors[0], "--max-waiting: expected an integer >= 1, got '0'");
  EXPECT_NE(bad.errors[1].find("is shorter than depth_filter.ogm.max_window 12"),
            std::string::npos);
  const EstimatorArgs rule = parseEstimatorArgs({"--set", "depth_filter.ogm.max_window=12"});
  ASSERT_EQ(rule.errors.size(), 1u);
  EXPECT_NE(rule.errors[0].find("window_length: 10 is shorter than depth_filter.ogm.max_window 12"),
            std::string::npos)
      << rule.errors[0];
  EXPECT_TRUE(
      parseEstimatorArgs({"--set", "depth_filter.ogm.max_window=12", "--depth-model", "cgm"})
          .errors.empty());
  testing::internal::CaptureStdout();
  testing::internal::CaptureStderr();
  EXPECT_EQ(node::argsExitCode(EstimatorNode::kName, rule.help, rule.errors, estimatorUsage()), 2);
  EXPECT_NE(testing::internal::GetCapturedStderr().find("pplvo-estimator: odometry.tracker"),
            std::string::npos);
  testing::internal::GetCapturedStdout();
  EXPECT_TRUE(parseEstimatorArgs({"--help"}).help);
  EXPECT_NE(estimatorUsage().find("--max-reference-wait-ms MS"), std::string::npos);
}

}  // namespace
}  // namespace pplvo::nodes
