#pragma once
/// Published poses (FramePose / pose_t) as relative-pose records for the NEES evaluation and
/// the covariance file (pplvo/eval/relative_pose_file.h). Library pplvo_eval_poses: depends on
/// pplvo_core and, for reading event logs, on LCM (pplvo_logging, pplvo_msgs_util).
#include <string>
#include <vector>

#include "pplvo/core/frame_pose.h"
#include "pplvo/eval/relative_pose_file.h"

namespace pplvo {
namespace eval {

/// One record per pose after the first: T_prev_curr and its covariance from each pose, the
/// previous stamp from the pose before it in `poses` (the previous posed frame). Poses are
/// taken in the given order; a FIRST_FRAME pose starts over (no record for it).
/// `fps` > 0: stamps are frame indices (stamp_s = index / fps). Stamps that are not numbers
/// give stamp_s = NaN (such records cannot be evaluated, but are written verbatim).
std::vector<RelativePoseRecord> relativePoseRecords(const std::vector<FramePose>& poses,
                                                    double fps = 0.0);

struct PoseLogReadResult {
  bool ok = false;
  std::string error;
  std::vector<FramePose> poses;  ///< every valid pose_t on `channel`, ordered by seq
  int invalid_messages = 0;      ///< undecodable or rejected by msgs::fromMsg
  bool truncated = false;        ///< the log ends with an incomplete event
};

/// Reads every pose_t of `channel` from an LCM event log (pplvo-run --log, pplvo-logger).
PoseLogReadResult readPoseLog(const std::string& path, const std::string& channel = "PPLVO_POSE");

/// True if the file starts with the LCM event log sync word (0xEDA1DA01).
bool isLcmEventLog(const std::string& path);

}  // namespace eval
}  // namespace pplvo
