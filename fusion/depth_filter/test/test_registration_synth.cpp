// The paper's rig on the shared synthetic sequence: a 90 deg colour camera and a 58 deg depth
// camera 2.5 cm aside and turned 1 deg. Registered depth against the colour camera's noiseless
// truth inside the depth camera's view; nothing outside it before O-GM; O-GM fills part of the
// outside from past frames (true poses).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "pplvo/depth_filter/measurement_stages.h"
#include "pplvo/depth_filter/ogm_fusion.h"
#include "pplvo/fixtures/synthetic_sequence.h"

namespace pplvo::depth_filter {
namespace {

double focalForHfov(int width, double hfov_deg) {
  return width / 2.0 / std::tan(hfov_deg * M_PI / 360.0);
}

synth::SynthOptions rigOptions(int frames) {
  synth::SynthOptions o;
  o.frames = frames;
  o.seed = 3;
  o.width = 320;
  o.height = 240;
  o.cx = 159.5;
  o.cy = 119.5;
  o.fx = o.fy = focalForHfov(o.width, 90.0);
  DepthCamera d;
  d.camera.width = 320;
  d.camera.height = 240;
  d.camera.cx = 159.5;
  d.camera.cy = 119.5;
  d.camera.fx = d.camera.fy = focalForHfov(320, 58.0);
  d.T_c_d.linear() = Eigen::AngleAxisd(M_PI / 180.0, Eigen::Vector3d::UnitY()).toRotationMatrix();
  d.T_c_d.translation() = Eigen::Vector3d(0.025, 0, 0);
  o.depth_camera = d;
  return o;
}

/// Colour pixels whose true surface point the depth camera sees in its image.
cv::Mat depthViewMask(const synth::SynthFrame& f, const PinholeCamera& colour,
                      const DepthCamera& d) {
  cv::Mat mask(colour.height, colour.width, CV_8UC1, cv::Scalar(0));
  const Pose3 T_d_c = d.T_c_d.inverse();
  for (int v = 0; v < colour.height; ++v) {
    for (int u = 0; u < colour.width; ++u) {
      const float z = f.depth_true_m.at<float>(v, u);
      if (!(z > 0)) continue;
      const Eigen::Vector3d p_d = T_d_c * colour.backproject(u, v, z);
      if (p_d.z() > 0 && d.camera.inImage(d.camera.project(p_d), 0.5)) mask.at<uint8_t>(v, u) = 255;
    }
  }
  return mask;
}

struct Coverage {
  int64_t inside = 0, inside_with = 0, outside = 0, outside_with = 0;
  double inside_abs = 0, outside_abs = 0;
  void add(const cv::Mat& depth, const cv::Mat& truth, const cv::Mat& mask) {
    for (int v = 0; v < depth.rows; ++v) {
      for (int u = 0; u < depth.cols; ++u) {
        const float t = truth.at<float>(v, u);
        if (!(t > 0)) continue;
        const float z = depth.at<float>(v, u);
        const bool in = mask.at<uint8_t>(v, u) != 0;
        (in ? inside : outside) += 1;
        if (!(z > 0)) continue;
        (in ? inside_with : outside_with) += 1;
        (in ? inside_abs : outside_abs) += std::abs(z - t);
      }
    }
  }
};

TEST(RigSynth, RegisteredDepthMatchesTheTruthInsideTheDepthViewAndO_GmFillsBeyondIt) {
  constexpr int kFrames = 12;
  const synth::SyntheticSequence seq(rigOptions(kFrames));
  const DepthCamera& rig = *seq.options().depth_camera;
  DepthFilterOptions options;
  options.model = DepthModel::kCgm;
  MeasurementStages stages(options);
  OgmFusion ogm;
  Coverage cgm, fused;
  for (int i = 0; i < kFrames; ++i) {
    const synth::SynthFrame f = seq.render(i);
    ASSERT_TRUE(f.frame.depth_camera.has_value());
    ASSERT_EQ(f.frame.depth_m.size(), cv::Size(320, 240));
    StageTimings timings;
    const DepthWithVariance d = stages.apply(f.frame, timings);
    ASSERT_EQ(d.depth_m.size(), cv::Size(seq.camera().width, seq.camera().height));
    ASSERT_TRUE(ogm.addFrame(i, seq.camera(), d));
    const OgmResult r = ogm.fuse(i, f.T_w_c);
    ASSERT_TRUE(r.ok);
    if (i < kFrames / 2) continue;
    const cv::Mat mask = depthViewMask(f, seq.camera(), rig);
    cgm.add(d.depth_m, f.depth_true_m, mask);
    fused.add(r.depth.depth_m, f.depth_true_m, mask);
  }
  const auto share = [](int64_t a, int64_t b) { return b ? static_cast<double>(a) / b : 0.0; };
  std::printf("C-GM: inside %.3f (mean |err| %.2f mm), outside %.3f\n",
              share(cgm.inside_with, cgm.inside), 1e3 * cgm.inside_abs / cgm.inside_with,
              share(cgm.outside_with, cgm.outside));
  std::printf("O-GM: inside %.3f (mean |err| %.2f mm), outside %.3f (mean |err| %.2f mm)\n",
              share(fused.inside_with, fused.inside), 1e3 * fused.inside_abs / fused.inside_with,
              share(fused.outside_with, fused.outside),
              fused.outside_with ? 1e3 * fused.outside_abs / fused.outside_with : 0.0);
  // The depth camera sees about (tan 29 / tan 45)^2 = 31 % of the colour image.
  ASSERT_GT(cgm.inside, 0);
  ASSERT_GT(cgm.outside, cgm.inside);
  // Inside its view the registered depth covers the colour pixels (no sieve; edges, grazing
  // and range dropouts of the sensor model missing) with the sensor's accuracy.
  EXPECT_GT(share(cgm.inside_with, cgm.inside), 0.85);
  EXPECT_LT(cgm.inside_abs / cgm.inside_with, 0.02);
  // Outside it nothing but a pixel's rim (nearest-pixel rounding at the border of the view).
  EXPECT_LT(share(cgm.outside_with, cgm.outside), 0.01);
  // O-GM moves past frames' depth in: part of the outside gets depth, as accurate as inside.
  EXPECT_GT(share(fused.outside_with, fused.outside), 0.02);
  EXPECT_LT(fused.outside_abs / fused.outside_with, 0.03);
}

TEST(RigSynth, NoiselessRegisteredDepthEqualsTheColourCamerasTruth) {
  synth::SynthOptions o = rigOptions(3);
  o.noise.enabled = false;
  const synth::SyntheticSequence seq(o);
  DepthFilterOptions options;
  options.model = DepthModel::kSensor;
  MeasurementStages stages(options);
  for (int i = 0; i < 3; ++i) {
    const synth::SynthFrame f = seq.render(i);
    StageTimings timings;
    const DepthWithVariance d = stages.apply(f.frame, timings);
    const cv::Mat mask = depthViewMask(f, seq.camera(), *o.depth_camera);
    std::vector<float> err;
    int64_t inside = 0;
    for (int v = 0; v < mask.rows; ++v) {
      for (int u = 0; u < mask.cols; ++u) {
        if (!mask.at<uint8_t>(v, u)) continue;
        ++inside;
        const float z = d.depth_m.at<float>(v, u);
        if (z > 0) err.push_back(std::abs(z - f.depth_true_m.at<float>(v, u)));
      }
    }
    ASSERT_GT(inside, 10000);
    // Every pixel of the view has depth but a few at the border of the view.
    EXPECT_GT(static_cast<double>(err.size()) / inside, 0.99);
    // A point lands up to half a colour pixel from the pixel centre it is read at: the error
    // is the surface's depth change over that distance, small but at depth edges.
    std::sort(err.begin(), err.end());
    const float median = err[err.size() / 2], p95 = err[err.size() * 95 / 100];
    std::printf("frame %d: |error| median %.2f mm, 95 %% %.2f mm\n", i, 1e3 * median, 1e3 * p95);
    EXPECT_LT(median, 0.002f);
    EXPECT_LT(p95, 0.01f);
  }
}

}  // namespace
}  // namespace pplvo::depth_filter
