#pragma once
/// Reader for the shared TUM-layout sequences (tests and benchmarks only: the library does no
/// I/O). ICL: associations.txt, integer stamps = frame index, ground truth with the same stamp.
/// TUM: rgb.txt entries whose files exist, nearest existing depth file and nearest
/// ground-truth pose (within max_dt_s).
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "pplvo/core/camera.h"
#include "pplvo/core/geometry.h"

namespace pplvo::features::testdata {

struct SequenceFrame {
  std::string rgb_path, depth_path;  ///< absolute paths
  double stamp = 0;
  bool has_gt = false;
  Pose3 T_w_c = Pose3::Identity();
};

struct SharedSequence {
  std::string name;
  PinholeCamera camera;
  std::vector<SequenceFrame> frames;
};

/// Directory of the shared data: $PPLVO_SHARED_DATA, else ../shared/data from the cwd.
std::string sharedDataDir();
/// Loads "icl_living_room_kt0_short" or "tum_fr3_sitting_static_short"; nullopt if missing.
std::optional<SharedSequence> loadSharedSequence(const std::string& name);

/// Grey image (CV_8UC1); empty on failure.
cv::Mat loadGray(const SequenceFrame& f);
/// Depth in metres (CV_32F, 0 = missing), scale 5000; empty on failure.
cv::Mat loadDepthM(const SequenceFrame& f);

}  // namespace pplvo::features::testdata
