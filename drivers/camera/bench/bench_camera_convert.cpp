// Per-frame costs of the camera conversions and encodings at 640x480 (not run by ctest).
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <opencv2/imgcodecs.hpp>
#include <random>
#include <string>

#include "pplvo/camera/convert.h"
#include "pplvo/msgs/convert.h"

namespace pc = pplvo::camera;

namespace {
// A real TUM frame (fr3/sitting_static, first pair) when the shared data is reachable: the
// encoded sizes depend on content. Falls back to synthetic images.
std::string tumFile(const char* rel) {
  const char* env = std::getenv("PPLVO_SHARED_DATA");
  return std::string(env ? env : "../shared/data") + "/tum_fr3_sitting_static_short/" + rel;
}
cv::Mat tumBgr() { return cv::imread(tumFile("rgb/1341845688.561749.png"), cv::IMREAD_COLOR); }
cv::Mat tumDepthMm() {
  cv::Mat d = cv::imread(tumFile("depth/1341845688.562015.png"), cv::IMREAD_ANYDEPTH);
  if (d.empty()) return d;
  cv::Mat m;
  d.convertTo(m, CV_32F, 1.0 / 5000);
  const pc::KinectRawToMm conv;
  return conv.convert(pc::kinectRawFromMetres(m, conv.model()));  // as the camera publishes
}
cv::Mat syntheticRaw() {
  cv::Mat raw(480, 640, CV_16UC1);
  std::mt19937 rng(1);
  std::uniform_int_distribution<int> d(400, 1000);
  for (int r = 0; r < raw.rows; ++r)
    for (int c = 0; c < raw.cols; ++c) raw.at<uint16_t>(r, c) = (c % 50 == 0) ? 2047 : d(rng);
  return raw;
}
cv::Mat smoothBgr() {
  cv::Mat bgr(480, 640, CV_8UC3);
  for (int r = 0; r < bgr.rows; ++r)
    for (int c = 0; c < bgr.cols; ++c)
      bgr.at<cv::Vec3b>(r, c) = cv::Vec3b(c % 256, r % 256, (r + c) % 256);
  return bgr;
}
}  // namespace

static void BM_KinectRawToMm(benchmark::State& state) {
  const pc::KinectRawToMm conv;
  const cv::Mat raw = syntheticRaw();
  for (auto _ : state) benchmark::DoNotOptimize(conv.convert(raw));
}
BENCHMARK(BM_KinectRawToMm)->Unit(benchmark::kMillisecond);

static void BM_KinectRawFromMetres(benchmark::State& state) {
  const pc::KinectRawToMm conv;
  cv::Mat m;
  conv.convert(syntheticRaw()).convertTo(m, CV_32F, 1e-3);
  for (auto _ : state) benchmark::DoNotOptimize(pc::kinectRawFromMetres(m, conv.model()));
}
BENCHMARK(BM_KinectRawFromMetres)->Unit(benchmark::kMillisecond);

static void BM_Rgb888ToBgr(benchmark::State& state) {
  const cv::Mat rgb = smoothBgr();
  for (auto _ : state) benchmark::DoNotOptimize(pc::bgrFromRgb888(rgb.data, 640, 480));
}
BENCHMARK(BM_Rgb888ToBgr)->Unit(benchmark::kMillisecond);

static void BM_EncodeRgb(benchmark::State& state) {
  cv::Mat bgr = tumBgr();
  if (bgr.empty()) bgr = smoothBgr();
  const auto enc = static_cast<int8_t>(state.range(0));
  size_t bytes = 0;
  for (auto _ : state) bytes = pplvo::msgs::encodeImage(bgr, enc).data.size();
  state.counters["kB"] = bytes / 1024.0;
}
BENCHMARK(BM_EncodeRgb)->Arg(1)->Arg(3)->Arg(4)->Unit(benchmark::kMillisecond);  // raw jpeg png

static void BM_EncodeDepth(benchmark::State& state) {
  const pc::KinectRawToMm conv;
  cv::Mat mm = tumDepthMm();
  if (mm.empty()) mm = conv.convert(syntheticRaw());
  const auto enc = static_cast<int8_t>(state.range(0));
  size_t bytes = 0;
  for (auto _ : state) bytes = pplvo::msgs::encodeImage(mm, enc).data.size();
  state.counters["kB"] = bytes / 1024.0;
}
BENCHMARK(BM_EncodeDepth)->Arg(5)->Arg(6)->Arg(7)->Unit(benchmark::kMillisecond);  // raw zlib png

BENCHMARK_MAIN();
