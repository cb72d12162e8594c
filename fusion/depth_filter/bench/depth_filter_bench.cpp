// Timing of the depth filter stages on the shared sequences (VGA; O-GM with 1 and 2 threads by
// default), and depth RMSE on the synthetic sequence (which has noiseless truth). Prints tables;
// not part of ctest. Options: --help.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "pplvo/core/allocator.h"
#include "pplvo/core/rgbd_frame.h"
#include "pplvo/core/stage_timer.h"
#include "pplvo/core/trajectory.h"
#include "pplvo/dataset/dataset.h"
#include "pplvo/depth_filter/cgm_filter.h"
#include "pplvo/depth_filter/ogm_fusion.h"
#include "pplvo/fixtures/synthetic_sequence.h"

using namespace pplvo;
using namespace pplvo::depth_filter;

namespace {

const char* const kUsage =
    "pplvo_depth_filter_bench [--data DIR] [--threads LIST] [--synth-frames N] "
    "[--timing-only 1]\n"
    "  Times the depth filter stages on the shared sequences (VGA): stage 1, C-GM and O-GM with\n"
    "  windows 5 and 10, then prints depth RMSE against the synthetic room's truth.\n"
    "  --data DIR        folder holding icl_living_room_kt0_short and\n"
    "                    tum_fr3_sitting_static_short (default $PPLVO_SHARED_DATA or\n"
    "                    ../shared/data)\n"
    "  --threads LIST    O-GM thread counts (OgmOptions::threads) timed side by side, frame by\n"
    "                    frame in turn, e.g. 1,2 (the default); each prints an output checksum,\n"
    "                    which must not depend on the thread count\n"
    "  --synth-frames N  synthetic frames for the RMSE (default 40, at least 11)\n"
    "  --timing-only 1   skip the synthetic RMSE\n";

/// "1,2,3" -> {1, 2, 3}; empty on a malformed list or a count < 1.
std::vector<int> parseThreads(const std::string& text) {
  std::vector<int> out;
  size_t pos = 0;
  while (pos <= text.size()) {
    const size_t comma = std::min(text.find(',', pos), text.size());
    const std::string item = text.substr(pos, comma - pos);
    char* end = nullptr;
    const long v = std::strtol(item.c_str(), &end, 10);
    if (item.empty() || *end != '\0' || v < 1 || v > 64) return {};
    out.push_back(static_cast<int>(v));
    pos = comma + 1;
  }
  return out;
}

struct Sequence {
  std::string name;
  PinholeCamera camera;
  std::vector<cv::Mat> depth_m;
  std::vector<Pose3> T_w_c;
};

/// Frames read with pplvo_dataset (associations.txt, or rgb.txt + depth.txt associated within
/// 20 ms with absent files dropped; camera and depth scale from calib_params.xml), each with the
/// ground-truth pose of its depth stamp: the same stamp for ICL (integer frame indices), the
/// nearest within 20 ms for TUM.
bool loadSequence(const std::string& dir, Sequence* seq) {
  try {
    const dataset::Dataset ds = dataset::Dataset::open(dir);
    seq->camera = ds.camera().camera;
    const TrajectoryReadResult gt = readTumTrajectory(dir + "/groundtruth.txt");
    const bool icl = ds.index().summary.index_stamps;
    for (size_t i = 0; i < ds.size(); ++i) {
      const double stamp = std::atof(ds.entry(i).depth_stamp_text.c_str());
      const StampedPose* best = nullptr;
      double best_dt = icl ? 1e-6 : 0.02;
      for (const StampedPose& p : gt.poses) {
        const double dt = std::abs(p.stamp - stamp);
        if (dt <= best_dt) {
          best_dt = dt;
          best = &p;
        }
      }
      if (!best) continue;
      RgbdFrame frame;
      try {
        frame = ds.loadFrame(i);
      } catch (const dataset::FrameLoadError& e) {
        std::fprintf(stderr, "skipping frame: %s\n", e.what());
        continue;
      }
      seq->depth_m.push_back(frame.depth_m);
      seq->T_w_c.push_back(best->T_w_c);
    }
  } catch (const std::exception& e) {  // DatasetError, unreadable groundtruth.txt
    std::fprintf(stderr, "%s\n", e.what());
    return false;
  }
  return !seq->depth_m.empty();
}

/// Thread CPU time (ms): the machine is shared, wall time includes waiting for a core.
double cpuMs() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return 1e3 * static_cast<double>(ts.tv_sec) + 1e-6 * static_cast<double>(ts.tv_nsec);
}

