// pplvo-viewer's node, headless, on a synthetic stream published in-process on memq://.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <string>
#include <thread>

#include "pplvo/msgs/convert_features.h"
#include "pplvo/msgs/convert_pose.h"
#include "synthetic_data.h"
#include "viewer_node.h"

namespace pplvo {
namespace viewer {
namespace {

std::string tempDir() {
  char tmpl[] = "/tmp/pplvo_viewer_test_XXXXXX";
  const char* d = mkdtemp(tmpl);
  EXPECT_NE(d, nullptr);
  return d ? d : "/tmp";
}

void publishFrame(lcm::LCM& lcm, int64_t seq) {
  const RgbdFrame f = testdata::frame(seq);
  const pplvo_msgs::rgbd_frame_t m =
      msgs::toMsg(f, 5000.0, pplvo_msgs::image_t::ENCODING_PNG,
                  pplvo_msgs::image_t::ENCODING_PNG_U16, "synthetic");
  lcm.publish(channels::kRgbd, &m);
}

void publishAll(lcm::LCM& lcm, int64_t seq) {
  publishFrame(lcm, seq);
  const FrameFeatures f2 = testdata::features(seq, false);
  const pplvo_msgs::features_t m2 = msgs::toMsg(f2, pplvo_msgs::features_t::STAGE_2D);
  lcm.publish(channels::kFeatures, &m2);
  const pplvo_msgs::pose_t p = msgs::toMsg(testdata::pose(seq));
  lcm.publish(channels::kPose, &p);
  const DepthWithVariance d = testdata::fused(seq);
  const RgbdFrame f = testdata::frame(seq);
  const pplvo_msgs::depth_map_t dm =
      msgs::toMsg(d, f.camera, f.utime, seq, f.stamp, pplvo_msgs::depth_map_t::STAGE_OGM, true);
  lcm.publish(channels::kDepthFused, &dm);
  const FrameFeatures f3 = testdata::features(seq, true);
  const pplvo_msgs::features_t m3 = msgs::toMsg(f3, pplvo_msgs::features_t::STAGE_3D);
  lcm.publish(channels::kFeatures3d, &m3);
  msgs::NodeCounters c;
  c.frames_in = seq + 1;
  c.last_seq = seq;
  StageTimings t;
  t.add("detect", 4.0 + static_cast<double>(seq));
  t.add("match", 1.5);
  const pplvo_msgs::node_status_t st = msgs::toStatusMsg("pplvo-frontend", c, t, f.utime);
  lcm.publish(channels::kStatus, &st);
}

ViewerOptions headless(const std::string& dir) {
  ViewerOptions o;
  o.show_window = false;
  o.snapshot_dir = dir;
  o.max_fps = 1000.0;  // draw on every spin in these tests
  return o;
}

void publishDepthMap(lcm::LCM& lcm, const std::string& channel, const DepthWithVariance& d,
                     int64_t seq, int64_t utime, int8_t stage) {
  const RgbdFrame f = testdata::frame(seq);
  const pplvo_msgs::depth_map_t m = msgs::toMsg(d, f.camera, utime, seq, f.stamp, stage, true);
  lcm.publish(channel, &m);
}

TEST(ViewerNode, CountsDepthOnlyThroughFusionAgainstTheSameFramesCgm) {
  lcm::LCM lcm("memq://");
  ASSERT_TRUE(lcm.good());
  ViewerNode node(headless(""), lcm);
  const int64_t seq = 3;
  const RgbdFrame f = testdata::frame(seq);
  const DepthWithVariance fused = testdata::fused(seq);
  // The frame's own (C-GM) depth misses the left quarter: a narrower depth camera.
  DepthWithVariance cgm = testdata::fused(seq);
  const int quarter = cgm.depth_m.cols / 4;
  cgm.depth_m(cv::Rect(0, 0, quarter, cgm.depth_m.rows)).setTo(0);
  cgm.var_m2(cv::Rect(0, 0, quarter, cgm.depth_m.rows)).setTo(0);
  const FusionOnlyDepth want = fusionOnlyPixels(fused.depth_m, cgm.depth_m);
  ASSERT_GT(want.n_fusion_only, 0);

  publishFrame(lcm, seq);
  publishDepthMap(lcm, channels::kDepthCgm, cgm, seq, f.utime, pplvo_msgs::depth_map_t::STAGE_CGM);
  publishDepthMap(lcm, channels::kDepthFused, fused, seq, f.utime,
                  pplvo_msgs::depth_map_t::STAGE_OGM);
  node.spinOnce(0.0);
  ASSERT_TRUE(node.frameData().status.fusion_only_px);
  EXPECT_EQ(*node.frameData().status.fusion_only_px, want.n_fusion_only);
  EXPECT_DOUBLE_EQ(node.frameData().status.fusion_only_share, want.share());
  EXPECT_EQ(cv::countNonZero(node.frameData().fusion_only_mask != want.mask), 0);
  EXPECT_EQ(node.counters().errors, 0);

  // The next fused map without its frame's C-GM map (other seq): unknown, no tint.
  publishDepthMap(lcm, channels::kDepthFused, fused, seq + 1, f.utime + 33333,
                  pplvo_msgs::depth_map_t::STAGE_OGM);
  node.spinOnce(0.0);
  EXPECT_FALSE(node.frameData().status.fusion_only_px);
  EXPECT_TRUE(node.frameData().fusion_only_mask.empty());
  // Its C-GM map arriving late (frames on other routes) fills it in.
  publishDepthMap(lcm, channels::kDepthCgm, cgm, seq + 1, f.utime + 33333,
                  pplvo_msgs::depth_map_t::STAGE_CGM);
  node.spinOnce(0.0);
  ASSERT_TRUE(node.frameData().status.fusion_only_px);
  EXPECT_EQ(*node.frameData().status.fusion_only_px, want.n_fusion_only);

  // A C-GM map published as the fused one (O-GM off or failed): nothing is fusion-only.
  publishDepthMap(lcm, channels::kDepthCgm, cgm, seq + 2, f.utime + 66666,
                  pplvo_msgs::depth_map_t::STAGE_CGM);
  publishDepthMap(lcm, channels::kDepthFused, cgm, seq + 2, f.utime + 66666,
                  pplvo_msgs::depth_map_t::STAGE_CGM);
  node.spinOnce(0.0);
  EXPECT_FALSE(node.frameData().status.fusion_only_px);

  // A C-GM map of another size than its fused map: counted as a skipped message, no crash.
  DepthWithVariance small;
  small.depth_m = cv::Mat(8, 8, CV_32FC1, cv::Scalar(1.0f));
  small.var_m2 = cv::Mat(8, 8, CV_32FC1, cv::Scalar(1e-4f));
  PinholeCamera small_camera = f.camera;  // a consistent message: only the sizes differ
  small_camera.width = small_camera.height = 8;
  const pplvo_msgs::depth_map_t small_msg = msgs::toMsg(
      small, small_camera, f.utime + 99999, seq + 3, f.stamp, pplvo_msgs::depth_map_t::STAGE_CGM);
  lcm.publish(channels::kDepthCgm, &small_msg);
  publishDepthMap(lcm, channels::kDepthFused, fused, seq + 3, f.utime + 99999,
                  pplvo_msgs::depth_map_t::STAGE_OGM);
  node.spinOnce(0.0);
  EXPECT_FALSE(node.frameData().status.fusion_only_px);
  // Another C-GM map arriving (the next frame's) does not count the bad pair again.
  publishDepthMap(lcm, channels::kDepthCgm, cgm, seq + 4, f.utime + 133332,
                  pplvo_msgs::depth_map_t::STAGE_CGM);
  node.spinOnce(0.0);
  EXPECT_EQ(node.counters().messages_skipped, 1);
  EXPECT_EQ(node.counters().errors, 0);
  EXPECT_NE(node.counters().last_warning.find("sizes differ"), std::string::npos)
      << node.counters().last_warning;
  EXPECT_FALSE(node.lastCanvas().empty());
}

TEST(ViewerNode, CreatesItsSnapshotFolder) {
  const std::string root = tempDir();
  const std::string dir = root + "/not/yet/there";
  lcm::LCM lcm("memq://");
  ASSERT_TRUE(lcm.good());
  ViewerNode node(headless(dir), lcm);
  publishAll(lcm, 0);
  node.spinOnce(0.0);
  EXPECT_EQ(node.snapshotsWritten(), 1);
  EXPECT_FALSE(cv::imread(dir + "/canvas_000000.png").empty());
  EXPECT_EQ(node.counters().errors, 0);
  // A folder that cannot be created (a path through a regular file) fails at construction.
  const std::string file = dir + "/canvas_000000.png";
  EXPECT_THROW(ViewerNode(headless(file + "/sub"), lcm), std::runtime_error);
  std::filesystem::remove_all(root);
}

TEST(ViewerNode, HeadlessSnapshotsShowEveryPanelAndTheOverlay) {
  const std::string dir = tempDir();
  lcm::LCM lcm("memq://");
  ASSERT_TRUE(lcm.good());
  ViewerOptions o = headless(dir);
  o.every = 2;
  ViewerNode node(o, lcm);
  const int n = 6;
  for (int64_t seq = 0; seq < n; ++seq) {
    publishAll(lcm, seq);
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
    EXPECT_GE(node.spinOnce(0.0), 6);
  }
  EXPECT_EQ(node.canvasesDrawn(), n);
  EXPECT_EQ(node.snapshotsWritten(), n / 2);
  EXPECT_EQ(node.counters().frames_in, n);
  EXPECT_EQ(node.counters().frames_dropped, 0);
  EXPECT_EQ(node.counters().errors, 0);
  EXPECT_EQ(node.counters().frames_skipped, 0);
  const cv::Mat last = cv::imread(dir + "/canvas_000004.png");
  ASSERT_FALSE(last.empty());
  EXPECT_FALSE(std::ifstream(dir + "/canvas_000005.png").good());  // --every 2
  const CanvasOptions co;
  ASSERT_EQ(last.size(), cv::Size(4 * co.cell.width, 2 * co.cell.height));
  const std::vector<cv::Rect> cells = canvasLayout(co);
  for (size_t i = 0; i < cells.size(); ++i) {
    EXPECT_GT(testdata::regionVariance(last(cells[i])), 50.0) << "panel " << i;
  }
  // Overlay: around each keypoint the colour panel differs from the plain image panel.
  const RgbdFrame f = testdata::frame(4);
  const RgbdFrame decoded = msgs::fromMsg(msgs::toMsg(f, 5000.0, pplvo_msgs::image_t::ENCODING_PNG,
                                                      pplvo_msgs::image_t::ENCODING_PNG_U16));
  const cv::Mat plain = renderFeaturePanel(decoded.bgr, nullptr, nullptr, "x", co.cell);
  cv::Mat diff;
  cv::absdiff(plain, last(cells[0]), diff);
  cv::cvtColor(diff, diff, cv::COLOR_BGR2GRAY);
  const cv::Rect img = featureImageRect(f.bgr.size(), co.cell);
  const double s = static_cast<double>(img.width) / f.bgr.cols;
  for (const PointFeature& p : testdata::features(4, true).points) {
    const cv::Point c(img.x + static_cast<int>(p.px.x() * s),
                      img.y + static_cast<int>(p.px.y() * s));
    EXPECT_GT(cv::countNonZero(diff(cv::Rect(c.x - 6, c.y - 6, 13, 13)) > 30), 10);
  }
  if (std::getenv("PPLVO_VIEWER_TEST_KEEP")) {  // for looking at the canvas by eye
    std::printf("snapshots kept in %s\n", dir.c_str());
    return;
  }
  // Away from features and planes the image is the plain image (same frame shown).
  const cv::Rect free_area(img.x + static_cast<int>(180 * s), img.y + static_cast<int>(80 * s),
                           static_cast<int>(100 * s), static_cast<int>(50 * s));
  EXPECT_LT(cv::countNonZero(diff(free_area) > 10), free_area.area() / 50);
  std::system(("rm -rf " + dir).c_str());
}

TEST(ViewerNode, DropsFramesItCannotDrawAndReportsIt) {
  lcm::LCM lcm("memq://");
  ViewerOptions o;
  o.show_window = false;
  o.max_fps = 15.0;
  o.status_period_s = 0.0;  // publish status on every spin
  ViewerNode node(o, lcm);
  // A burst of 20 frames: only the newest is drawn.
  for (int64_t seq = 0; seq < 20; ++seq) publishFrame(lcm, seq);
  node.spinOnce(0.0);
  EXPECT_EQ(node.counters().frames_in, 20);
  EXPECT_EQ(node.counters().frames_dropped, 19);
  EXPECT_EQ(node.canvasesDrawn(), 1);
  EXPECT_EQ(node.counters().frames_out, 1);
  // Three frames per spin for 0.6 s against --max-fps 15: at least two of every three are
  // dropped whatever the machine's speed, and at most ~15 canvases per second are drawn.
  const auto start = std::chrono::steady_clock::now();
  int64_t seq = 20;
  int spins = 0;
  while (std::chrono::steady_clock::now() - start < std::chrono::milliseconds(600)) {
    for (int k = 0; k < 3; ++k) publishFrame(lcm, seq++);
    node.spinOnce(0.0);
    ++spins;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  const double elapsed_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  node.drawIfNew();
  const int64_t received = seq;
  EXPECT_EQ(node.counters().frames_in, received);
  // Each frame is either drawn or dropped.
  EXPECT_EQ(node.counters().frames_out + node.counters().frames_dropped, received);
  EXPECT_LE(node.canvasesDrawn(), 1 + static_cast<int64_t>(std::ceil(15.0 * elapsed_s)) + 2);
  EXPECT_GE(node.counters().frames_dropped, 19 + 2 * spins);
  EXPECT_GT(spins, 3);
  // The drop count is published in the viewer's node_status_t and printed on the canvas
  // (status panel; checked through the counters it is rendered from).
  struct Catcher {
    int64_t dropped = -1;
    void on(const lcm::ReceiveBuffer*, const std::string&, const pplvo_msgs::node_status_t* m) {
      if (m->node == "pplvo-viewer") dropped = m->frames_dropped;
    }
  } catcher;
  lcm.subscribe(channels::kStatus, &Catcher::on, &catcher);
  node.spinOnce(0.0);   // publishes
  node.spinOnce(0.01);  // delivers
  EXPECT_EQ(catcher.dropped, node.counters().frames_dropped);
}

TEST(ViewerNode, BadMessagesAreCountedNotFatal) {
  const std::string dir = tempDir();
  lcm::LCM lcm("memq://");
  ViewerNode node(headless(dir), lcm);
  pplvo_msgs::rgbd_frame_t m =
      msgs::toMsg(testdata::frame(0), 5000.0, pplvo_msgs::image_t::ENCODING_PNG,
                  pplvo_msgs::image_t::ENCODING_PNG_U16);
  m.depth.data.resize(m.depth.data.size() / 2);  // truncated PNG, size field disagrees
  m.depth.size = static_cast<int32_t>(m.depth.data.size());
  lcm.publish(channels::kRgbd, &m);
  pplvo_msgs::pose_t p = msgs::toMsg(testdata::pose(0));
  p.position[0] = NAN;
  lcm.publish(channels::kPose, &p);
  node.spinOnce(0.0);
  EXPECT_EQ(node.counters().messages_skipped, 2);
  EXPECT_EQ(node.canvasesDrawn(), 1);  // still draws (panels say "no data")
  // A features message with a corrupt label image is counted once, not at every later draw.
  pplvo_msgs::features_t f =
      msgs::toMsg(testdata::features(0, false), pplvo_msgs::features_t::STAGE_2D);
  ASSERT_GT(f.plane_labels.data.size(), 16u);
  f.plane_labels.data.resize(f.plane_labels.data.size() / 2);
  f.plane_labels.size = static_cast<int32_t>(f.plane_labels.data.size());
  lcm.publish(channels::kFeatures, &f);
  node.spinOnce(0.0);
  publishFrame(lcm, 1);
  std::this_thread::sleep_for(std::chrono::milliseconds(2));
  node.spinOnce(0.0);
  EXPECT_EQ(node.counters().messages_skipped, 3);
  EXPECT_EQ(node.canvasesDrawn(), 3);
  publishAll(lcm, 2);
  std::this_thread::sleep_for(std::chrono::milliseconds(2));
  node.spinOnce(0.0);
  EXPECT_EQ(node.canvasesDrawn(), 4);
  EXPECT_EQ(node.counters().messages_skipped, 3);
  std::system(("rm -rf " + dir).c_str());
}

TEST(ViewerNode, ExitsAfterStreamEndAndWritesVideo) {
  const std::string dir = tempDir();
  lcm::LCM lcm("memq://");
  ViewerOptions o = headless("");
  o.video_path = dir + "/out.avi";
  o.exit_after_end = true;
  o.timeout_s = 20.0;
  o.max_fps = 30.0;
  ViewerNode node(o, lcm);
  for (int64_t seq = 0; seq < 4; ++seq) publishAll(lcm, seq);
  pplvo_msgs::stream_event_t end{};
  end.event = pplvo_msgs::stream_event_t::EVENT_END;
  end.frames_published = 4;
  lcm.publish(channels::kStream, &end);
  const auto start = std::chrono::steady_clock::now();
  EXPECT_EQ(node.run(), 0);
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 5.0);
  EXPECT_TRUE(node.streamEnded());
  EXPECT_GE(node.canvasesDrawn(), 1);
  cv::VideoCapture cap(dir + "/out.avi", cv::CAP_OPENCV_MJPEG);  // OpenCV's own reader
  ASSERT_TRUE(cap.isOpened());
  cv::Mat frame;
  ASSERT_TRUE(cap.read(frame));
  EXPECT_EQ(frame.size(), cv::Size(1600, 900));
  std::system(("rm -rf " + dir).c_str());
}

TEST(ViewerNode, GroundTruthIsShownInTheTrajectoryViews) {
  const std::string dir = tempDir();
  // Ground truth = the synthetic poses in a rotated world frame, drifting away by 3 cm per frame.
  std::string gt_path = dir + "/gt.txt";
  {
    FILE* f = std::fopen(gt_path.c_str(), "w");
    ASSERT_NE(f, nullptr);
    const Pose3 T_g_w =
        makePose(Eigen::Vector3d(1, 2, 0.5),
                 Eigen::Quaterniond(Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitX())));
    for (int i = 0; i < 20; ++i) {
      const FramePose p = testdata::pose(i);
      const Pose3 T = T_g_w * p.T_w_c;
      const Eigen::Quaterniond q(T.rotation());
      std::fprintf(f, "%s %.9f %.9f %.9f %.9f %.9f %.9f %.9f\n", p.stamp.c_str(),
                   T.translation().x() + 0.03 * i, T.translation().y(), T.translation().z(), q.x(),
                   q.y(), q.z(), q.w());
    }
    std::fclose(f);
  }
  lcm::LCM lcm("memq://");
  ViewerOptions o = headless(dir);
  o.groundtruth_path = gt_path;
  ViewerNode with_gt(o, lcm);
  for (int64_t seq = 0; seq < 20; ++seq) {
    const pplvo_msgs::pose_t p = msgs::toMsg(testdata::pose(seq));
    lcm.publish(channels::kPose, &p);
  }
  with_gt.spinOnce(0.0);
  ASSERT_FALSE(with_gt.lastCanvas().empty());
  const cv::Mat top = with_gt.lastCanvas()(canvasLayout()[4]);
  cv::Mat mask;
  cv::inRange(top, cv::Scalar(60, 180, 60), cv::Scalar(100, 220, 100), mask);
  EXPECT_GT(cv::countNonZero(mask), 100);  // the green ground-truth path
  o.groundtruth_path = dir + "/missing.txt";
  lcm::LCM lcm2("memq://");
  EXPECT_THROW(ViewerNode(o, lcm2), std::runtime_error);
  std::system(("rm -rf " + dir).c_str());
}

TEST(ViewerNode, ProgramReplaysAFileLogHeadless) {
  const std::string dir = tempDir();
  {
    lcm::LCM log("file://" + dir + "/run.lcmlog?mode=w");
    ASSERT_TRUE(log.good());
    for (int64_t seq = 0; seq < 5; ++seq) publishAll(log, seq);
    pplvo_msgs::stream_event_t end{};
    end.event = pplvo_msgs::stream_event_t::EVENT_END;
    log.publish(channels::kStream, &end);
  }
  // No DISPLAY: --headless must not touch the GUI.
  const std::string cmd =
      "env -u DISPLAY " + std::string(PPLVO_VIEWER_BINARY) + " --replay " + dir +
      "/run.lcmlog --replay-speed 0 --headless --max-fps 1000 --snapshot-dir " + dir + " 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  ASSERT_NE(p, nullptr);
  std::string out;
  char buf[512];
  while (fgets(buf, sizeof buf, p)) out += buf;
  EXPECT_EQ(pclose(p), 0) << out;
  EXPECT_NE(out.find("frames 5 "), std::string::npos) << out;
  const cv::Mat first = cv::imread(dir + "/canvas_000000.png");
  ASSERT_FALSE(first.empty()) << out;
  EXPECT_EQ(first.size(), cv::Size(1600, 900));
  // A log that does not exist is a clear failure.
  p = popen(("env -u DISPLAY " + std::string(PPLVO_VIEWER_BINARY) + " --replay " + dir +
             "/missing.lcmlog --headless 2>&1")
                .c_str(),
            "r");
  ASSERT_NE(p, nullptr);
  out.clear();
  while (fgets(buf, sizeof buf, p)) out += buf;
  EXPECT_NE(pclose(p), 0) << out;
  std::system(("rm -rf " + dir).c_str());
}

}  // namespace
}  // namespace viewer
}  // namespace pplvo
