// Benchmarks of the 3D frontend on the shared sequences (VGA): plane extraction + WLS fitting,
// point and line lifting, plane matching. Time per iteration = per frame, one thread.
// Data: $PPLVO_SHARED_DATA (default ../shared/data from the repository root), read with
// pplvo_dataset (index, calib_params.xml, depth PNG / depth_scale metres); variance from the
// sensor model (1.425e-3 z^2)^2 since no depth filter runs here.
// Line segments: OpenCV LSD on the grey image, only to have realistic inputs.
#include <benchmark/benchmark.h>

#include <cstdio>
#include <cstdlib>
#include <optional>
#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "pplvo/dataset/dataset.h"
#include "pplvo/geometry/lifting.h"
#include "pplvo/geometry/plane_extraction.h"
#include "pplvo/geometry/plane_matching.h"

namespace {

using namespace pplvo;
using namespace pplvo::geometry;

struct Frame {
  DepthWithVariance depth;
  FrameFeatures feats;  // points, lines (2D) and planes (filled once for the matching benchmark)
};

struct Sequence {
  std::string name;
  PinholeCamera cam;
  std::vector<Frame> frames;
};

constexpr int kMaxFrames = 60;

std::string dataDir() {
  const char* e = std::getenv("PPLVO_SHARED_DATA");
  return e ? e : "../shared/data";
}

Sequence load(const std::string& name) {
  Sequence s;
  s.name = name;
  const std::string dir = dataDir() + "/" + name;
  // Index, camera (calib_params.xml) and frame decoding: pplvo_dataset.
  std::optional<dataset::Dataset> ds;
  try {
    ds.emplace(dataset::Dataset::open(dir));
  } catch (const dataset::DatasetError& e) {
    std::fprintf(stderr, "cannot open %s: %s\n", dir.c_str(), e.what());
    return s;
  }
  s.cam = ds->camera().camera;
  auto lsd = cv::createLineSegmentDetector();
  auto fast = cv::FastFeatureDetector::create(20);
  const DepthNoiseModel model;
  for (size_t i = 0; i < ds->size(); ++i) {
    if (static_cast<int>(s.frames.size()) >= kMaxFrames) break;
    RgbdFrame frame;
    try {
      frame = ds->loadFrame(i);
    } catch (const dataset::FrameLoadError& e) {
      std::fprintf(stderr, "skipping frame: %s\n", e.what());
      continue;
    }
    cv::Mat grey;
    cv::cvtColor(frame.bgr, grey, cv::COLOR_BGR2GRAY);
    Frame f;
    f.depth.depth_m = frame.depth_m;
    f.depth.var_m2 = cv::Mat(f.depth.depth_m.size(), CV_32F);
    f.depth.depth_m.forEach<float>([&](float& z, const int* p) {
      f.depth.var_m2.at<float>(p[0], p[1]) = z > 0 ? static_cast<float>(model.varianceZ(z)) : 0.0f;
    });
    f.feats.camera = s.cam;
    std::vector<cv::Vec4f> segs;
    lsd->detect(grey, segs);
    for (const auto& v : segs) {
      LineFeature l;
      l.px1 = {v[0], v[1]};
      l.px2 = {v[2], v[3]};
      if ((l.px2 - l.px1).norm() < 20.0) continue;  // the frontend keeps longer segments
      f.feats.lines.push_back(l);
    }
    std::vector<cv::KeyPoint> kps;
    fast->detect(grey, kps);
    cv::KeyPointsFilter::retainBest(kps, 1000);
    for (const auto& k : kps) {
      PointFeature p;
      p.px = {k.pt.x, k.pt.y};
      f.feats.points.push_back(p);
    }
    s.frames.push_back(std::move(f));
  }
  PlaneExtractor ex(s.cam);
  for (auto& f : s.frames) {
    auto r = ex.extract(f.depth);
    f.feats.planes = r.planes;
    f.feats.plane_labels = r.labels;
  }
  // Optional visual check: PPLVO_GEOMETRY_DUMP=<dir> writes the first frame's plane labels.
  if (const char* dump = std::getenv("PPLVO_GEOMETRY_DUMP"); dump && !s.frames.empty()) {
    const Frame& f = s.frames.front();
    cv::Mat vis;
    f.depth.depth_m.convertTo(vis, CV_8U, 50.0);
    cv::cvtColor(vis, vis, cv::COLOR_GRAY2BGR);
    for (int v = 0; v < vis.rows; ++v)
      for (int u = 0; u < vis.cols; ++u)
        if (const int l = f.feats.plane_labels.at<uint8_t>(v, u))
          vis.at<cv::Vec3b>(v, u) = cv::Vec3b((l * 67) % 256, (l * 151) % 256, (l * 29 + 80) % 256);
    cv::imwrite(std::string(dump) + "/" + name + "_planes.png", vis);
    for (const auto& p : f.feats.planes)
      std::fprintf(stderr, "%s plane %d: n [%.3f %.3f %.3f] d %.3f m, %d px, sigma_d %.4f m\n",
                   name.c_str(), p.label, p.plane.normal().x(), p.plane.normal().y(),
                   p.plane.normal().z(), p.plane.d(), p.n_points, std::sqrt(p.plane.cov(3, 3)));
  }
  return s;
}

const std::vector<Sequence>& sequences() {
  static const std::vector<Sequence> s = {load("icl_living_room_kt0_short"),
                                          load("tum_fr3_sitting_static_short")};
  return s;
}

void BM_PlaneExtractionAndFit(benchmark::State& state) {
  const Sequence& s = sequences()[state.range(0)];
  if (s.frames.empty()) {
    state.SkipWithError("no frames");
    return;
  }
  state.SetLabel(s.name);
  PlaneExtractor ex(s.cam);
  size_t i = 0;
  double planes = 0, n = 0;
  for (auto _ : state) {
    auto r = ex.extract(s.frames[i++ % s.frames.size()].depth);
    planes += r.planes.size();
    n += 1;
    benchmark::DoNotOptimize(r);
  }
  state.counters["planes_per_frame"] = planes / n;
}

void BM_LiftPoints(benchmark::State& state) {
  const Sequence& s = sequences()[state.range(0)];
  if (s.frames.empty()) {
    state.SkipWithError("no frames");
    return;
  }
  state.SetLabel(s.name);
  size_t i = 0;
  double lifted = 0, total = 0;
  for (auto _ : state) {
    state.PauseTiming();
    const Frame& src = s.frames[i++ % s.frames.size()];
    FrameFeatures f;
    f.camera = src.feats.camera;
    f.points = src.feats.points;
    state.ResumeTiming();
    const LiftStats st = liftPoints(f, src.depth);
    lifted += st.points_lifted;
    total += f.points.size();
  }
  state.counters["points_per_frame"] = total / state.iterations();
  state.counters["lifted_fraction"] = total > 0 ? lifted / total : 0;
}

void BM_LiftLines(benchmark::State& state) {
  const Sequence& s = sequences()[state.range(0)];
  if (s.frames.empty()) {
    state.SkipWithError("no frames");
    return;
  }
  state.SetLabel(s.name);
  size_t i = 0;
  double lifted = 0, total = 0;
  for (auto _ : state) {
    state.PauseTiming();
    const Frame& src = s.frames[i++ % s.frames.size()];
    FrameFeatures f;
    f.camera = src.feats.camera;
    f.lines = src.feats.lines;
    state.ResumeTiming();
    const LiftStats st = liftLines(f, src.depth);
    lifted += st.lines_lifted;
    total += f.lines.size();
  }
  state.counters["lines_per_frame"] = total / state.iterations();
  state.counters["lifted_fraction"] = total > 0 ? lifted / total : 0;
}

void BM_PlaneMatching(benchmark::State& state) {
  const Sequence& s = sequences()[state.range(0)];
  if (s.frames.size() < 2) {
    state.SkipWithError("no frames");
    return;
  }
  state.SetLabel(s.name);
  size_t i = 0;
  double matches = 0;
  for (auto _ : state) {
    const size_t k = i++ % (s.frames.size() - 1);
    const auto m = matchPlanesWithStats(s.frames[k].feats, s.frames[k + 1].feats);
    matches += m.matches.size();
  }
  state.counters["matches_per_pair"] = matches / state.iterations();
}

BENCHMARK(BM_PlaneExtractionAndFit)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_LiftPoints)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_LiftLines)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_PlaneMatching)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