/// FNV-1a over the bytes of a matrix (continuous rows), chained through `h`: identical fused
/// outputs give identical checksums, e.g. across versions or thread counts.
uint64_t fnv1a(const cv::Mat& m, uint64_t h) {
  for (int v = 0; v < m.rows; ++v) {
    const uint8_t* p = m.ptr<uint8_t>(v);
    const size_t n = m.elemSize() * static_cast<size_t>(m.cols);
    for (size_t i = 0; i < n; ++i) h = (h ^ p[i]) * 1099511628211ULL;
  }
  return h;
}

/// CPU time of the whole process (ms): all threads of a parallel fusion.
double processCpuMs() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return 1e3 * static_cast<double>(ts.tv_sec) + 1e-6 * static_cast<double>(ts.tv_nsec);
}

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}
double mean(const std::vector<double>& v) {
  double a = 0;
  for (double x : v) a += x;
  return v.empty() ? 0 : a / static_cast<double>(v.size());
}

void timeSequence(const Sequence& s, const std::vector<int>& threads) {
  const int n = static_cast<int>(s.depth_m.size());
  QuadraticSensorModel sensor;
  CgmFilter cgm;
  std::vector<DepthWithVariance> cgm_out;
  std::vector<double> t_sensor, t_cgm, c_cgm;
  DepthWithVariance buffer;  // steady state: output buffers reused (no page faults)
  for (int i = 0; i < n; ++i) {
    Stopwatch w;
    DepthWithVariance d = applySensorModel(sensor, s.depth_m[i]);
    t_sensor.push_back(w.elapsedMs());
    w.restart();
    const double c0 = cpuMs();
    cgm.apply(s.depth_m[i], &buffer);
    c_cgm.push_back(cpuMs() - c0);
    t_cgm.push_back(w.elapsedMs());
    cgm_out.push_back({buffer.depth_m.clone(), buffer.var_m2.clone(), 1});
  }
  std::printf("%-32s %4d frames %dx%d\n", s.name.c_str(), n, s.camera.width, s.camera.height);
  std::printf("  %-10s mean %6.2f ms  median %6.2f ms\n", "sensor", mean(t_sensor),
              median(t_sensor));
  std::printf("  %-10s mean %6.2f ms  median %6.2f ms  (CPU mean %.2f median %.2f ms)\n", "C-GM",
              mean(t_cgm), median(t_cgm), mean(c_cgm), median(c_cgm));
  // O-GM with each thread count, interleaved frame by frame so that every setting sees the same
  // machine load; the outputs must be identical (same checksum) whatever the thread count.
  for (int window : {5, 10}) {
    struct Run {
      int threads;
      OgmFusion ogm;
      OgmResult r;
      std::vector<double> t, c;
      uint64_t checksum = 1469598103934665603ULL;
    };
    std::vector<Run> runs;
    runs.reserve(threads.size());
    for (int th : threads) {
      OgmOptions o;
      o.max_window = window;
      o.threads = th;
      runs.push_back(Run{th, OgmFusion(o), {}, {}, {}});
    }
    double filled = 0, window_sum = 0;
    for (int i = 0; i < n; ++i) {
      for (Run& run : runs) {
        Stopwatch w;
        const double c0 = processCpuMs();
        run.ogm.addFrame(i, s.camera, cgm_out[i]);
        run.ogm.fuse(i, s.T_w_c[i], &run.r);
        run.c.push_back(processCpuMs() - c0);
        run.t.push_back(w.elapsedMs());
        run.checksum = fnv1a(run.r.depth.var_m2, fnv1a(run.r.depth.depth_m, run.checksum));
      }
      const OgmResult& r = runs.front().r;
      window_sum += r.depth.window_length;
      filled += static_cast<double>(cv::countNonZero(r.depth.depth_m)) -
                cv::countNonZero(cgm_out[i].depth_m);
    }
    for (const Run& run : runs) {
      std::printf(
          "  O-GM_%-2d %d thr mean %6.2f ms  median %6.2f ms  (CPU of all threads mean %.2f "
          "median %.2f ms; output checksum %016llx)\n",
          window, run.threads, mean(run.t), median(run.t), mean(run.c), median(run.c),
          static_cast<unsigned long long>(run.checksum));
    }
    const OgmStats& st = runs.front().ogm.stats();
    std::printf("  O-GM_%-2d mean window %.1f, filled %.0f px/frame, gated %.1f%% of projected\n",
                window, window_sum / n, filled / n,
                100.0 * static_cast<double>(st.points_gated) /
                    std::max<double>(1.0, static_cast<double>(st.points_projected)));
  }
}

