#pragma once
/// Fast plane segmentation of an organised point cloud, CAPE-style (Proenca & Gao 2018):
/// per-cell moments, a planarity test tied to the depth noise model, a histogram of cell normals
/// to pick seeds, region growing over cells, O(1) merging of adjacent segments by moment
/// addition, pixel refinement of boundary cells, then the WLS plane fit (eqs. 11-12) on the
/// pixels of each segment. Camera frame, metres. Details: docs/geometry.md.
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "pplvo/core/config_schema.h"
#include "pplvo/core/features.h"
#include "pplvo/core/rgbd_frame.h"
#include "pplvo/geometry/backprojection.h"
#include "pplvo/geometry/plane_fit.h"

namespace pplvo::geometry {

struct PlaneExtractionOptions {
  int cell_size_px = 20;  ///< CAPE: 20x20 px cells at VGA
  DepthNoiseModel noise;  ///< sigma_z(z) = 1.425e-3 z^2 m (paper eq. 1)
  double pixel_variance_px2 = kPixelVariancePx2;
  /// Cell planarity: at least this fraction of valid pixels, and
  /// MSE (smallest eigenvalue of the cell covariance) < (k sigma_z(z_mean) + margin)^2.
  double min_valid_fraction = 0.5;
  double planarity_sigma_factor = 2.0;
  double planarity_margin_m = 0.002;
  /// Continuity along the middle row and column of a cell: no jump between consecutive valid
  /// pixels larger than k sigma_z(z) + margin.
  double jump_sigma_factor = 6.0;
  double jump_margin_m = 0.02;
  /// Histogram of cell normals (n_x, n_y) in [-1, 1]^2 (x 2 for the sign of n_z): bins per axis,
  /// and the smallest bin count that may still seed a region.
  int histogram_bins = 20;
  int min_seed_bin_count = 3;
  /// Region growing from the seed cell's plane: normal angle and centroid-to-plane distance
  /// (k sigma_z(z_cell) + margin).
  double grow_max_angle_deg = 15.0;  ///< CAPE: pi/12
  double grow_dist_sigma_factor = 3.0;
  double grow_dist_margin_m = 0.02;
  int min_region_cells = 6;  ///< smaller regions are not planes
  /// A region must span at least this many cells in both image directions: a one-cell strip
  /// (e.g. the floor along the image border at a grazing angle) gives a normal that is
  /// ill-conditioned across the strip and biased by depth quantisation.
  int min_region_span_cells = 2;
  /// Merging of adjacent segments (both centroid-to-other-plane distances must pass).
  double merge_max_angle_deg = 15.0;
  double merge_max_dist_m = 0.05;  ///< CAPE: 50 mm
  /// A segment is kept if its MSE < (k sigma_z(z_mean) + margin)^2 (rejects curved surfaces).
  double segment_sigma_factor = 3.0;
  double segment_margin_m = 0.01;
  /// Pixel refinement: a pixel of an interior cell (its whole (2R+1)^2 neighbourhood in one
  /// segment) stays with that segment if within the distance below; in the other cells in or
  /// next to a segment, every valid pixel joins the nearest
  /// plane among the segments of the (2R+1)^2 cell neighbourhood if |n.p + d| < k sigma_z(z) +
  /// margin (this also trims pixels of planar-looking cells that straddle a corner at long range).
  /// false: labels are the valid pixels of the segment cells (CAPE without refinement).
  bool refine_boundaries = true;
  /// R: candidate planes of a cell are the segments within R cells (1 or 2: 3x3 or 5x5).
  /// 2 reaches across the one or two non-planar cells that separate two surfaces at a corner.
  int refine_neighbourhood_cells = 2;
  double refine_sigma_factor = 3.0;
  double refine_margin_m = 0.01;
  int min_plane_points = 1500;  ///< after refinement (about 4 cells at VGA)
  /// WLS fit on a regular grid subsample of the segment pixels with step
  /// floor(sqrt(n_pixels / max_fit_points)) (so between max_fit_points and 4x as many points).
  int max_fit_points = 3000;
  int max_planes = 64;  ///< labels are CV_8U (<= 254)
  /// Threads for the per-pixel passes and the plane fits. The image is always cut into the
  /// same bands of cell rows, so the result does not depend on this number.
  int threads = 2;
  PlaneFitOptions fit;
};

/// Schema of PlaneExtractionOptions (pplvo/core/config_schema.h): names, docs and ranges, once.
template <class V>
void visit(V& v, PlaneExtractionOptions& o) {
  v.field("cell_size_px", o.cell_size_px, "CAPE cells of N x N px (VGA: 20)", config::atLeast(2));
  v.section("noise", "depth noise used by the planarity tests (paper eq. 1)",
            [&] { visit(v, o.noise); });
  v.field("pixel_variance_px2", o.pixel_variance_px2,
          "pixel quantisation variance sigma_p^2 (Sec. 4.2: 1/12 px^2)", config::atLeast(0));
  v.field("min_valid_fraction", o.min_valid_fraction,
          "a planar cell has at least this fraction of valid depth pixels",
          config::openClosed(0, 1));
  v.field("planarity_sigma_factor", o.planarity_sigma_factor,
          "cell planar if MSE < (k sigma_z(z) + margin)^2: k", config::atLeast(0));
  v.field("planarity_margin_m", o.planarity_margin_m, "... margin (m)", config::atLeast(0));
  v.field("jump_sigma_factor", o.jump_sigma_factor,
          "no depth jump inside a cell larger than k sigma_z(z) + margin: k", config::atLeast(0));
  v.field("jump_margin_m", o.jump_margin_m, "... margin (m)", config::atLeast(0));
  v.field("histogram_bins", o.histogram_bins, "normal histogram bins per axis", config::atLeast(1));
  v.field("min_seed_bin_count", o.min_seed_bin_count,
          "smallest histogram bin count that may seed a region", config::atLeast(1));
  v.field("grow_max_angle_deg", o.grow_max_angle_deg,
          "region growing: normal angle to the seed plane (deg; CAPE pi/12)",
          config::openClosed(0, 180));
  v.field("grow_dist_sigma_factor", o.grow_dist_sigma_factor,
          "region growing: cell centroid within k sigma_z(z) + margin of the plane: k",
          config::atLeast(0));
  v.field("grow_dist_margin_m", o.grow_dist_margin_m, "... margin (m)", config::atLeast(0));
  v.field("min_region_cells", o.min_region_cells, "smaller regions are not planes",
          config::atLeast(1));
  v.field("min_region_span_cells", o.min_region_span_cells,
          "a region spans at least this many cells in both image directions", config::atLeast(1));
  v.field("merge_max_angle_deg", o.merge_max_angle_deg,
          "merging adjacent segments: normal angle (deg)", config::openClosed(0, 180));
  v.field("merge_max_dist_m", o.merge_max_dist_m,
          "merging: centroid-to-other-plane distance (m; CAPE 50 mm)", config::atLeast(0));
  v.field("segment_sigma_factor", o.segment_sigma_factor,
          "segment kept if MSE < (k sigma_z(z) + margin)^2: k", config::atLeast(0));
  v.field("segment_margin_m", o.segment_margin_m, "... margin (m)", config::atLeast(0));
  v.field("refine_boundaries", o.refine_boundaries,
          "per-pixel refinement of the plane boundaries (false: CAPE without refinement)");
  v.field("refine_neighbourhood_cells", o.refine_neighbourhood_cells,
          "refinement candidates within R cells (1: 3x3, 2: 5x5)", config::between(1, 2));
  v.field("refine_sigma_factor", o.refine_sigma_factor,
          "a pixel joins a plane if |n.p + d| < k sigma_z(z) + margin: k", config::atLeast(0));
  v.field("refine_margin_m", o.refine_margin_m, "... margin (m)", config::atLeast(0));
  v.field("min_plane_points", o.min_plane_points, "pixels of a plane after refinement",
          config::atLeast(3));
  v.field("max_fit_points", o.max_fit_points,
          "the WLS fit uses a grid subsample of between this and 4x as many pixels",
          config::atLeast(3));
  v.field("max_planes", o.max_planes, "planes per frame (labels are 8-bit)",
          config::between(1, 254));
  v.field("threads", o.threads,
          "threads for the per-pixel passes and the fits (results do not depend on it)",
          config::atLeast(1));
  v.section("fit", "WLS plane fitting (Sec. 4.3, eqs. 11-12)", [&] { visit(v, o.fit); });
}

struct PlaneExtractionStats {
  std::string error;  ///< non-empty when the input was rejected
  int n_cells = 0, n_planar_cells = 0, n_regions_grown = 0, n_regions_too_small = 0;
  int n_segments = 0, n_merges = 0, n_segments_not_planar = 0, n_too_few_points = 0;
  int n_fit_rejected = 0;  ///< WLS fit failed (e.g. plane through the camera centre)
  int n_planes = 0;
};

struct PlaneExtractionResult {
  std::vector<PlaneFeature> planes;  ///< plane i has label i + 1, sorted by n_points (desc)
  cv::Mat labels;                    ///< CV_8UC1, 0 = no plane
  PlaneExtractionStats stats;
};

/// Holds the buffers sized once from the camera; call extract() per depth map.
class PlaneExtractor {
 public:
  PlaneExtractor(const PinholeCamera& camera, const PlaneExtractionOptions& options = {});
  PlaneExtractionResult extract(const DepthWithVariance& depth);
  const PinholeCamera& camera() const { return camera_; }

