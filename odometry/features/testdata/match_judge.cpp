#include "match_judge.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace pplvo::features::testdata {

double depthAt(const cv::Mat& depth_m, const Eigen::Vector2d& px) {
  const int u = static_cast<int>(std::lround(px.x())), v = static_cast<int>(std::lround(px.y()));
  if (depth_m.empty() || u < 0 || v < 0 || u >= depth_m.cols || v >= depth_m.rows) return 0.0;
  const float z = depth_m.at<float>(v, u);
  return std::isfinite(z) && z > 0 ? z : 0.0;
}

Verdict judgePointMatch(const Eigen::Vector2d& px1, const Eigen::Vector2d& px2,
                        const cv::Mat& depth1_m, const PinholeCamera& cam,
                        const Pose3& T_c2_c1, double tol_px) {
  const double z = depthAt(depth1_m, px1);
  if (z <= 0) return Verdict::kUnjudged;
  const Eigen::Vector3d p2 = T_c2_c1 * cam.backproject(px1.x(), px1.y(), z);
  if (p2.z() <= 0) return Verdict::kUnjudged;
  return (cam.project(p2) - px2).norm() < tol_px ? Verdict::kCorrect : Verdict::kWrong;
}

Verdict judgeLineMatch(const Eigen::Vector2d& a1, const Eigen::Vector2d& b1,
                       const Eigen::Vector3d& eq2, const cv::Mat& depth1_m,
                       const PinholeCamera& cam, const Pose3& T_c2_c1, double tol_px,
                       int samples) {
  std::vector<double> d;
  for (int k = 0; k < samples; ++k) {
    const double t = (k + 0.5) / samples;
    const Eigen::Vector2d p = a1 + t * (b1 - a1);
    const double z = depthAt(depth1_m, p);
    if (z <= 0) continue;
    const Eigen::Vector3d q = T_c2_c1 * cam.backproject(p.x(), p.y(), z);
    if (q.z() <= 0) continue;
    const Eigen::Vector2d pp = cam.project(q);
    d.push_back(std::abs(eq2.x() * pp.x() + eq2.y() * pp.y() + eq2.z()));
  }
  if (d.size() < 3) return Verdict::kUnjudged;
  std::nth_element(d.begin(), d.begin() + d.size() / 2, d.end());
  return d[d.size() / 2] < tol_px ? Verdict::kCorrect : Verdict::kWrong;
}

}  // namespace pplvo::features::testdata
