#pragma once
/// Frame-to-frame matching of 2D points and lines (paper Sec. "Matching Points, Lines and
/// Planes"): descriptor nearest neighbours, then "the strongest match per query that satisfies
/// an image geometric distance constraint" — points within a Euclidean pixel distance, lines
/// with similar slope angle and distance to the origin (image top-left corner) in their
/// Hessian normal form. Matches are one-to-one (cross-check).
///
/// Implementation note: the gate is applied before the descriptor search, i.e. the k-NN (k=2)
/// search runs over the gated candidates only. The strongest gated match is the same as in
/// "k-NN over the whole image, then keep the strongest that satisfies the gate" with k large
/// enough; the ratio test (optional) compares the best and second-best gated candidates.
#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <utility>
#include <vector>

#include "pplvo/core/config_schema.h"
#include "pplvo/core/features.h"

namespace pplvo::features {

struct PointMatchOptions {
  /// Gate: |px_curr - px_prev| < max_px_distance (VGA, 30 Hz: hand-held motion rarely exceeds
  /// 40 px between frames; the paper gives no value).
  double max_px_distance = 40.0;
  /// Gate used instead around a predicted position, when one is given for the query.
  double predicted_max_px_distance = 15.0;
  /// Reject if best >= ratio * second best (Lowe); disabled when ratio_test is false.
  bool ratio_test = true;
  double ratio = 0.75;
  /// Maximum descriptor distance: bits for binary descriptors (ORB: 256 bits), L2 for float
  /// (SIFT, unit-normalised x512 in OpenCV). Negative disables.
  double max_hamming_bits = 70.0;
  double max_l2 = 250.0;
  /// One-to-one: keep (i, j) only if i is also the best gated candidate of j.
  bool cross_check = true;
};

/// Schema of PointMatchOptions (pplvo/core/config_schema.h): names, docs and ranges, once.
template <class V>
void visit(V& v, PointMatchOptions& o) {
  v.field("max_px_distance", o.max_px_distance,
          "gate: pixel distance to the previous position (Sec. 4.5; no value in the paper)",
          config::positive());
  v.field("predicted_max_px_distance", o.predicted_max_px_distance,
          "gate around a predicted position instead, when there is one (px)", config::positive());
  v.field("ratio_test", o.ratio_test, "Lowe ratio test on the two best gated candidates");
  v.field("ratio", o.ratio, "reject if best >= ratio * second best", config::openClosed(0, 1));
  v.field("max_hamming_bits", o.max_hamming_bits,
          "largest binary descriptor distance (bits of 256 for ORB); negative disables");
  v.field("max_l2", o.max_l2, "largest float descriptor distance (SIFT); negative disables");
  v.field("cross_check", o.cross_check, "one-to-one matches (mutual best)");
}

struct LineMatchOptions {
  /// Gate on the Hessian normal form (theta, rho) of the line a u + b v + c = 0 with the origin
  /// at the image top-left corner: |theta - theta'| mod 180 deg and |rho - rho'|.
  double max_angle_deg = 10.0;
  double max_rho_px = 40.0;
  bool ratio_test = true;
  double ratio = 0.9;
  /// LBD is 256 bits.
  double max_hamming_bits = 80.0;
  bool cross_check = true;
};

/// Schema of LineMatchOptions (pplvo/core/config_schema.h): names, docs and ranges, once.
template <class V>
void visit(V& v, LineMatchOptions& o) {
  v.field("max_angle_deg", o.max_angle_deg,
          "gate: slope angle difference of the Hessian forms (deg; Sec. 4.5, no value given)",
          config::openClosed(0, 180));
  v.field("max_rho_px", o.max_rho_px, "gate: difference of the distances to the origin (px)",
          config::positive());
  v.field("ratio_test", o.ratio_test, "ratio test on the two best gated candidates");
  v.field("ratio", o.ratio, "reject if best >= ratio * second best", config::openClosed(0, 1));
  v.field("max_hamming_bits", o.max_hamming_bits,
          "largest LBD distance (bits of 256); negative disables");
  v.field("cross_check", o.cross_check, "one-to-one matches (mutual best)");
}

struct MatchStats {
  int queries = 0;            ///< previous features with a descriptor
  int candidates = 0;         ///< (prev, curr) pairs inside the geometric gate
  int no_candidate = 0;       ///< queries with no current feature inside the gate
  int rejected_distance = 0;  ///< best gated candidate above the descriptor distance limit
  int rejected_ratio = 0;     ///< failed the ratio test
  int rejected_cross_check = 0;  ///< not the mutual best
  int matches = 0;
};

struct MatchResult {
  std::vector<std::pair<int, int>> pairs;  ///< (index in previous, index in current)
  std::vector<float> descriptor_distance;  ///< per pair (bits or L2)
  MatchStats stats;
};

/// Descriptor norm (cv::NORM_HAMMING or cv::NORM_L2) inferred from the descriptor type:
/// CV_8U is binary, CV_32F is float.
int descriptorNormOf(const cv::Mat& descriptors);

/// Matches points of `prev` to points of `curr` (descriptors one row per point, same type).
/// `predicted_px` (optional): per previous point, its predicted pixel in the current frame
/// (e.g. from a predicted pose and its depth); entries with NaN use the previous pixel and the
/// normal gate. Must be empty or have prev_points.size() entries (otherwise it is ignored).
MatchResult matchPoints(const std::vector<PointFeature>& prev_points,
                        const cv::Mat& prev_descriptors,
                        const std::vector<PointFeature>& curr_points,
                        const cv::Mat& curr_descriptors, const PointMatchOptions& options,
                        const std::vector<Eigen::Vector2d>& predicted_px = {});
MatchResult matchPoints(const FrameFeatures& prev, const FrameFeatures& curr,
                        const PointMatchOptions& options,
                        const std::vector<Eigen::Vector2d>& predicted_px = {});

/// Hessian normal form of a line equation: theta in (-pi, pi] the angle of (a, b), rho = -c
/// (distance of the origin, top-left corner, to the line; sign follows (a, b)).
void lineHessian(const Eigen::Vector3d& eq, double* theta_rad, double* rho_px);
/// The gate test used by matchLines (direction sign of the segments is irrelevant).
bool lineGate(const Eigen::Vector3d& eq_prev, const Eigen::Vector3d& eq_curr,
              double max_angle_deg, double max_rho_px);

MatchResult matchLines(const std::vector<LineFeature>& prev_lines,
                       const cv::Mat& prev_descriptors,
                       const std::vector<LineFeature>& curr_lines,
                       const cv::Mat& curr_descriptors, const LineMatchOptions& options);
MatchResult matchLines(const FrameFeatures& prev, const FrameFeatures& curr,
                       const LineMatchOptions& options);

}  // namespace pplvo::features
