// Rendering speed of the synthetic sequence generator (one core, Release).
#include <benchmark/benchmark.h>

#include "pplvo/synth/synthetic_sequence.h"

namespace {

void BM_Render(benchmark::State& state, const char* scene, bool noise, bool moving) {
  pplvo::synth::SynthOptions o;
  o.scene = scene;
  o.noise.enabled = noise;
  o.moving_object = moving;
  const pplvo::synth::SyntheticSequence seq(o);
  int i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(seq.render(i));
    i = (i + 7) % seq.size();
  }
  state.SetLabel("640x480");
}

void BM_Construct(benchmark::State& state) {
  pplvo::synth::SynthOptions o;
  for (auto _ : state) {
    const pplvo::synth::SyntheticSequence seq(o);
    benchmark::DoNotOptimize(seq.size());
  }
}

}  // namespace

BENCHMARK_CAPTURE(BM_Render, room_noisy, "room", true, false)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Render, room_noiseless, "room", false, false)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Render, room_moving, "room", true, true)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Render, lines_noisy, "lines", true, false)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Render, textureless_noisy, "textureless", true, false)
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Construct)->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
