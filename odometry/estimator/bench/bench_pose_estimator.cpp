// Pose-estimation time per frame (paper Sec. "Processing time": 33 ms; target <= 5 ms).
//  - Synthetic: 300 points, 50 lines, 4 planes (the test generator), identity start.
//  - ICL-NUIM kt0 (shared data, if found): ORB (1000) + brute-force Hamming cross-check
//    matches between consecutive frames, previous keypoints backprojected with the sensor
//    model sigma_z = 1.425e-3 z^2 (paper eq. 1) and sigma_p^2 = 1/12; points only. This
//    harness exists only for the benchmark. Accuracy against the ground truth is reported in
//    the counters (median translation / rotation error of the accepted frames).
// Only PoseEstimator::estimate() is timed.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "../test/synthetic_scene.h"
#include "pplvo/core/trajectory.h"
#include "pplvo/estimator/pose_estimator.h"

namespace pplvo::estimator {
namespace {

struct Dataset {
  PinholeCamera camera;
  std::vector<Correspondences> pairs;
  std::vector<Pose3> T_curr_prev_true;
};

std::vector<Correspondences> syntheticScenes(const testing::SceneConfig& cfg, int n) {
  testing::SceneGenerator gen(testing::testCamera(), cfg, 1234);
  std::vector<Correspondences> out;
  for (int i = 0; i < n; ++i) out.push_back(gen.generate(testing::typicalMotion()));
  return out;
}

void runEstimator(benchmark::State& state, const PoseEstimatorOptions& opts,
                  const std::vector<Correspondences>& scenes, const PinholeCamera& cam,
                  const std::vector<Pose3>* truth) {
  const PoseEstimator est(opts);
  size_t i = 0;
  int lm = 0, irls = 0, n = 0;
  for (auto _ : state) {
    const PoseEstimate e = est.estimate(scenes[i % scenes.size()], cam);
    benchmark::DoNotOptimize(e.T_curr_prev);
    lm += e.lm_iterations;
    irls += e.irls_iterations;
    ++n;
    ++i;
  }
  state.counters["lm_its"] = static_cast<double>(lm) / std::max(1, n);
  state.counters["irls_its"] = static_cast<double>(irls) / std::max(1, n);
  if (truth) {
    std::vector<double> et, er, tvar;
    int accepted = 0;
    for (size_t k = 0; k < scenes.size(); ++k) {
      const PoseEstimate e = est.estimate(scenes[k], cam);
      tvar.push_back(e.max_translation_variance_m2);
      if (!e.accepted()) continue;
      ++accepted;
      const Pose3 D = (*truth)[k].inverse() * e.T_curr_prev;
      et.push_back(D.translation().norm() * 1e3);
      er.push_back(rotationAngle(D.linear()) * 180.0 / M_PI);
    }
    auto median = [](std::vector<double> v) {
      if (v.empty()) return -1.0;
      std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
      return v[v.size() / 2];
    };
    state.counters["accepted_pct"] = 100.0 * accepted / scenes.size();
    state.counters["med_err_mm"] = median(et);
    state.counters["med_err_deg"] = median(er);
    state.counters["med_max_t_var_m2"] = median(tvar);
    state.counters["max_max_t_var_m2"] = *std::max_element(tvar.begin(), tvar.end());
    double pts = 0;
    for (const auto& c : scenes) pts += static_cast<double>(c.points.size());
    state.counters["matches"] = pts / scenes.size();
  }
}

void BM_Synthetic_All(benchmark::State& state) {
  static const auto scenes = syntheticScenes(testing::SceneConfig{}, 50);
  runEstimator(state, PoseEstimatorOptions{}, scenes, testing::testCamera(), nullptr);
}
void BM_Synthetic_PointsOnly(benchmark::State& state) {
  static const auto scenes = syntheticScenes(testing::SceneConfig{}, 50);
  PoseEstimatorOptions o;
  o.use_lines = o.use_planes = false;
  runEstimator(state, o, scenes, testing::testCamera(), nullptr);
}
void BM_Synthetic_All_30pctOutliers(benchmark::State& state) {
  testing::SceneConfig cfg;
  cfg.outlier_fraction = 0.3;
  static const auto scenes = syntheticScenes(cfg, 50);
  runEstimator(state, PoseEstimatorOptions{}, scenes, testing::testCamera(), nullptr);
}
void BM_Synthetic_All_FullWhitening(benchmark::State& state) {
  static const auto scenes = syntheticScenes(testing::SceneConfig{}, 50);
  PoseEstimatorOptions o;
  o.full_whitening = true;
  runEstimator(state, o, scenes, testing::testCamera(), nullptr);
}
BENCHMARK(BM_Synthetic_All)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Synthetic_PointsOnly)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Synthetic_All_30pctOutliers)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Synthetic_All_FullWhitening)->Unit(benchmark::kMillisecond);

// ------------------------------------------------------------------------------------------
// ICL-NUIM harness.

