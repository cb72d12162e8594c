// Speed of the dataset library: frame decoding and association. Not part of ctest.
// Run: build/bin/bench_dataset (needs PPLVO_SHARED_DATA or ../shared/data from the repo root).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <opencv2/imgcodecs.hpp>
#include <random>

#include "pplvo/dataset/dataset.h"
#include "pplvo/dataset/png_decode.h"

namespace {
std::string sharedData() {
  const char* env = std::getenv("PPLVO_SHARED_DATA");
  return env ? env : "../shared/data";
}

void BM_LoadRawFrame(benchmark::State& state, const char* folder) {
  const auto ds = pplvo::dataset::Dataset::open(sharedData() + "/" + folder);
  size_t i = 0;
  for (auto _ : state) {
    auto f = ds.loadRaw(i++ % ds.size());
    benchmark::DoNotOptimize(f.depth_units.data);
  }
}
BENCHMARK_CAPTURE(BM_LoadRawFrame, icl, "icl_living_room_kt0_short")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_LoadRawFrame, tum, "tum_fr3_sitting_static_short")
    ->Unit(benchmark::kMillisecond);

// One PNG decode from memory (the first 20 colour or depth files of a sequence in turn):
// cv::imdecode against the fast decoder (pplvo/dataset/png_decode.h).
std::vector<std::vector<uint8_t>> pngFiles(const std::string& dir) {
  std::vector<std::string> names;
  for (const auto& e : std::filesystem::directory_iterator(dir)) names.push_back(e.path());
  std::sort(names.begin(), names.end());
  names.resize(std::min<size_t>(names.size(), 20));
  std::vector<std::vector<uint8_t>> files;
  for (const auto& n : names) {
    std::ifstream in(n, std::ios::binary);
    files.emplace_back(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  return files;
}

void BM_DecodePng(benchmark::State& state, const char* folder, bool depth, bool fast) {
  const auto files = pngFiles(sharedData() + "/" + folder + (depth ? "/depth" : "/rgb"));
  const int flags = depth ? cv::IMREAD_UNCHANGED : cv::IMREAD_COLOR;
  size_t i = 0;
  for (auto _ : state) {
    const auto& f = files[i++ % files.size()];
    const cv::Mat m =
        fast ? pplvo::dataset::decodePng(f.data(), f.size(), flags) : cv::imdecode(f, flags);
    benchmark::DoNotOptimize(m.data);
  }
}
BENCHMARK_CAPTURE(BM_DecodePng, icl_colour_opencv, "icl_living_room_kt0_short", false, false)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_DecodePng, icl_colour_fast, "icl_living_room_kt0_short", false, true)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_DecodePng, icl_depth_opencv, "icl_living_room_kt0_short", true, false)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_DecodePng, icl_depth_fast, "icl_living_room_kt0_short", true, true)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_DecodePng, tum_colour_opencv, "tum_fr3_sitting_static_short", false, false)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_DecodePng, tum_colour_fast, "tum_fr3_sitting_static_short", false, true)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_DecodePng, tum_depth_opencv, "tum_fr3_sitting_static_short", true, false)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_DecodePng, tum_depth_fast, "tum_fr3_sitting_static_short", true, true)
    ->Unit(benchmark::kMillisecond);

void BM_LoadFrameMetres(benchmark::State& state) {
  const auto ds = pplvo::dataset::Dataset::open(sharedData() + "/icl_living_room_kt0_short");
  size_t i = 0;
  for (auto _ : state) {
    auto f = ds.loadFrame(i++ % ds.size());
    benchmark::DoNotOptimize(f.depth_m.data);
  }
}
BENCHMARK(BM_LoadFrameMetres)->Unit(benchmark::kMillisecond);

// A full TUM sequence: ~3000 colour and ~3000 depth stamps with 10 ms jitter.
void BM_AssociateStamps(benchmark::State& state) {
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> jitter(-0.01, 0.01);
  std::vector<double> a, b;
  for (int i = 0; i < state.range(0); ++i) {
    a.push_back(i / 30.0);
    b.push_back(i / 30.0 + jitter(rng));
  }
  for (auto _ : state) {
    auto m = pplvo::dataset::associateStamps(a, b, 0.02);
    benchmark::DoNotOptimize(m.data());
  }
}
BENCHMARK(BM_AssociateStamps)->Arg(3000)->Unit(benchmark::kMillisecond);

void BM_BuildIndexTum(benchmark::State& state) {
  for (auto _ : state) {
    auto idx = pplvo::dataset::buildIndex(sharedData() + "/tum_fr3_sitting_static_short");
    benchmark::DoNotOptimize(idx.entries.data());
  }
}
BENCHMARK(BM_BuildIndexTum)->Unit(benchmark::kMillisecond);
}  // namespace

BENCHMARK_MAIN();
