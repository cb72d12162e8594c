// Integration: the tracker on a ray-cast synthetic sequence (pplvo_fixtures) with its Kinect-like
// depth noise (quantised disparity, dropouts). Correspondences come from the ground truth
// (no feature matching here): point pixels sampled in the previous frame with their *noisy*
// sensor depth, lines from the scene's straight edges, planes from the visible surfaces.
// Checks the trajectory error for each feature family and all together.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <random>

#include "pplvo/estimator/motion_chain.h"
#include "pplvo/fixtures/synthetic_sequence.h"

namespace pplvo::estimator {
namespace {

constexpr int kFrames = 21;

struct Sequence {
  synth::SyntheticSequence seq;
  std::vector<synth::SynthFrame> frames;
  explicit Sequence(const synth::SynthOptions& o) : seq(o) {
    for (int i = 0; i < seq.size(); ++i) frames.push_back(seq.render(i));
  }
};

const Sequence& sequence() {
  static const Sequence s([] {
    synth::SynthOptions o;
    o.scene = "room";
    o.frames = kFrames;
    o.seed = 7;
    return o;
  }());
  return s;
}

Eigen::Matrix3d backprojectionCov(const PinholeCamera& K, double u, double v, double z) {
  Eigen::Matrix3d J;
  J << z / K.fx, 0, (u - K.cx) / K.fx, 0, z / K.fy, (v - K.cy) / K.fy, 0, 0, 1;
  // Depth noise: sensor model plus the disparity quantisation step (uniform, step^2/12).
  const double sz = 1.425e-3 * z * z;
  const double q = 0.125 * z * z / (K.fx * 0.075);
  const Eigen::Vector3d var(1.0 / 12.0, 1.0 / 12.0, sz * sz + q * q / 12.0);
  return J * var.asDiagonal() * J.transpose();
}

/// True depth near pixel (u, v) closest to z (3x3), or +inf.
double depthGap(const cv::Mat& depth_true, const Eigen::Vector2d& px, double z) {
  const int u0 = static_cast<int>(std::lround(px.x())), v0 = static_cast<int>(std::lround(px.y()));
  double best = std::numeric_limits<double>::infinity();
  for (int dv = -1; dv <= 1; ++dv) {
    for (int du = -1; du <= 1; ++du) {
      const int u = u0 + du, v = v0 + dv;
      if (u < 0 || v < 0 || u >= depth_true.cols || v >= depth_true.rows) continue;
      const float d = depth_true.at<float>(v, u);
      if (d > 0) best = std::min(best, std::abs(d - z));
    }
  }
  return best;
}

Correspondences makeCorrespondences(const Sequence& s, int i, std::mt19937& rng) {
  const synth::SynthFrame& fp = s.frames[i - 1];
  const synth::SynthFrame& fc = s.frames[i];
  const PinholeCamera& K = s.seq.camera();
  const Pose3 T_cp = fc.T_w_c.inverse() * fp.T_w_c;
  std::normal_distribution<double> N01;
  std::uniform_int_distribution<int> U(5, K.width - 6), V(5, K.height - 6);
  const double sp = std::sqrt(1.0 / 12.0);
  Correspondences c;
  // Points.
  for (int tries = 0; tries < 5000 && c.points.size() < 300; ++tries) {
    const int u = U(rng), v = V(rng);
    const float z = fp.frame.depth_m.at<float>(v, u);
    const float zt = fp.depth_true_m.at<float>(v, u);
    if (!(z > 0) || !(zt > 0) || std::abs(z - zt) > 0.1) continue;
    const Eigen::Vector3d P_true = K.backproject(u, v, zt);
    const Eigen::Vector3d X = T_cp * P_true;
    if (X.z() < 0.3) continue;
    const Eigen::Vector2d px = K.project(X);
    if (!K.inImage(px, 2.0) || depthGap(fc.depth_true_m, px, X.z()) > 0.02) continue;
    PointMatch3D2D m;
    m.P_prev.p = K.backproject(u, v, z);  // the sensor's noisy depth
    m.P_prev.cov = backprojectionCov(K, u, v, z);
    m.px_curr = px + sp * Eigen::Vector2d(N01(rng), N01(rng));
    c.points.push_back(m);
  }
  // Lines: scene edges visible (unoccluded at both ends and the middle) in both frames.
  const Pose3 T_pw = fp.T_w_c.inverse();
  for (const synth::SceneEdge& e : s.seq.sceneEdges(i - 1)) {
    if (c.lines.size() >= 50) break;
    Eigen::Vector3d P[2] = {T_pw * e.a_w, T_pw * e.b_w};
    bool ok = true;
    for (int k = 0; k < 3 && ok; ++k) {
      const Eigen::Vector3d Pp = k < 2 ? P[k] : 0.5 * (P[0] + P[1]);
      const Eigen::Vector3d Pk = 0.95 * Pp + 0.05 * (k < 2 ? P[1 - k] : Pp);  // 5% inside
      const Eigen::Vector3d Xk = T_cp * Pk;
      if (Pk.z() < 0.4 || Xk.z() < 0.4) {
        ok = false;
        break;
      }
      const Eigen::Vector2d pp = K.project(Pk), pc = K.project(Xk);
      ok = K.inImage(pp, 5) && K.inImage(pc, 5) && depthGap(fp.depth_true_m, pp, Pk.z()) < 0.03 &&
           depthGap(fc.depth_true_m, pc, Xk.z()) < 0.03;
    }
    if (!ok) continue;
    for (auto& Pk : P) Pk = 0.95 * Pk + 0.05 * (P[0] + P[1]) * 0.5;  // keep inside the image
    const Eigen::Vector2d q1 = K.project(T_cp * P[0]), q2 = K.project(T_cp * P[1]);
    if ((q1 - q2).norm() < 30) continue;
    LineMatch3D2D m;
    for (int k = 0; k < 2; ++k) {
      const Eigen::Vector2d pp = K.project(P[k]);
      const Eigen::Matrix3d cov = backprojectionCov(K, pp.x(), pp.y(), P[k].z());
      const Eigen::Vector3d noisy =
          P[k] + cov.llt().matrixL() * Eigen::Vector3d(N01(rng), N01(rng), N01(rng));
      (k == 0 ? m.L_prev.p1 : m.L_prev.p2) = noisy;
      (k == 0 ? m.L_prev.cov1 : m.L_prev.cov2) = cov;
    }
    const Eigen::Vector2d n1 = q1 + sp * Eigen::Vector2d(N01(rng), N01(rng));
    const Eigen::Vector2d n2 = q2 + sp * Eigen::Vector2d(N01(rng), N01(rng));
    m.l_curr = Eigen::Vector3d(n1.x(), n1.y(), 1).cross(Eigen::Vector3d(n2.x(), n2.y(), 1));
    m.l_curr /= m.l_curr.head<2>().norm();
    c.lines.push_back(m);
  }
  // Planes: large static surfaces seen in both frames (3 mrad / 2 mm noise).
  auto noisy = [&](const Eigen::Vector4d& h) {
    const Eigen::Vector3d n = h.head<3>();
    const Eigen::Vector3d b1 = n.unitOrthogonal(), b2 = n.cross(b1);
    PlaneWithCov p;
    p.cov.setZero();
    p.cov.topLeftCorner<3, 3>() = 9e-6 * (b1 * b1.transpose() + b2 * b2.transpose());
    p.cov(3, 3) = 4e-6;
    p.hessian << (n + 3e-3 * (N01(rng) * b1 + N01(rng) * b2)).normalized(), h(3) + 2e-3 * N01(rng);
    return p;
  };
  const auto vis_p = s.seq.visibleSurfaces(fp, 5000);
  const auto vis_c = s.seq.visibleSurfaces(fc, 5000);
  for (const auto& a : vis_p) {
    if (a.dynamic) continue;
    for (const auto& b : vis_c) {
      if (b.surface_id == a.surface_id) c.planes.push_back({noisy(a.plane_c), noisy(b.plane_c)});
    }
  }
  return c;
}

struct TrackRun {
  double max_t_err_m = 0, max_r_err_deg = 0;
  int tracking = 0;
  double mean_points = 0, mean_lines = 0, mean_planes = 0;
};

TrackRun runTracker(const PoseEstimatorOptions& eo) {
  const Sequence& s = sequence();
  std::mt19937 rng(99);
  MotionChainOptions o;
  o.estimator = eo;
  MotionChain tracker(o);
  tracker.initialise(0);
  TrackRun r;
  for (int i = 1; i < static_cast<int>(s.frames.size()); ++i) {
    const Correspondences c = makeCorrespondences(s, i, rng);
    r.mean_points += c.points.size();
    r.mean_lines += c.lines.size();
    r.mean_planes += c.planes.size();
    const MotionChainOutput out = tracker.track(i, c, s.seq.camera());
    if (out.status == TrackingStatus::kTracking) ++r.tracking;
    if (std::getenv("PPLVO_DEBUG_SYNTH")) {
      std::printf(
          "  frame %d: %s (%s) lines in %d used %d, max t var %.2e, rot var %.2e, min eig %.1e\n",
          i, toString(out.status), toString(out.estimate.status), out.estimate.n_lines_in,
          out.estimate.n_lines_used, out.estimate.max_translation_variance_m2,
          out.estimate.max_rotation_variance, out.estimate.min_relative_eigenvalue);
    }
    const Pose3 T_true = s.frames[0].T_w_c.inverse() * s.frames[i].T_w_c;
    const Pose3 D = T_true.inverse() * out.T_w_c;
    r.max_t_err_m = std::max(r.max_t_err_m, D.translation().norm());
    r.max_r_err_deg = std::max(r.max_r_err_deg, rotationAngle(D.linear()) * 180 / M_PI);
  }
  const double n = s.frames.size() - 1;
  r.mean_points /= n;
  r.mean_lines /= n;
  r.mean_planes /= n;
  return r;
}

TEST(EstimatorSynth, TracksEachFamilyAndAll) {
  struct Case {
    const char* name;
    bool p, l, pl;
    double alpha;
    int min_tracking;
    double max_t, max_r;
  };
  // 20 frames (0.67 s). Bounds: ~3-4x the drift observed, to hold on other machines.
  // Lines alone (~20 room/box edges, few directions) are weak: from frame ~15 the translation
  // std exceeds 1 cm and the gate hands over to the velocity model, which is the intended
  // behaviour; at least the first 10 frames must be tracked.
  // With the paper's alpha = 0.02 the planes barely count next to ~20 lines (see
  // docs/estimator.md); lines+planes is run with alpha = 1 as well.
  const Case cases[] = {{"points", true, false, false, 0.02, kFrames - 1, 0.02, 0.3},
                        {"lines", false, true, false, 0.02, 10, 0.15, 3.0},
                        {"lines+planes", false, true, true, 0.02, 10, 0.15, 3.0},
                        {"lines+planes a=1", false, true, true, 1.0, kFrames - 1, 0.06, 1.0},
                        {"points+planes", true, false, true, 0.02, kFrames - 1, 0.02, 0.3},
                        {"all", true, true, true, 0.02, kFrames - 1, 0.02, 0.3}};
  for (const Case& k : cases) {
    PoseEstimatorOptions eo;
    eo.use_points = k.p;
    eo.use_lines = k.l;
    eo.use_planes = k.pl;
    eo.plane_scale_alpha = k.alpha;
    const TrackRun r = runTracker(eo);
    std::printf(
        "%-16s tracking %d/%d, max drift %.2f mm %.3f deg (mean %.0f pts %.0f lines "
        "%.1f planes)\n",
        k.name, r.tracking, kFrames - 1, 1e3 * r.max_t_err_m, r.max_r_err_deg, r.mean_points,
        r.mean_lines, r.mean_planes);
    EXPECT_GE(r.tracking, k.min_tracking) << k.name;
    EXPECT_LT(r.max_t_err_m, k.max_t) << k.name;
    EXPECT_LT(r.max_r_err_deg, k.max_r) << k.name;
  }
}

}  // namespace
}  // namespace pplvo::estimator