std::string findIcl() {
  std::vector<std::string> roots;
  if (const char* env = std::getenv("PPLVO_SHARED_DATA")) roots.emplace_back(env);
  roots.emplace_back("../shared/data");
  roots.emplace_back("/work/shared/data");
  for (const auto& r : roots) {
    const std::string dir = r + "/icl_living_room_kt0_short";
    if (std::ifstream(dir + "/associations.txt").good()) return dir;
  }
  return {};
}

Dataset loadIcl(const std::string& dir, int n_pairs) {
  Dataset ds;
  ds.camera.width = 640;
  ds.camera.height = 480;
  ds.camera.fx = 481.20;  // calib_params.xml (signed fy: mirrored model)
  ds.camera.fy = -480.0;
  ds.camera.cx = 319.5;
  ds.camera.cy = 239.5;
  const TrajectoryReadResult gt = readTumTrajectory(dir + "/groundtruth.txt");
  std::ifstream assoc(dir + "/associations.txt");
  std::vector<std::pair<std::string, std::string>> frames;  // depth, rgb
  std::vector<double> stamps;
  std::string line;
  while (std::getline(assoc, line)) {
    std::istringstream is(line);
    std::string sd, d, sr, r;
    if (!(is >> sd >> d >> sr >> r)) continue;
    frames.emplace_back(d, r);
    stamps.push_back(std::stod(sr));
  }
  auto gtPose = [&](double stamp, Pose3& T) {
    for (const auto& p : gt.poses) {
      if (std::abs(p.stamp - stamp) < 1e-6) {
        T = p.T_w_c;
        return true;
      }
    }
    return false;
  };
  cv::Ptr<cv::ORB> orb = cv::ORB::create(1000);
  cv::BFMatcher matcher(cv::NORM_HAMMING, true);
  std::vector<cv::KeyPoint> kp_prev;
  cv::Mat desc_prev, depth_prev;
  Pose3 T_w_prev;
  bool have_prev = false;
  for (size_t f = 1; f < frames.size() && static_cast<int>(ds.pairs.size()) < n_pairs; ++f) {
    const cv::Mat grey = cv::imread(dir + "/" + frames[f].second, cv::IMREAD_GRAYSCALE);
    const cv::Mat depth_u16 = cv::imread(dir + "/" + frames[f].first, cv::IMREAD_UNCHANGED);
    Pose3 T_w_curr;
    if (grey.empty() || depth_u16.empty() || !gtPose(stamps[f], T_w_curr)) {
      have_prev = false;
      continue;
    }
    std::vector<cv::KeyPoint> kp;
    cv::Mat desc;
    orb->detectAndCompute(grey, cv::noArray(), kp, desc);
    if (have_prev && !desc.empty() && !desc_prev.empty()) {
      std::vector<cv::DMatch> matches;
      matcher.match(desc_prev, desc, matches);
      Correspondences c;
      for (const cv::DMatch& m : matches) {
        const cv::Point2f& pp = kp_prev[m.queryIdx].pt;
        const cv::Point2f& pc = kp[m.trainIdx].pt;
        if (cv::norm(pp - pc) > 80.0 || m.distance > 64) continue;
        const int u = static_cast<int>(std::lround(pp.x)), v = static_cast<int>(std::lround(pp.y));
        if (u < 5 || v < 5 || u >= depth_prev.cols - 5 || v >= depth_prev.rows - 5) continue;
        const double z = depth_prev.at<uint16_t>(v, u) / 5000.0;
        if (!(z > 0.1)) continue;
        const PinholeCamera& K = ds.camera;
        const double sz = 1.425e-3 * z * z, sp2 = 1.0 / 12.0;
        Eigen::Matrix3d J;
        J << z / K.fx, 0, (pp.x - K.cx) / K.fx, 0, z / K.fy, (pp.y - K.cy) / K.fy, 0, 0, 1;
        PointMatch3D2D pm;
        pm.P_prev.p = K.backproject(pp.x, pp.y, z);
        pm.P_prev.cov = J * Eigen::Vector3d(sp2, sp2, sz * sz).asDiagonal() * J.transpose();
        pm.px_curr = {pc.x, pc.y};
        c.points.push_back(pm);
      }
      ds.pairs.push_back(std::move(c));
      ds.T_curr_prev_true.push_back(T_w_curr.inverse() * T_w_prev);
    }
    kp_prev = kp;
    desc_prev = desc;
    depth_prev = depth_u16;
    T_w_prev = T_w_curr;
    have_prev = true;
  }
  return ds;
}

void BM_IclOrbPoints(benchmark::State& state) {
  static const std::string dir = findIcl();
  if (dir.empty()) {
    state.SkipWithError("shared data not found (set PPLVO_SHARED_DATA)");
    return;
  }
  static const Dataset ds = loadIcl(dir, 100);
  if (ds.pairs.empty()) {
    state.SkipWithError("no frame pairs loaded");
    return;
  }
  PoseEstimatorOptions o;
  o.use_lines = o.use_planes = false;
  runEstimator(state, o, ds.pairs, ds.camera, &ds.T_curr_prev_true);
}
BENCHMARK(BM_IclOrbPoints)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace pplvo::estimator

BENCHMARK_MAIN();
