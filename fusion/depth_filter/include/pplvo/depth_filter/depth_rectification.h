#pragma once
/// Depth in the colour camera's undistorted pinhole model.
///
/// Registered depth (TUM, OpenNI2, libfreenect) is indexed by the colour camera's raw, distorted
/// pixels, while every geometric step after it (lifting features at their undistorted pixels,
/// plane extraction, O-GM's reprojection of past frames) back-projects a pixel with the
/// pinhole model. With TUM fr1's lens (k1 = 0.26) a keypoint's undistorted pixel is 4 px away
/// from where its depth was measured at mid-image and ~25 px at the corners. Resampling the
/// depth map once onto the undistorted pixel grid makes the whole pipeline consistent: each
/// undistorted pixel takes the depth of the raw pixel nearest to where the lens maps it
/// (nearest neighbour, so no depth is invented across a discontinuity; the value is z along
/// the optical axis, which the resampling does not change). Pixels the lens maps outside the
/// raw image have no depth. Without distortion the map is the identity and the input is
/// returned unchanged.
#include <opencv2/core.hpp>
#include <vector>

#include "pplvo/core/camera.h"

namespace pplvo::depth_filter {

class DepthRectifier {
 public:
  /// Depth (CV_32FC1, camera.height x camera.width) resampled to the undistorted pinhole model
  /// of `camera`; `depth_m` itself (no copy) when the camera has no distortion. The map is
  /// computed on the first call for a camera and kept while the camera stays the same.
  cv::Mat apply(const PinholeCamera& camera, const cv::Mat& depth_m);

  /// Raw pixel index (row * width + col) each undistorted pixel reads, -1 for none; empty
  /// without distortion. Exposed for tests.
  const std::vector<int32_t>& sourceIndex() const { return source_; }

 private:
  void build(const PinholeCamera& camera);

  PinholeCamera camera_;
  bool built_ = false;
  std::vector<int32_t> source_;
};

}  // namespace pplvo::depth_filter
