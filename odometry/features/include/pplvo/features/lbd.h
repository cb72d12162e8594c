#pragma once
/// Binary LBD, the Line Band Descriptor of Zhang and Koch ("An efficient and robust line
/// segment matching approach based on LBD descriptor and pairwise geometric consistency",
/// JVCIR 2013), at one resolution: the descriptor the paper's pipeline uses for lines.
///
/// The line support region is 9 bands of `band_width` rows parallel to the segment, as
/// long as the segment. Image gradients (3x3 Sobel) are projected on the line's direction and
/// its normal; each row sums their positive and negative parts (4 values), weighted by a global
/// Gaussian across the region (sigma = (rows - 1) / 2). A band is described by the mean and
/// standard deviation of the rows of itself and its two neighbours, weighted by a local Gaussian
/// around its centre row (sigma = band width): 8 values. The means and the deviations are
/// normalised separately, clipped at 0.4 and normalised together (LBD's float descriptor); 32
/// pairs of bands then give one byte each, a bit per value: is it larger in the first band of
/// the pair? (the binary form of OpenCV's BinaryDescriptor).
///
/// The region is oriented by the segment: LSD segments are oriented by their gradient, so the
/// same edge gets the same descriptor from frame to frame.
#include <vector>

#include <opencv2/core.hpp>

namespace pplvo::features {

/// LBD's m: 9 bands give 36 pairs, of which the 32 nearest make the 256 bits.
inline constexpr int kLbdBands = 9;
inline constexpr int kLbdBytes = 32;

struct LbdOptions {
  int band_width = 7;  ///< LBD's w, rows per band (1 to 64)
};

/// 256-bit descriptors (CV_8UC1, 32 bytes per row, one row per segment) of `segments`
/// ((x1, y1, x2, y2) in pixel-centre coordinates of `gray`, CV_8UC1). Region pixels outside
/// the image contribute nothing. Throws cv::Exception on another image type or bad options.
cv::Mat describeLineSegments(const cv::Mat& gray, const std::vector<cv::Vec4f>& segments,
                             const LbdOptions& options = {});

}  // namespace pplvo::features
