#pragma once
/// 2D keypoint detection and description (paper Sec. "Extraction of Points, Lines and Planes").
/// The paper uses SURF, which is non-free and absent from Debian's OpenCV 4.6; the detector is
/// chosen in PointExtractorOptions (ORB by default, see docs/features.md for the comparison).
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>

#include "pplvo/core/camera.h"
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
  /// Sub-pixel keypoint positions: the peak of the Shi-Tomasi corner response around the
  /// detected pixel, interpolated by a quadratic (as SIFT/SURF interpolate their extrema).
  /// FAST corners are integer pixels (x 1.2^octave above level 0); with slow motion their
  /// rounding errors are the same for most points of a frame and bias the pose. Measured
  /// (docs/features.md): synthetic room RPE 25 -> 11 mm/s with points alone, but no gain on
  /// the real ICL/TUM sequences (image noise moves the response peak), hence off by default.
  bool subpixel_refinement = false;
  int subpixel_window_px = 2;  ///< half-width of the structure-tensor window

  /// Calls v(name, field) for every field (config load/dump/compare; `detector` is passed as
  /// PointDetector&: use parsePointDetector / pointDetectorName for text).
  template <typename V> void visit(V&& v) { visitFields(*this, v); }
  template <typename V> void visit(V&& v) const { visitFields(*this, v); }

 private:
  template <typename Self, typename V> static void visitFields(Self& s, V& v) {
    v("detector", s.detector);
    v("max_points", s.max_points);
    v("grid_bucketing", s.grid_bucketing);
    v("grid_cols", s.grid_cols);
    v("grid_rows", s.grid_rows);
    v("min_separation_px", s.min_separation_px);
    v("oversample", s.oversample);
    v("min_image_side_px", s.min_image_side_px);
    v("orb_levels", s.orb_levels);
    v("orb_scale_factor", s.orb_scale_factor);
    v("orb_fast_threshold", s.orb_fast_threshold);
    v("orb_edge_threshold_px", s.orb_edge_threshold_px);
    v("akaze_threshold", s.akaze_threshold);
    v("sift_contrast_threshold", s.sift_contrast_threshold);
    v("brisk_threshold", s.brisk_threshold);
    v("subpixel_refinement", s.subpixel_refinement);
    v("subpixel_window_px", s.subpixel_window_px);
  }
};

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
