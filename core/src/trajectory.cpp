#include "pplvo/core/trajectory.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace pplvo {

TrajectoryReadResult parseTumTrajectory(std::istream& in) {
  TrajectoryReadResult result;
  std::string line;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    const auto first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    std::istringstream ss(line);
    StampedPose p;
    double v[7];
    ss >> p.stamp_text;
    bool ok = static_cast<bool>(ss);
    for (double& x : v) ok = ok && static_cast<bool>(ss >> x);
    if (ok) {
      try {
        p.stamp = std::stod(p.stamp_text);
      } catch (const std::exception&) {
        ok = false;
      }
    }
    const Eigen::Quaterniond q(v[6], v[3], v[4], v[5]);
    if (ok && (q.norm() < 0.5 || !std::isfinite(q.norm()))) ok = false;
    if (!ok) {
      ++result.skipped_lines;
      if (result.first_error.empty()) {
        result.first_error = "line " + std::to_string(line_no) + ": expected 'stamp tx ty tz qx qy qz qw'";
      }
      continue;
    }
    p.T_w_c = makePose({v[0], v[1], v[2]}, q);
    result.poses.push_back(std::move(p));
  }
  return result;
}

TrajectoryReadResult readTumTrajectory(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open trajectory file '" + path + "'");
  return parseTumTrajectory(in);
}

std::string formatTumLine(const StampedPose& pose) {
  const Eigen::Vector3d t = pose.T_w_c.translation();
  Eigen::Quaterniond q(pose.T_w_c.linear());
  q.normalize();
  char buf[256];
  std::snprintf(buf, sizeof(buf), " %.9f %.9f %.9f %.9f %.9f %.9f %.9f", t.x(), t.y(), t.z(),
                q.x(), q.y(), q.z(), q.w());
  const std::string stamp =
      pose.stamp_text.empty() ? std::to_string(pose.stamp) : pose.stamp_text;
  return stamp + buf;
}

void writeTumTrajectory(const std::string& path, const Trajectory& poses) {
  std::ofstream out(path);
  if (!out) throw std::runtime_error("cannot write trajectory file '" + path + "'");
  out << "# pplvo trajectory: timestamp tx ty tz qx qy qz qw (camera to world)\n";
  for (const auto& p : poses) out << formatTumLine(p) << '\n';
  out.flush();
  if (!out) throw std::runtime_error("write failed for trajectory file '" + path + "'");
}

}  // namespace pplvo