 private:
  struct Moments {  // sums over valid pixels (double for stable covariances)
    double n = 0, sx = 0, sy = 0, sz = 0, sxx = 0, syy = 0, szz = 0, sxy = 0, sxz = 0, syz = 0;
    void add(const Moments& o);
  };
  struct CellPlane {
    Eigen::Vector3d normal = Eigen::Vector3d::Zero(), mean = Eigen::Vector3d::Zero();
    double d = 0, mse = 0;
  };
  struct Segment;         // a grown region: moments and plane
  struct CellCandidates;  // the planes a cell's pixels may join
  struct CellSums;        // per-cell label counts and point sums by candidate
  struct LabelStats;      // per-plane label counts, point sums and bounding boxes
  static bool fitMoments(const Moments& m, CellPlane* out);
  double sigmaZ(double z) const { return options_.noise.sigma_z_coeff_per_m * z * z; }

  // The steps of extract(), in order (docs/geometry.md): each reads the buffers the earlier
  // ones filled.
  /// 1) cell_moments_: per-cell moments of the backprojected points.
  void accumulateCellMoments(const cv::Mat& depth_m);
  /// Cell rows [*c0, *c1) of one of the fixed bands the per-pixel passes split the image into.
  void bandCellRows(int band, int* c0, int* c1) const;
  /// 2) planar_, cell_planes_, cell_bin_, bin_count_: planarity test per cell, normal histogram.
  void classifyCells(const cv::Mat& depth_m, PlaneExtractionStats* stats);
  /// No depth jump along the middle row and column of cell (cx, cy).
  bool cellIsContinuous(const cv::Mat& depth_m, int cx, int cy) const;
  /// 3) cell_segment_: regions grown from histogram seeds; the segments large enough to keep.
  std::vector<Segment> growRegions(PlaneExtractionStats* stats);
  /// Grows one region from `seed` into cell_segment_ (id `sid`), returning its cells.
  void growRegion(int seed, int sid, std::vector<int>* region);
  /// 4) Merges adjacent similar segments, drops curved ones; cell_segment_ then holds indices
  /// into the returned planes.
  std::vector<CellPlane> mergeSegments(std::vector<Segment>& segs, PlaneExtractionStats* stats);
  /// 5) Pixel labels 1..np in `labels` and their per-plane statistics (planes below np only).
  LabelStats labelPixels(const cv::Mat& depth_m, const std::vector<CellPlane>& planes, int np,
                         cv::Mat& labels) const;
  bool cellCandidates(int cx, int cy, int np, CellCandidates* out) const;
  void labelCell(const cv::Mat& depth_m, int cx, int cy, const CellCandidates& cand,
                 const std::vector<CellPlane>& planes, cv::Mat& labels, LabelStats* bs) const;
  /// 6) WLS fit of each labelled segment; res->planes in size order, labels renumbered.
  void fitSegments(const DepthWithVariance& depth, const LabelStats& ls, int np,
                   PlaneExtractionResult* res);
  /// The sampled points of one segment fit: kept from frame to frame (capacity only), so that
  /// the per-point arrays (~0.9 MB for 12,000 points) are neither grown nor faulted in anew.
  struct FitSamples {
    std::vector<Eigen::Vector3d> points;
    std::vector<Eigen::Matrix3d> covs;
    std::vector<double> var_z;
  };
  PlaneFitResult fitSegment(const DepthWithVariance& depth, const cv::Mat& labels,
                            const LabelStats& ls, int i, FitSamples* samples) const;

  PinholeCamera camera_;
  PlaneExtractionOptions options_;
  int cells_x_ = 0, cells_y_ = 0;
  std::vector<float> x_factor_, y_factor_;  // (u - cx)/fx per column, (v - cy)/fy per row
  std::vector<double> ray_x_, ray_y_;       // the same in double (backprojectRayWithCov)
  std::vector<int> cell_of_col_;
  std::vector<Moments> cell_moments_;
  std::vector<CellPlane> cell_planes_;
  std::vector<char> planar_;
  std::vector<int> cell_segment_, cell_bin_, bin_count_, queue_;
  std::vector<FitSamples> fit_samples_;  ///< one per segment fit of a frame (they run in parallel)
};

/// Convenience: extracts planes of `depth` with frame.camera and stores them in frame.planes
/// and frame.plane_labels (allocates a PlaneExtractor; keep one per camera for speed).
PlaneExtractionStats extractPlanes(FrameFeatures& frame, const DepthWithVariance& depth,
                                   const PlaneExtractionOptions& options = {});

}  // namespace pplvo::geometry
