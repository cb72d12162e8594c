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
  /// QVGA (0.5) for real time; 0.4 keeps the same accuracy on the shared data and is ~30 %
  /// faster (docs/features.md). Endpoints are returned in full resolution.
  double detection_scale = 0.4;
  /// Compute LBD on the full-resolution image instead of the resized one (about twice the
  /// descriptor cost; see docs/features.md).
  bool describe_full_resolution = false;
  /// Segments shorter than this (full-resolution pixels, VGA) are dropped.
  double min_length_px = 25.0;
  /// Keep at most this many segments, longest first.
  int max_lines = 150;
  /// LSD refinement: cv::LSD_REFINE_NONE (default: pplvo's LSD, pplvo/features/lsd.h) or
  /// cv::LSD_REFINE_STD / cv::LSD_REFINE_ADV (OpenCV's LSD, which splits curved segments and,
  /// with ADV, validates them; about 3x slower before refining).
  int lsd_refine = cv::LSD_REFINE_NONE;
  /// LBD band width (LBD's and OpenCV's 7) and number of pyramid octaves (1: the detection
  /// image only, pplvo's LBD; more: OpenCV's BinaryDescriptor).
  int lbd_band_width = 7;
  int lbd_octaves = 1;
  /// LSD and LBD from OpenCV instead of pplvo's own (pplvo/features/lsd.h, lbd.h), for
  /// comparison: the same algorithms, several times slower (docs/features.md).
  bool use_opencv = false;
  /// Images smaller than this on either side give no lines.
  int min_image_side_px = 32;
};

/// Schema of LineExtractorOptions (pplvo/core/config_schema.h): names, docs and ranges, once.
template <class V>
void visit(V& v, LineExtractorOptions& o) {
  v.field("detection_scale", o.detection_scale,
          "LSD and LBD run on the image resized by this factor (Sec. 5.3 suggests QVGA = 0.5 "
          "for real time; 0.4 keeps the accuracy, docs/features.md)",
          config::openClosed(0, 1));
  v.field("describe_full_resolution", o.describe_full_resolution,
          "compute LBD on the full-resolution image");
  v.field("min_length_px", o.min_length_px, "shorter segments are dropped (px, VGA)",
          config::atLeast(0));
  v.field("max_lines", o.max_lines, "segments kept per frame, longest first", config::atLeast(1));
  v.field("lsd_refine", o.lsd_refine,
          "LSD refinement: 0 none (pplvo's LSD), 1 standard, 2 advanced (OpenCV's)",
          config::between(0, 2));
  v.field("lbd_band_width", o.lbd_band_width, "LBD band width (rows per band, LBD's 7)",
          config::between(1, 64));
  v.field("lbd_octaves", o.lbd_octaves,
          "LBD pyramid octaves (1 = one resolution, pplvo's LBD; more: OpenCV's)",
          config::atLeast(1));
  v.field("use_opencv", o.use_opencv, "LSD and LBD from OpenCV instead of pplvo's (slower)");
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
  explicit LineExtractor(const LineExtractorOptions& options = {});

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
  cv::Ptr<cv::LineSegmentDetector> opencv_lsd_;                ///< use_opencv or a refinement
  cv::Ptr<cv::line_descriptor::BinaryDescriptor> opencv_lbd_;  ///< use_opencv or octaves > 1
};

}  // namespace pplvo::features