struct Err {
  double sse = 0;
  int64_t n = 0;
  void add(double e) {
    sse += e * e;
    ++n;
  }
  double mm() const { return n ? 1e3 * std::sqrt(sse / static_cast<double>(n)) : 0; }
};

void synthRmse(int frames, bool moving) {
  synth::SynthOptions so;
  so.frames = frames;
  so.seed = 1;
  so.moving_object = moving;
  synth::SyntheticSequence seq(so);
  CgmFilter cgm;
  OgmOptions o5, o10, o10k1;
  o5.max_window = 5;
  o10k1.k_consistency = 1;
  OgmFusion f5(o5), f10(o10), f10k1(o10k1);
  Err raw, c, e5, e10, e10k1;
  for (int i = 0; i < frames; ++i) {
    const synth::SynthFrame f = seq.render(i);
    const DepthWithVariance d = cgm.apply(f.frame.depth_m);
    f5.addFrame(i, seq.camera(), d);
    f10.addFrame(i, seq.camera(), d);
    f10k1.addFrame(i, seq.camera(), d);
    const OgmResult r5 = f5.fuse(i, f.T_w_c), r10 = f10.fuse(i, f.T_w_c),
                    r10k1 = f10k1.fuse(i, f.T_w_c);
    if (i < 10) continue;
    for (int v = 0; v < f.depth_true_m.rows; ++v)
      for (int u = 0; u < f.depth_true_m.cols; ++u) {
        const float t = f.depth_true_m.at<float>(v, u), z = f.frame.depth_m.at<float>(v, u);
        if (!(t > 0 && z > 0) || f.dynamic_mask.at<uint8_t>(v, u)) continue;
        raw.add(z - t);
        c.add(d.depth_m.at<float>(v, u) - t);
        e5.add(r5.depth.depth_m.at<float>(v, u) - t);
        e10.add(r10.depth.depth_m.at<float>(v, u) - t);
        e10k1.add(r10k1.depth.depth_m.at<float>(v, u) - t);
      }
  }
  std::printf(
      "synthetic room%s, frames 10..%d, static pixels with raw depth (%lld px):\n"
      "  depth RMSE mm: raw %.2f  C-GM %.2f  O-GM_5 %.2f  O-GM_10 %.2f  O-GM_10(k=1) %.2f\n",
      moving ? " + moving box" : "", frames - 1, static_cast<long long>(raw.n), raw.mm(), c.mm(),
      e5.mm(), e10.mm(), e10k1.mm());
}

}  // namespace

int main(int argc, char** argv) {
  pplvo::keepFrameBuffersMapped();  // frame-sized buffers: no page faults per frame
  std::string data;
  if (const char* e = std::getenv("PPLVO_SHARED_DATA")) data = e;
  if (data.empty()) data = "../shared/data";
  int synth_frames = 40;
  bool timing_only = false;
  std::vector<int> threads = {1, 2};
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      std::printf("%s", kUsage);
      return 0;
    }
  }
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i];
    if (a == "--data")
      data = argv[i + 1];
    else if (a == "--synth-frames")
      synth_frames = std::max(11, std::atoi(argv[i + 1]));
    else if (a == "--timing-only")
      timing_only = std::atoi(argv[i + 1]) != 0;
    else if (a == "--threads")
      threads = parseThreads(argv[i + 1]);
  }
  if (threads.empty()) {
    std::fprintf(stderr, "--threads: expected a list such as 1,2\n");
    return 2;
  }
  for (const char* name : {"icl_living_room_kt0_short", "tum_fr3_sitting_static_short"}) {
    Sequence s;
    s.name = name;
    if (!loadSequence(data + "/" + name, &s)) {
      std::fprintf(stderr, "cannot load %s/%s\n", data.c_str(), name);
      continue;
    }
    timeSequence(s, threads);
  }
  if (timing_only) return 0;
  synthRmse(synth_frames, false);
  synthRmse(synth_frames, true);
  return 0;
}
