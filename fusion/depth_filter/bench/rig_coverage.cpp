// The paper's rig on the synthetic room (issue 23): how much of a wide colour image has depth,
// inside and outside the narrower depth camera's view, and how accurate it is there, for the
// sensor model, C-GM and O-GM_10 (true poses). Prints a markdown table (docs/depth_filter.md,
// "Depth beyond the depth camera's view").
//   pplvo_depth_filter_rig [--frames N] [--seed S] [--colour-hfov D] [--depth-hfov D]
//                          [--trajectory-scale X]
// The first row is the reference: the same sequence with depth registered by the sensor (the
// colour camera's own depth over its whole view, same noise model).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "pplvo/depth_filter/measurement_stages.h"
#include "pplvo/depth_filter/ogm_fusion.h"
#include "pplvo/fixtures/synthetic_sequence.h"

namespace {

using namespace pplvo;

double focalForHfov(int width, double hfov_deg) {
  return width / 2.0 / std::tan(hfov_deg * M_PI / 360.0);
}

/// Colour pixels whose true surface point falls inside the depth camera's image.
cv::Mat depthViewMask(const cv::Mat& depth_true_m, const PinholeCamera& colour,
                      const DepthCamera& d) {
  cv::Mat mask(colour.height, colour.width, CV_8UC1, cv::Scalar(0));
  const Pose3 T_d_c = d.T_c_d.inverse();
  for (int v = 0; v < colour.height; ++v) {
    for (int u = 0; u < colour.width; ++u) {
      const float z = depth_true_m.at<float>(v, u);
      if (!(z > 0)) continue;
      const Eigen::Vector3d p_d = T_d_c * colour.backproject(u, v, z);
      if (p_d.z() > 0 && d.camera.inImage(d.camera.project(p_d), 0.5)) mask.at<uint8_t>(v, u) = 255;
    }
  }
  return mask;
}

struct Region {
  int64_t pixels = 0, with_depth = 0;
  double sum_abs = 0, sum_sq = 0, nees = 0;
  std::vector<float> abs_err;
  void add(float z, float var, float truth) {
    ++pixels;
    if (!(z > 0)) return;
    ++with_depth;
    const double e = z - truth;
    sum_abs += std::abs(e);
    sum_sq += e * e;
    if (var > 0) nees += e * e / var;
    abs_err.push_back(static_cast<float>(std::abs(e)));
  }
  double share() const { return pixels ? static_cast<double>(with_depth) / pixels : 0.0; }
  double rmseMm() const { return with_depth ? 1e3 * std::sqrt(sum_sq / with_depth) : 0.0; }
  double meanNees() const { return with_depth ? nees / with_depth : 0.0; }
  double p90Mm() { return quantileMm(0.9); }
  double medianMm() { return quantileMm(0.5); }
  double quantileMm(double q) {
    if (abs_err.empty()) return 0.0;
    const size_t k = static_cast<size_t>(abs_err.size() * q);
    std::nth_element(abs_err.begin(), abs_err.begin() + static_cast<std::ptrdiff_t>(k),
                     abs_err.end());
    return 1e3 * abs_err[k];
  }
};

struct Stage {
  const char* name;
  Region inside, outside;
};

}  // namespace

