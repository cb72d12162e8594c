#pragma once
/// 2D line segments: LSD (von Gioi et al.) with binary LBD descriptors (Zhang & Koch), as in
/// the paper Sec. "Extraction of Points, Lines and Planes".
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/line_descriptor.hpp>
#include <string>
#include <vector>

#include "pplvo/core/camera.h"
#include "pplvo/core/config_schema.h"
#include "pplvo/core/features.h"
#include "pplvo/features/lbd.h"
#include "pplvo/features/lsd.h"

namespace pplvo::features {

struct LineExtractorOptions {
  /// LSD and LBD work on the image resized by this factor (area averaging). The paper suggests
  /// QVGA (0.5) for real time; 0.4 keeps the same accuracy on the shared data and is faster
  /// (docs/features.md). Endpoints are returned in full resolution.
  double detection_scale = 0.4;
  /// Segments shorter than this (full-resolution pixels, VGA) are dropped.
  double min_length_px = 25.0;
  /// Keep at most this many segments, longest first.
  int max_lines = 150;
  /// LBD band width (rows per band, LBD's and OpenCV's 7).
  int lbd_band_width = 7;
  /// Images smaller than this on either side give no lines.
  int min_image_side_px = 32;
};

/// Alternatives to pplvo's own LSD and LBD (pplvo/features/lsd.h, lbd.h), for the comparison
/// in features_bench and the tests only: not configuration, since they measured slower and no
/// more accurate (docs/features.md). The defaults are pplvo's own.
struct LineDetectorVariant {
  /// LSD and LBD from OpenCV: the same algorithms, several times slower.
  bool use_opencv = false;
  /// OpenCV's LSD refinement: cv::LSD_REFINE_STD / ADV split curved segments and, with ADV,
  /// validate them (about 3x slower before refining); anything but NONE means OpenCV's LSD.
  int lsd_refine = cv::LSD_REFINE_NONE;
  /// LBD pyramid octaves: more than 1 means OpenCV's BinaryDescriptor.
  int lbd_octaves = 1;
  /// LBD on the full-resolution image instead of the resized one (about twice the cost).
  bool describe_full_resolution = false;
};

/// Schema of LineExtractorOptions (pplvo/core/config_schema.h): names, docs and ranges, once.
template <class V>
void visit(V& v, LineExtractorOptions& o) {
  v.field("detection_scale", o.detection_scale,
          "LSD and LBD run on the image resized by this factor (Sec. 5.3 suggests QVGA = 0.5 "
          "for real time; 0.4 keeps the accuracy, docs/features.md)",
          config::openClosed(0, 1));
  v.field("min_length_px", o.min_length_px, "shorter segments are dropped (px, VGA)",
          config::atLeast(0));
  v.field("max_lines", o.max_lines, "segments kept per frame, longest first", config::atLeast(1));
  v.field("lbd_band_width", o.lbd_band_width, "LBD band width (rows per band, LBD's 7)",
          config::between(1, 64));
  v.field("min_image_side_px", o.min_image_side_px, "smaller images give no lines (px)",
          config::atLeast(1));
}

struct LineExtractionStats {
  int detected = 0;  ///< segments from LSD
  int kept = 0;      ///< after the length filter and the cap, with a descriptor
  std::string error;
};

struct LineExtraction {
  std::vector<LineFeature> lines;  ///< px1, px2 undistorted, eq normalised
  cv::Mat descriptors;             ///< CV_8U, 32 bytes (256-bit binary LBD) per line
  LineExtractionStats stats;
};

/// Normalised line through two pixels: (a, b, c) with a u + b v + c = 0, a^2 + b^2 = 1.
/// Zero vector if the points coincide.
Eigen::Vector3d lineEquation(const Eigen::Vector2d& p1, const Eigen::Vector2d& p2);

/// OpenCV KeyLines of `segments` ((x1, y1, x2, y2) in pixels of an image of size `image`) at
/// octave 0, class_id = index: what OpenCV's BinaryDescriptor::compute takes.
std::vector<cv::line_descriptor::KeyLine> toKeyLines(const std::vector<cv::Vec4f>& segments,
                                                     cv::Size image);

/// Not thread-safe (holds OpenCV objects): use one instance per thread.
class LineExtractor {
 public:
  explicit LineExtractor(const LineExtractorOptions& options = {},
                         const LineDetectorVariant& variant = {});

  /// `image`: CV_8UC1 grey or CV_8UC3 BGR at full resolution.
  LineExtraction extract(const cv::Mat& image, const PinholeCamera& camera) const;
  /// Same, writing FrameFeatures::lines and line_descriptors.
  LineExtractionStats extractInto(const cv::Mat& image, const PinholeCamera& camera,
                                  FrameFeatures& frame) const;
  const LineExtractorOptions& options() const { return options_; }

 private:
  /// OpenCV's LBD on `segments` of `image`, rows in their order; empty on a count mismatch.
  cv::Mat describeWithOpenCv(const cv::Mat& image, const std::vector<cv::Vec4f>& segments) const;

  LineExtractorOptions options_;
  LineDetectorVariant variant_;
  cv::Ptr<cv::LineSegmentDetector> opencv_lsd_;                ///< OpenCV's LSD (variant_)
  cv::Ptr<cv::line_descriptor::BinaryDescriptor> opencv_lbd_;  ///< OpenCV's LBD (variant_)
};

}  // namespace pplvo::features
