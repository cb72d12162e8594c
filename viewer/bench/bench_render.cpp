// Time to render the viewer's panels and whole canvas at VGA (640x480) inputs.
#include <benchmark/benchmark.h>

#include <opencv2/imgproc.hpp>

#include "../test/synthetic_data.h"
#include "pplvo/viewer/render.h"

namespace {
using namespace pplvo;
using namespace pplvo::viewer;

RgbdFrame vgaFrame() {
  RgbdFrame f = testdata::frame(3);
  cv::resize(f.bgr, f.bgr, cv::Size(640, 480));
  cv::resize(f.depth_m, f.depth_m, cv::Size(640, 480), 0, 0, cv::INTER_NEAREST);
  return f;
}

FrameFeatures vgaFeatures() {
  FrameFeatures ff = testdata::features(3, true);
  cv::resize(ff.plane_labels, ff.plane_labels, cv::Size(640, 480), 0, 0, cv::INTER_NEAREST);
  ff.points.resize(500, ff.points[0]);
  for (size_t i = 0; i < ff.points.size(); ++i) {
    ff.points[i].px = Eigen::Vector2d(10 + (i * 37) % 620, 10 + (i * 53) % 460);
  }
  ff.lines.resize(100, ff.lines[0]);
  return ff;
}

void BM_ScalarPanel(benchmark::State& state) {
  const RgbdFrame f = vgaFrame();
  for (auto _ : state) {
    benchmark::DoNotOptimize(renderScalarPanel(f.depth_m, "depth", cv::Size(400, 450)));
  }
}
BENCHMARK(BM_ScalarPanel)->Unit(benchmark::kMillisecond);

void BM_FeaturePanel(benchmark::State& state) {
  const RgbdFrame f = vgaFrame();
  const FrameFeatures ff = vgaFeatures();
  const FramePose p = testdata::pose(3);
  for (auto _ : state) {
    benchmark::DoNotOptimize(renderFeaturePanel(f.bgr, &ff, &p, "colour", cv::Size(400, 450)));
  }
}
BENCHMARK(BM_FeaturePanel)->Unit(benchmark::kMillisecond);

void BM_Canvas(benchmark::State& state) {
  ViewerFrameData d;
  d.frame = vgaFrame();
  d.feature_frame = d.frame;
  d.features = vgaFeatures();
  DepthWithVariance fused;
  fused.depth_m = d.frame->depth_m.clone();
  fused.var_m2 = fused.depth_m.mul(fused.depth_m) * 1e-4;
  d.fused_depth = fused;
  for (int i = 0; i < 1000; ++i) d.trajectory.push_back(testdata::pose(i).T_w_c.translation());
  d.status.pose = testdata::pose(999);
  for (auto _ : state) benchmark::DoNotOptimize(renderCanvas(d));
}
BENCHMARK(BM_Canvas)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