int main(int argc, char** argv) {
  int frames = 60;
  uint64_t seed = 1;
  // The paper's rig (its Fig. 9): colour 85 x 70 deg, depth 58 x 45 deg, 38 mm apart, VGA.
  double colour_hfov = 85, depth_hfov = 58, trajectory_scale = 1;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i];
    if (a == "--frames") {
      frames = std::max(12, std::atoi(argv[i + 1]));
    } else if (a == "--seed") {
      seed = std::strtoull(argv[i + 1], nullptr, 10);
    } else if (a == "--colour-hfov") {
      colour_hfov = std::atof(argv[i + 1]);
    } else if (a == "--depth-hfov") {
      depth_hfov = std::atof(argv[i + 1]);
    } else if (a == "--trajectory-scale") {
      trajectory_scale = std::atof(argv[i + 1]);
    } else {
      std::fprintf(stderr,
                   "usage: pplvo_depth_filter_rig [--frames N] [--seed S] [--colour-hfov D] "
                   "[--depth-hfov D] [--trajectory-scale X]\n");
      return 2;
    }
  }
  synth::SynthOptions o;
  o.frames = frames;
  o.seed = seed;
  o.fx = o.fy = focalForHfov(o.width, colour_hfov);
  o.trajectory_scale = trajectory_scale;
  const synth::SyntheticSequence registered_seq(o);  // the reference: registered depth
  DepthCamera d;
  d.camera.width = 640;
  d.camera.height = 480;
  d.camera.cx = 319.5;
  d.camera.cy = 239.5;
  d.camera.fx = d.camera.fy = focalForHfov(640, depth_hfov);
  d.T_c_d.linear() = Eigen::AngleAxisd(M_PI / 180.0, Eigen::Vector3d::UnitY()).toRotationMatrix();
  d.T_c_d.translation() = Eigen::Vector3d(0.038, 0, 0);
  o.depth_camera = d;
  const synth::SyntheticSequence seq(o);

  depth_filter::DepthFilterOptions sensor_options, cgm_options;
  sensor_options.model = depth_filter::DepthModel::kSensor;
  cgm_options.model = depth_filter::DepthModel::kCgm;
  depth_filter::MeasurementStages sensor(sensor_options), cgm(cgm_options);
  depth_filter::OgmFusion ogm;
  Stage stages[4] = {{"sensor (rig, registered)", {}, {}},
                     {"C-GM", {}, {}},
                     {"O-GM_10", {}, {}},
                     {"reference: sensor registered by the device", {}, {}}};
  constexpr int kFirst = 10;  // the window is full from here on
  StageTimings timings;
  for (int i = 0; i < frames; ++i) {
    const synth::SynthFrame f = seq.render(i);
    const DepthWithVariance s = sensor.apply(f.frame, timings);
    const DepthWithVariance c = cgm.apply(f.frame, timings);
    ogm.addFrame(i, seq.camera(), c);
    const depth_filter::OgmResult r = ogm.fuse(i, f.T_w_c);
    if (i < kFirst || !r.ok) continue;
    const cv::Mat mask = depthViewMask(f.depth_true_m, seq.camera(), d);
    const DepthWithVariance ref = sensor.apply(registered_seq.render(i).frame, timings);
    const DepthWithVariance* maps[4] = {&s, &c, &r.depth, &ref};
    for (int v = 0; v < mask.rows; ++v) {
      for (int u = 0; u < mask.cols; ++u) {
        const float t = f.depth_true_m.at<float>(v, u);
        if (!(t > 0)) continue;
        for (int k = 0; k < 4; ++k) {
          Region& reg = mask.at<uint8_t>(v, u) ? stages[k].inside : stages[k].outside;
          reg.add(maps[k]->depth_m.at<float>(v, u), maps[k]->var_m2.at<float>(v, u), t);
        }
      }
    }
  }
  const double inside_share = static_cast<double>(stages[0].inside.pixels) /
                              (stages[0].inside.pixels + stages[0].outside.pixels);
  std::printf("synthetic room, seed %llu, frames %d..%d of %d, VGA, colour %.0f deg, depth %.0f "
              "deg (3.8 cm aside, 1 deg about y), trajectory scale %.1f, true poses; the depth "
              "camera sees %.1f %% of the colour pixels\n\n",
              static_cast<unsigned long long>(seed), kFirst, frames - 1, frames, colour_hfov,
              depth_hfov, trajectory_scale, 100 * inside_share);
  std::printf("| depth | inside: with depth | median mm | p90 mm | RMSE mm | NEES | outside: "
              "with depth | median mm | p90 mm | RMSE mm | NEES |\n"
              "|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (Stage& s : stages) {
    std::printf("| %s | %.1f %% | %.1f | %.1f | %.1f | %.2f | %.1f %% | %.1f | %.1f | %.1f | %.2f |\n",
                s.name, 100 * s.inside.share(), s.inside.medianMm(), s.inside.p90Mm(),
                s.inside.rmseMm(), s.inside.meanNees(), 100 * s.outside.share(),
                s.outside.medianMm(), s.outside.p90Mm(), s.outside.rmseMm(),
                s.outside.meanNees());
  }
  return 0;
}
