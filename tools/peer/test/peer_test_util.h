#pragma once
// Helpers shared by the peer odometry tests: rendered synthetic frames and drift errors.
#include <cmath>
#include <cstdio>
#include <map>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "pplvo/fixtures/synthetic_sequence.h"
#include "pplvo/peer/peer_odometry.h"

namespace pplvo::peer::test {

/// trajectory_scale 0 gives a camera that stays put (with independent sensor noise per frame).
inline synth::SynthOptions synthOptions(double fy, int frames, double trajectory_scale = 1.0) {
  synth::SynthOptions o;
  o.scene = "room";
  o.frames = frames;
  o.seed = 3;
  o.fy = fy;  // cy stays 239.5, the image centre, so a mirrored render sees the same scene
  o.trajectory_scale = trajectory_scale;
  return o;
}

/// Rendered frames of one sequence, cached per (fy, frames, trajectory_scale): rendering is the
/// slow part.
/// Tests must not write into these buffers (assign new cv::Mats instead).
struct Rendered {
  std::vector<RgbdFrame> frames;  ///< noisy sensor frames
  std::vector<cv::Mat> depth_true_m;
  std::vector<Pose3> T_w_c;  ///< ground truth, world = the synthetic room
};

inline const Rendered& rendered(double fy, int frames, double trajectory_scale = 1.0) {
  static std::map<std::tuple<double, int, double>, Rendered> cache;
  const auto key = std::make_tuple(fy, frames, trajectory_scale);
  auto it = cache.find(key);
  if (it != cache.end()) return it->second;
  const synth::SyntheticSequence seq(synthOptions(fy, frames, trajectory_scale));
  Rendered r;
  for (int i = 0; i < seq.size(); ++i) {
    synth::SynthFrame f = seq.render(i);
    r.frames.push_back(f.frame);
    r.depth_true_m.push_back(f.depth_true_m);
    r.T_w_c.push_back(f.T_w_c);
  }
  return cache.emplace(key, std::move(r)).first->second;
}

/// Errors of a trajectory (world = first camera) against the truth re-expressed in the first
/// camera's frame. No alignment: this is the drift from the start.
struct DriftErrors {
  double max_trans_m = 0.0;
  double final_trans_m = 0.0;
  double rmse_trans_m = 0.0;
  double max_rot_deg = 0.0;
  double gt_path_m = 0.0;  ///< length of the true path, for context
};

inline DriftErrors driftErrors(const std::vector<Pose3>& est, const std::vector<Pose3>& gt) {
  DriftErrors e;
  double sum2 = 0.0;
  const Pose3 T_c0_w = gt.front().inverse();
  for (size_t i = 0; i < est.size(); ++i) {
    const Pose3 T_c0_ci = T_c0_w * gt[i];
    const Pose3 err = T_c0_ci.inverse() * est[i];
    const double t = err.translation().norm();
    const double r = rotationAngle(err.linear()) * 180.0 / M_PI;
    e.max_trans_m = std::max(e.max_trans_m, t);
    e.max_rot_deg = std::max(e.max_rot_deg, r);
    sum2 += t * t;
    e.final_trans_m = t;
    if (i > 0) e.gt_path_m += (gt[i].translation() - gt[i - 1].translation()).norm();
  }
  e.rmse_trans_m = std::sqrt(sum2 / static_cast<double>(est.size()));
  return e;
}

struct RunResult {
  std::vector<Pose3> T_w_c;
  std::vector<PeerFrameResult> results;
  PeerStats stats;
};

inline RunResult run(const std::vector<RgbdFrame>& frames, const PeerOdometryOptions& options) {
  PeerOdometry odo(options);
  RunResult out;
  for (const RgbdFrame& f : frames) {
    out.results.push_back(odo.process(f));
    out.T_w_c.push_back(out.results.back().T_w_c);
  }
  out.stats = odo.stats();
  return out;
}

inline std::string describe(const DriftErrors& e) {
  char buf[256];
  std::snprintf(buf, sizeof buf,
                "drift max %.4f m, final %.4f m, rmse %.4f m, max rot %.3f deg over a %.3f m path",
                e.max_trans_m, e.final_trans_m, e.rmse_trans_m, e.max_rot_deg, e.gt_path_m);
  return buf;
}

}  // namespace pplvo::peer::test
