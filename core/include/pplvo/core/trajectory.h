#pragma once
/// TUM RGB-D trajectory files: one pose per line, `stamp tx ty tz qx qy qz qw`,
/// camera-to-world (T_w_c); lines starting with '#' are comments.
#include <iosfwd>
#include <string>
#include <vector>

#include "pplvo/core/geometry.h"

namespace pplvo {

struct StampedPose {
  std::string stamp_text;  ///< the stamp as written in the source, copied verbatim on output
  double stamp = 0.0;      ///< seconds (or frame index for ICL-NUIM)
  Pose3 T_w_c = Pose3::Identity();
};

using Trajectory = std::vector<StampedPose>;

/// Result of parsing a trajectory: entries plus lines that could not be parsed.
struct TrajectoryReadResult {
  Trajectory poses;
  int skipped_lines = 0;
  std::string first_error;  ///< e.g. "line 7: expected 8 numbers"
};

/// Reads a TUM trajectory. Throws std::runtime_error if the file cannot be opened.
TrajectoryReadResult readTumTrajectory(const std::string& path);
TrajectoryReadResult parseTumTrajectory(std::istream& in);

/// One TUM line, stamp verbatim, 9 significant decimals for the pose.
std::string formatTumLine(const StampedPose& pose);
/// Writes a whole trajectory with a header comment. Throws on I/O failure.
void writeTumTrajectory(const std::string& path, const Trajectory& poses);

}  // namespace pplvo
