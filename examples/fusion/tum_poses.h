#pragma once
/// Ground truth by stamp for the fusion example, on pplvo's TUM reader and writer
/// (pplvo/core/trajectory.h).
#include <map>
#include <ostream>
#include <stdexcept>
#include <string>

#include "pplvo/core/trajectory.h"

namespace pplvo::examples {

/// Poses of a TUM file by stamp (seconds); throws when it cannot be read or has bad lines.
inline std::map<double, Pose3> readTumByStamp(const std::string& path) {
  const TrajectoryReadResult r = readTumTrajectory(path);
  if (r.skipped_lines > 0) throw std::runtime_error(path + ": " + r.first_error);
  std::map<double, Pose3> poses;
  for (const StampedPose& p : r.poses) poses[p.stamp] = p.T_w_c;
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
  out << formatTumLine({stamp, 0.0, T}) << '\n';
}

}  // namespace pplvo::examples
