#pragma once
/// Relative poses with their covariance, one line per frame: what `pplvo-run --covariance`
/// writes and `pplvo-eval --nees` reads (docs/evaluation.md, "Covariance file").
///
/// Line: `stamp prev_stamp status tx ty tz qx qy qz qw c00 c01 c02 c03 c04 c05 c11 ... c55`
///  - stamp, prev_stamp: the frame's and the previous posed frame's stamps, verbatim;
///  - status: pose_t STATUS_* (0 first, 1 tracking, 2 velocity model, 3 lost, 4 reinitialised);
///  - T_prev_curr (maps points of the current camera into the previous camera): translation in
///    metres, unit quaternion qx qy qz qw with qw >= 0;
///  - the 21 upper-triangle entries (row by row) of the 6x6 covariance of
///    xi = [tx ty tz qx qy qz] of T_prev_curr (m^2, m, 1), exactly pose_t.rel_covariance.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <iosfwd>
#include <string>
#include <vector>

namespace pplvo {
namespace eval {

using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;

/// pose_t STATUS_* values.
enum class RelativePoseStatus : int {
  kFirstFrame = 0,
  kTracking = 1,
  kVelocityModel = 2,
  kLost = 3,
  kReinitialised = 4,
};

struct RelativePoseRecord {
  std::string stamp_text, prev_stamp_text;   ///< verbatim
  double stamp_s = 0.0, prev_stamp_s = 0.0;  ///< seconds (divided by fps when fps > 0)
  int status = 1;                            ///< RelativePoseStatus value
  Eigen::Isometry3d T_prev_curr = Eigen::Isometry3d::Identity();
  Matrix6d covariance = Matrix6d::Zero();  ///< of xi = [t; q_xyz] of T_prev_curr
  int line_no = 0;                         ///< 1-based line of the file (0: not read)
};

/// The header comment lines (each starting with '#', ending with '\n').
std::string relativePoseFileHeader();
/// One line (with '\n'); values with 17 significant digits.
std::string formatRelativePoseLine(const RelativePoseRecord& record);

struct RelativePoseReadResult {
  bool ok = false;
  std::string error;  ///< names the file and line
  std::vector<RelativePoseRecord> records;
};

/// Parses the text format; `fps` > 0: stamps are frame indices, divided by fps.
/// Lines starting with '#' (after blanks) and blank lines are skipped; any other line must
/// have exactly 31 numeric fields (stamps are numbers too).
RelativePoseReadResult parseRelativePoseFile(std::istream& in, const std::string& name,
                                             double fps = 0.0);
RelativePoseReadResult readRelativePoseFile(const std::string& path, double fps = 0.0);

/// xi = [t; q_xyz] of T with the quaternion sign chosen so that q_w >= 0 (the estimator's
/// parameterisation, odometry/estimator/pose_parameterisation.h).
Vector6d poseToXi(const Eigen::Isometry3d& T);

}  // namespace eval
}  // namespace pplvo
