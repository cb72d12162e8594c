#include "shared_sequence.h"

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include <opencv2/imgcodecs.hpp>

#include "pplvo/core/rgbd_frame.h"
#include "pplvo/core/trajectory.h"

namespace fs = std::filesystem;

namespace pplvo::features::testdata {

std::string sharedDataDir() {
  if (const char* env = std::getenv("PPLVO_SHARED_DATA")) return env;
  return "../shared/data";
}

namespace {

bool readCamera(const std::string& dir, PinholeCamera* cam, int w, int h) {
  cv::FileStorage fsr(dir + "/calib_params.xml", cv::FileStorage::READ);
  if (!fsr.isOpened()) return false;
  cv::Mat k, d;
  fsr["RGB_intrinsic_params"] >> k;
  fsr["RGB_distortion_coefficients"] >> d;
  if (k.rows != 3 || k.cols != 3) return false;
  k.convertTo(k, CV_64F);
  cam->width = w;
  cam->height = h;
  cam->fx = k.at<double>(0, 0);
  cam->fy = k.at<double>(1, 1);
  cam->cx = k.at<double>(0, 2);
  cam->cy = k.at<double>(1, 2);
  if (d.total() >= 5) {
    d.convertTo(d, CV_64F);
    for (int i = 0; i < 5; ++i) cam->distortion[i] = d.at<double>(i);
  }
  return true;
}

std::vector<std::pair<double, std::string>> readList(const std::string& path) {
  std::vector<std::pair<double, std::string>> out;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ss(line);
    double t;
    std::string f;
    if (ss >> t >> f) out.emplace_back(t, f);
  }
  return out;
}

}  // namespace

std::optional<SharedSequence> loadSharedSequence(const std::string& name) {
  const std::string dir = sharedDataDir() + "/" + name;
  if (!fs::exists(dir)) return std::nullopt;
  SharedSequence seq;
  seq.name = name;
  Trajectory gt;
  try {
    gt = readTumTrajectory(dir + "/groundtruth.txt").poses;
  } catch (const std::exception&) {
  }
  if (fs::exists(dir + "/associations.txt")) {
    std::map<std::string, Pose3> gt_by_stamp;
    for (const auto& p : gt) gt_by_stamp[p.stamp_text] = p.T_w_c;
    std::ifstream in(dir + "/associations.txt");
    std::string line;
    while (std::getline(in, line)) {
      if (line.empty() || line[0] == '#') continue;
      std::istringstream ss(line);
      std::string ts_d, fd, ts_c, fc;
      if (!(ss >> ts_d >> fd >> ts_c >> fc)) continue;
      SequenceFrame f;
      f.depth_path = dir + "/" + fd;
      f.rgb_path = dir + "/" + fc;
      f.stamp = std::atof(ts_c.c_str());
      auto it = gt_by_stamp.find(ts_c);
      if (it != gt_by_stamp.end()) {
        f.has_gt = true;
        f.T_w_c = it->second;
      }
      seq.frames.push_back(f);
    }
  } else {
    std::vector<std::pair<double, std::string>> depth;
    for (const auto& e : fs::directory_iterator(dir + "/depth")) {
      const std::string stem = e.path().stem().string();
      depth.emplace_back(std::atof(stem.c_str()), e.path().string());
    }
    std::sort(depth.begin(), depth.end());
    for (const auto& [t, f] : readList(dir + "/rgb.txt")) {
      const std::string rgb = dir + "/" + f;
      if (!fs::exists(rgb) || depth.empty()) continue;
      SequenceFrame fr;
      fr.rgb_path = rgb;
      fr.stamp = t;
      auto it = std::lower_bound(depth.begin(), depth.end(), std::make_pair(t, std::string()));
      double best = 1e9;
      for (auto c : {it, it == depth.begin() ? it : it - 1}) {
        if (c == depth.end()) continue;
        if (std::abs(c->first - t) < best) {
          best = std::abs(c->first - t);
          fr.depth_path = c->second;
        }
      }
      if (best > 0.02) continue;
      // Ground truth: linear interpolation of translation, nearest rotation (100 Hz mocap).
      for (size_t k = 1; k < gt.size(); ++k) {
        if (gt[k - 1].stamp <= t && t <= gt[k].stamp && gt[k].stamp - gt[k - 1].stamp < 0.05) {
          const double a = (t - gt[k - 1].stamp) / (gt[k].stamp - gt[k - 1].stamp);
          const Eigen::Quaterniond q0(gt[k - 1].T_w_c.linear()), q1(gt[k].T_w_c.linear());
          fr.T_w_c.linear() = q0.slerp(a, q1).toRotationMatrix();
          fr.T_w_c.translation() = (1 - a) * gt[k - 1].T_w_c.translation() +
                                   a * gt[k].T_w_c.translation();
          fr.has_gt = true;
          break;
        }
      }
      seq.frames.push_back(fr);
    }
  }
  if (seq.frames.empty()) return std::nullopt;
  const cv::Mat first = cv::imread(seq.frames.front().rgb_path, cv::IMREAD_GRAYSCALE);
  if (first.empty() || !readCamera(dir, &seq.camera, first.cols, first.rows)) return std::nullopt;
  return seq;
}

cv::Mat loadGray(const SequenceFrame& f) { return cv::imread(f.rgb_path, cv::IMREAD_GRAYSCALE); }

cv::Mat loadDepthM(const SequenceFrame& f) {
  const cv::Mat d = cv::imread(f.depth_path, cv::IMREAD_ANYDEPTH);
  if (d.empty() || d.type() != CV_16U) return {};
  return depthUnitsToMetres(d, 5000.0);
}

}  // namespace pplvo::features::testdata
