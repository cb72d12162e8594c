#pragma once
/// TUM trajectory text ("stamp tx ty tz qx qy qz qw") in and out, for the fusion example.
#include <Eigen/Geometry>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>

#include "pplvo/core/geometry.h"

namespace pplvo::examples {

/// Poses by stamp (seconds); throws on a file that cannot be read.
inline std::map<double, Pose3> readTum(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read " + path);
  std::map<double, Pose3> poses;
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream s(line);
    double t, x, y, z, qx, qy, qz, qw;
    if (!(s >> t >> x >> y >> z >> qx >> qy >> qz >> qw)) {
      throw std::runtime_error(path + ": bad line '" + line + "'");
    }
    poses[t] = makePose({x, y, z}, Eigen::Quaterniond(qw, qx, qy, qz).normalized());
  }
  return poses;
}

/// The pose whose stamp is within `tolerance_s` of `t`, or nullptr.
inline const Pose3* poseAt(const std::map<double, Pose3>& poses, double t,
                           double tolerance_s = 1e-3) {
  auto it = poses.lower_bound(t - tolerance_s);
  if (it == poses.end() || it->first > t + tolerance_s) return nullptr;
  return &it->second;
}

inline void writeTumLine(std::ostream& out, const std::string& stamp, const Pose3& T) {
  const Eigen::Quaterniond q(T.linear());
  char buf[256];
  std::snprintf(buf, sizeof buf, " %.9f %.9f %.9f %.9f %.9f %.9f %.9f\n", T.translation().x(),
                T.translation().y(), T.translation().z(), q.x(), q.y(), q.z(), q.w());
  out << stamp << buf;
}

}  // namespace pplvo::examples
