#pragma once
/// 2D keypoint detection and description (paper Sec. "Extraction of Points, Lines and Planes").
/// The paper uses SURF, which is non-free and absent from Debian's OpenCV 4.6; the detector is
/// chosen in PointExtractorOptions (ORB by default, see docs/features.md for the comparison).
#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <string>
#include <vector>

#include "pplvo/core/camera.h"
#include "pplvo/core/config_schema.h"
#include "pplvo/core/features.h"

namespace pplvo::features {

enum class PointDetector {
  kOrb,    ///< oFAST + rBRIEF, 256-bit binary (default: fastest with good precision)
  kAkaze,  ///< nonlinear scale space, 486-bit binary MLDB
  kSift,   ///< DoG + 128-float SIFT (free since OpenCV 4.4)
  kBrisk,  ///< AGAST + 512-bit binary BRISK
};

/// Parses "orb", "akaze", "sift", "brisk" (case-insensitive); returns false if unknown.
bool parsePointDetector(const std::string& name, PointDetector* out);
const char* pointDetectorName(PointDetector d);

struct PointExtractorOptions {
  PointDetector detector = PointDetector::kOrb;
  /// Cap on the number of points kept per frame (VGA). The paper does not state its SURF count;
  /// 800 gives ~250-450 matches per frame on the shared sequences (docs/features.md).
  int max_points = 800;
  /// Spread: the image is split into grid_cols x grid_rows cells and each cell may contribute
  /// at most ceil(max_points / cells) of the strongest candidates in a first pass; leftover
  /// slots go to the strongest remaining candidates anywhere (grid bucketing).
  bool grid_bucketing = true;
  int grid_cols = 8;
  int grid_rows = 6;
  /// Kept points are at least this far apart (strongest first): removes near-duplicates from
  /// adjacent pyramid levels, which otherwise give near-miss matches (docs/features.md).
  /// 0 disables.
  double min_separation_px = 0.0;
  /// Candidates detected before bucketing, as a multiple of max_points (ORB, SIFT).
  double oversample = 2.0;
  /// Images smaller than this on either side give no points (ORB needs a border of ~31 px).
  int min_image_side_px = 64;

