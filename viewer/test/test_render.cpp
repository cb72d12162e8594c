// Render functions of pplvo_viewer_render, one by one, on analytic data.
#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/imgproc.hpp>

#include "pplvo/viewer/render.h"
#include "pplvo/viewer/ticks.h"
#include "synthetic_data.h"

namespace pplvo {
namespace viewer {
namespace {

TEST(ViewerTicks, NiceStepsInsideRange) {
  const std::vector<double> t = niceTicks(0.93, 3.2, 6);
  ASSERT_GE(t.size(), 4u);
  EXPECT_NEAR(t.front(), 1.0, 1e-12);
  EXPECT_NEAR(t[1] - t[0], 0.5, 1e-12);
  EXPECT_LE(t.back(), 3.2);
  EXPECT_EQ(tickDecimals(t), 1);
  EXPECT_EQ(formatTick(-0.0001, 2), "0.00");
  EXPECT_TRUE(niceTicks(1.0, 1.0).empty());
  EXPECT_TRUE(niceTicks(0.0, NAN).empty());
}

TEST(ViewerRender, RangeAutoAndFixed) {
  cv::Mat v(10, 10, CV_32FC1);
  for (int i = 0; i < 100; ++i) v.at<float>(i) = static_cast<float>(1.0 + 0.01 * i);
  v.at<float>(0) = 0.f;
  v.at<float>(1) = NAN;
  ScalarPanelOptions o;
  ValueRange r = chooseRange(v, o);
  EXPECT_EQ(r.n_valid, 98);
  EXPECT_GT(r.min_m, 1.01);
  EXPECT_LT(r.max_m, 1.99);
  EXPECT_LT(r.min_m, r.max_m);
  o.min_value_m = 0.5;
  o.max_value_m = 4.0;
  r = chooseRange(v, o);
  EXPECT_DOUBLE_EQ(r.min_m, 0.5);
  EXPECT_DOUBLE_EQ(r.max_m, 4.0);
}

TEST(ViewerRender, ColorizeMarksMissingAndSpansTheMap) {
  cv::Mat v(1, 3, CV_32FC1);
  v.at<float>(0) = 0.f;
  v.at<float>(1) = 1.f;
  v.at<float>(2) = 5.f;
  ScalarPanelOptions o;
  o.missing_bgr = cv::Scalar(0, 0, 0);
  const cv::Mat c = colorizeScalar(v, ValueRange{1.0, 5.0, 2}, o);
  ASSERT_EQ(c.type(), CV_8UC3);
  EXPECT_EQ(c.at<cv::Vec3b>(0), cv::Vec3b(0, 0, 0));
  EXPECT_NE(c.at<cv::Vec3b>(1), c.at<cv::Vec3b>(2));
  EXPECT_NE(c.at<cv::Vec3b>(1), cv::Vec3b(0, 0, 0));
}

/// A 4x3 map from rows of values (0 = missing).
cv::Mat map4x3(std::initializer_list<float> v) {
  cv::Mat m(3, 4, CV_32FC1);
  int i = 0;
  for (float x : v) m.at<float>(i++) = x;
  return m;
}

TEST(ViewerRender, FusionOnlyPixelsAreFusedButNotCgm) {
  // A narrow depth camera's view: the C-GM map has depth in the middle two columns only; O-GM
  // filled the left column from the window, and lost one C-GM pixel (an outlier it rejected).
  const cv::Mat cgm = map4x3({0, 1.0f, 1.1f, 0,   //
                              0, 1.2f, NAN, 0,    //
                              0, 1.3f, 1.4f, 0});
  const cv::Mat fused = map4x3({2.0f, 1.0f, 1.1f, 0,  //
                                2.1f, 1.2f, 1.5f, 0,  //
                                -1.0f, 0, 1.4f, NAN});
  const FusionOnlyDepth f = fusionOnlyPixels(fused, cgm);
  ASSERT_TRUE(f.error.empty()) << f.error;
  ASSERT_EQ(f.mask.type(), CV_8UC1);
  ASSERT_EQ(f.mask.size(), cv::Size(4, 3));
  // By hand: (0,0) and (1,0) fused only (row, col); (1,2) C-GM NaN but fused 1.5: fused only;
  // (2,0) fused -1 is not valid; (2,1) lost by fusion is not fusion-only; NaN and 0 are missing.
  const cv::Mat want = (cv::Mat_<uint8_t>(3, 4) << 255, 0, 0, 0,  //
                        255, 0, 255, 0,                           //
                        0, 0, 0, 0);
  EXPECT_EQ(cv::countNonZero(f.mask != want), 0) << f.mask;
  EXPECT_EQ(f.n_fusion_only, 3);
  EXPECT_EQ(f.n_fused_valid, 7);
  EXPECT_EQ(f.n_cgm_valid, 5);
  EXPECT_DOUBLE_EQ(f.share(), 3.0 / 7.0);
  // The same map twice: nothing is fusion-only.
  const FusionOnlyDepth same = fusionOnlyPixels(cgm, cgm);
  EXPECT_EQ(same.n_fusion_only, 0);
  EXPECT_EQ(cv::countNonZero(same.mask), 0);
}

TEST(ViewerRender, FusionOnlyPixelsRefuseMapsThatDoNotMatch) {
  const cv::Mat a = map4x3({1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1});
  const FusionOnlyDepth size = fusionOnlyPixels(a, cv::Mat(4, 3, CV_32FC1, cv::Scalar(1)));
  EXPECT_TRUE(size.mask.empty());
  EXPECT_NE(size.error.find("sizes differ"), std::string::npos) << size.error;
  const FusionOnlyDepth type = fusionOnlyPixels(a, cv::Mat(3, 4, CV_16UC1, cv::Scalar(1)));
  EXPECT_FALSE(type.error.empty());
  EXPECT_FALSE(fusionOnlyPixels(cv::Mat(), a).error.empty());
  EXPECT_EQ(type.share(), 0.0);
}

TEST(ViewerRender, FusionOnlyPixelsAreTintedInTheFusedPanel) {
  cv::Mat bgr(1, 2, CV_8UC3, cv::Scalar(100, 50, 10));
  const cv::Mat mask = (cv::Mat_<uint8_t>(1, 2) << 0, 255);
  tintPixels(bgr, mask, cv::Scalar(255, 0, 255), 0.6);
  EXPECT_EQ(bgr.at<cv::Vec3b>(0), cv::Vec3b(100, 50, 10));
  EXPECT_EQ(bgr.at<cv::Vec3b>(1), cv::Vec3b(193, 20, 157));  // 0.4 * (100, 50, 10) + 0.6 * tint
  tintPixels(bgr, cv::Mat(2, 2, CV_8UC1, cv::Scalar(255)), cv::Scalar(0, 0, 0), 1.0);  // ignored
  EXPECT_EQ(bgr.at<cv::Vec3b>(0), cv::Vec3b(100, 50, 10));

  // In the canvas: the fused panel's left half (fusion-only) turns magenta-ish, only with
  // show_fusion_only.
  ViewerFrameData d;
  DepthWithVariance fused;
  fused.depth_m = cv::Mat(60, 80, CV_32FC1, cv::Scalar(1.5f));
  fused.var_m2 = cv::Mat(60, 80, CV_32FC1, cv::Scalar(1e-4f));
  d.fused_depth = fused;
  d.fusion_only_mask = cv::Mat(60, 80, CV_8UC1, cv::Scalar(0));
  d.fusion_only_mask(cv::Rect(0, 0, 40, 60)).setTo(255);
  d.status.fusion_only_px = 2400;
  d.status.fusion_only_share = 0.5;
  CanvasOptions o;
  const cv::Mat tinted = renderCanvas(d, o)(canvasLayout(o)[2]);
  o.show_fusion_only = false;
  const cv::Mat plain = renderCanvas(d, o)(canvasLayout(o)[2]);
  const cv::Rect img = featureImageRect(cv::Size(80, 60), o.cell);
  // The panel's image is about img's size (fitted beside the colour bar); half of it tinted.
  cv::Mat diff;
  cv::absdiff(tinted, plain, diff);
  cv::cvtColor(diff, diff, cv::COLOR_BGR2GRAY);
  EXPECT_GT(cv::countNonZero(diff > 30), img.area() / 6);
  // Magenta dominates where tinted: blue and red above green.
  int magenta = 0;
  for (int y = 0; y < tinted.rows; ++y) {
    for (int x = 0; x < tinted.cols; ++x) {
      const cv::Vec3b p = tinted.at<cv::Vec3b>(y, x);
      if (diff.at<uint8_t>(y, x) > 30 && p[0] > p[1] + 60 && p[2] > p[1] + 60) ++magenta;
    }
  }
  EXPECT_GT(magenta, img.area() / 6);
  EXPECT_LT(magenta, img.area() / 2);  // the other half is not tinted
  // The status text mentions it (rendered text differs from the text without the line).
  StatusPanelData without = d.status;
  without.fusion_only_px.reset();
  cv::Mat sdiff;
  cv::absdiff(renderStatusPanel(d.status, cv::Size(800, 450)),
              renderStatusPanel(without, cv::Size(800, 450)), sdiff);
  EXPECT_GT(cv::countNonZero(sdiff.reshape(1) > 0), 100);
}

TEST(ViewerRender, SqrtVariance) {
  cv::Mat var(1, 4, CV_32FC1);
  var.at<float>(0) = 4e-4f;
  var.at<float>(1) = 0.f;
  var.at<float>(2) = -1.f;
  var.at<float>(3) = NAN;
  const cv::Mat s = sqrtVariance(var);
  EXPECT_NEAR(s.at<float>(0), 0.02f, 1e-7);
  EXPECT_EQ(s.at<float>(1), 0.f);
  EXPECT_EQ(s.at<float>(2), 0.f);
  EXPECT_EQ(s.at<float>(3), 0.f);
}

TEST(ViewerRender, ScalarPanelHasImageAndColourBar) {
  const RgbdFrame f = testdata::frame(0);
  const cv::Size size(400, 450);
  const cv::Mat p = renderScalarPanel(f.depth_m, "depth", size);
  ASSERT_EQ(p.size(), size);
  ASSERT_EQ(p.type(), CV_8UC3);
  EXPECT_GT(testdata::regionVariance(p(cv::Rect(10, 100, 250, 200))), 100.0);
  // The colour bar column (right of the image, left of the labels) changes colour top to
  // bottom.
  const cv::Mat bar = p(cv::Rect(size.width - 62 - 16 - 6 + 4, 100, 6, 200));
  EXPECT_GT(testdata::regionVariance(bar), 100.0);
  // No data: a flat panel apart from the title and the message.
  const cv::Mat empty = renderScalarPanel(cv::Mat(), "depth", size);
  EXPECT_LT(testdata::regionVariance(empty(cv::Rect(0, 30, 400, 150))), 1.0);
}

TEST(ViewerRender, FeatureOverlayChangesPixelsAroundKeypointsAndPlanes) {
  const RgbdFrame f = testdata::frame(3);
  const FrameFeatures ff = testdata::features(3, true);
  const FramePose pose = testdata::pose(3);
  const cv::Size size(400, 450);
  const cv::Mat plain = renderFeaturePanel(f.bgr, nullptr, nullptr, "c", size);
  const cv::Mat drawn = renderFeaturePanel(f.bgr, &ff, &pose, "c", size);
  ASSERT_EQ(drawn.size(), size);
  const cv::Rect img = featureImageRect(f.bgr.size(), size);
  ASSERT_GT(img.area(), 0);
  const double s = static_cast<double>(img.width) / f.bgr.cols;
  cv::Mat diff;
  cv::absdiff(plain, drawn, diff);
  cv::cvtColor(diff, diff, cv::COLOR_BGR2GRAY);
  for (const PointFeature& p : ff.points) {
    const cv::Point c(img.x + static_cast<int>(p.px.x() * s),
                      img.y + static_cast<int>(p.px.y() * s));
    const cv::Rect around =
        cv::Rect(c.x - 6, c.y - 6, 13, 13) & cv::Rect(0, 0, size.width, size.height);
    EXPECT_GT(cv::countNonZero(diff(around) > 30), 10) << "point at " << p.px.transpose();
  }
  // Planes tinted: most pixels of both labelled regions differ; an unlabelled, feature-free
  // region does not.
  const cv::Rect plane1(img.x + static_cast<int>(20 * s), img.y + static_cast<int>(170 * s),
                        static_cast<int>(100 * s), static_cast<int>(60 * s));
  EXPECT_GT(cv::countNonZero(diff(plane1) > 10), plane1.area() * 8 / 10);
  const cv::Rect free_area(img.x + static_cast<int>(180 * s), img.y + static_cast<int>(80 * s),
                           static_cast<int>(100 * s), static_cast<int>(50 * s));
  EXPECT_LT(cv::countNonZero(diff(free_area) > 10), free_area.area() / 50);
  // Lifted and 2D-only points are drawn differently.
  const cv::Vec3b lifted =
      drawn.at<cv::Vec3b>(img.y + static_cast<int>(60 * s), img.x + static_cast<int>(80 * s));
  EXPECT_GT(lifted[1], 200);  // filled green disc
  EXPECT_NE(planeColour(1), planeColour(2));
}

TEST(ViewerRender, TrajectoryPanelDrawsEstimateAndGroundTruth) {
  Positions est, gt;
  for (int i = 0; i < 50; ++i) {
    const Eigen::Vector3d p = testdata::pose(i).T_w_c.translation();
    est.push_back(p);
    gt.push_back(p + Eigen::Vector3d(0.02, 0, 0.01));
  }
  const cv::Size size(400, 450);
  const cv::Mat only_est = renderTrajectoryPanel(est, {}, topDownAxes(), "top", size);
  const cv::Mat both = renderTrajectoryPanel(est, gt, topDownAxes(), "top", size);
  ASSERT_EQ(both.size(), size);
  auto greenish = [](const cv::Mat& m) {
    cv::Mat mask;
    cv::inRange(m, cv::Scalar(60, 180, 60), cv::Scalar(100, 220, 100), mask);
    return cv::countNonZero(mask);
  };
  EXPECT_GT(greenish(both), greenish(only_est) + 50);
  EXPECT_GT(testdata::regionVariance(both(cv::Rect(60, 40, 320, 340))), 50.0);
  const cv::Mat side = renderTrajectoryPanel(est, gt, sideAxes(), "side", size);
  EXPECT_GT(testdata::regionVariance(side(cv::Rect(60, 40, 320, 340))), 50.0);
  // Non-finite positions are ignored, not drawn to garbage coordinates.
  Positions bad = est;
  bad.push_back(Eigen::Vector3d(NAN, 0, 0));
  EXPECT_NO_THROW(renderTrajectoryPanel(bad, {}, topDownAxes(), "t", size));
}

TEST(ViewerRender, CanvasHasEveryPanelFilled) {
  ViewerFrameData d;
  d.frame = testdata::frame(5);
  d.feature_frame = d.frame;
  d.features = testdata::features(5, true);
  d.fused_depth = testdata::fused(5);
  for (int i = 0; i <= 5; ++i) d.trajectory.push_back(testdata::pose(i).T_w_c.translation());
  d.status.pose = testdata::pose(5);
  NodeStatusView n;
  n.node = "pplvo-frontend";
  n.stages.push_back(StageTimingView{"detect", 6, 3.2, 3.0, 4.1});
  d.status.nodes.push_back(n);
  const CanvasOptions o;
  const cv::Mat canvas = renderCanvas(d, o);
  ASSERT_EQ(canvas.size(), cv::Size(1600, 900));
  const std::vector<cv::Rect> cells = canvasLayout(o);
  ASSERT_EQ(cells.size(), 7u);
  for (size_t i = 0; i < cells.size(); ++i) {
    EXPECT_GT(testdata::regionVariance(canvas(cells[i])), 50.0) << "panel " << i;
  }
  // With nothing to show, the image panels are flat except titles and messages.
  const cv::Mat empty = renderCanvas(ViewerFrameData{}, o);
  EXPECT_LT(testdata::regionVariance(empty(cv::Rect(410, 40, 380, 150))), 1.0);
}

}  // namespace
}  // namespace viewer
}  // namespace pplvo
