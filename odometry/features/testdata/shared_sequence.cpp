#include "shared_sequence.h"

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>

#include <opencv2/imgproc.hpp>

#include "pplvo/core/rgbd_frame.h"
#include "pplvo/core/trajectory.h"

namespace fs = std::filesystem;

namespace pplvo::features::testdata {

std::string sharedDataDir() {
  if (const char* env = std::getenv("PPLVO_SHARED_DATA")) return env;
  return "../shared/data";
}

namespace {

/// TUM ground truth (100 Hz mocap) at time t: linear interpolation of the translation, slerp of
/// the rotation, between two poses less than 50 ms apart.
std::optional<Pose3> interpolate(const Trajectory& gt, double t) {
  for (size_t k = 1; k < gt.size(); ++k) {
    if (gt[k - 1].stamp <= t && t <= gt[k].stamp && gt[k].stamp - gt[k - 1].stamp < 0.05) {
      const double a = (t - gt[k - 1].stamp) / (gt[k].stamp - gt[k - 1].stamp);
      const Eigen::Quaterniond q0(gt[k - 1].T_w_c.linear()), q1(gt[k].T_w_c.linear());
      Pose3 T = Pose3::Identity();
      T.linear() = q0.slerp(a, q1).toRotationMatrix();
      T.translation() = (1 - a) * gt[k - 1].T_w_c.translation() + a * gt[k].T_w_c.translation();
      return T;
    }
  }
  return std::nullopt;
}

}  // namespace

std::optional<SharedSequence> loadSharedSequence(const std::string& name) {
  const std::string dir = sharedDataDir() + "/" + name;
  if (!fs::exists(dir)) return std::nullopt;
  std::optional<dataset::Dataset> ds;
  try {
    ds.emplace(dataset::Dataset::open(dir));
  } catch (const dataset::DatasetError& e) {
    std::fprintf(stderr, "shared sequence %s: %s\n", name.c_str(), e.what());
    return std::nullopt;
  }
  SharedSequence seq;
  seq.name = name;
  seq.camera = ds->camera().camera;
  Trajectory gt;
  try {
    gt = readTumTrajectory(dir + "/groundtruth.txt").poses;
  } catch (const std::exception&) {
  }
  std::map<std::string, Pose3> gt_by_stamp;
  for (const auto& p : gt) gt_by_stamp[p.stamp_text] = p.T_w_c;
  const bool index_stamps = ds->index().summary.index_stamps;  // ICL: frame indices
  for (const dataset::DatasetEntry& e : ds->index().entries) {
    SequenceFrame f;
    f.rgb_path = e.rgb_path;
    f.depth_path = e.depth_path;
    f.stamp = e.stamp;
    f.entry = e;
    f.depth_scale = ds->camera().depth_scale;
    std::optional<Pose3> T_w_c;
    if (index_stamps) {
      if (auto it = gt_by_stamp.find(e.stamp_text); it != gt_by_stamp.end()) T_w_c = it->second;
    } else {
      T_w_c = interpolate(gt, e.stamp);
    }
    if (T_w_c) {
      f.has_gt = true;
      f.T_w_c = *T_w_c;
    }
    seq.frames.push_back(std::move(f));
  }
  if (seq.frames.empty()) return std::nullopt;
  return seq;
}

cv::Mat loadGray(const SequenceFrame& f) {
  try {
    const dataset::RawFrame raw = dataset::loadRawFrame(f.entry, f.depth_scale);
    cv::Mat gray;
    cv::cvtColor(raw.bgr, gray, cv::COLOR_BGR2GRAY);
    return gray;
  } catch (const dataset::FrameLoadError&) {
    return {};
  }
}

cv::Mat loadDepthM(const SequenceFrame& f) {
  try {
    return depthUnitsToMetres(dataset::loadRawFrame(f.entry, f.depth_scale).depth_units,
                              f.depth_scale);
  } catch (const dataset::FrameLoadError&) {
    return {};
  }
}

}  // namespace pplvo::features::testdata
