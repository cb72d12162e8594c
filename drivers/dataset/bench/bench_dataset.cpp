// Speed of the dataset library: frame decoding and association. Not part of ctest.
// Run: build/bin/bench_dataset (needs PPLVO_SHARED_DATA or ../shared/data from the repo root).
#include <cstdlib>
#include <random>

#include <benchmark/benchmark.h>

#include "pplvo/dataset/dataset.h"

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
