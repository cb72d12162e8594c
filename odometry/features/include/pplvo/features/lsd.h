#pragma once
/// LSD, the line segment detector of von Gioi, Jakubowicz, Morel and Randall ("LSD: a Line
/// Segment Detector", IPOL 2012), without refinement or NFA validation: the variant the paper's
/// pipeline runs (OpenCV's LSD_REFINE_NONE), about 3-5x faster than OpenCV's implementation on
/// the shared sequences and finding the same segments (docs/features.md).
///
/// The algorithm: the level-line field of a 2x2 gradient; pixels whose gradient norm exceeds
/// q / sin(tau) seed regions in decreasing order of gradient (a 1024-bin pseudo-ordering); a
/// region grows over 8-connected pixels whose level-line angle is within tau of the region's
/// mean angle; regions with fewer pixels than could be meaningful (-log10(N_tests) / log10(p))
/// are dropped, the others become the segment through the gradient-weighted centroid along the
/// principal axis of their inertia, clipped to the region's extent.
#include <vector>

#include <opencv2/core.hpp>

namespace pplvo::features {

struct LsdOptions {
  /// q: bound on the gradient's quantization error (grey levels), LSD's 2.
  double gradient_quantization = 2.0;
  /// tau: a pixel joins a region if its level-line angle is within this of the region's.
  double angle_tolerance_deg = 22.5;
  /// Bins of the pseudo-ordering of seeds by gradient norm.
  int gradient_bins = 1024;
};

/// Segments of an 8-bit single-channel image, as (x1, y1, x2, y2) in pixel-centre
/// coordinates (the centre of pixel (0, 0) is (0, 0)), in the order they were found (strongest
/// seed first). Images smaller than 2x2 give none. Throws cv::Exception on another image type.
std::vector<cv::Vec4f> detectLineSegments(const cv::Mat& gray, const LsdOptions& options = {});

}  // namespace pplvo::features
