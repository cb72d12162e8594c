#pragma once
/// The shared TUM-layout sequences for tests and benchmarks (the library does no I/O), read
/// with pplvo_dataset: frame index (ICL: associations.txt; TUM: rgb.txt + depth.txt associated
/// within 20 ms, absent files dropped), camera from calib_params.xml, frame decoding. Ground
/// truth is matched here: ICL by the same (integer) stamp, TUM interpolated at the colour stamp.
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "pplvo/core/camera.h"
#include "pplvo/core/geometry.h"
#include "pplvo/dataset/dataset.h"

namespace pplvo::features::testdata {

struct SequenceFrame {
  std::string rgb_path, depth_path;  ///< absolute paths
  double stamp = 0;                  ///< colour stamp
  bool has_gt = false;
  Pose3 T_w_c = Pose3::Identity();
  dataset::DatasetEntry entry;  ///< what loadGray / loadDepthM read
  double depth_scale = 5000.0;  ///< depth PNG units per metre (from the camera file)
};

struct SharedSequence {
  std::string name;
  PinholeCamera camera;
  std::vector<SequenceFrame> frames;
};

/// Directory of the shared data: $PPLVO_SHARED_DATA, else ../shared/data from the cwd.
std::string sharedDataDir();
/// Loads "icl_living_room_kt0_short" or "tum_fr3_sitting_static_short"; nullopt if missing or
/// unreadable (the reason is printed on stderr).
std::optional<SharedSequence> loadSharedSequence(const std::string& name);

/// Grey image (CV_8UC1); empty on failure.
cv::Mat loadGray(const SequenceFrame& f);
/// Depth in metres (CV_32F, 0 = missing); empty on failure.
cv::Mat loadDepthM(const SequenceFrame& f);

}  // namespace pplvo::features::testdata
