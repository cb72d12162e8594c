#pragma once
/// Plane matching between successive frames (paper, "Matching Points, Lines and Planes";
/// Proenca & Gao 2017): candidates by projection overlap and a geometric gate, best candidate by
/// the plane-to-plane distance ||d' N' - d N|| (eq. 18), one-to-one.
#include <optional>
#include <utility>
#include <vector>

#include "pplvo/core/config_schema.h"
#include "pplvo/core/features.h"
#include "pplvo/core/geometry.h"

namespace pplvo::geometry {

struct PlaneMatchOptions {
  /// Overlap of the label images >= this fraction of the smaller plane's pixel count (paper 50%).
  double min_overlap_fraction = 0.5;
  double max_normal_angle_deg = 10.0;  ///< paper: 10 deg
  double max_d_diff_m = 0.10;          ///< paper: 10 cm
  /// Overlap counted on every grid_step-th pixel in u and v (1 = every pixel).
  int grid_step_px = 2;
};

/// Schema of PlaneMatchOptions (pplvo/core/config_schema.h): names, docs and ranges, once.
template <class V>
void visit(V& v, PlaneMatchOptions& o) {
  v.field("min_overlap_fraction", o.min_overlap_fraction,
          "projection overlap >= this fraction of the smaller plane's pixels (Sec. 4.5: 50%)",
          config::between(0, 1));
  v.field("max_normal_angle_deg", o.max_normal_angle_deg,
          "angle between the normals (Sec. 4.5: 10 deg)", config::openClosed(0, 180));
  v.field("max_d_diff_m", o.max_d_diff_m, "|d - d'| (Sec. 4.5: 10 cm)", config::positive());
  v.field("grid_step_px", o.grid_step_px, "overlap counted on every n-th pixel in u and v",
          config::atLeast(1));
}

struct PlaneMatchStats {
  std::string error;
  int n_prev = 0, n_curr = 0;
  int n_overlap_pairs = 0;  ///< pairs passing the overlap test
  int n_candidates = 0;     ///< ... and the geometric gate
  int n_matches = 0;
};

struct PlaneMatchResult {
  std::vector<std::pair<int, int>> matches;  ///< (index in prev.planes, index in curr.planes)
  std::vector<double> distances_m;           ///< eq. 18 for each match
  PlaneMatchStats stats;
};

/// Matches prev.planes to curr.planes using prev.plane_labels / curr.plane_labels.
/// If `T_curr_prev` is given, previous planes are moved into the current frame
/// (PlaneWithCov::transformed) before the geometric gate and eq. 18; the overlap test still
/// compares the label images as they are (valid for small inter-frame motion).
PlaneMatchResult matchPlanesWithStats(const FrameFeatures& prev, const FrameFeatures& curr,
                                      const PlaneMatchOptions& options = {},
                                      const std::optional<Pose3>& T_curr_prev = std::nullopt);

/// Same, returning only the matches.
std::vector<std::pair<int, int>> matchPlanes(const FrameFeatures& prev, const FrameFeatures& curr,
                                             const PlaneMatchOptions& options = {});

}  // namespace pplvo::geometry