  // Detector-specific parameters (OpenCV defaults unless noted).
  int orb_levels = 4;  ///< OpenCV: 8. 30 Hz motion needs little scale range; coarse
                       ///< levels localise worse (docs/features.md)
  double orb_scale_factor = 1.2;
  int orb_fast_threshold = 12;  ///< lower than OpenCV's 20: the ICL render has soft texture
  int orb_edge_threshold_px = 19;
  double akaze_threshold = 0.0008;
  double sift_contrast_threshold = 0.03;
  int brisk_threshold = 20;
  /// Sub-pixel keypoint positions (ORB only: the other detectors interpolate their own
  /// extrema): the peak of the Shi-Tomasi corner response around the
  /// detected pixel, interpolated by a quadratic (as SIFT/SURF interpolate their extrema).
  /// FAST corners are integer pixels (x 1.2^octave above level 0); with slow motion their
  /// rounding errors are the same for most points of a frame and bias the pose. Measured in
  /// docs/features.md (ATE and RPE lower on the synthetic, ICL and TUM sequences).
  bool subpixel_refinement = true;
  /// Half-width of the structure-tensor window at level 0. 2 (5x5) gives the smallest spread
  /// of the point residuals between frames on all four benchmark sequences, real and rendered
  /// (measured: 1, 2, 3, 5 and no refinement; docs/features.md); 5 (11x11), the earlier
  /// default, lets the peak move with the surrounding texture as the view changes.
  int subpixel_window_px = 2;
  /// The window's half-width times orb_scale_factor^octave (rounded): the same image content
  /// around the corner at every pyramid level, as FAST's circle and the search radius scale.
  bool subpixel_window_scales_with_octave = true;
};

/// Schema of PointExtractorOptions (pplvo/core/config_schema.h): names, docs and ranges, once.
template <class V>
void visit(V& v, PointExtractorOptions& o) {
  v.field("detector", o.detector,
          "keypoint detector/descriptor: orb, akaze, sift or brisk (the paper's SURF is "
          "non-free and not in Debian's OpenCV; docs/features.md compares them)");
  v.field("max_points", o.max_points,
          "points kept per frame (VGA); the paper gives no count (docs/features.md)",
          config::atLeast(1));
  v.field("grid_bucketing", o.grid_bucketing,
          "spread the points over a grid_cols x grid_rows grid of cells");
  v.field("grid_cols", o.grid_cols, "bucketing grid columns", config::atLeast(1));
  v.field("grid_rows", o.grid_rows, "bucketing grid rows", config::atLeast(1));
  v.field("min_separation_px", o.min_separation_px,
          "kept points are at least this far apart (px); 0 disables", config::atLeast(0));
  v.field("oversample", o.oversample,
          "candidates detected before bucketing, as a multiple of max_points", config::atLeast(1));
  v.field("min_image_side_px", o.min_image_side_px, "smaller images give no points (px)",
          config::atLeast(1));
  v.field("orb_levels", o.orb_levels, "ORB pyramid levels (OpenCV default 8)", config::atLeast(1));
  v.field("orb_scale_factor", o.orb_scale_factor, "ORB pyramid scale factor",
          config::greaterThan(1.0));
  v.field("orb_fast_threshold", o.orb_fast_threshold, "ORB FAST threshold (OpenCV 20)",
          config::atLeast(0));
  v.field("orb_edge_threshold_px", o.orb_edge_threshold_px, "ORB border without features (px)",
          config::atLeast(0));
  v.field("akaze_threshold", o.akaze_threshold, "AKAZE detector response threshold",
          config::positive());
  v.field("sift_contrast_threshold", o.sift_contrast_threshold, "SIFT contrast threshold",
          config::positive());
  v.field("brisk_threshold", o.brisk_threshold, "BRISK AGAST threshold", config::atLeast(0));
  v.field("subpixel_refinement", o.subpixel_refinement,
          "sub-pixel keypoints: quadratic peak of the Shi-Tomasi response near the detection");
  v.field("subpixel_window_px", o.subpixel_window_px, "half-width of the structure-tensor window",
          config::atLeast(1));
  v.field("subpixel_window_scales_with_octave", o.subpixel_window_scales_with_octave,
          "the window's half-width times orb_scale_factor^octave (the keypoint's level)");
}

struct PointExtractionStats {
  int candidates = 0;   ///< keypoints found by the detector
  int kept = 0;         ///< after bucketing / cap and description
  std::string error;    ///< non-empty if OpenCV rejected the input (then no points)
};

struct PointExtraction {
  std::vector<PointFeature> points;  ///< px undistorted (full resolution)
  cv::Mat descriptors;               ///< one row per point; CV_8U binary or CV_32F (SIFT)
  std::vector<cv::KeyPoint> keypoints;  ///< the raw (distorted) keypoints, same order
  PointExtractionStats stats;
};

/// Detects, spreads, caps and describes keypoints. Not thread-safe (holds OpenCV objects):
/// use one instance per thread.
class PointExtractor {
 public:
  explicit PointExtractor(const PointExtractorOptions& options = {});

  /// `image`: CV_8UC1 grey or CV_8UC3 BGR. Empty, tiny or textureless images give an empty
  /// result. Keypoints are undistorted with `camera` (identity without distortion).
  PointExtraction extract(const cv::Mat& image, const PinholeCamera& camera) const;
  /// Same, writing FrameFeatures::points and point_descriptors (other fields untouched).
  PointExtractionStats extractInto(const cv::Mat& image, const PinholeCamera& camera,
                                   FrameFeatures& frame) const;

  /// cv::NORM_HAMMING for binary descriptors, cv::NORM_L2 for SIFT.
  int descriptorNorm() const;
  const PointExtractorOptions& options() const { return options_; }

 private:
  PointExtractorOptions options_;
  cv::Ptr<cv::Feature2D> detector_;
};

/// Grid bucketing used by PointExtractor: returns indices into `keypoints` (at most
/// `max_keep`), strongest first within the two passes described in PointExtractorOptions.
/// Candidates closer than min_separation_px to an already kept (stronger) one are dropped.
std::vector<int> selectSpread(const std::vector<cv::KeyPoint>& keypoints, int width, int height,
                              int max_keep, int grid_cols, int grid_rows,
                              double min_separation_px = 0.0);

}  // namespace pplvo::features

namespace pplvo::config {
template <>
struct EnumText<features::PointDetector> {
  static bool parse(const std::string& s, features::PointDetector* out) {
    return features::parsePointDetector(s, out);
  }
  static std::string name(features::PointDetector d) { return features::pointDetectorName(d); }
  static const char* choices() { return "orb, akaze, sift, brisk"; }
};
}  // namespace pplvo::config
